"""Ego-motion: the camera's angular velocity, the rotational flow (seed 004 eq. 11) and the
K R K^-1 warp agree with each other and with the head's kinematics; odometry interpolation and
the position history used for velocities."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import HeadPose, Odometry
from gazed.vision.ego_motion import EgoMotion, apply_homography, camera_angular_velocity
from gazed.vision.odometry_history import OdometryHistory
from gazed.vision.position_history import PositionHistory

CAMERA = CameraModel.from_fov(640, 480, math.radians(60))
PIXELS = [(10.0, 12.0), (319.5, 239.5), (600.0, 70.0), (90.0, 450.0)]


def vee(skew: np.ndarray) -> np.ndarray:
    return np.array([skew[2, 1], skew[0, 2], skew[1, 0]])


@pytest.mark.parametrize("kinematics", ["pan-tilt", "tilt-pan"])
def test_angular_velocity_is_the_kinematics_derivative(kinematics: str) -> None:
    head = HeadKinematics(kinematics)
    p, t, dp, dt = 0.5, -0.35, 0.8, -0.6
    h = 1e-6
    C = head.camera_to_base(p, t)
    C_dot = (
        head.camera_to_base(p + dp * h, t + dt * h) - head.camera_to_base(p - dp * h, t - dt * h)
    ) / (2 * h)
    expected = vee(C.T @ C_dot)  # [ω]x = C^T dC/dt
    np.testing.assert_allclose(camera_angular_velocity(head, p, t, dp, dt), expected, atol=1e-8)


def test_pan_right_moves_the_world_left_and_tilt_up_moves_it_down() -> None:
    ego = EgoMotion(CAMERA, HeadKinematics())
    centre = np.array(CAMERA.K[0, 2]), np.array(CAMERA.K[1, 2])
    fu, fv = ego.flow(HeadPose(pan_rad=0, tilt_rad=0, pan_rate_rad_s=1.0), *centre)
    assert fu == pytest.approx(-CAMERA.focal_px) and fv == pytest.approx(0.0)
    fu, fv = ego.flow(HeadPose(pan_rad=0, tilt_rad=0, tilt_rate_rad_s=1.0), *centre)
    assert fu == pytest.approx(0.0) and fv == pytest.approx(CAMERA.focal_px)


@pytest.mark.parametrize("kinematics", ["pan-tilt", "tilt-pan"])
def test_rotational_flow_is_the_warp_derivative(kinematics: str) -> None:
    ego = EgoMotion(CAMERA, HeadKinematics(kinematics))
    head = HeadPose(pan_rad=0.4, tilt_rad=-0.3, pan_rate_rad_s=0.9, tilt_rate_rad_s=-0.5)
    h = 1e-6
    before = HeadPose(pan_rad=0.4 - 0.9 * h, tilt_rad=-0.3 + 0.5 * h)
    after = HeadPose(pan_rad=0.4 + 0.9 * h, tilt_rad=-0.3 - 0.5 * h)
    H = ego.homography(before, after)
    for u, v in PIXELS:
        moved = np.array(apply_homography(H, u, v))
        fu, fv = ego.flow(head, np.array(u), np.array(v))
        np.testing.assert_allclose((moved - (u, v)) / (2 * h), [fu, fv], rtol=1e-4, atol=1e-3)


@pytest.mark.parametrize("kinematics", ["pan-tilt", "tilt-pan"])
def test_warp_moves_a_static_direction_to_its_new_pixel(kinematics: str) -> None:
    head = HeadKinematics(kinematics)
    ego = EgoMotion(CAMERA, head)
    one, two = HeadPose(pan_rad=0.2, tilt_rad=0.1), HeadPose(pan_rad=0.35, tilt_rad=-0.05)
    for u, v in PIXELS:
        direction = head.camera_to_base(one.pan_rad, one.tilt_rad) @ CAMERA.ray(u, v)
        seen = CAMERA.pixel(head.camera_to_base(two.pan_rad, two.tilt_rad).T @ direction)
        np.testing.assert_allclose(
            apply_homography(ego.homography(one, two), u, v), seen, atol=1e-9
        )


def test_step_displacement_matches_the_warp_at_60_deg_per_s() -> None:
    """The flow over a frame interval (mid-interval evaluation) is second-order accurate: a
    2.4° step (60°/s at 25 Hz) moves pixels by ~23 px and the two agree within 0.1 px."""
    ego = EgoMotion(CAMERA, HeadKinematics())
    one = HeadPose(pan_rad=0.30, tilt_rad=0.10)
    two = HeadPose(pan_rad=0.30 + math.radians(2.4), tilt_rad=0.10 - math.radians(1.2))
    step = ego.step(one, two, 0.04)
    inverse = np.linalg.inv(step.H)
    for u, v in PIXELS:
        origin = np.array(apply_homography(inverse, u, v))  # where the point was
        du, dv = step.displacement(np.array(u), np.array(v))
        assert math.hypot(du, dv) > 15.0
        np.testing.assert_allclose([du, dv], np.array([u, v]) - origin, atol=0.1)


def test_a_reduced_step_is_the_step_of_the_reduced_camera() -> None:
    """Frames reduced twice are seen by a camera of half the resolution (half the focal length,
    the principal point at the reduced pixel centres): the full step reduced is that camera's."""
    one = HeadPose(pan_rad=0.30, tilt_rad=0.10)
    two = HeadPose(pan_rad=0.30 + math.radians(2.4), tilt_rad=0.10 - math.radians(1.2))
    reduced = EgoMotion(CAMERA, HeadKinematics()).step(one, two, 0.04).reduced(2)
    half = EgoMotion(CameraModel.from_fov(320, 240, math.radians(60)), HeadKinematics())
    expected = half.step(one, two, 0.04)
    np.testing.assert_allclose(reduced.K, expected.K, atol=1e-9)
    for u, v in PIXELS:
        u, v = u / 2.0, v / 2.0
        np.testing.assert_allclose(reduced.transport(u, v), expected.transport(u, v), atol=1e-9)


