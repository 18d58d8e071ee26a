"""The compiled Kalman/IMM kernel (`gazed.estimation.kalman`, `_kalman.c`) against the
textbook equations written out in NumPy, and its handling of bad arguments."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gazed.estimation import kalman
from gazed.estimation.ground_models import GroundModelBank, cd, cs, csd, measure
from gazed.estimation.imm import combine, mix, switching_matrix

BANK = GroundModelBank((csd(0.09, 0.01), cs(0.09, 30.0), cd(0.25, 0.01)))
LOG_2PI = math.log(2 * math.pi)


def random_spd(rng: np.random.Generator, shape: tuple[int, ...], n: int) -> np.ndarray:
    A = rng.normal(size=(*shape, n, n))
    return A @ A.mT + 0.1 * np.eye(n)


def ground_bank(rng: np.random.Generator, N: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x = rng.normal(size=(N, 3, 6))
    x[..., 2] = np.abs(x[..., 2]) + 0.5  # positive speeds
    P = random_spd(rng, (N, 3), 6) * 0.1
    mu = rng.dirichlet(np.ones(3), size=N)
    return x, P, mu


@pytest.mark.parametrize("m", [2, 4])
def test_innovation_and_update_are_the_textbook_equations(m: int) -> None:
    """ν, S, K, NIS, log N(ν; 0, S) and the Joseph-form update of a linear bank, against the
    equations computed with numpy.linalg."""
    rng = np.random.default_rng(1)
    N, M, n = 5, 2, 6
    x = rng.normal(size=(N, M, n))
    P = random_spd(rng, (N, M), n)
    H = np.ascontiguousarray(rng.normal(size=(m, n)))
    z = rng.normal(size=(N, m))
    R = random_spd(rng, (N,), m)
    innovation = kalman.innovate(x, P, slice(None), z, R, H=H)
    x_new, P_new = x.copy(), P.copy()
    kalman.correct(x_new, P_new, slice(None), innovation, H=H)
    for k in range(N):
        for j in range(M):
            y = z[k] - H @ x[k, j]
            S = H @ P[k, j] @ H.T + R[k]
            K = P[k, j] @ H.T @ np.linalg.inv(S)
            nis = y @ np.linalg.solve(S, y)
            log_likelihood = -0.5 * (nis + np.linalg.slogdet(S)[1] + m * LOG_2PI)
            np.testing.assert_allclose(innovation.y[k, j], y, rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(innovation.S[k, j], S, rtol=1e-12)
            np.testing.assert_allclose(innovation.K[k, j], K, rtol=1e-9, atol=1e-12)
            assert innovation.nis[k, j] == pytest.approx(nis, rel=1e-9)
            assert innovation.log_likelihood[k, j] == pytest.approx(log_likelihood, rel=1e-9)
            A = np.eye(n) - K @ H
            np.testing.assert_allclose(x_new[k, j], x[k, j] + K @ y, rtol=1e-9, atol=1e-12)
            expected_P = A @ P[k, j] @ A.T + K @ R[k] @ K.T
            np.testing.assert_allclose(P_new[k, j], expected_P, rtol=1e-8, atol=1e-12)
            np.testing.assert_array_equal(P_new[k, j], P_new[k, j].T)


def test_fused_imm_prediction_is_mixing_then_each_model() -> None:
    """`predict` with J is §5 step 1 (`mix`) followed by each ground model's f, F P0 Fᵀ + Q,
    and leaves μ = c̄; tracks not selected are untouched."""
    rng = np.random.default_rng(2)
    N = 4
    x, P, mu = ground_bank(rng, N)
    J = switching_matrix(0.9, 3)
    rows = np.array([3, 1])
    dt = np.array([0.04, 0.3])
    x1, P1, mu1 = x.copy(), P.copy(), mu.copy()
    kalman.predict(x1, P1, rows, dt, ground=BANK.parameters, mu=mu1, J=J, angle_index=3)
    cbar, x0, P0 = mix(mu[rows], J, x[rows], P[rows], 3)
    xn, F, Q = BANK.propagate(x0, dt)
    np.testing.assert_allclose(mu1[rows], cbar, rtol=1e-14)
    np.testing.assert_allclose(x1[rows], xn, rtol=1e-12, atol=1e-14)
    expected_P = F @ P0 @ F.mT + Q
    np.testing.assert_allclose(P1[rows], 0.5 * (expected_P + expected_P.mT), rtol=1e-10, atol=1e-14)
    for untouched in (0, 2):
        np.testing.assert_array_equal(x1[untouched], x[untouched])
        np.testing.assert_array_equal(P1[untouched], P[untouched])
        np.testing.assert_array_equal(mu1[untouched], mu[untouched])


def test_forecast_is_each_model_ahead_then_the_mixture_moments() -> None:
    rng = np.random.default_rng(3)
    x, P, mu = ground_bank(rng, 3)
    dt = np.array([0.0, 0.15, 1.2])
    mean, cov = kalman.forecast(x, P, mu, slice(None), dt, BANK.parameters)
    for k in range(3):
        xk, Pk = x[k], P[k]
        if dt[k] > 0:
            xk, F, Q = BANK.propagate(xk[None], dt[k : k + 1])
            xk, Pk = xk[0], (F @ P[k][None] @ F.mT + Q)[0]
        g, G = measure(xk, with_velocity=True)
        expected_mean, expected_cov = combine(mu[k : k + 1], g[None], (G @ Pk @ G.mT)[None], None)
        np.testing.assert_allclose(mean[k], expected_mean[0], rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(cov[k], expected_cov[0], rtol=1e-9, atol=1e-14)


def test_a_covariance_that_is_not_positive_definite_is_outside_every_gate() -> None:
    """S = H P Hᵀ + R not positive definite (here R = -P): NIS inf, likelihood 0, no gain;
    nothing raises, and an update with it does not move the state."""
    x = np.zeros((1, 1, 2))
    P = np.eye(2)[None, None].copy()
    H = np.eye(2)
    innovation = kalman.innovate(x, P, slice(None), np.ones((1, 2)), -np.eye(2)[None], H=H)
    assert innovation.nis[0, 0] == math.inf
    assert innovation.log_likelihood[0, 0] == -math.inf
    np.testing.assert_array_equal(innovation.K, 0.0)
    kalman.correct(x, P, slice(None), innovation, H=H)
    np.testing.assert_array_equal(x, 0.0)
    np.testing.assert_array_equal(P[0, 0], np.eye(2))


def test_a_model_nobody_can_switch_to_keeps_its_own_state() -> None:
    """A column of zeros in J: c̄_j = 0, and model j is not mixed (no 0/0)."""
    J = np.array([[1.0, 0.0], [0.5, 0.5]])  # nobody switches to model 1 ... from model 0
    mu = np.array([[1.0, 0.0]])  # ... and model 1 has no probability: c̄_1 = 0
    x = np.array([[[1.0, 2.0], [5.0, 6.0]]])
    P = np.tile(np.eye(2), (1, 2, 1, 1))
    cbar, x0, P0 = mix(mu, J, x, P, None)
    np.testing.assert_array_equal(cbar, [[1.0, 0.0]])
    np.testing.assert_array_equal(x0[0, 1], [5.0, 6.0])
    np.testing.assert_array_equal(P0[0, 1], np.eye(2))
    assert np.isfinite(x0).all() and np.isfinite(P0).all()


def test_a_large_batch_runs_without_the_gil_and_equals_its_tracks_one_by_one() -> None:
    """From 64 rows the kernel releases the GIL; the results are those of each track alone."""
    rng = np.random.default_rng(6)
    N = 70
    x, P, mu = ground_bank(rng, N)
    J = switching_matrix(0.9, 3)
    dt = rng.uniform(0.02, 0.2, N)
    z = rng.normal(size=(N, 4))
    R = np.tile(np.eye(4) * 0.05, (N, 1, 1))
    batch = [x.copy(), P.copy(), mu.copy()]
    kalman.predict(
        *batch[:2], slice(None), dt, ground=BANK.parameters, mu=batch[2], J=J, angle_index=3
    )
    innovation = kalman.innovate(*batch[:2], slice(None), z, R, ground=BANK.parameters)
    kalman.correct(
        *batch[:2], slice(None), innovation, ground=BANK.parameters, mu=batch[2], angle_index=3
    )
    for k in (0, 33, 69):
        one = [x[k : k + 1].copy(), P[k : k + 1].copy(), mu[k : k + 1].copy()]
        kalman.predict(
            *one[:2],
            slice(None),
            dt[k : k + 1],
            ground=BANK.parameters,
            mu=one[2],
            J=J,
            angle_index=3,
        )
        i = kalman.innovate(
            *one[:2], slice(None), z[k : k + 1], R[k : k + 1], ground=BANK.parameters
        )
        kalman.correct(*one[:2], slice(None), i, ground=BANK.parameters, mu=one[2], angle_index=3)
        for b, o in zip(batch, one, strict=True):
            np.testing.assert_array_equal(b[k], o[0])


def test_a_negative_speed_comes_out_of_the_update_positive() -> None:
    """The ground update turns (s, θ, ṡ) -> (-s, θ + π, -ṡ) when s < 0 (the same motion)."""
    x = np.array([[[0.0, 0.0, 0.1, 0.0, 0.0, 0.0]] * 3])
    P = np.tile(np.eye(6), (1, 3, 1, 1))
    mu = np.full((1, 3), 1 / 3)
    z = np.array([[0.0, 0.0, -1.0, 0.0]])  # moving along -X
    innovation = kalman.innovate(
        x, P, slice(None), z, np.eye(4)[None] * 1e-4, ground=BANK.parameters
    )
    flipped = kalman.correct(x, P, slice(None), innovation, ground=BANK.parameters, mu=mu)
    assert flipped == 3
    assert (x[0, :, 2] > 0.9).all()
    np.testing.assert_allclose(np.abs(x[0, :, 3]), math.pi, atol=1e-3)


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        (lambda a: a.astype(np.float32), ValueError, "float64"),
        (lambda a: a[:, :, ::-1], (ValueError, BufferError), "contiguous"),
        (lambda a: a[:1], ValueError, "expected"),  # too short for N
    ],
)
def test_bad_arrays_are_refused_not_read(change, error, match) -> None:
    rng = np.random.default_rng(4)
    x, P, mu = ground_bank(rng, 2)
    with pytest.raises(error, match=match):
        kalman._kalman.predict(
            2,
            3,
            6,
            2,
            change(x),
            P,
            mu,
            None,
            np.full(2, 0.04),
            BANK.parameters,
            None,
            None,
            None,
            -1,
            None,
        )


@pytest.mark.parametrize("dt", [-0.04, math.nan, math.inf])
def test_an_interval_that_is_not_finite_and_positive_is_refused(dt: float) -> None:
    rng = np.random.default_rng(7)
    x, P, mu = ground_bank(rng, 1)
    with pytest.raises(ValueError, match="finite dt"):
        kalman.predict(x, P, slice(None), np.array([dt]), ground=BANK.parameters)
    with pytest.raises(ValueError, match="finite dt"):
        kalman.forecast(x, P, mu, slice(None), np.array([dt]), BANK.parameters)


@pytest.mark.parametrize("angle", [6, 7, 100, -2])
def test_an_angle_index_outside_the_state_is_refused(angle: int) -> None:
    """The kernel would read and write past the state with it."""
    rng = np.random.default_rng(8)
    x, P, mu = ground_bank(rng, 1)
    with pytest.raises(ValueError, match="angle index"):
        kalman._kalman.predict(
            1,
            3,
            6,
            1,
            x,
            P,
            mu,
            None,
            np.full(1, 0.04),
            BANK.parameters,
            None,
            None,
            None,
            angle,
            None,
        )
    with pytest.raises(ValueError, match="angle index"):
        combine(mu, x, P, angle)


def test_sizes_that_would_overflow_are_refused() -> None:
    with pytest.raises(ValueError, match="out of range"):
        kalman._kalman.canonicalise(2**60, np.empty(0), np.empty(0))


def test_tracks_are_not_selected_by_a_mask() -> None:
    rng = np.random.default_rng(9)
    x, P, _ = ground_bank(rng, 2)
    with pytest.raises(TypeError, match="mask"):
        kalman.predict(x, P, np.array([True, False]), np.full(1, 0.04), ground=BANK.parameters)


def test_rows_outside_the_bank_are_refused() -> None:
    rng = np.random.default_rng(5)
    x, P, _ = ground_bank(rng, 2)
    with pytest.raises(IndexError, match="outside"):
        kalman.predict(x, P, np.array([0, 2]), np.full(2, 0.04), ground=BANK.parameters)


def test_a_process_noise_scale_multiplies_each_tracks_q() -> None:
    """q_scale (K,) in predict and forecast equals the same bank with its noise variances
    multiplied by that track's factor; None is a factor of 1."""
    rng = np.random.default_rng(11)
    x, P, mu = ground_bank(rng, 2)
    dt = np.array([0.04, 0.3])
    scale = np.array([3.0, 0.25])
    J = switching_matrix(0.96, 3)
    for k in range(2):
        scaled = BANK.parameters.copy()
        scaled[:, 2:] *= scale[k]
        xs, Ps, mus = x[k : k + 1].copy(), P[k : k + 1].copy(), mu[k : k + 1].copy()
        kalman.predict(xs, Ps, slice(None), dt[k : k + 1], ground=scaled, mu=mus, J=J)
        xq, Pq, muq = x.copy(), P.copy(), mu.copy()
        kalman.predict(xq, Pq, slice(None), dt, ground=BANK.parameters, mu=muq, J=J, q_scale=scale)
        np.testing.assert_allclose(xq[k], xs[0], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(Pq[k], Ps[0], rtol=1e-12, atol=1e-12)
        mean_s, cov_s = kalman.forecast(
            x[k : k + 1], P[k : k + 1], mu[k : k + 1], slice(None), dt[k : k + 1], scaled
        )
        mean_q, cov_q = kalman.forecast(x, P, mu, slice(None), dt, BANK.parameters, scale)
        np.testing.assert_allclose(mean_q[k], mean_s[0], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(cov_q[k], cov_s[0], rtol=1e-12, atol=1e-12)
    plain, ones = P.copy(), P.copy()
    kalman.predict(x.copy(), plain, slice(None), dt, ground=BANK.parameters)
    kalman.predict(x.copy(), ones, slice(None), dt, ground=BANK.parameters, q_scale=np.ones(2))
    np.testing.assert_array_equal(plain, ones)


@pytest.mark.parametrize("bad", [-1.0, math.nan, math.inf])
def test_a_process_noise_scale_that_is_not_finite_and_positive_is_refused(bad: float) -> None:
    rng = np.random.default_rng(12)
    x, P, mu = ground_bank(rng, 1)
    with pytest.raises(ValueError, match="process-noise scale"):
        kalman.predict(
            x, P, slice(None), np.array([0.04]), ground=BANK.parameters, q_scale=np.array([bad])
        )
    with pytest.raises(ValueError, match="process-noise scale"):
        kalman.forecast(x, P, mu, slice(None), np.array([0.04]), BANK.parameters, np.array([bad]))
