"""The gaze's demands (gazed.gaze.demand): stamps, the limits and the acceleration ramp of the
feed-forward rates, and the hold."""

from __future__ import annotations

import math

import pytest
from test_gaze_controller import Clock, prediction

from gazed.config import parse_rig
from gazed.gaze.demand import DemandShaper, Hold, make_demand
from gazed.messages import Odometry

RIG = parse_rig(
    '[rig]\nname = "d"\n[head]\npan_max_deg = 60\npan_rate_max_deg_s = 100\n'
    "pan_accel_max_deg_s2 = 400\ntilt_rate_max_deg_s = 50\ntilt_accel_max_deg_s2 = 100\n"
)
DEG = math.radians(1.0)
T0 = 10**18


def test_a_demand_carries_its_sources_capture_and_stamps_then_the_gazes() -> None:
    alone = make_demand("hold", 0.1, 0.2, T0)
    assert alone.t_capture_ns == T0 and alone.stamps == (("gaze", T0),)
    assert (alone.pan_rate_rad_s, alone.tilt_rate_rad_s) == (0.0, 0.0)
    source = prediction(Clock(), 0.0, 0.0)
    demand = make_demand("pursuit", 0.1, 0.2, T0, source, (0.3, -0.4))
    assert demand.t_capture_ns == source.t_capture_ns
    assert [stage for stage, _ in demand.stamps] == ["vision", "estimator", "gaze"]
    assert (demand.pan_rate_rad_s, demand.tilt_rate_rad_s) == (0.3, -0.4)


def test_pursuit_rates_ramp_by_the_acceleration_limit_per_tick() -> None:
    shaper = DemandShaper(RIG.head)
    # 30°/s asked from rest, one 20 ms tick: pan may gain 8°/s (400°/s²), tilt 2°/s (100°/s²)
    first = shaper.shape(make_demand("pursuit", 0.0, 0.0, T0, None, (30 * DEG, -30 * DEG)), 0.02)
    assert first is not None
    assert (first.pan_rate_rad_s, first.tilt_rate_rad_s) == pytest.approx((8 * DEG, -2 * DEG))
    second = shaper.shape(make_demand("pursuit", 0.0, 0.0, T0, None, (30 * DEG, -30 * DEG)), 0.02)
    assert second is not None
    assert (second.pan_rate_rad_s, second.tilt_rate_rad_s) == pytest.approx((16 * DEG, -4 * DEG))
    # a position demand carries its rate unramped, and the ramp starts from rest after it
    position = shaper.shape(make_demand("position", 0.0, 0.0, T0, None, (30 * DEG, 0.0)), 0.02)
    assert position is not None and position.pan_rate_rad_s == pytest.approx(30 * DEG)
    again = shaper.shape(make_demand("pursuit", 0.0, 0.0, T0, None, (30 * DEG, 0.0)), 0.02)
    assert again is not None and again.pan_rate_rad_s == pytest.approx(8 * DEG)


def test_demands_are_clamped_to_the_joint_and_rate_limits_and_non_finite_ones_refused() -> None:
    shaper = DemandShaper(RIG.head)
    clamped = shaper.shape(make_demand("position", 70 * DEG, 0.0, T0, None, (200 * DEG, 0.0)), 1.0)
    assert clamped is not None
    assert clamped.pan_rad == pytest.approx(60 * DEG)
    assert clamped.pan_rate_rad_s == pytest.approx(100 * DEG)
    assert shaper.clamps == 2
    # a demand built by copying (no validation) can carry a NaN
    broken = make_demand("pursuit", 0.0, 0.0, T0).model_copy(update={"pan_rad": math.nan})
    assert shaper.shape(broken, 0.02) is None
    assert shaper.refused == 1


def test_a_hold_stays_where_it_began_until_released() -> None:
    hold = Hold()
    assert hold.demand(None, T0) is None  # nowhere to hold without odometry
    here = Odometry(t_capture_ns=T0, pan_rad=0.1, tilt_rad=-0.2)
    first = hold.demand(here, T0)
    assert first is not None and first.kind == "hold"
    moved = Odometry(t_capture_ns=T0 + 1, pan_rad=0.1015, tilt_rad=-0.2)
    again = hold.demand(moved, T0 + 1)
    assert again is not None and (again.pan_rad, again.tilt_rad) == (0.1, -0.2)
    hold.release()
    after = hold.demand(moved, T0 + 2)
    assert after is not None and after.pan_rad == 0.1015
