"""Park before the port closes (`gazed.servo.park`), on an emulated Pelco-D line and its own
clock: set-points every period, never a jump, until the head is at the park angles; a park
that would take longer than its timeout stops there."""

from __future__ import annotations

import math

import pytest
from servo_link_support import link_rig, pan_setpoints_deg, pan_steps_deg
from test_servo_line import VirtualLine

from gazed.servo import make_codec
from gazed.servo.driver import ServoDriver
from gazed.servo.park import park
from gazed.servo.setpoints import SetpointGenerator

PERIOD_S = 0.02


def parked_from(pan_deg: float, timeout_s: float) -> tuple[VirtualLine, SetpointGenerator]:
    rig = link_rig()
    line = VirtualLine(rig)
    driver = ServoDriver(
        make_codec("pelco-d", **rig.servo_params()), line, 0.05, lambda: line.now_s
    )
    driver.connect()
    setpoints = SetpointGenerator(rig.head, line.now_s)
    setpoints.reset(math.radians(pan_deg), 0.0, line.now_s)
    park(
        driver,
        setpoints,
        rig.head,
        PERIOD_S,
        timeout_s,
        mono_s=lambda: line.now_s,
        sleep=lambda s: line.run_until(line.now_s + s),
    )
    return line, setpoints


def test_the_head_is_driven_to_park_without_a_jump() -> None:
    line, setpoints = parked_from(40.0, timeout_s=2.5)
    pans = pan_setpoints_deg(line.written)
    assert pans[-1] == pytest.approx(5.0)
    steps = pan_steps_deg(line.written)
    assert all(-300.0 * PERIOD_S - 0.01 <= step <= 0 for step in steps), steps
    assert setpoints.settled
    line.run_until(line.now_s + 1.0)
    pose = line.line.mechanics.pose_at(line.now_s)
    assert math.degrees(pose.pan_rad) == pytest.approx(5.0, abs=0.01)
    assert math.degrees(pose.tilt_rad) == pytest.approx(-5.0, abs=0.01)


def test_the_port_closes_on_a_parked_head_not_on_settled_set_points() -> None:
    line, setpoints = parked_from(40.0, timeout_s=2.5)
    assert setpoints.settled
    # no time after park returns: the head that follows its set-points late is there already
    pose = line.line.mechanics.pose_at(line.now_s)
    assert math.degrees(pose.pan_rad) == pytest.approx(5.0, abs=0.02)
    assert math.degrees(pose.tilt_rad) == pytest.approx(-5.0, abs=0.02)


def test_a_park_that_takes_too_long_stops_at_the_timeout() -> None:
    line, setpoints = parked_from(40.0, timeout_s=0.05)
    pans = pan_setpoints_deg(line.written)
    assert len(pans) == 4  # at 0, 20, 40 and 60 ms: the last one past the deadline
    assert not setpoints.settled and pans[-1] > 5.0
