"""`gazed calibrate speeds`: measure the rate of each speed step of an ONVIF camera with its own
position readings, and print the rig's table (`pan_speed_steps_deg_s`, `tilt_speed_steps_deg_s`).

    gazed calibrate speeds --rig RIG [--steps N] [--seconds S]

For each axis and each step k of N (velocity k/N), the camera runs at that speed towards the
farther of its joint limits. Readings taken in the first `SETTLE_S` (the camera gathering
speed) are left out; the rate is the least-squares slope of the rest against their dates. The
run ends early, with Stop, once the camera could no longer brake before the limit at its rate
and acceleration limit, so it never leaves the limits; then it stops and reads the next step.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from gazed.config import HeadSection, load_rig_or_exit
from gazed.config.servo import OnvifServo
from gazed.servo.codec import CodecError, HandshakeError
from gazed.servo.driver import DeviceError
from gazed.servo.onvif_driver import rig_folder
from gazed.servo.onvif_head import OnvifHead
from gazed.servo.speed_mode import DEFAULT_STEPS
from gazed.servo.transport import LinkError
from gazed.sim.head_mechanics import device_bounds

SETTLE_S = 0.3
MIN_READINGS = 3


def speeds_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rig", required=True, type=Path, help="rig description (TOML)")
    parser.add_argument(
        "--steps",
        type=int,
        help="speed steps per axis (default: the rig's table length, or 32)",
    )
    parser.add_argument(
        "--seconds", type=float, default=1.5, help="how long to run each step (default 1.5)"
    )


def speeds_command(args: argparse.Namespace) -> int:
    rig = load_rig_or_exit(args.rig)
    servo = rig.servo
    if not isinstance(servo, OnvifServo):
        print(f"gazed calibrate speeds: the {servo.protocol} head takes no speed steps here")
        return 2
    steps = args.steps or len(servo.pan_speed_steps_deg_s) or DEFAULT_STEPS
    if steps < 1 or not args.seconds > SETTLE_S:
        print(f"gazed calibrate speeds: expected --steps >= 1 and --seconds > {SETTLE_S}")
        return 2
    try:
        with OnvifHead(servo, folder=rig_folder(rig)) as camera:
            tables = measure_speeds(
                camera, rig.head, steps, args.seconds, 1.0 / servo.odometry_rate_hz
            )
    except (LinkError, HandshakeError, DeviceError, CodecError, ValueError) as exc:
        print(f"failed: {exc}")
        return 1
    for key, table in zip(("pan_speed_steps_deg_s", "tilt_speed_steps_deg_s"), tables, strict=True):
        print(f"{key} = [{', '.join(f'{rate:.2f}' for rate in table)}]")
        if any(b <= a for a, b in zip([0.0, *table], table, strict=False)):
            print(f"# {key}: not rising with the step; run again, or with fewer --steps")
    return 0


def measure_speeds(
    camera: OnvifHead,
    head: HeadSection,
    steps: int,
    seconds: float,
    poll_s: float,
    mono_s: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> tuple[list[float], list[float]]:
    """Each axis's rate (deg/s) at steps 1..`steps`, measured on `camera`."""
    caps = camera.capabilities
    if caps is None or not caps.continuous:
        raise ValueError("the camera has no continuous moves to measure")
    bounds = device_bounds(head)
    tables: tuple[list[float], list[float]] = ([], [])
    for axis in (0, 1):
        for step in range(1, steps + 1):
            rate = _run_step(
                camera,
                axis,
                step / steps,
                bounds[axis],
                head.accel_max_rad_s2[axis],
                seconds,
                poll_s,
                mono_s,
                sleep,
            )
            tables[axis].append(math.degrees(rate))
    return tables


def _run_step(
    camera: OnvifHead,
    axis: int,
    fraction: float,
    bounds: tuple[float, float],
    accel_rad_s2: float,
    seconds: float,
    poll_s: float,
    mono_s: Callable[[], float],
    sleep: Callable[[float], None],
) -> float:
    """Run one axis at `fraction` towards its farther limit; the rate its readings show."""
    lower, upper = bounds
    start = camera.query_position()
    at = (start.pan_rad, start.tilt_rad)[axis]
    sign = 1.0 if upper - at >= at - lower else -1.0
    velocity = [0.0, 0.0]
    velocity[axis] = sign * fraction
    began_s = mono_s()
    renewed_s = -math.inf
    readings: list[tuple[float, float]] = []
    last: tuple[float, float] | None = None
    try:
        while (now_s := mono_s()) - began_s < seconds:
            if now_s - renewed_s > seconds / 2.0:
                camera.set_speed(velocity[0], velocity[1], seconds)
                renewed_s = now_s
            sleep(poll_s)
            position = camera.query_position()
            angle, t_s = (position.pan_rad, position.tilt_rad)[axis], position.t_pan_ns / 1e9
            if mono_s() - began_s >= SETTLE_S:
                readings.append((t_s, angle))
            rate = abs(angle - last[1]) / (t_s - last[0]) if last and t_s > last[0] else 0.0
            last = (t_s, angle)
            room = (upper - angle) if sign > 0 else (angle - lower)
            if room <= rate * rate / (2.0 * accel_rad_s2) + 2.0 * rate * poll_s:
                break  # it must brake now to stop inside the limit
    finally:
        camera.stop()
    sleep(SETTLE_S)  # at rest before the next step
    if len(readings) < MIN_READINGS:
        raise ValueError(
            f"{'pan' if axis == 0 else 'tilt'} at velocity {fraction:.3f}: too few readings "
            "before the limit (lower --seconds, or start nearer the middle)"
        )
    times, angles = zip(*readings, strict=True)
    return abs(float(np.polyfit(times, angles, 1)[0]))
