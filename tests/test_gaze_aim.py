"""Aims (gazed.gaze.aim): extrapolation, image points to joint angles, move durations at the
limits, and the saccade's arrival aim, against closed forms."""

from __future__ import annotations

import math

import pytest
from test_gaze_controller import Clock, detection, prediction

from gazed.config import parse_rig
from gazed.gaze.aim import (
    Aim,
    MoveLimits,
    angle_between,
    arrival_aim,
    detection_aim,
    image_aim,
    move_duration_s,
)
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import HeadPose

RIG = parse_rig('[rig]\nname = "a"\n')
CAMERA = CameraModel.from_section(RIG.camera)
KINEMATICS = HeadKinematics.from_section(RIG.head)
F = CAMERA.K[0, 0]
CX, CY = CAMERA.K[0, 2], CAMERA.K[1, 2]
T0 = 10**18
DEG = math.radians(1.0)
LIMITS = MoveLimits((100 * DEG, 50 * DEG), (400 * DEG, 100 * DEG))  # pan, tilt


def test_an_aim_extrapolates_at_its_rates_both_ways_in_time() -> None:
    aim = Aim(T0, 0.1, -0.2, pan_rate_rad_s=0.5, tilt_rate_rad_s=-1.0)
    assert aim.at(T0 + 200_000_000) == pytest.approx((0.2, -0.4))
    assert aim.at(T0 - 100_000_000) == pytest.approx((0.05, -0.1))
    assert aim.at(T0) == (0.1, -0.2)


def test_a_prediction_is_an_aim_for_the_instant_it_was_made_for() -> None:
    clock = Clock()
    p = prediction(clock, 10.0, -5.0, pan_rate_deg_s=20.0, actuation_s=0.03)
    aim = Aim.of_prediction(p)
    assert aim == Aim(clock.wall_ns + 30_000_000, 10 * DEG, -5 * DEG, 20 * DEG, 0.0)


def test_an_image_point_aims_by_its_offset_from_the_centre() -> None:
    """200 px right of the centre, moving right at 100 px/s, seen from pan 10°: pan by
    atan(200/F) more, at a rate of 100/F · cos²(atan(200/F)); tilt unchanged."""
    head = HeadPose(pan_rad=10 * DEG, tilt_rad=0.0)
    aim = image_aim(CAMERA, KINEMATICS, head, T0, (CX + 200.0, CY), (100.0, 0.0))
    off = math.atan(200.0 / F)
    assert aim.t_ns == T0
    assert aim.pan_rad == pytest.approx(10 * DEG + off, abs=1e-9)
    assert aim.tilt_rad == pytest.approx(0.0, abs=1e-9)
    assert aim.pan_rate_rad_s == pytest.approx(100.0 / F * math.cos(off) ** 2, rel=1e-6)
    assert aim.tilt_rate_rad_s == pytest.approx(0.0, abs=1e-9)
    below = image_aim(
        CAMERA, KINEMATICS, HeadPose(pan_rad=0.0, tilt_rad=0.0), T0, (CX, CY + 100.0), (0.0, 0.0)
    )
    assert below.tilt_rad == pytest.approx(-math.atan(100.0 / F), abs=1e-9)  # image v is down


def test_a_detection_aims_from_its_own_head_pose_at_its_capture() -> None:
    clock = Clock()
    seen = detection(clock, CX, CY, head_deg=(12.0, -6.0), du=50.0, age_s=0.04)
    aim = detection_aim(ZoomLens.fixed(CAMERA), KINEMATICS, seen)
    assert aim.t_ns == clock.wall_ns - 40_000_000
    assert (aim.pan_rad, aim.tilt_rad) == pytest.approx((12 * DEG, -6 * DEG), abs=1e-9)
    # at tilt t, an image step of du turns the pan axis by du / (F cos t)
    assert aim.pan_rate_rad_s == pytest.approx(50.0 / F / math.cos(6 * DEG), rel=1e-3)


