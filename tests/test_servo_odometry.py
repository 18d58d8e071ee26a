"""Odometry from position replies (`gazed.servo.odometry`): both axes at the later of their two
instants, rates from successive readings of each axis over its own instants, a pan that wraps
taken into (-π, π] and its change the short way round, the rig's signs and zeros applied."""

from __future__ import annotations

import math

import pytest

from gazed.config import HeadSection
from gazed.servo.driver import DevicePosition
from gazed.servo.odometry import OdometryDating, rate_rad_s, wrap_angle

MS = 1_000_000


def test_wrap_angle_is_into_minus_pi_exclusive_to_pi_inclusive() -> None:
    assert wrap_angle(math.pi) == math.pi
    assert wrap_angle(-math.pi) == math.pi
    assert wrap_angle(1.5 * math.pi) == pytest.approx(-0.5 * math.pi)
    assert wrap_angle(-1.5 * math.pi) == pytest.approx(0.5 * math.pi)
    assert wrap_angle(0.25) == 0.25


def test_a_rate_over_no_time_is_zero() -> None:
    assert rate_rad_s(1.0, 0) == 0.0
    assert rate_rad_s(1.0, -5) == 0.0
    assert rate_rad_s(0.5, 250 * MS) == pytest.approx(2.0)


def test_the_first_reading_has_no_rate_and_is_dated_by_the_later_axis() -> None:
    dating = OdometryDating(HeadSection(), pan_wraps=False)
    reading = dating.reading(DevicePosition(0.1, -0.2, 1000 * MS, 1016 * MS))
    assert reading.t_ns == 1016 * MS
    assert (reading.pan_rad, reading.tilt_rad) == (0.1, -0.2)
    assert (reading.pan_rate_rad_s, reading.tilt_rate_rad_s) == (0.0, 0.0)
    assert not reading.dead_reckoned


def test_rates_over_each_axis_instants_and_both_axes_moved_to_the_later_one() -> None:
    """Pan read 16 ms before tilt, each 20 ms after its previous reading: pan's rate is its own
    change over its own 20 ms, and pan is carried 16 ms on at that rate."""
    dating = OdometryDating(HeadSection(), pan_wraps=False)
    dating.reading(DevicePosition(0.0, 0.0, 1000 * MS, 1016 * MS))
    reading = dating.reading(DevicePosition(0.02, -0.01, 1020 * MS, 1036 * MS))
    assert reading.pan_rate_rad_s == pytest.approx(1.0)
    assert reading.tilt_rate_rad_s == pytest.approx(-0.5)
    assert reading.t_ns == 1036 * MS
    assert reading.pan_rad == pytest.approx(0.02 + 1.0 * 0.016)
    assert reading.tilt_rad == pytest.approx(-0.01)  # read at the reading's instant itself


def test_a_pan_that_wraps_changes_the_short_way_round() -> None:
    dating = OdometryDating(HeadSection(pan_min_deg=-180, pan_max_deg=180), pan_wraps=True)
    dating.reading(DevicePosition(math.radians(179.0), 0.0, 0, 0))
    reading = dating.reading(DevicePosition(math.radians(181.0), 0.0, 100 * MS, 100 * MS))
    assert reading.pan_rad == pytest.approx(math.radians(-179.0))
    assert reading.pan_rate_rad_s == pytest.approx(math.radians(20.0))  # 2° in 0.1 s, not -358°


def test_a_pan_that_does_not_wrap_is_left_as_it_is() -> None:
    dating = OdometryDating(HeadSection(pan_min_deg=-200, pan_max_deg=200), pan_wraps=False)
    pan, _ = dating.joint(DevicePosition(math.radians(190.0), 0.0, 0, 0))
    assert pan == pytest.approx(math.radians(190.0))


def test_the_rigs_signs_and_zeros_turn_device_angles_into_joint_angles() -> None:
    head = HeadSection(pan_sign=-1, pan_zero_deg=10.0, tilt_zero_deg=-5.0)
    dating = OdometryDating(head, pan_wraps=False)
    pan, tilt = dating.joint(DevicePosition(math.radians(30.0), math.radians(-5.0), 0, 0))
    assert math.degrees(pan) == pytest.approx(-20.0)
    assert math.degrees(tilt) == pytest.approx(0.0)


def test_reset_forgets_the_last_reading() -> None:
    dating = OdometryDating(HeadSection(), pan_wraps=False)
    dating.reading(DevicePosition(0.0, 0.0, 0, 0))
    dating.reset()
    reading = dating.reading(DevicePosition(0.5, 0.5, 100 * MS, 100 * MS))
    assert (reading.pan_rate_rad_s, reading.tilt_rate_rad_s) == (0.0, 0.0)
