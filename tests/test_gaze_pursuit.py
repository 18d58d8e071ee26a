"""Pursuit's demand (gazed.gaze.pursuit): the prediction at the instant the demand acts, the
residual feedback, and the detection where no fresh prediction is at hand."""

from __future__ import annotations

import math

import pytest

from gazed.config import parse_rig
from gazed.gaze.aim import Aim
from gazed.gaze.pursuit import Pursuit, ResidualFeedback
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Detection, HeadPose, Prediction

RIG = parse_rig('[rig]\nname = "p"\n[gaze]\nresidual_gain = 0.5\nresidual_smoothing = 0.25\n')
CAMERA = CameraModel.from_section(RIG.camera)
F = CAMERA.K[0, 0]
T0 = 10**18
MS = 1_000_000


def prediction(t_effect_ns: int, pan_rad: float, pan_rate_rad_s: float = 0.0) -> Prediction:
    return Prediction(
        t_capture_ns=t_effect_ns - 170 * MS,
        stamps=(("vision", t_effect_ns - 50 * MS),),
        filter="imm",
        t_effect_ns=t_effect_ns,
        horizon_s=0.17,
        pan_rad=pan_rad,
        tilt_rad=-0.1,
        pan_rate_rad_s=pan_rate_rad_s,
        tilt_rate_rad_s=0.0,
        visual_latency_s=0.15,
        actuation_latency_s=0.03,
    )


def detection(t_ns: int, u_px: float, du_px_s: float = 0.0) -> Detection:
    return Detection(
        t_capture_ns=t_ns,
        stamps=(("vision", t_ns + 10 * MS),),
        seq=1,
        detector="flow",
        found=True,
        u_px=u_px,
        v_px=CAMERA.K[1, 2],
        du_px_s=du_px_s,
        width_px=640,
        height_px=480,
        head=HeadPose(pan_rad=0.0, tilt_rad=0.0),
    )


def pursuit() -> Pursuit:
    fovea_rad = math.radians(RIG.gaze.fovea_half_angle_deg)
    return Pursuit(
        RIG.gaze, fovea_rad, ZoomLens.fixed(CAMERA), HeadKinematics.from_section(RIG.head)
    )


def test_the_residual_is_smoothed_against_the_prediction_for_the_detections_instant() -> None:
    feedback = ResidualFeedback(smoothing=0.25, bound_rad=0.05)
    feedback.update(Aim(T0, 0.1, 0.0))  # nothing predicted yet: nothing to compare
    assert feedback.correction == (0.0, 0.0)
    feedback.on_prediction(prediction(T0 - 20 * MS, 0.10, pan_rate_rad_s=0.5))  # 0.11 at T0
    feedback.on_prediction(prediction(T0 + 20 * MS, 0.50))  # made for later: not this one's
    feedback.update(Aim(T0, 0.13, -0.06))
    assert feedback.correction == pytest.approx((0.25 * 0.02, 0.25 * 0.04))
    feedback.update(Aim(T0, 0.13, -0.06))
    assert feedback.correction == pytest.approx((0.005 + 0.25 * 0.015, 0.01 + 0.25 * 0.03))
    for _ in range(50):  # a residual of 0.4 rad, beyond the bound
        feedback.update(Aim(T0, 0.51, -0.1))
    assert feedback.correction == pytest.approx((0.05, 0.0), abs=1e-6)


def test_a_prediction_is_used_while_fresh_and_a_stale_one_is_counted() -> None:
    p = pursuit()
    assert p.aim(T0) is None and p.stale_predictions == 0
    p.on_prediction(prediction(T0, 0.2))
    assert p.aim(T0 + 500 * MS) == Aim(T0, 0.2, -0.1)
    assert p.aim(T0 + 501 * MS) is None
    assert p.aim(T0 - 501 * MS) is None  # from the future
    assert p.stale_predictions == 2


def test_the_demand_is_the_prediction_at_now_plus_the_actuation_latency_plus_feedback() -> None:
    p = pursuit()
    p.on_prediction(prediction(T0, 0.2, pan_rate_rad_s=0.4))
    p.feedback.correction = (0.01, -0.02)
    demand = p.demand(T0 + 10 * MS, found=None, correction=True)
    assert demand is not None and demand.kind == "pursuit"
    # 40 ms past the prediction's instant at 0.4 rad/s, plus half the correction
    assert demand.pan_rad == pytest.approx(0.2 + 0.4 * 0.04 + 0.5 * 0.01)
    assert demand.tilt_rad == pytest.approx(-0.1 - 0.5 * 0.02)
    assert (demand.pan_rate_rad_s, demand.tilt_rate_rad_s) == (0.4, 0.0)
    assert demand.t_capture_ns == T0 - 170 * MS  # the prediction's, to read the latency
    assert demand.stamps == (("vision", T0 - 50 * MS), ("gaze", T0 + 10 * MS))
    coast = p.demand(T0 + 10 * MS, found=None, correction=False)
    assert coast is not None and coast.pan_rad == pytest.approx(0.2 + 0.4 * 0.04)


def test_without_a_fresh_prediction_it_follows_the_detection() -> None:
    p = pursuit()
    assert p.demand(T0, found=None, correction=True) is None  # nothing to follow
    seen = detection(T0 - 40 * MS, CAMERA.K[0, 2], du_px_s=50.0)
    demand = p.demand(T0, found=seen, correction=True)
    assert demand is not None
    assert demand.pan_rad == pytest.approx(50.0 / F * 0.04)  # no actuation latency known
    assert demand.pan_rate_rad_s == pytest.approx(50.0 / F)
    assert demand.t_capture_ns == T0 - 40 * MS


def test_a_detection_in_pursuit_updates_the_feedback() -> None:
    p = pursuit()
    p.on_prediction(prediction(T0 - 10 * MS, 0.0))
    p.on_detection(detection(T0, CAMERA.K[0, 2] + 100.0))
    residual = math.atan(100.0 / F)
    assert p.feedback.correction == pytest.approx((0.25 * residual, 0.25 * 0.1))


def test_the_ground_position_at_an_instant_walks_the_latest_prediction_before_it_on() -> None:
    p = pursuit()
    assert p.ground_at(T0) is None  # no prediction
    p.on_prediction(prediction(T0, 0.0))  # no ground position (an image-cv track)
    assert p.ground_at(T0) is None
    for k, xy in enumerate([(1.0, 2.0), (1.1, 2.0)]):
        walking = prediction(T0 + 100 * k * MS, 0.0).model_copy(
            update={"ground_xy_m": xy, "ground_velocity_m_s": (1.0, -0.5)}
        )
        p.on_prediction(walking)
    assert p.ground_at(T0 + 50 * MS) == pytest.approx((1.05, 1.975))  # the first, walked on
    assert p.ground_at(T0 + 300 * MS) == pytest.approx((1.3, 1.9))  # the newest, walked on
    assert p.ground_at(T0 + 700 * MS) is None  # past PREDICTION_FRESH_S from the newest
    p.restart()
    assert p.ground_at(T0 + 300 * MS) is None
