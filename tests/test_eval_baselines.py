"""The pedestrian evaluation's baselines: closed forms on synthetic tracks, the constant-velocity
filter against filterpy's, and the likelihood fit recovering a known noise."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.common import Q_continuous_white_noise
from filterpy.kalman import KalmanFilter

from gazed.eval.baselines import (
    ConstantPosition,
    ConstantVelocity,
    TwoPoint,
    fit_constant_velocity,
)


def feed(predictor, t: np.ndarray, z: np.ndarray) -> None:
    for k in range(t.shape[1]):
        predictor.step(t[:, k], z[:, k], np.ones(t.shape[0], dtype=bool))


def straight_track(speed_m_s: float = 1.3, steps: int = 6) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(steps)[None, :] * 0.4
    z = np.stack([speed_m_s * t, -0.5 * speed_m_s * t], axis=-1)
    return t, z


def test_constant_position_holds_the_last_measurement() -> None:
    t, z = straight_track()
    predictor = ConstantPosition(1)
    feed(predictor, t, z)
    forecast = predictor.forecast(np.array([t[0, -1] + 0.8]))
    assert forecast.valid.all()
    assert np.allclose(forecast.position, z[:, -1])


def test_two_point_is_exact_on_a_straight_walk_and_follows_a_turn_after_one_step() -> None:
    t, z = straight_track()
    predictor = TwoPoint(1)
    feed(predictor, t, z)
    h = 0.8
    assert np.allclose(
        predictor.forecast(t[:, -1] + h).position, z[:, -1] + np.array([1.3, -0.65]) * h
    )
    # only the last two points count: a late change of velocity is followed at once
    predictor.step(np.array([2.4]), np.array([[z[0, -1, 0], z[0, -1, 1] + 0.4]]), np.ones(1, bool))
    assert np.allclose(predictor.forecast(np.array([2.8])).position, [[2.6, -0.5]])


def test_two_point_needs_two_measurements() -> None:
    predictor = TwoPoint(2)
    predictor.step(
        np.array([0.0, 0.0]), np.array([[1.0, 1.0], [2.0, 2.0]]), np.array([True, False])
    )
    assert not predictor.forecast(np.array([0.4, 0.4])).valid.any()


def test_constant_velocity_matches_filterpy_state_and_likelihood() -> None:
    rng = np.random.default_rng(5)
    q, r = 0.3, 0.02
    t = np.cumsum(rng.uniform(0.3, 0.5, 30))[None, :]
    z = np.stack([np.sin(t), 0.5 * t], axis=-1) + rng.normal(0, np.sqrt(r), (1, 30, 2))
    ours = ConstantVelocity(1, q, r)
    feed(ours, t, z)

    log_likelihood = 0.0
    for axis in range(2):
        kf = KalmanFilter(dim_x=2, dim_z=1)
        kf.H = np.array([[1.0, 0.0]])
        kf.R = np.array([[r]])
        dt0 = t[0, 1] - t[0, 0]
        kf.x = np.array([z[0, 1, axis], (z[0, 1, axis] - z[0, 0, axis]) / dt0])
        kf.P = np.array([[r, r / dt0], [r / dt0, 2 * r / dt0**2]])
        for k in range(2, 30):
            dt = t[0, k] - t[0, k - 1]
            kf.F = np.array([[1.0, dt], [0.0, 1.0]])
            kf.Q = Q_continuous_white_noise(dim=2, dt=dt, spectral_density=q)
            kf.predict()
            kf.update(z[0, k, axis])
            log_likelihood += kf.log_likelihood
        assert ours.p[0, axis] == pytest.approx(kf.x[0], abs=1e-9)
        assert ours.v[0, axis] == pytest.approx(kf.x[1], abs=1e-9)
    assert ours.log_likelihood[0] == pytest.approx(log_likelihood, rel=1e-9)


def test_the_likelihood_fit_recovers_the_injected_noises() -> None:
    rng = np.random.default_rng(17)
    n, steps, dt = 150, 40, 0.4
    q_true, r_true = 0.05, 0.01
    t = np.tile(np.arange(steps) * dt, (n, 1))
    # white-noise acceleration: the exact discrete process noise of the model, per axis
    Q = q_true * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    L = np.linalg.cholesky(Q)
    state = np.zeros((n, 2, 2))  # track, axis, [p, v]
    state[:, :, 1] = rng.normal(0, 1.0, (n, 2))
    xy = np.zeros((n, steps, 2))
    for k in range(steps):
        xy[:, k] = state[:, :, 0]
        state[:, :, 0] += dt * state[:, :, 1]
        state += rng.normal(0, 1.0, (n, 2, 2)) @ L.T
    z = xy + rng.normal(0, np.sqrt(r_true), xy.shape)
    q, r = fit_constant_velocity(t, z, np.full(n, steps))
    assert r == pytest.approx(r_true, rel=0.2)
    assert q == pytest.approx(q_true, rel=0.5)


def test_unequal_track_lengths_leave_the_padding_out() -> None:
    t, z = straight_track(steps=8)
    t2 = np.vstack([t, t])
    z2 = np.concatenate([z, z], axis=0)
    z2[1, 4:] = np.nan  # the second track ends after 4 samples
    t2[1, 4:] = np.nan
    predictor = ConstantVelocity(2, 0.1, 1e-4)
    for k in range(8):
        predictor.step(t2[:, k], np.nan_to_num(z2[:, k]), np.array([True, k < 4]))
    assert predictor.count.tolist() == [8, 4]
    forecast = predictor.forecast(np.array([3.2, 1.6]))
    assert forecast.valid.all()
    assert np.allclose(forecast.position[1], [1.3 * 1.6, -0.65 * 1.6], atol=1e-3)
