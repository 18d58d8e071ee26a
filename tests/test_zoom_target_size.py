"""The target's size for the zoom: on a calibrated rig, the body's constant size from each box
at the estimator's position, with the detector's merged boxes left out however long their run,
carried to the latest predicted range; without ranges, the median of the last sightings."""

from __future__ import annotations

import math
from collections import deque

import pytest

from gazed.gaze.target_size import RECENT_SIGHTINGS, TargetSize
from gazed.messages import Prediction

CAMERA_XYZ_M = (0.0, 0.0, 3.0)
POINT_M = 0.2
BODY = 0.05  # a·R²/d of the body (its height, in the units of h / f)
S = 1_000_000_000


def prediction(t_s: float, x_m: float, track_id: int = 1, vx_m_s: float = 0.0) -> Prediction:
    return Prediction(
        t_capture_ns=round(t_s * S),
        filter="imm",
        t_effect_ns=round(t_s * S),
        horizon_s=0.0,
        pan_rad=0.0,
        tilt_rad=0.0,
        pan_rate_rad_s=0.0,
        tilt_rate_rad_s=0.0,
        ground_xy_m=(x_m, 0.0),
        ground_velocity_m_s=(vx_m_s, 0.0),
        visual_latency_s=0.0,
        actuation_latency_s=0.0,
        track_id=track_id,
    )


def angular_at(x_m: float) -> float:
    """The body's true angular size a = L·d/R² with the tracked point at (x, 0)."""
    c = CAMERA_XYZ_M[2] - POINT_M
    return BODY * x_m / (x_m * x_m + c * c)


def test_a_long_run_of_merged_boxes_leaves_the_size_alone() -> None:
    predictions: deque[Prediction] = deque(maxlen=64)
    size = TargetSize(CAMERA_XYZ_M, POINT_M, predictions)
    t_s, x_m = 0.0, 10.0
    for k in range(120):  # approaching at 1 m/s, the boxes within a few per cent
        t_s, x_m = k * 0.04, 10.0 - k * 0.04
        predictions.append(prediction(t_s, x_m, vx_m_s=-1.0))
        size.add(round(t_s * S), angular_at(x_m) * (1.0 + 0.03 * math.sin(k)))
    for k in range(120, 120 + 2 * RECENT_SIGHTINGS):  # merged with an edge: twice as tall
        t_s, x_m = k * 0.04, 10.0 - k * 0.04
        predictions.append(prediction(t_s, x_m, vx_m_s=-1.0))
        size.add(round(t_s * S), 2.0 * angular_at(x_m))
    assert size.outliers == 2 * RECENT_SIGHTINGS
    assert size.angular() == pytest.approx(angular_at(x_m), rel=0.03)
    predictions.append(prediction(t_s + 1.0, x_m - 1.0))  # carried to the predicted range
    assert size.angular() == pytest.approx(angular_at(x_m - 1.0), rel=0.03)


def test_each_box_is_sized_at_the_position_predicted_for_its_capture() -> None:
    predictions = deque([prediction(0.0, 8.0, vx_m_s=-2.0), prediction(1.0, 6.0, vx_m_s=-2.0)])
    size = TargetSize(CAMERA_XYZ_M, POINT_M, predictions)
    size.add(round(0.25 * S), angular_at(7.5))  # nearest the first, moved on 0.5 m
    assert size.angular() == pytest.approx(angular_at(6.0), rel=1e-9)


def test_another_track_is_sized_afresh() -> None:
    predictions = deque([prediction(0.0, 8.0)])
    size = TargetSize(CAMERA_XYZ_M, POINT_M, predictions)
    for _ in range(3 * RECENT_SIGHTINGS):
        size.add(0, angular_at(8.0))
    predictions.append(prediction(0.1, 8.0, track_id=2))
    size.add(round(0.1 * S), 3.0 * angular_at(8.0))  # a body three times as tall
    assert size.outliers == 0
    assert size.angular() == pytest.approx(3.0 * angular_at(8.0))


def test_without_ranges_the_size_is_the_median_of_the_last_sightings() -> None:
    size = TargetSize(None, 0.0, None)
    assert size.angular() is None
    for a in [1.0] * RECENT_SIGHTINGS + [2.0] * (RECENT_SIGHTINGS // 2 + 1):
        size.add(0, a)
    assert size.angular() == 2.0 and size.outliers == 0  # the range may have halved
    size.clear_recent()
    assert size.angular() is None
