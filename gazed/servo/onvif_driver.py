"""The ONVIF head as the head link drives it: `OnvifHead` behind `SpeedHead`, which sends the
set-points as AbsoluteMove in position mode and as ContinuousMove speeds in speed mode
(`[servo] mode = "speed"`, or a camera whose PTZ node has no absolute moves)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path

import httpx

from gazed.config import Rig
from gazed.config.servo import OnvifServo
from gazed.servo.onvif_head import OnvifHead
from gazed.servo.speed_mode import SpeedDevice, SpeedHead, SpeedSteps


def speed_steps(steps_deg_s: list[float], rate_max_deg_s: float) -> SpeedSteps:
    """The rig's table of rates per step, or even steps up to the rate at velocity 1."""
    if steps_deg_s:
        return SpeedSteps([math.radians(rate) for rate in steps_deg_s])
    return SpeedSteps.even(math.radians(rate_max_deg_s))


def rig_folder(rig: Rig) -> Path | None:
    """The rig file's folder, which a relative password file is taken from."""
    return rig.source_path.parent if rig.source_path is not None else None


def camera_stream_uri(rig: Rig) -> str:
    """`[camera] source = "onvif"`: the camera's own stream, as GetStreamUri gives it (raises
    `LinkError`, `HandshakeError`, `DeviceError`)."""
    servo = rig.servo
    assert isinstance(servo, OnvifServo)
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

    return SpeedHead(
        camera,
        rig.head,
        (
            speed_steps(servo.pan_speed_steps_deg_s, servo.pan_speed_max_deg_s),
            speed_steps(servo.tilt_speed_steps_deg_s, servo.tilt_speed_max_deg_s),
        ),
        gain_per_s=servo.speed_gain_per_s,
        command_timeout_s=servo.command_timeout_ms / 1000.0,
        poll_period_s=1.0 / servo.odometry_rate_hz,
        mono_s=mono_s,
        wall_ns=wall_ns,
        by_speed=by_speed,
    )
