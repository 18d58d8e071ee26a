"""The IMM (seed 000 §5): filterpy equivalence, the switching-matrix convention, heading
wrap-around, and model probabilities on seeded switching motions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from filterpy.kalman import IMMEstimator, KalmanFilter

from gazed.config import EstimatorSection
from gazed.estimation import Measurement, build_estimator
from gazed.estimation.ground_models import ITD, ITH
from gazed.estimation.imm import (
    ImmFilter,
    check_switching_matrix,
    combine,
    mix,
    switching_matrix,
)
from gazed.estimation.kinematic_models import KinematicModelBank, kinematic_model
from gazed.eval.scenarios import rounded_square

# rows: from-model; J[i, j] = P(i -> j); deliberately not symmetric
J_ASYMMETRIC = np.array([[0.90, 0.07, 0.03], [0.05, 0.90, 0.05], [0.01, 0.04, 0.95]])


class PaddedModels:
    """CP / CV / CA with a small full-rank floor on Q so all three are proper 6-state filters."""

    def __init__(self) -> None:
        self.bank = KinematicModelBank(
            (kinematic_model("CP", 0.3), kinematic_model("CV", 0.5), kinematic_model("CA", 0.7))
        )
        self.names = self.bank.names

    def matrices(self, dt):
        F, Q = self.bank.matrices(dt)
        return F, Q + 1e-3 * np.eye(6)


def test_imm_matches_filterpy_imm_estimator() -> None:
    models = PaddedModels()
    dt = 0.1
    F, Q = models.matrices(np.array([dt]))
    H = np.zeros((2, 6))
    H[0, 0] = H[1, 3] = 1.0
    R = np.diag([0.04, 0.09])
    x0 = np.array([0.0, 1.0, 0.0, 0.0, 0.5, 0.0])
    P0 = np.diag([1.0, 2.0, 3.0, 1.0, 2.0, 3.0])
    mu0 = np.array([0.2, 0.5, 0.3])
    filters = []
    for m in range(3):
        kf = KalmanFilter(6, 2)
        kf.F, kf.Q, kf.H, kf.R = F[0, m], Q[0, m], H, R
        kf.x, kf.P = x0.copy(), P0.copy()
        filters.append(kf)
    reference = IMMEstimator(filters, mu0, J_ASYMMETRIC)
    ours = ImmFilter.empty(models, J_ASYMMETRIC, 1, 6, H={2: H})
    ours.x[:], ours.P[:], ours.mu[:] = x0, P0, mu0
    rng = np.random.default_rng(7)
    leading = []
    for k in range(200):
        t = k * dt
        z = np.array([0.5 * t, 0.1 * t * t if k < 100 else 10.0]) + rng.normal(0, [0.2, 0.3])
        reference.predict()
        reference.update(z)
        ours.predict(slice(None), np.array([dt]))
        ours.correct(slice(None), ours.innovate(slice(None), z[None], R[None]))
        x, P = ours.combined()
        np.testing.assert_allclose(ours.mu[0], reference.mu, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(x[0], reference.x, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(P[0], reference.P, rtol=1e-9, atol=1e-9)
        leading.append(reference.mu.max())
    assert max(leading) > 0.6  # the models were told apart: probabilities really moved


def test_switching_matrix_convention_with_an_asymmetric_matrix() -> None:
    """J[i, j] = P(i -> j): starting surely in model 0, the predicted probabilities are row 0;
    the mixed state of model j weighs model i by J[i, j] μ_i / c̄_j."""
    mu = np.array([[1.0, 0.0, 0.0]])
    x = np.array([[[1.0], [2.0], [3.0]]])
    P = np.ones((1, 3, 1, 1))
    cbar, x0, _ = mix(mu, J_ASYMMETRIC, x, P, None)
    np.testing.assert_allclose(cbar[0], J_ASYMMETRIC[0])  # not column 0 (0.90, 0.05, 0.01)
    np.testing.assert_allclose(x0[0, :, 0], [1.0, 1.0, 1.0])
    mu = np.array([[0.5, 0.3, 0.2]])
    cbar, x0, _ = mix(mu, J_ASYMMETRIC, x, P, None)
    expected_cbar = mu[0] @ J_ASYMMETRIC
    np.testing.assert_allclose(cbar[0], expected_cbar)
    for j in range(3):
        w = J_ASYMMETRIC[:, j] * mu[0] / expected_cbar[j]
        assert x0[0, j, 0] == pytest.approx(w @ [1.0, 2.0, 3.0])
    # the transposed matrix gives different numbers: the convention is observable
    assert not np.allclose(mix(mu, J_ASYMMETRIC.T, x, P, None)[0], cbar)


def test_switching_matrix_is_validated() -> None:
    np.testing.assert_allclose(switching_matrix(0.96, 3).sum(axis=1), 1.0)
    assert switching_matrix(0.96, 3)[0, 1] == pytest.approx(0.02)
    with pytest.raises(ValueError, match="rows"):
        check_switching_matrix(J_ASYMMETRIC.T * 1.1)


def test_heading_mixes_across_the_wrap() -> None:
    """Mixing π-ε and -π+ε with equal weight gives π, not 0 (DESIGN §10)."""
    eps = 0.1
    x = np.zeros((1, 2, 6))
    x[0, 0, ITH], x[0, 1, ITH] = math.pi - eps, -math.pi + eps
    x[0, :, 2] = 1.0
    P = np.tile(np.eye(6) * 0.01, (1, 2, 1, 1))
    J = np.array([[0.5, 0.5], [0.5, 0.5]])
    mu = np.array([[0.5, 0.5]])
    _, x0, P0 = mix(mu, J, x, P, ITH)
    for j in range(2):
        assert abs(math.remainder(x0[0, j, ITH] - math.pi, 2 * math.pi)) < 1e-12
        assert P0[0, j, ITH, ITH] == pytest.approx(0.01 + eps**2)  # spread of ±ε, not ±π
    xc, Pc = combine(mu, x, P, ITH)
    assert abs(math.remainder(xc[0, ITH] - math.pi, 2 * math.pi)) < 1e-12
    assert Pc[0, ITH, ITH] == pytest.approx(0.01 + eps**2)
    # unequal weights: 3/4 at π-ε, 1/4 at -π+ε -> π - ε/2
    xc, _ = combine(np.array([[0.75, 0.25]]), x, P, ITH)
    assert xc[0, ITH] == pytest.approx(math.pi - eps / 2)


def run_rounded_square(seed: int, **settings: float):
    scenario = rounded_square(seed)
    estimator = build_estimator(EstimatorSection(**settings), mode="imm")
    R_p, R_v = np.eye(2) * 0.05**2, np.eye(2) * 0.2**2
    likely, heading_error, mu = [], [], []
    for k, t in enumerate(scenario.t_s):
        estimator.update(
            Measurement.ground(t, scenario.z_position[k], R_p, scenario.z_velocity[k], R_v)
        )
        x, _ = estimator.combined_state()
        heading_error.append(math.remainder(x[0, ITH] - scenario.truth[k, ITH], 2 * math.pi))
        likely.append(estimator.most_likely())
        mu.append(estimator.probabilities[0].copy())
    return scenario, np.array(likely), np.array(heading_error), np.array(mu), estimator


def test_imm_tracks_heading_through_the_wrap_and_picks_the_turning_model() -> None:
    scenario, likely, heading_error, mu, estimator = run_rounded_square(seed=1)
    headings = scenario.truth[:, ITH]
    assert headings.max() > 3.0 and headings.min() < -3.0  # the square crosses ±π
    assert np.abs(heading_error[20:]).max() < 0.3
    assert np.sqrt(np.mean(heading_error[20:] ** 2)) < 0.12
    truth = scenario.phase
    assert np.mean(likely == truth) > 0.7
    # late in every turn CS leads, late in every straight CSD leads
    for start in range(50, 400, 100):
        late_turn = slice(start + 25, start + 50)
        assert np.mean(mu[late_turn, 1]) > 0.5
        late_straight = slice(start + 75, min(start + 100, 400))
        if start + 75 < 400:
            assert np.mean(mu[late_straight, 0]) > np.mean(mu[late_straight, 1])
    # the CS model's own turn rate at the end (inside the last turn) is near 45°/s
    assert truth[-1] == "CS"
    assert estimator.imm.x[0, 1, ITD] == pytest.approx(math.radians(45), rel=0.25)


def test_imm_picks_constant_direction_while_accelerating() -> None:
    """Straight, then accelerating at 1 m/s² for 2 s, then straight: CD leads while the speed
    changes (position and velocity measured, seeded noise)."""
    rng = np.random.default_rng(5)
    estimator = build_estimator(EstimatorSection(), mode="imm")
    T, s, X = 0.04, 1.0, 0.0
    leader = []
    for k in range(200):
        accelerating = 50 <= k < 100
        estimator.update(
            Measurement.ground(
                k * T,
                np.array([X, 0.0]) + rng.normal(0, 0.02, 2),
                np.eye(2) * 0.02**2,
                np.array([s, 0.0]) + rng.normal(0, 0.05, 2),
                np.eye(2) * 0.05**2,
            )
        )
        leader.append(estimator.most_likely())
        a = 1.0 if accelerating else 0.0
        X += s * T + a * T * T / 2
        s += a * T
    leader = np.array(leader)
    assert np.mean(leader[65:100] == "CD") > 0.7
    assert np.mean(leader[165:200] == "CD") < 0.3


def test_posterior_with_an_unreachable_model() -> None:
    """A switching matrix with zeros can leave the most likely model with prior 0; the
    probabilities stay finite (computed in logarithms then) and that model keeps 0."""
    from gazed.estimation.imm import posterior

    prior = np.array([[0.0, 0.5, 0.5], [0.2, 0.3, 0.5]])
    log_likelihood = np.array([[0.0, -900.0, -901.0], [-1.0, -2.0, -3.0]])
    mu = posterior(prior, log_likelihood)
    assert np.isfinite(mu).all()
    np.testing.assert_allclose(mu.sum(axis=-1), 1.0)
    assert mu[0, 0] == 0.0 and mu[0, 1] == pytest.approx(1 / (1 + math.exp(-1)))
    expected = prior[1] * np.exp(log_likelihood[1])
    np.testing.assert_allclose(mu[1], expected / expected.sum())
