"""The target's size for the zoom: a body's height learned over a long window, seen at the
estimator's predicted range."""

from __future__ import annotations

import math

import pytest

from gazed.config import CalibrationSection
from gazed.gaze.zoom_size import SIZE_SAMPLES, SIZE_WINDOW_S, TargetSize, weighted_median
from gazed.messages import Prediction

CAMERA_M = (0.0, 0.0, 3.0)
POINT_M = 1.0  # the tracked middle's height
BODY_M = 1.8
S = 1_000_000_000  # ns per second


class Source:
    """Holds a prediction, as the pursuit does."""

    prediction: Prediction | None = None


def predict(
    x_m: float,
    y_m: float,
    t_effect_s: float = 0.0,
    velocity_m_s: tuple[float, float] = (0.0, 0.0),
    track_id: int | None = 3,
) -> Prediction:
    return Prediction(
        t_capture_ns=0,
        filter="imm",
        t_effect_ns=round(t_effect_s * S),
        horizon_s=0.2,
        pan_rad=0.0,
        tilt_rad=0.0,
        pan_rate_rad_s=0.0,
        tilt_rate_rad_s=0.0,
        ground_xy_m=(x_m, y_m),
        ground_velocity_m_s=velocity_m_s,
        visual_latency_s=0.1,
        actuation_latency_s=0.1,
        track_id=track_id,
    )


def angular_height(x_m: float, y_m: float, body_m: float = BODY_M) -> float:
    """H d / r² of a body at (x, y) seen from CAMERA_M, its middle at POINT_M."""
    d = math.hypot(x_m - CAMERA_M[0], y_m - CAMERA_M[1])
    return body_m * d / (d * d + (CAMERA_M[2] - POINT_M) ** 2)


def ranged() -> tuple[TargetSize, Source]:
    source = Source()
    calibration = CalibrationSection(camera_xyz_m=CAMERA_M, target_height_m=POINT_M)
    return TargetSize(calibration, source), source


def test_the_size_is_the_bodys_height_at_the_predicted_range() -> None:
    size, source = ranged()
    assert size.size() is None  # nothing seen yet
    for k, x_m in enumerate((4.0, 6.0, 9.0)):  # walking away
        source.prediction = predict(x_m, 2.0, t_effect_s=k)
        size.add(k * S, angular_height(x_m, 2.0), 1000.0)
    source.prediction = predict(15.0, -1.0, t_effect_s=3.0)  # further still, never seen there
    assert size.size() == pytest.approx(angular_height(15.0, -1.0))


def test_each_sighting_is_ranged_at_its_capture_from_the_predictions_velocity() -> None:
    size, source = ranged()
    # the prediction is for 0.3 s after the capture, the target walking at 2 m/s in x: it was
    # 0.6 m short of the predicted point when the frame was taken
    source.prediction = predict(8.6, 0.0, t_effect_s=1.3, velocity_m_s=(2.0, 0.0))
    size.add(1 * S, angular_height(8.0, 0.0), 1000.0)
    source.prediction = predict(5.0, 0.0, t_effect_s=1.4)
    assert size.size() == pytest.approx(angular_height(5.0, 0.0))


def test_a_run_of_merged_boxes_shorter_than_half_the_window_does_not_move_the_size() -> None:
    size, source = ranged()
    source.prediction = predict(6.0, 0.0)
    right = angular_height(6.0, 0.0)
    frames = 25 * round(SIZE_WINDOW_S)  # the window at 25 Hz
    for k in range(frames):  # the last 40 % of the window, twice the height
        size.add(k * S // 25, right * (2.0 if k >= 0.6 * frames else 1.0), 1000.0)
    assert size.size() == pytest.approx(right)
    for k in range(frames, frames + 2 * frames):  # a body that stays twice as tall is taken up
        size.add(k * S // 25, 2.0 * right, 1000.0)
    assert size.size() == pytest.approx(2.0 * right)


def test_another_tracks_prediction_forgets_the_last_ones_height() -> None:
    size, source = ranged()
    source.prediction = predict(6.0, 0.0, track_id=3)
    size.add(0, angular_height(6.0, 0.0), 1000.0)
    source.prediction = predict(6.0, 0.0, track_id=4)
    assert size.size() is None
    size.add(S, angular_height(6.0, 0.0, body_m=0.9), 1000.0)
    assert size.size() == pytest.approx(angular_height(6.0, 0.0, body_m=0.9))
    size.restart()  # a new pursuit of the same track keeps its height
    assert size.size() == pytest.approx(angular_height(6.0, 0.0, body_m=0.9))


def test_without_a_range_the_size_is_the_recent_sightings_median_each_pursuit_afresh() -> None:
    source = Source()
    size = TargetSize(CalibrationSection(), source)
    for k in range(SIZE_SAMPLES):
        size.add(k, 0.01 if k < SIZE_SAMPLES // 2 else 0.02, 500.0)  # the older half smaller
    assert size.size() == 0.02
    source.prediction = predict(6.0, 0.0, track_id=None)  # a ground point, no camera position
    assert size.size() == 0.02
    size.restart()
    assert size.size() is None


def test_the_bodys_height_trusts_the_longer_focal_lengths_the_recent_size_the_last_boxes() -> None:
    size, source = ranged()
    source.prediction = predict(6.0, 0.0)
    right = angular_height(6.0, 0.0)
    for k in range(40):  # from the widest view, f = 500: 10 % short
        size.add(k, 0.9 * right, 500.0)
    for k in range(40, 60):  # zoomed in, f = 1500: right
        size.add(k, right, 1500.0)
    assert size.size() == pytest.approx(right)  # 20 x 1500² outweighs 40 x 500²
    assert size.recent_size() == pytest.approx(right)
    for k in range(60, 60 + SIZE_SAMPLES):  # a clutter's boxes, twice as tall, for a while
        size.add(k, 2.0 * right, 1500.0)
    assert size.size() == pytest.approx(right)
    assert size.recent_size() == pytest.approx(2.0 * right)


def test_the_weighted_median_splits_the_weight_in_half() -> None:
    assert weighted_median([3.0, 1.0, 2.0], [1.0, 1.0, 1.0]) == 2.0
    assert weighted_median([1.0, 2.0], [1.0, 1.0]) == 1.0  # the lower of a tie
    assert weighted_median([1.0, 2.0, 9.0], [1.0, 1.0, 5.0]) == 9.0
