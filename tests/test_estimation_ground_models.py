"""CSD / CS / CD (seed 000 §4.1 with the DESIGN §10 errata): update equations, analytic
Jacobians against finite differences, the ω -> 0 limit, process noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gazed.estimation.ground_models import (
    SERIES_LIMIT,
    GroundModelBank,
    canonicalise,
    cd,
    cs,
    csd,
    measure,
)

BANK = GroundModelBank((csd(0.09, 0.01), cs(0.09, 30.0), cd(0.25, 0.01)))
CSD, CS, CD = 0, 1, 2


def propagate_one(model: int, x: np.ndarray, dt: float):
    xs = np.broadcast_to(x, (1, 3, 6)).copy()
    xn, F, Q = BANK.propagate(xs, np.array([dt]))
    return xn[0, model], F[0, model], Q[0, model]


def numeric_jacobian(model: int, x: np.ndarray, dt: float, eps: float = 1e-6) -> np.ndarray:
    J = np.zeros((6, 6))
    for k in range(6):
        e = np.zeros(6)
        e[k] = eps
        d = propagate_one(model, x + e, dt)[0] - propagate_one(model, x - e, dt)[0]
        d[3] = math.remainder(d[3], 2 * math.pi)
        J[:, k] = d / (2 * eps)
    return J


STATES = [
    np.array([1.0, -2.0, 1.3, 0.4, 0.2, 0.7]),
    np.array([0.0, 0.0, 0.8, -2.9, -0.3, -1.4]),
    np.array([5.0, 3.0, 2.0, 3.1, 0.0, 2e-4]),  # CS inside the series region
    np.array([5.0, 3.0, 2.0, 1.0, 0.5, 0.0]),  # ω = 0 exactly
]


@pytest.mark.parametrize("model", [CSD, CS, CD], ids=["CSD", "CS", "CD"])
@pytest.mark.parametrize("dt", [0.04, 0.4, 2.0])
@pytest.mark.parametrize("state", range(len(STATES)))
def test_jacobian_matches_finite_differences(model: int, dt: float, state: int) -> None:
    x = STATES[state]
    _, F, _ = propagate_one(model, x, dt)
    np.testing.assert_allclose(F, numeric_jacobian(model, x, dt), atol=2e-7)


@pytest.mark.parametrize("with_velocity", [False, True])
def test_measurement_jacobian_matches_finite_differences(with_velocity: bool) -> None:
    x = np.array([1.0, 2.0, 1.5, 2.5, 0.1, 0.3])
    h, H = measure(x, with_velocity)
    eps = 1e-6
    numeric = np.stack(
        [
            (measure(x + e, with_velocity)[0] - measure(x - e, with_velocity)[0]) / (2 * eps)
            for e in np.eye(6) * eps
        ],
        axis=1,
    )
    np.testing.assert_allclose(H, numeric, atol=1e-8)
    if with_velocity:  # errata: h = (X, Y, s cos θ, s sin θ)
        np.testing.assert_allclose(h[2:], [1.5 * math.cos(2.5), 1.5 * math.sin(2.5)])


def test_update_equations_are_the_corrected_ones() -> None:
    X, Y, s, th, sd, w, T = 1.0, -1.0, 1.5, 0.7, 0.4, 0.9, 0.3
    x = np.array([X, Y, s, th, sd, w])
    # CSD (§4.1.2, errata: cos in X): s and θ constant, the unmodelled rates predicted as 0
    np.testing.assert_allclose(
        propagate_one(CSD, x, T)[0],
        [X + s * math.cos(th) * T, Y + s * math.sin(th) * T, s, th, 0.0, 0.0],
    )
    # CS (§4.1.3 with the errata's signs)
    expected_cs = [
        X + s / w * (math.sin(th + w * T) - math.sin(th)),
        Y + s / w * (math.cos(th) - math.cos(th + w * T)),
        s,
        th + w * T,
        0.0,
        w,
    ]
    np.testing.assert_allclose(propagate_one(CS, x, T)[0], expected_cs, rtol=1e-12)
    # CD (§4.1.4, errata: cos in X)
    d = s * T + sd * T * T / 2
    np.testing.assert_allclose(
        propagate_one(CD, x, T)[0],
        [X + math.cos(th) * d, Y + math.sin(th) * d, s + sd * T, th, sd, 0.0],
    )


def test_turn_rate_limit_is_continuous() -> None:
    """CS at ω -> 0 becomes CSD; the series and the closed form agree at the switch-over."""
    x = np.array([0.0, 0.0, 1.2, 0.3, 0.0, 0.0])
    straight = propagate_one(CSD, x, 0.5)[0]
    limit = propagate_one(CS, x, 0.5)[0]
    np.testing.assert_allclose(limit[:4], straight[:4], atol=1e-15)
    below, above = x.copy(), x.copy()
    below[5] = SERIES_LIMIT / 0.5 * (1 - 1e-9)
    above[5] = SERIES_LIMIT / 0.5 * (1 + 1e-9)
    (xb, Fb, _), (xa, Fa, _) = propagate_one(CS, below, 0.5), propagate_one(CS, above, 0.5)
    np.testing.assert_allclose(xb, xa, atol=1e-12)
    np.testing.assert_allclose(Fb, Fa, atol=1e-9)


def test_csd_process_noise_is_the_papers_first_order_noise() -> None:
    """§4.1.2: e = ((e_ṡ c - e_θ̇ s sn)T²/2, (e_ṡ sn + e_θ̇ s c)T²/2, e_ṡ T, e_θ̇ T, e_ṡ, e_θ̇)."""
    s, th, T = 1.3, 0.6, 0.2
    _, _, Q = propagate_one(CSD, np.array([0, 0, s, th, 0, 0]), T)
    c, sn = math.cos(th), math.sin(th)
    G = np.array(
        [
            [c * T * T / 2, -s * sn * T * T / 2],
            [sn * T * T / 2, s * c * T * T / 2],
            [T, 0],
            [0, T],
            [1, 0],
            [0, 1],
        ]
    )
    np.testing.assert_allclose(Q, G @ np.diag([0.09, 0.01]) @ G.T, atol=1e-15)


@pytest.mark.parametrize("model", [CSD, CS, CD])
def test_process_noise_is_symmetric_positive_semidefinite(model: int) -> None:
    _, _, Q = propagate_one(model, STATES[0], 0.4)
    np.testing.assert_allclose(Q, Q.T)
    eig = np.linalg.eigvalsh(Q)
    assert eig.min() > -1e-12 * eig.max()
    assert np.sum(eig > 1e-9 * eig.max()) == 2  # two noise inputs


def test_negative_speed_becomes_positive_with_heading_turned() -> None:
    x = np.array([[1.0, 2.0, -1.5, 0.5, 0.2, 0.3]])
    P = np.diag([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])[None]
    P[0, 2, 4] = P[0, 4, 2] = 0.5
    P[0, 2, 3] = P[0, 3, 2] = 0.25
    h_before = measure(x[0], True)[0]
    canonicalise(x, P)
    assert x[0, 2] == 1.5 and x[0, 4] == -0.2
    assert x[0, 3] == pytest.approx(0.5 - math.pi)
    np.testing.assert_allclose(measure(x[0], True)[0], h_before, atol=1e-12)
    assert P[0, 2, 4] == 0.5 and P[0, 2, 3] == -0.25


@pytest.mark.parametrize(
    ("heading", "turn", "expected"),
    [
        (-math.pi, 0.0, math.pi),  # -π is π
        (math.pi, 0.0, math.pi),
        (math.pi - 0.1, 0.3, -math.pi + 0.2),  # a turn across π
        (-math.pi + 0.1, -0.3, math.pi - 0.2),
        (3.0 * math.pi, 0.0, math.pi),
        (7.0, 0.0, 7.0 - 2 * math.pi),
    ],
)
def test_heading_is_wrapped_to_the_half_open_interval(heading, turn, expected) -> None:
    """θ' = θ + ωT wrapped to (-π, π] (CS over 1 s at θ̇ = turn)."""
    theta = propagate_one(CS, np.array([0.0, 0.0, 1.0, heading, 0.0, turn]), 1.0)[0][3]
    assert theta == pytest.approx(expected, abs=1e-12)
    assert -math.pi < theta <= math.pi


def test_batch_propagation_equals_one_state_at_a_time() -> None:
    """The bank on (K, M, 6) states with K different intervals gives each state its own
    model and interval (state i is model i % M over dt[i // M]), the turning rows' series and
    closed forms side by side."""
    K = 7
    rng = np.random.default_rng(3)
    x = rng.normal(size=(K, 3, 6))
    x[:2, :, 5] = [[1e-5], [0.0]]  # ω -> 0 rows next to turning ones
    x[2, :, 3] = math.pi - 1e-3  # a heading that wraps
    x[2, :, 5] = 1.0
    dt = rng.uniform(0.01, 1.0, K)
    xn, F, Q = BANK.propagate(x, dt)
    for k in range(K):
        xk, Fk, Qk = BANK.propagate(x[k : k + 1], dt[k : k + 1])
        np.testing.assert_allclose(xn[k], xk[0], rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(F[k], Fk[0], rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(Q[k], Qk[0], rtol=1e-14, atol=1e-15)
    assert xn[2, 1, 3] < 0  # wrapped to (-π, π] on both paths
