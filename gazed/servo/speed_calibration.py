"""`gazed calibrate speeds`: measure the rate of each speed step of a head driven by speed (an
ONVIF camera's ContinuousMove, a VISCA or Pelco-D drive) and how long it takes to act on a speed
command, with its own position readings, and print the rig's keys (`pan_speed_steps_deg_s`,
`tilt_speed_steps_deg_s`, `speed_latency_ms`).

    gazed calibrate speeds --rig RIG [--steps N] [--seconds S]

For each axis and each step k of N (velocity k/N), the camera runs at that speed towards the
farther of its joint limits. Readings taken in the first `SETTLE_S` (the camera gathering
speed) are left out; the rate is the least-squares slope of the rest against their dates. The
line crosses the angle the camera started from when a head that jumped to the rate would have
set off; less the half of the ramp to the rate at the `[head]` acceleration limit that this
adds, and the time the command was sent, that is the latency, whose median over the steps is
printed. The run ends early, with Stop, once the camera could no longer brake before the limit
at its rate and acceleration limit, so it never leaves the limits; then it stops and reads the
next step.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from gazed.config import HeadSection, Rig, load_rig_or_exit
from gazed.config.servo import SPEED_PROTOCOLS, OnvifServo
from gazed.servo import make_codec
from gazed.servo.codec import CodecError, HandshakeError
from gazed.servo.drive_speeds import DriveSpeeds, drive_rates_rad_s
from gazed.servo.driver import DeviceError, ServoDriver, ServoTimeout
from gazed.servo.onvif_driver import rig_folder
from gazed.servo.onvif_head import OnvifHead
from gazed.servo.speed_mode import SpeedDevice
from gazed.servo.speed_steps import rig_speed_steps
from gazed.servo.transport import LinkError
from gazed.servo.visca_ip_transport import open_transport
from gazed.sim.head_mechanics import device_bounds

SETTLE_S = 0.3
MIN_READINGS = 3


def speeds_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rig", required=True, type=Path, help="rig description (TOML)")
    parser.add_argument(
        "--steps",
        type=int,
        help="speed steps per axis (default: the rig's tables, or the protocol's speed codes)",
    )
    parser.add_argument(
        "--seconds", type=float, default=1.5, help="how long to run each step (default 1.5)"
    )


def speeds_command(args: argparse.Namespace) -> int:
    rig = load_rig_or_exit(args.rig)
    servo = rig.servo
    if servo.protocol not in SPEED_PROTOCOLS:
        print(f"gazed calibrate speeds: the {servo.protocol} head takes no speed commands")
        return 2
    pan_steps, tilt_steps = (table.count for table in rig_speed_steps(rig))
    steps = (args.steps, args.steps) if args.steps else (pan_steps, tilt_steps)
    if min(steps) < 1 or not args.seconds > SETTLE_S:
        print(f"gazed calibrate speeds: expected --steps >= 1 and --seconds > {SETTLE_S}")
        return 2
    try:
        with connected_speed_device(rig) as device:
            *tables, latency_ms = measure_speeds(
                device, rig.head, steps, args.seconds, 1.0 / servo.odometry_rate_hz
            )
    except (LinkError, HandshakeError, DeviceError, CodecError, ValueError) as exc:
        print(f"failed: {exc}")
        return 1
    for key, table in zip(("pan_speed_steps_deg_s", "tilt_speed_steps_deg_s"), tables, strict=True):
        print(f"{key} = [{', '.join(f'{rate:.2f}' for rate in table)}]")
        if any(b <= a for a, b in zip([0.0, *table], table, strict=False)):
            print(f"# {key}: not rising with the step; run again, or with fewer --steps")
    print(f"speed_latency_ms = {latency_ms:.1f}")
    return 0


@contextlib.contextmanager
def connected_speed_device(rig: Rig) -> Iterator[SpeedDevice]:
    """The rig's head as a speed device, connected for the `with` block."""
    servo = rig.servo
    device: OnvifHead | DriveSpeeds
    if isinstance(servo, OnvifServo):
        device = OnvifHead(servo, folder=rig_folder(rig))
    else:
        timeout_s = servo.timeout_ms / 1000.0
        driver = ServoDriver(
            make_codec(servo.protocol, **rig.servo_params()),
            open_transport(servo.port, servo.baud, timeout_s),
            timeout_s,
        )
        device = DriveSpeeds(driver, drive_rates_rad_s(servo))
    device.connect()
    try:
        if isinstance(device, OnvifHead) and not (
            device.capabilities and device.capabilities.continuous
        ):
            raise ValueError("the camera has no continuous moves to measure")
        yield device
    finally:
        device.disconnect()


def measure_speeds(
    device: SpeedDevice,
    head: HeadSection,
    steps: tuple[int, int],
    seconds: float,
    poll_s: float,
    mono_s: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> tuple[list[float], list[float], float]:
    """Each axis's rate (deg/s) at its steps 1..N (`steps` per axis), measured on `device`, and
    the median latency (ms) from a speed command to the head acting on it."""
    bounds = device_bounds(head)
    tables: tuple[list[float], list[float]] = ([], [])
    latencies_s = []
    for axis in (0, 1):
        for step in range(1, steps[axis] + 1):
            rate, latency_s = _run_step(
                device,
                axis,
                step / steps[axis],
                bounds[axis],
                head.accel_max_rad_s2[axis],
                seconds,
                poll_s,
                mono_s,
                sleep,
            )
            tables[axis].append(math.degrees(rate))
            latencies_s.append(latency_s - rate / (2.0 * head.accel_max_rad_s2[axis]))
    return tables[0], tables[1], max(0.0, float(np.median(latencies_s))) * 1000.0


def _run_step(
    camera: SpeedDevice,
    axis: int,
    fraction: float,
    bounds: tuple[float, float],
    accel_rad_s2: float,
    seconds: float,
    poll_s: float,
    mono_s: Callable[[], float],
    sleep: Callable[[float], None],
) -> tuple[float, float]:
    """Run one axis at `fraction` towards its farther limit; the rate its readings show, and
    when (after the command was sent) that rate's line leaves the starting angle."""
    lower, upper = bounds
    start = camera.query_position()
    at = (start.pan_rad, start.tilt_rad)[axis]
    sign = 1.0 if upper - at >= at - lower else -1.0
    velocity = [0.0, 0.0]
    velocity[axis] = sign * fraction
    began_s = mono_s()
    renewed_s = -math.inf
    sent_s: float | None = None
    readings: list[tuple[float, float]] = []
    last: tuple[float, float] | None = None
    try:
        while (now_s := mono_s()) - began_s < seconds:
            if now_s - renewed_s > seconds / 2.0:
                t_ns = camera.set_speed(velocity[0], velocity[1], seconds)
                sent_s = t_ns / 1e9 if sent_s is None else sent_s
                renewed_s = now_s
            sleep(poll_s)
            try:
                position = camera.query_position()
            except ServoTimeout:
                continue  # a reply lost on the network (counted by the link): poll on
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
    t0_s = times[0]  # fitted about the first reading: seconds since the epoch lose digits
    slope, offset = np.polyfit(np.subtract(times, t0_s), angles, 1)
    assert sent_s is not None
    crossed_s = t0_s + ((start.pan_rad, start.tilt_rad)[axis] - offset) / slope
    return abs(float(slope)), float(crossed_s - sent_s)
