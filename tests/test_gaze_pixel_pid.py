"""The peers' PID on the pixel error: its law, deadband, anti-windup and limits, without a bus."""

from __future__ import annotations

import math

import pytest

from gazed.config import parse_rig
from gazed.gaze.pixel_pid import PixelPid, pixel_error
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Detection, HeadPose, Odometry

RATE_MAX = (2.0, 1.0)  # rad/s
LIMITS = ((-1.0, 1.0), (-0.5, 0.5))  # rad
T0 = 1_000_000_000_000
FRAME_NS = 40_000_000


def pid(kp: float = 4.0, ki: float = 0.0, kd: float = 0.0, deadband_px: float = 10.0) -> PixelPid:
    return PixelPid((kp, ki, kd), deadband_px, RATE_MAX, LIMITS, stale_s=0.12)


def odometry(pan: float = 0.0, tilt: float = 0.0) -> Odometry:
    return Odometry(t_capture_ns=T0, pan_rad=pan, tilt_rad=tilt)


def test_proportional_rate_and_the_position_it_integrates() -> None:
    law = pid(kp=4.0)
    law.update((0.1, -0.05), error_px=60.0, t_capture_ns=T0)
    first = law.demand(odometry(0.2, 0.1), T0 + 150_000_000)
    assert first.kind == "pursuit"
    assert (first.pan_rate_rad_s, first.tilt_rate_rad_s) == pytest.approx((0.4, -0.2))
    assert (first.pan_rad, first.tilt_rad) == pytest.approx((0.2, 0.1))  # starts where the head is
    later = law.demand(None, T0 + 170_000_000)
    assert (later.pan_rad, later.tilt_rad) == pytest.approx((0.2 + 0.4 * 0.02, 0.1 - 0.2 * 0.02))


def test_no_demand_before_odometry() -> None:
    law = pid()
    law.update((0.1, 0.0), 60.0, T0)
    assert law.demand(None, T0) is None


def test_inside_the_deadband_the_error_counts_as_none() -> None:
    law = pid(kp=4.0, ki=10.0)
    law.update((0.01, 0.01), error_px=9.0, t_capture_ns=T0)
    law.update((0.01, 0.01), error_px=9.0, t_capture_ns=T0 + FRAME_NS)
    assert law.rate_rad_s == [0.0, 0.0] and law.integral == [0.0, 0.0]
    law.update((0.01, 0.0), error_px=11.0, t_capture_ns=T0 + 2 * FRAME_NS)
    assert law.rate_rad_s[0] == pytest.approx(4.0 * 0.01 + 10.0 * 0.01 * 0.04)


def test_integral_and_derivative_terms() -> None:
    law = pid(kp=0.0, ki=2.0, kd=0.5, deadband_px=0.0)
    law.update((0.1, 0.0), 50.0, T0)  # the first: no interval yet
    assert law.rate_rad_s[0] == 0.0
    law.update((0.2, 0.0), 50.0, T0 + FRAME_NS)
    # ki ∫e = 2 * 0.2 * 0.04; kd de/dt = 0.5 * 0.1 / 0.04
    assert law.rate_rad_s[0] == pytest.approx(2.0 * 0.2 * 0.04 + 0.5 * 0.1 / 0.04)


def test_the_integral_alone_never_asks_more_than_the_rate_limit() -> None:
    law = pid(kp=0.0, ki=5.0, deadband_px=0.0)
    for k in range(200):  # a large error held for 8 s
        law.update((0.5, 0.5), 300.0, T0 + k * FRAME_NS)
    assert law.ki * law.integral[0] == pytest.approx(RATE_MAX[0])
    assert law.ki * law.integral[1] == pytest.approx(RATE_MAX[1])
    law.update((-0.01, -0.01), 300.0, T0 + 200 * FRAME_NS)  # unwinds at once when it turns
    assert law.integral[0] < RATE_MAX[0] / law.ki


def test_rate_and_joint_limits() -> None:
    law = pid(kp=100.0)
    law.update((0.5, -0.5), 300.0, T0)
    assert law.rate_rad_s == [RATE_MAX[0], -RATE_MAX[1]]
    law.demand(odometry(0.9, -0.45), T0)
    law.update((0.5, -0.5), 300.0, T0 + FRAME_NS)
    at_limit = law.demand(None, T0 + 200_000_000)
    assert (at_limit.pan_rad, at_limit.tilt_rad) == pytest.approx((1.0, -0.5))
    assert (at_limit.pan_rate_rad_s, at_limit.tilt_rate_rad_s) == (0.0, 0.0)


def test_no_new_detection_stops_the_head_and_a_restart_forgets() -> None:
    law = pid(kp=4.0)
    law.update((0.1, 0.0), 60.0, T0)
    assert law.demand(odometry(), T0 + 150_000_000).pan_rate_rad_s == pytest.approx(0.4)
    # stale_s after the tick that saw the detection: the head stops where it got to
    stopped = law.demand(None, T0 + 300_000_000)
    assert stopped.pan_rate_rad_s == 0.0
    assert 0.0 <= stopped.pan_rad <= 0.4 * 0.15
    assert law.demand(None, T0 + 340_000_000).pan_rad == stopped.pan_rad
    law.restart()
    assert law.demand(None, T0 + 320_000_000) is None
    assert law.integral == [0.0, 0.0] and law.last_error is None


def test_pixel_error_is_the_angle_to_the_target_from_the_head_at_capture() -> None:
    rig = parse_rig('[rig]\nname = "p"\n')
    camera = CameraModel.from_section(rig.camera)
    kinematics = HeadKinematics.from_section(rig.head)
    cx, cy = camera.K[0, 2], camera.K[1, 2]
    f = camera.K[0, 0]
    d = Detection(
        t_capture_ns=T0,
        seq=1,
        detector="flow",
        found=True,
        u_px=cx + 30.0,
        v_px=cy + 40.0,
        width_px=rig.camera.width_px,
        height_px=rig.camera.height_px,
        head=HeadPose(pan_rad=0.3, tilt_rad=0.1),
    )
    error_rad, error_px = pixel_error(ZoomLens.fixed(camera), kinematics, d)
    assert error_px == pytest.approx(50.0)
    # right in the image is more pan, down is less tilt; each about its pixels' angle
    assert error_rad[0] == pytest.approx(math.atan(30.0 / f), rel=0.1)
    assert error_rad[1] == pytest.approx(-math.atan(40.0 / f), rel=0.1)
