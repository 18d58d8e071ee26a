"""Calibrations measured with the running rig that belong to no single process: the camera's
delay from exposure to arrival (`camera_latency`)."""
