"""Rate/acceleration-limited axis motion, the demand limiter and the set-point generator: closed
forms of the time-optimal move, bounds, and the counts of every clamp."""

from __future__ import annotations

import math

import pytest

from gazed.config import parse_rig
from gazed.messages import GazeDemand
from gazed.servo.axis_motion import STEP_S, AxisMotion
from gazed.servo.limits import DemandLimiter
from gazed.servo.setpoints import SetpointGenerator

RATE, ACCEL = 2.0, 10.0


def run(axis: AxisMotion, duration_s: float) -> list[tuple[float, float]]:
    """(position, velocity) every millisecond."""
    samples = []
    for _ in range(round(duration_s / STEP_S)):
        axis.advance(STEP_S)
        samples.append((axis.position_rad, axis.velocity_rad_s))
    return samples


def settle_time(axis: AxisMotion, limit_s: float = 10.0) -> float:
    t = 0.0
    while not axis.settled and t < limit_s:
        axis.advance(STEP_S)
        t += STEP_S
    return t


@pytest.mark.parametrize(
    ("distance", "expected_s"),
    [
        (1.0, 1.0 / RATE + RATE / ACCEL),  # trapezoid: cruise at the rate limit
        (0.2, 2.0 * math.sqrt(0.2 / ACCEL)),  # triangle: never reaches it
        (-0.5, 0.5 / RATE + RATE / ACCEL),
    ],
)
def test_moves_take_the_time_optimal_time(distance: float, expected_s: float) -> None:
    axis = AxisMotion(RATE, ACCEL)
    axis.move_to(distance)
    assert settle_time(axis) == pytest.approx(expected_s, abs=0.006)
    assert axis.position_rad == distance


def test_moves_respect_the_limits_and_do_not_overshoot() -> None:
    axis = AxisMotion(RATE, ACCEL)
    axis.move_to(1.3)
    samples = run(axis, 1.2)
    positions = [p for p, _ in samples]
    velocities = [v for _, v in samples]
    assert max(abs(v) for v in velocities) <= RATE + 1e-12
    # acceleration over 10 ms windows (the last step may stop from a·h)
    window = 10
    accels = [
        abs(velocities[i + window] - velocities[i]) / (window * STEP_S)
        for i in range(len(velocities) - window)
    ]
    assert max(accels) <= ACCEL * (1 + 1 / window) + 1e-9
    assert max(positions) <= 1.3 + 1e-6
    assert positions == sorted(positions)


def test_a_constant_rate_target_is_tracked_without_lag() -> None:
    axis = AxisMotion(RATE, ACCEL)
    axis.move_to(0.0, target_rate_rad_s=0.5)
    run(axis, 2.0)
    assert axis.velocity_rad_s == pytest.approx(0.5)
    assert axis.position_rad == pytest.approx(axis.target_rad, abs=1e-6)
    assert axis.target_rad == pytest.approx(1.0, abs=2e-3)


def test_hold_stops_in_the_braking_distance() -> None:
    axis = AxisMotion(RATE, ACCEL)
    axis.move_at(RATE)
    run(axis, 0.5)
    start = axis.position_rad
    axis.hold()
    settle_time(axis)
    assert axis.position_rad - start == pytest.approx(RATE**2 / (2 * ACCEL), abs=0.005)


def test_bounds_clamp_targets_and_stop_velocity_moves() -> None:
    axis = AxisMotion(RATE, ACCEL, lower_rad=-0.3, upper_rad=0.4)
    axis.move_to(2.0)
    assert axis.target_rad == 0.4 and axis.clamps == 1
    settle_time(axis)
    axis.move_at(-RATE)
    run(axis, 1.0)
    assert axis.position_rad == -0.3
    assert axis.limit_hit


def rig(**head: float):
    keys = "\n".join(f"{k} = {v}" for k, v in head.items())
    return parse_rig(f'[rig]\nname = "m"\n[head]\n{keys}\n')


def demand(kind: str = "pursuit", **values: float) -> GazeDemand:
    fields = {"pan_rad": 0.0, "tilt_rad": 0.0, **values}
    return GazeDemand(t_capture_ns=1, kind=kind, **fields)


def test_limiter_clamps_and_counts_every_axis() -> None:
    limiter = DemandLimiter(rig(pan_max_deg=60, tilt_min_deg=-30, pan_rate_max_deg_s=90).head)
    target = limiter.limit(demand(pan_rad=math.radians(75), tilt_rad=math.radians(-45)))
    assert math.degrees(target.pan_rad) == pytest.approx(60)
    assert math.degrees(target.tilt_rad) == pytest.approx(-30)
    assert (limiter.joint_clamps, limiter.rate_clamps, limiter.refused) == (2, 0, 0)
    target = limiter.limit(demand(pan_rate_rad_s=-10.0))
    assert math.degrees(target.pan_rate_rad_s) == pytest.approx(-90)
    assert limiter.rate_clamps == 1
    assert limiter.limit(demand(pan_rad=0.1)) is not None
    assert limiter.clamps == 3


def test_limiter_refuses_non_finite() -> None:
    limiter = DemandLimiter(rig().head)
    nan = GazeDemand.model_construct(
        t_capture_ns=1,
        kind="position",
        pan_rad=math.nan,
        tilt_rad=0.0,
        pan_rate_rad_s=0.0,
        tilt_rate_rad_s=0.0,
        stamps=(),
    )
    assert limiter.limit(nan) is None
    inf = nan.model_copy(update={"pan_rad": 0.0, "tilt_rate_rad_s": math.inf})
    assert limiter.limit(inf) is None
    assert limiter.refused == 2 and limiter.clamps == 0


def test_park_and_hold_demands() -> None:
    limiter = DemandLimiter(rig(park_pan_deg=10, park_tilt_deg=-5).head)
    park = limiter.limit(demand("park", pan_rad=1.0, pan_rate_rad_s=1.0))
    assert (math.degrees(park.pan_rad), math.degrees(park.tilt_rad)) == pytest.approx((10, -5))
    assert park.pan_rate_rad_s == 0.0
    hold = limiter.limit(demand("hold", pan_rad=0.2, pan_rate_rad_s=1.0))
    assert (hold.pan_rad, hold.pan_rate_rad_s) == (0.2, 0.0)


def test_setpoints_never_jump() -> None:
    head = rig(pan_rate_max_deg_s=60, pan_accel_max_deg_s2=300).head
    generator = SetpointGenerator(head, 0.0)
    generator.track(DemandLimiter(head).limit(demand("position", pan_rad=math.radians(90))), 0.0)
    previous, t = 0.0, 0.0
    for _ in range(100):
        t += 0.02
        pan, _ = generator.advance(t)
        assert abs(pan - previous) <= math.radians(60) * 0.02 + 1e-9
        previous = pan
    assert math.degrees(pan) == pytest.approx(90)  # 1.5 s + 0.2 s of acceleration < 2 s


def test_setpoints_extrapolate_pursuit_and_count_limit_hits() -> None:
    head = rig(pan_max_deg=20).head
    generator = SetpointGenerator(head, 0.0)
    target = DemandLimiter(head).limit(
        demand(pan_rad=math.radians(10), pan_rate_rad_s=math.radians(10))
    )
    generator.track(target, 0.0)
    pan, _ = generator.advance(3.0)
    assert math.degrees(pan) == pytest.approx(20)  # 10 + 10 deg/s, stopped at the limit
    assert generator.clamps == 1