def test_still_step_is_the_identity() -> None:
    step = EgoMotion(CAMERA, HeadKinematics()).still_step(0.04)
    assert step.transport(100.0, 50.0) == (100.0, 50.0)
    assert step.displacement(np.array(3.0), np.array(4.0)) == (0.0, 0.0)


def odometry(t_s: float, pan: float, tilt: float, pan_rate: float = 0.0, tilt_rate: float = 0.0):
    return Odometry(
        t_capture_ns=round(t_s * 1e9),
        pan_rad=pan,
        tilt_rad=tilt,
        pan_rate_rad_s=pan_rate,
        tilt_rate_rad_s=tilt_rate,
    )


def test_odometry_interpolates_between_samples_in_any_arrival_order() -> None:
    history = OdometryHistory(span_s=2.0, max_gap_s=0.1)
    # constant rates 0.5 and -0.25 rad/s, sampled at 50 Hz, arriving shuffled
    samples = [odometry(0.02 * i, 0.5 * 0.02 * i, -0.25 * 0.02 * i, 0.5, -0.25) for i in range(20)]
    for i in np.random.default_rng(3).permutation(20):
        history.add(samples[i])
    pose = history.pose_at(round(0.123 * 1e9))
    assert pose is not None
    assert pose.pan_rad == pytest.approx(0.0615) and pose.tilt_rad == pytest.approx(-0.03075)
    assert pose.pan_rate_rad_s == pytest.approx(0.5) and pose.tilt_rate_rad_s == pytest.approx(
        -0.25
    )


