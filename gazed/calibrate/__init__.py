"""Calibrations measured with the running rig that belong to no single process: the camera's
delay from exposure to arrival (`camera_latency`) and a zoom lens's focal length at each zoom
position (`zoom_calibration`, with the image scale between two views in `zoom_scale`); both
drive the head through `head_session`."""