def test_move_durations_follow_the_triangle_and_trapezoid_profiles() -> None:
    rate, accel = 100 * DEG, 400 * DEG  # full rate after 25° of accelerating and braking
    assert move_duration_s(10 * DEG, rate, accel) == pytest.approx(2 * math.sqrt(10 / 400))
    assert move_duration_s(-10 * DEG, rate, accel) == pytest.approx(2 * math.sqrt(10 / 400))
    assert move_duration_s(25 * DEG, rate, accel) == pytest.approx(0.5)
    assert move_duration_s(40 * DEG, rate, accel) == pytest.approx(0.5 + 15 / 100)
    assert move_duration_s(0.0, rate, accel) == 0.0


def test_a_move_takes_as_long_as_its_slower_axis() -> None:
    # pan 10° at 100°/s, 400°/s²: 0.316 s; tilt 5° at 50°/s, 100°/s²: 2·sqrt(5/100) = 0.447 s
    assert LIMITS.duration_s(10 * DEG, 5 * DEG) == pytest.approx(2 * math.sqrt(5 / 100))
    assert LIMITS.duration_s(10 * DEG, -1 * DEG) == pytest.approx(2 * math.sqrt(10 / 400))


def test_the_arrival_aim_leads_the_target_by_the_move_and_the_settling() -> None:
    """Seen 100 ms ago at pan 10° moving at 20°/s: now at 12°; the pan move of 12° takes
    2·sqrt(12/400) s, then 0.1 s settling; the goal is where the target is then."""
    seen = Aim(T0 - 100_000_000, 10 * DEG, -2 * DEG, pan_rate_rad_s=20 * DEG)
    goal = arrival_aim(seen, (0.0, 0.0), T0, LIMITS, settle_s=0.1)
    lead_s = 2 * math.sqrt(12 / 400) + 0.1
    assert goal.t_ns == T0 + round(lead_s * 1e9)
    assert math.degrees(goal.pan_rad) == pytest.approx(10 + 20 * (0.1 + lead_s), abs=1e-6)
    assert math.degrees(goal.tilt_rad) == pytest.approx(-2.0, abs=1e-9)
    assert (goal.pan_rate_rad_s, goal.tilt_rate_rad_s) == (0.0, 0.0)  # a goal, not a track


def test_the_arrival_aim_waits_for_the_slower_axis_from_where_the_head_is() -> None:
    """From pan 12°, tilt 0 to a target at pan 12°, tilt 5° moving at 10°/s in pan: only the
    (slow) tilt axis moves, 0.447 s, and the target moves on in pan meanwhile."""
    target = Aim(T0, 12 * DEG, 5 * DEG, pan_rate_rad_s=10 * DEG)
    goal = arrival_aim(target, (12 * DEG, 0.0), T0, LIMITS, settle_s=0.0)
    lead_s = 2 * math.sqrt(5 / 100)
    assert goal.t_ns == T0 + round(lead_s * 1e9)
    assert math.degrees(goal.pan_rad) == pytest.approx(12 + 10 * lead_s, abs=1e-6)
    assert math.degrees(goal.tilt_rad) == pytest.approx(5.0, abs=1e-9)
    # from pan -20°, the same target is 32° away: a trapezoid of 0.5 + 7/100 s, longer than tilt
    goal = arrival_aim(target, (-20 * DEG, 0.0), T0, LIMITS, settle_s=0.0)
    assert goal.t_ns == T0 + round(0.57 * 1e9)
    assert math.degrees(goal.pan_rad) == pytest.approx(12 + 10 * 0.57, abs=1e-6)


def test_angle_between_two_gazes() -> None:
    assert angle_between(0.0, 0.0, 0.3, 0.0, KINEMATICS) == pytest.approx(0.3)
    assert angle_between(0.1, 0.2, 0.1, 0.2, KINEMATICS) == pytest.approx(0.0, abs=1e-7)
    # pan-tilt head: the same pan difference at 60° tilt spans half the angle on the sphere
    assert angle_between(0.0, math.radians(60), 0.2, math.radians(60), KINEMATICS) == pytest.approx(
        2 * math.asin(0.5 * math.sin(0.1)), rel=1e-6
    )
