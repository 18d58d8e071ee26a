"""ipycam, a virtual ONVIF camera nobody here wrote, serving a video file on loopback only:
`python ipycam_loopback.py VIDEO PORT USER PASSWORD`, printing READY once it listens.

ipycam's own start-up would multicast a WS-Discovery Hello to 239.255.255.250 and bind every
interface; here discovery is a no-op and its HTTP server binds 127.0.0.1. Its digital PTZ
crops each frame of VIDEO (looped) and serves ONVIF on PORT and MJPEG at /stream.mjpeg.
"""

from __future__ import annotations

import logging
import sys

import cv2
import ipycam.camera as camera_module
from ipycam import CameraConfig, IPCamera, configure_logging


class NoDiscovery:
    def __init__(self, *_args: object, **_kwargs: object) -> None: ...

    def start(self) -> None: ...

    def stop(self) -> None: ...


class LoopbackServer(camera_module.ReusableThreadingTCPServer):  # type: ignore[name-defined,misc]
    def __init__(self, address, handler, *args, **kwargs) -> None:  # type: ignore[no-untyped-def]
        super().__init__(("127.0.0.1", address[1]), handler, *args, **kwargs)


def main() -> None:
    video, port, user, password = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
    camera_module.WSDiscoveryServer = NoDiscovery
    camera_module.ReusableThreadingTCPServer = LoopbackServer
    configure_logging(level=logging.WARNING)
    config = CameraConfig(
        local_ip="127.0.0.1",
        onvif_port=port,
        rtsp_port=port + 1,
        rtmp_port=port + 2,
        web_port=port + 3,
        go2rtc_api_port=port + 4,
        main_width=480,
        main_height=360,
        main_fps=10,
        sub_width=320,
        sub_height=240,
        username=user,
        password=password,
        show_timestamp=False,
    )
    cam = IPCamera(config)
    cam.start()
    capture = cv2.VideoCapture(video)
    print("READY", flush=True)
    try:
        while cam.is_running:
            ok, frame = capture.read()
            if not ok:
                capture.set(cv2.CAP_PROP_POS_FRAMES, 0)
                continue
            cam.stream(frame)
    finally:
        cam.stop()


if __name__ == "__main__":
    main()
