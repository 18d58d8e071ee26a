"""Each filter recovers the motion of its own model (seeded simulations, RMSE bounds)."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest

from gazed.config import EstimatorSection
from gazed.estimation import Measurement, build_estimator
from gazed.estimation.ground_imm import ImmEstimator
from gazed.estimation.ground_models import GroundModelBank, cd, cs, csd

SECTION = EstimatorSection()
SIGMA_P, SIGMA_V, T, STEPS = 0.05, 0.1, 0.04, 300


def simulate_ground(model: str, seed: int) -> np.ndarray:
    """Noise-free states [X, Y, s, θ, ṡ, θ̇] of one model's motion (the model's own f)."""
    x = {
        "CSD": [0.0, 0.0, 1.2, 0.4, 0.0, 0.0],
        "CS": [0.0, 0.0, 1.0, -2.0, 0.0, 0.6],
        "CD": [0.0, 0.0, 0.5, 2.5, 0.4, 0.0],
    }[model]
    bank = GroundModelBank((csd(1, 1), cs(1, 1), cd(1, 1)))
    m = ("CSD", "CS", "CD").index(model)
    states = [np.array(x)]
    for _ in range(STEPS - 1):
        xs = np.broadcast_to(states[-1], (1, 3, 6)).copy()
        states.append(bank.propagate(xs, np.array([T]))[0][0, m])
    return np.array(states)


def measure_ground(estimator, truth: np.ndarray, seed: int) -> Iterator[None]:
    """Update with each true state as a noisy position and velocity, T apart; yields after
    each update."""
    rng = np.random.default_rng(seed)
    for k, state in enumerate(truth):
        v = state[2] * np.array([math.cos(state[3]), math.sin(state[3])])
        estimator.update(
            Measurement.ground(
                k * T,
                state[:2] + rng.normal(0, SIGMA_P, 2),
                np.eye(2) * SIGMA_P**2,
                v + rng.normal(0, SIGMA_V, 2),
                np.eye(2) * SIGMA_V**2,
            )
        )
        yield


@pytest.mark.parametrize(
    ("model", "factory", "bounds"),
    [
        ("CSD", lambda: csd(0.01, 0.01), (0.03, 0.03, 0.02)),
        ("CS", lambda: cs(0.01, 0.1), (0.03, 0.03, 0.05)),
        ("CD", lambda: cd(0.01, 0.01), (0.03, 0.03, 0.05)),
    ],
)
def test_each_ground_ekf_recovers_its_own_motion(model: str, factory, bounds) -> None:
    """A one-model IMM is that model's EKF. RMSE bounds over the second half: position (m),
    speed (m/s), and the model's rate (turn rate for CS rad/s, ṡ for CD m/s², heading rad for
    CSD)."""
    truth = simulate_ground(model, 0)
    estimator = ImmEstimator((factory(),), np.array([[1.0]]))
    estimates = [estimator.imm.x[0, 0].copy() for _ in measure_ground(estimator, truth, seed=0)]
    est, tru = np.array(estimates)[STEPS // 2 :], truth[STEPS // 2 :]
    position = np.sqrt(np.mean(np.sum((est[:, :2] - tru[:, :2]) ** 2, axis=1)))
    speed = np.sqrt(np.mean((est[:, 2] - tru[:, 2]) ** 2))
    rate = {"CSD": 3, "CS": 5, "CD": 4}[model]
    error = est[:, rate] - tru[:, rate]
    if rate == 3:
        error = np.remainder(error + math.pi, 2 * math.pi) - math.pi
    assert position < bounds[0] and speed < bounds[1]
    assert np.sqrt(np.mean(error**2)) < bounds[2]


def test_imm_prediction_at_its_own_time_continues_the_propagated_one() -> None:
    """Predicting to the state's own time skips the propagation (it is the identity there):
    the result must match a prediction a nanosecond later, mean and covariance."""
    truth = simulate_ground("CS", 0)[:60]
    estimator = build_estimator(SECTION, mode="imm")
    for _ in measure_ground(estimator, truth, seed=4):
        pass
    t_last = (len(truth) - 1) * T
    now, later = estimator.predict(t_last), estimator.predict(t_last + 1e-9)
    assert now is not None and later is not None
    assert now.position == pytest.approx(later.position, abs=1e-8)
    assert now.velocity == pytest.approx(later.velocity, abs=1e-7)
    assert np.allclose(now.covariance, later.covariance, rtol=1e-6, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(now.covariance) > 0)


@pytest.mark.parametrize(
    ("mode", "acceleration", "bound_m"),
    [("cv", (0.0, 0.0), 0.07), ("ca", (0.3, -0.2), 0.08), ("innovation", (0.3, -0.2), 0.11)],
)
def test_linear_filters_recover_their_motion(mode: str, acceleration, bound_m: float) -> None:
    """Measured with 0.1 m noise per axis (0.141 m RMS): the filtered position's RMSE over the
    second half stays well below that."""
    rng = np.random.default_rng(1)
    estimator = build_estimator(SECTION, mode=mode)
    a = np.array(acceleration)
    errors = []
    for k in range(200):
        t = k * 0.1
        truth = np.array([1.0, 0.5]) * t + a * t * t / 2
        estimator.update(Measurement.ground(t, truth + rng.normal(0, 0.1, 2), np.eye(2) * 0.01))
        if k >= 100:
            errors.append(estimator.predict(t).position - truth)
    assert np.sqrt(np.mean(np.sum(np.square(errors), axis=1))) < bound_m


def test_constant_position_filter_holds_a_still_target() -> None:
    rng = np.random.default_rng(2)
    estimator = build_estimator(SECTION, mode="innovation")
    for k in range(100):
        estimator.update(
            Measurement.ground(
                k * 0.1, np.array([3.0, -1.0]) + rng.normal(0, 0.1, 2), np.eye(2) * 0.01
            )
        )
    assert estimator.most_likely() == "CP"
    p = estimator.predict(10.0)
    assert np.allclose(p.position, [3.0, -1.0], atol=0.08) and np.allclose(p.velocity, 0.0)


def test_image_cv_follows_gaze_angles() -> None:
    """Constant pan and tilt rates measured with 2 mrad noise: rates within 25 mrad/s and the
    angles 0.2 s ahead within 10 mrad."""
    rng = np.random.default_rng(3)
    estimator = build_estimator(SECTION, mode="image-cv")
    assert estimator.space == "gaze"
    rates = np.array([0.2, -0.05])
    for k in range(100):
        t = k * 0.04
        angles = np.array([0.1, -0.3]) + rates * t
        estimator.update(Measurement.gaze(t, angles + rng.normal(0, 0.002, 2), np.eye(2) * 4e-6))
    p = estimator.predict(4.0 + 0.2)
    np.testing.assert_allclose(p.velocity, rates, atol=0.025)
    np.testing.assert_allclose(p.position, [0.1, -0.3] + rates * 4.2, atol=0.01)


@pytest.mark.parametrize("mode", ["imm", "innovation", "alphabeta", "cv", "ca", "image-cv"])
def test_one_tracks_prediction_is_its_forecast(mode: str) -> None:
    """`predict` (track 0's shortcut) gives exactly what `forecast` gives for the track, from
    its first measurement on, and refuses a time before the state as `forecast` does."""
    rng = np.random.default_rng(3)
    estimator = build_estimator(SECTION, mode=mode)
    assert estimator.predict(0.0) is None
    for k in range(30):
        t = k * 0.04
        position = np.array([1.0, 0.5]) * t + rng.normal(0, 0.05, 2)
        velocity = np.array([1.0, 0.5]) + rng.normal(0, 0.1, 2)
        estimator.update(
            Measurement.ground(t, position, np.eye(2) * 0.0025, velocity, np.eye(2) * 0.01)
        )
        for ahead_s in (0.0, 0.19):
            predicted = estimator.predict(t + ahead_s)
            forecast = estimator.forecast(np.array([t + ahead_s]))
            assert predicted is not None
            assert np.array_equal(predicted.position, forecast.position[0])
            assert np.array_equal(predicted.velocity, forecast.velocity[0])
            assert np.array_equal(predicted.covariance, forecast.covariance[0])
    with pytest.raises(ValueError):
        estimator.predict(t - 0.01)
