"""The rig's `[camera]` as a frame source: the simulator's frames on the bus for 'sim', the ONVIF
camera's own stream for 'onvif' (GetStreamUri), else an OpenCV capture (device index, file,
RTSP/HTTP URL). The vision process and the calibrations that watch the camera open it alike."""

from __future__ import annotations

from gazed.bus import Bus
from gazed.config import Rig
from gazed.vision.bus_frames import BusFrameSource
from gazed.vision.opencv_camera import OpenCvCamera, capture_target
from gazed.vision.source import FrameSource


def rig_camera(rig: Rig, bus: Bus) -> FrameSource:
    """The rig's camera, its frames waking `bus`'s loop as they arrive."""
    camera = rig.camera
    if camera.source == "sim":
        return BusFrameSource(bus, silence_s=camera.timeout_ms * 1e-3)
    source = camera.source
    if source == "onvif":  # the ONVIF camera's own stream; its client loaded only then
        from gazed.servo.onvif_driver import camera_stream_uri

        source = camera_stream_uri(rig)
    return OpenCvCamera(
        capture_target(source),
        width_px=camera.width_px,
        height_px=camera.height_px,
        rate_hz=camera.rate_hz,
        reopen_max_s=camera.reopen_max_s,
        timeout_ms=camera.timeout_ms,
        on_frame=bus.notify,
    )
