"""The ONVIF head as the head link drives it: `OnvifHead` behind `SpeedHead`, which sends the
set-points as AbsoluteMove in position mode and as ContinuousMove speeds in speed mode
(`[servo] mode = "speed"`, or a camera whose PTZ node has no absolute moves)."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import httpx

from gazed.config import Rig
from gazed.config.servo import OnvifServo
from gazed.servo.codec import HandshakeError
from gazed.servo.onvif_head import OnvifHead
from gazed.servo.speed_mode import SpeedDevice, SpeedHead, speed_head


def rig_folder(rig: Rig) -> Path | None:
    """The rig file's folder, which a relative password file is taken from."""
    return rig.source_path.parent if rig.source_path is not None else None


def camera_stream_uri(rig: Rig) -> str:
    """`[camera] source = "onvif"`: the camera's own stream, as GetStreamUri gives it (raises
    `LinkError`, `HandshakeError`, `DeviceError`)."""
    servo = rig.servo
    if not isinstance(servo, OnvifServo):
        raise HandshakeError(
            f'[camera] source = "onvif" asks an ONVIF camera, but [servo] is {servo.protocol}'
        )
    with OnvifHead(servo, folder=rig_folder(rig)) as camera:
        return camera.stream_uri()


def onvif_driver(
    rig: Rig,
    *,
    password: str | None = None,
    transport: httpx.BaseTransport | None = None,
    mono_s: Callable[[], float] = time.monotonic,
    wall_ns: Callable[[], int] = time.time_ns,
) -> SpeedHead:
    """The rig's ONVIF camera; `password` and `transport` replace the rig's (tests)."""
    servo = rig.servo
    assert isinstance(servo, OnvifServo)
    camera = OnvifHead(
        servo, folder=rig_folder(rig), password=password, transport=transport, wall_ns=wall_ns
    )

    def by_speed(_device: SpeedDevice) -> bool:
        return servo.mode == "speed" or not (
            camera.capabilities is not None and camera.capabilities.absolute
        )

    return speed_head(rig, camera, mono_s=mono_s, wall_ns=wall_ns, by_speed=by_speed)