def test_odometry_extrapolates_only_within_the_gap_and_not_before_the_first_sample() -> None:
    history = OdometryHistory(span_s=2.0, max_gap_s=0.1)
    history.add(odometry(1.0, 0.2, 0.1, 1.0, 0.0))
    history.add(odometry(1.5, 0.7, 0.1, 1.0, 0.0))
    ahead = history.pose_at(round(1.55e9))
    assert ahead is not None and ahead.pan_rad == pytest.approx(0.75)
    assert history.pose_at(round(1.65e9)) is None  # too far past the newest sample
    assert history.pose_at(round(1.2e9)) is None  # samples 0.5 s apart: a gap
    assert history.pose_at(round(0.9e9)) is None  # before the first sample


def test_a_stalled_odometry_stream_is_not_extrapolated_past_two_of_its_periods() -> None:
    """A servo killed mid-turn: its last sample says 0.12 rad/s, the head has stopped. A frame
    taken 150 ms later must get no pose (uncompensated), not one turned on by 18 mrad."""
    history = OdometryHistory(span_s=2.0, max_gap_s=0.2)
    for i in range(50):  # 50 Hz, turning at 0.12 rad/s
        history.add(odometry(0.02 * i, 0.12 * 0.02 * i, 0.0, 0.12, 0.0))
    newest_s = 0.02 * 49
    assert history.extrapolation_ns() == round(0.04e9)
    ahead = history.pose_at(round((newest_s + 0.03) * 1e9))  # a sample late: still extrapolated
    assert ahead is not None and ahead.pan_rad == pytest.approx(0.12 * (newest_s + 0.03))
    assert history.pose_at(round((newest_s + 0.05) * 1e9)) is None
    assert history.pose_at(round((newest_s + 0.15) * 1e9)) is None  # within max_gap, stalled
    history.add(odometry(newest_s + 1.0, 0.2, 0.0))  # the servo is back: one long interval
    assert history.extrapolation_ns() == round(0.04e9)  # the period is still 20 ms
    assert history.pose_at(round((newest_s + 0.5) * 1e9)) is None  # across the outage: none


def test_odometry_forgets_what_is_older_than_the_span() -> None:
    history = OdometryHistory(span_s=0.5, max_gap_s=0.1)
    for i in range(100):
        history.add(odometry(0.01 * i, 0.0, 0.0))
    assert len(history) == 51
    assert history.pose_at(round(0.3e9)) is None


def test_position_history_slope_transport_and_gate() -> None:
    history = PositionHistory(4)
    for i in range(6):
        history.add(0.04 * i, 100.0 + 2.0 * i, 50.0 - 1.0 * i)  # 50 px/s, -25 px/s
    assert history.velocity() == pytest.approx((50.0, -25.0))
    # the head turns: every stored position moves by the same 10 px, the slope stays
    ego = EgoMotion(CAMERA, HeadKinematics())
    shift = ego.still_step(0.04)
    shift = type(shift)(
        np.array([[1.0, 0, 10.0], [0, 1.0, 0], [0, 0, 1.0]]), shift.omega, 0.04, CAMERA.K
    )
    history.transport(shift)
    assert history.last()[1] == pytest.approx(120.0)
    assert history.velocity() == pytest.approx((50.0, -25.0))
    history.add(0.24, 122.0, 44.0, gate_px=5.0)  # where it was predicted
    assert len(history) == 4
    history.add(0.28, 300.0, 44.0, gate_px=5.0)  # something else
    assert len(history) == 1 and history.velocity() is None


def test_odometry_from_the_future_is_refused() -> None:
    history = OdometryHistory(span_s=2.0, max_gap_s=0.1)
    now_ns = 10_000_000_000
    assert history.add(odometry(10.0, 0.2, 0.1, 1.0, 0.0), now_ns)
    bogus = odometry(10.0 + 11 * 86400.0, 5.0, 5.0)  # eleven days ahead
    assert not history.add(bogus, now_ns)
    assert len(history) == 1 and history.pose_at(now_ns) is not None
