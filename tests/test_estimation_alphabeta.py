"""Adaptive α-β of seed 004 §4: the least-squares quadratic predictor (DESIGN §10 erratum),
the 0/0 guards, prediction to any horizon, and the adaptation of α and β."""

from __future__ import annotations

import numpy as np
import pytest

from gazed.config import EstimatorSection
from gazed.estimation import Measurement, build_estimator
from gazed.estimation.alphabeta import AlphaBetaEstimator, polynomial_fit, polynomial_value, weight


def test_weights_guard_zero_over_zero() -> None:
    np.testing.assert_allclose(
        weight(np.array([0.0, 1.0, 3.0]), np.array([0.0, 0.0, 1.0])), [0.5, 1.0, 0.75]
    )


def test_least_squares_quadratic_is_exact_on_quadratics() -> None:
    """Five samples of a parabola at uneven times extrapolate exactly; the printed 5-point
    formula of eq. 8 does not (it is exact for lines only)."""
    t = np.array([[-0.5, -0.35, -0.3, -0.1, 0.0]])
    y = np.stack([2.0 - 1.5 * t + 4.0 * t**2, 0.5 + 3.0 * t**2], axis=-1)
    c = polynomial_fit(t, y, np.ones_like(t, bool), 2)
    for ahead in (0.1, 0.4, 2.0):
        np.testing.assert_allclose(
            polynomial_value(c, np.array([ahead]))[0],
            [2.0 - 1.5 * ahead + 4.0 * ahead**2, 0.5 + 3.0 * ahead**2],
            rtol=1e-10,
        )
        np.testing.assert_allclose(
            polynomial_value(c, np.array([ahead]), 1)[0],
            [-1.5 + 8.0 * ahead, 6.0 * ahead],
            rtol=1e-9,
        )
    # eq. 8 as printed, on unit steps of θ(k) = k²: (9θ(k) - 4θ(k-2) + 3[θ(k-5) - θ(k-4)]) / 5
    theta = {k: float(k * k) for k in range(-5, 1)}
    printed = (9 * theta[0] - 4 * theta[-2] + 3 * (theta[-5] - theta[-4])) / 5
    assert printed != pytest.approx(1.0)


def feed(estimator: AlphaBetaEstimator, t: np.ndarray, xy: np.ndarray, sigma: float) -> None:
    for tk, zk in zip(t, xy, strict=True):
        estimator.update(Measurement.ground(tk, zk, np.eye(2) * sigma**2))


def test_exact_quadratic_motion_is_predicted_exactly_to_any_horizon() -> None:
    """Measurements that agree with a parabola: once five estimates are in, the quadratic
    predictor is exact; with eq. 10's instantaneous σ_q² (smoothing 1) it is then 0, β2 = 1,
    and every horizon is exact."""
    estimator = AlphaBetaEstimator(smoothing=1.0)
    t = np.cumsum(np.r_[0.0, np.full(11, 0.1), np.full(8, 0.07)])  # variable intervals
    xy = np.stack([1.0 + 0.5 * t + 0.3 * t**2, -2.0 * t + 0.1 * t**2], axis=-1)
    feed(estimator, t, xy, 1e-6)
    for ahead in (0.04, 0.4, 1.2):
        p = estimator.predict(t[-1] + ahead)
        T = t[-1] + ahead
        np.testing.assert_allclose(
            p.position, [1.0 + 0.5 * T + 0.3 * T**2, -2.0 * T + 0.1 * T**2], atol=1e-5
        )
        np.testing.assert_allclose(p.velocity, [0.5 + 0.6 * T, -2.0 + 0.2 * T], atol=1e-4)


def test_alpha_follows_the_measurement_when_the_prediction_is_poor() -> None:
    """A target that reverses: the running prediction error grows above the measurement
    variance, so α2 (the weight of the measurement) rises; on a smooth path it falls."""
    estimator = build_estimator(EstimatorSection(), mode="alphabeta")
    rng = np.random.default_rng(0)
    t = np.arange(60) * 0.1
    x = np.where(t < 3.0, t, 6.0 - t)  # reverses at t = 3 s
    xy = np.stack([x, np.zeros_like(x)], axis=-1) + rng.normal(0, 0.02, (60, 2))
    trust = []
    for tk, zk in zip(t, xy, strict=True):
        estimator.update(Measurement.ground(tk, zk, np.eye(2) * 0.02**2))
        var_p = np.maximum(estimator.spread[0, 0] - 0.02**2, 0.0)
        trust.append(var_p / (var_p + 0.02**2))
    trust = np.array(trust)
    assert trust[31:35].max() > 0.8  # just after the reversal: mostly the measurement
    assert trust[20:30].mean() < trust[31:35].mean()
    p = estimator.predict(t[-1] + 0.4)
    assert p.position[0] == pytest.approx(6.0 - (t[-1] + 0.4), abs=0.15)


def test_straight_line_is_recovered_within_noise() -> None:
    """RMSE of the one-step prediction on a noisy line stays below the measurement noise × 2."""
    estimator = build_estimator(EstimatorSection(), mode="alphabeta")
    rng = np.random.default_rng(1)
    t = np.arange(200) * 0.1
    truth = np.stack([1.2 * t, 0.4 * t], axis=-1)
    z = truth + rng.normal(0, 0.05, truth.shape)
    errors = []
    for k, (tk, zk) in enumerate(zip(t, z, strict=True)):
        if k > 10:
            errors.append(estimator.predict(tk).position - truth[k])
        estimator.update(Measurement.ground(tk, zk, np.eye(2) * 0.05**2))
    rmse = np.sqrt(np.mean(np.square(errors)))
    assert rmse < 0.1
