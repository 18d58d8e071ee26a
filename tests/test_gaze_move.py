"""A move of the head (gazed.gaze.move) and the look-and-move cycle (gazed.gaze.look_and_move):
at rest, at the goal, settled for settle_ms; the move's goal from the arrival aim."""

from __future__ import annotations

import math

import pytest
from test_gaze_controller import T0, Clock, detection

from gazed.config import parse_rig
from gazed.gaze.aim import Aim, MoveLimits, move_duration_s
from gazed.gaze.look_and_move import LookAndMove
from gazed.gaze.move import Move, Settling, at_goal, at_rest
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import Detection, HeadPose, Odometry

RIG = parse_rig('[rig]\nname = "m"\n')
KINEMATICS = HeadKinematics.from_section(RIG.head)
DEG = math.radians(1.0)
LIMITS = MoveLimits((100 * DEG, 100 * DEG), (400 * DEG, 400 * DEG))


def odometry(pan_deg: float, tilt_deg: float = 0.0, rate_deg_s: float = 0.0) -> Odometry:
    return Odometry(
        t_capture_ns=T0,
        pan_rad=pan_deg * DEG,
        tilt_rad=tilt_deg * DEG,
        pan_rate_rad_s=rate_deg_s * DEG,
    )


def settling() -> Settling:
    return Settling(KINEMATICS, tolerance_rad=0.5 * DEG, settle_s=0.1)


def test_at_rest_below_two_degrees_a_second_on_both_joints() -> None:
    assert at_rest(HeadPose(pan_rad=0.0, tilt_rad=0.0, pan_rate_rad_s=1.9 * DEG))
    assert not at_rest(HeadPose(pan_rad=0.0, tilt_rad=0.0, tilt_rate_rad_s=-2.0 * DEG))


def test_at_the_goal_means_at_rest_and_within_the_tolerance() -> None:
    goal = (10 * DEG, 0.0)
    assert at_goal(odometry(10.4), goal, 0.5 * DEG, KINEMATICS)
    assert not at_goal(odometry(10.6), goal, 0.5 * DEG, KINEMATICS)
    assert not at_goal(odometry(10.0, rate_deg_s=5.0), goal, 0.5 * DEG, KINEMATICS)
    assert not at_goal(None, goal, 0.5 * DEG, KINEMATICS)


def test_settled_after_settle_s_at_the_goal_and_not_before() -> None:
    s = settling()
    goal = (10 * DEG, 0.0)
    assert not s.settled(odometry(10.0), goal, 5.0)
    assert not s.settled(odometry(10.0), goal, 5.09)
    assert not s.settled(odometry(12.0), goal, 5.095)  # overshoot: the wait starts again
    assert not s.settled(odometry(10.0), goal, 5.1)
    assert not s.settled(odometry(10.0), goal, 5.19)
    assert s.settled(odometry(10.0), goal, 5.2)
    s.restart()
    assert not s.settled(odometry(10.0), goal, 5.3)


def test_a_move_aims_at_the_arrival_and_restarts_the_settling() -> None:
    move = Move(LIMITS, settling())
    assert move.start(Aim(T0, 10 * DEG, 0.0), None, T0) is None and move.goal is None
    target = Aim(T0, 10 * DEG, 0.0, pan_rate_rad_s=20 * DEG)
    goal = move.start(target, odometry(0.0), T0)
    lead_s = move_duration_s(10 * DEG, 100 * DEG, 400 * DEG) + 0.1
    assert goal is not None and goal is move.goal
    assert goal.pan_rad == pytest.approx((10 + 20 * lead_s) * DEG)
    at_goal_deg = math.degrees(goal.pan_rad)
    assert not move.over(odometry(at_goal_deg), 1.0)
    assert move.over(odometry(at_goal_deg), 1.1)
    move.start(target, odometry(at_goal_deg), T0)  # a new move waits its own settling
    assert move.settling.since_s is None


def seen(t_ns: int) -> Detection:
    """A detection at the image centre captured at t_ns."""
    return detection(Clock(), 319.5, 239.5, age_s=(T0 - t_ns) / 1e9)


def test_look_and_move_moves_on_a_fresh_look_then_waits_for_one_after_settling() -> None:
    cycle = LookAndMove(Move(LIMITS, settling()))
    target = Aim(T0, 5 * DEG, 0.0)

    def step(found: Detection | None, pan_deg: float, wall_ns: int, mono_s: float):
        return cycle.step(found, lambda d: target, odometry(pan_deg), T0, wall_ns, mono_s)

    assert step(None, 0.0, T0, 1.0) is None  # nothing seen: hold
    assert step(seen(T0 - 1), 0.0, T0, 1.0) is None  # from before pursuit began
    move = step(seen(T0), 0.0, T0, 1.0)
    assert move is not None and move.kind == "position" and not cycle.looking
    assert move.pan_rad == pytest.approx(5 * DEG) and move.t_capture_ns == T0
    for mono_s in (1.2, 1.3):  # at the goal, settling
        demand = step(seen(T0), 5.0, T0 + 10**9, mono_s)
        assert demand is not None and demand.pan_rad == pytest.approx(5 * DEG)
    assert cycle.looking and cycle.look_since_ns == T0 + 10**9
    assert step(seen(T0 + 10**9 - 1), 5.0, T0 + 10**9, 1.4) is None  # from before settling
    assert step(seen(T0 + 10**9), 5.0, T0 + 10**9, 1.4) is not None
    assert not cycle.looking
    cycle.restart()
    assert cycle.looking
