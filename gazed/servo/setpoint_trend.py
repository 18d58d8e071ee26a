"""Where the set-points written to a speed-driven head are heading (speed mode's feed-forward is
the set-points' rate when its command acts, a latency after it is sent): as their generator
plans them, or, where it is not known, from the last three written (their rates and the rates'
change) run on a while."""

from __future__ import annotations

import copy
import math

from gazed.config import HeadSection
from gazed.geometry.kinematics import device_from_joint
from gazed.servo.axis_motion import STEP_S
from gazed.servo.drive_model import Pair
from gazed.servo.setpoints import SetpointGenerator


def planned(setpoints: SetpointGenerator, head: HeadSection, t_s: float) -> tuple[Pair, Pair, Pair]:
    """The set-points at `t_s` as their generator moves them with no new demand, in device
    angles (`head`'s signs and zeros), their rates and the rates' change then: exactly what
    the writer will send, however long since it last wrote (a busy host), braking included."""
    ahead_s = max(0.0, t_s - setpoints.t_s)
    at, rates, accels = [], [], []
    for motion, sign in ((setpoints.pan, head.pan_sign), (setpoints.tilt, head.tilt_sign)):
        axis = copy.copy(motion)
        axis.advance(ahead_s)
        at.append(axis.position_rad)
        rate = axis.velocity_rad_s
        axis.advance(STEP_S)
        rates.append(sign * rate)
        accels.append(sign * (axis.velocity_rad_s - rate) / STEP_S)
    return device_from_joint(head, at[0], at[1]), (rates[0], rates[1]), (accels[0], accels[1])


def set_point_rates(
    set_point: Pair, last: Pair, dt_s: float, last_middle: tuple[Pair, float] | None
) -> tuple[Pair, Pair, Pair]:
    """A set-point's rates and their change, `dt_s` after the `last` one: the interval's rate
    is its middle's, the change is from the previous interval's middle (`last_middle`: its
    rates and length) to this one's, and the rates at the set-point are the middle's moved on
    by half the interval. Also this interval's middle rates."""
    middle = ((set_point[0] - last[0]) / dt_s, (set_point[1] - last[1]) / dt_s)
    if last_middle is None:
        return middle, (0.0, 0.0), middle
    before, before_dt_s = last_middle
    span_s = (dt_s + before_dt_s) / 2.0
    accels = ((middle[0] - before[0]) / span_s, (middle[1] - before[1]) / span_s)
    rates = (middle[0] + accels[0] * dt_s / 2.0, middle[1] + accels[1] * dt_s / 2.0)
    return rates, accels, middle


def run_on(
    at_rad: float, rate_rad_s: float, accel_rad_s2: float, rate_max_rad_s: float, dt_s: float
) -> tuple[float, float, float]:
    """A set-point moved on `dt_s` at its rate and the rate's change, until the rate reaches
    rest (braking) or `rate_max_rad_s`; where it is, its rate and the rate's change then."""
    if accel_rad_s2 == 0.0 or dt_s <= 0.0:
        return at_rad + rate_rad_s * max(dt_s, 0.0), rate_rad_s, accel_rad_s2
    end_rad_s = (
        0.0 if accel_rad_s2 * rate_rad_s < 0.0 else math.copysign(rate_max_rad_s, accel_rad_s2)
    )
    changing_s = min(dt_s, max(0.0, (end_rad_s - rate_rad_s) / accel_rad_s2))
    rate_then = rate_rad_s + accel_rad_s2 * changing_s
    moved = (rate_rad_s + rate_then) / 2.0 * changing_s + rate_then * (dt_s - changing_s)
    return at_rad + moved, rate_then, accel_rad_s2 if changing_s == dt_s else 0.0
