"""The Interacting Multiple Model of seed 000 §5, batched over tracks.

Switching matrix convention (stated here, tested with an asymmetric matrix):
    J[i, j] = P(model j at step k+1 | model i at step k); every row sums to 1.
The paper's text says "J(ij) is switching from i to j" but prints Σ_j J(ij) p(j), which mixes
the two conventions (and filterpy's `IMMEstimator` docstring says j -> i while its code does
i -> j); the code below follows the statement, which is also what filterpy's code computes.

One cycle, for N tracks and M models (x (N, M, n), P (N, M, n, n), mu (N, M)):
1. c̄_j = Σ_i J_ij μ_i; ω_ij = J_ij μ_i / c̄_j                     (§5 step 1)
   x0_j = Σ_i ω_ij x_i;  P0_j = Σ_i ω_ij (P_i + (x_i - x0_j)(x_i - x0_j)ᵀ)
2. each model's (E)KF predict from (x0_j, P0_j), then update        (§5 step 2)
3. μ_j ∝ c̄_j N(ν_j; 0, S_j)                                         (§5 step 3)
4. x = Σ_j μ_j x_j,  P = Σ_j μ_j (P_j + (x_j - x)(x_j - x)ᵀ)         (§5 step 4)
A predict-only cycle (missing data) stops after step 2's predict with μ = c̄.
Heading (DESIGN §10): with `angle_index` set, that component is averaged as an angle — each
model's differences to the mean are wrapped to (-π, π] — in mixing and in combination.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from gazed.estimation.ground_models import wrap_angle
from gazed.estimation.kalman import (
    gaussian_terms,
    innovation_covariance,
    joseph_update,
    predict_covariance,
)
from gazed.estimation.masks import every


class MotionModels(Protocol):
    """A bank of M motion models on a common state: x (..., M, n) -> (x', F, Q)."""

    @property
    def names(self) -> tuple[str, ...]: ...

    def propagate(
        self, x: np.ndarray, dt: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


# (x (..., n), m) -> (h (..., m), H (..., m, n)) for a measurement of dimension m
MeasurementFunction = Callable[[np.ndarray, int], tuple[np.ndarray, np.ndarray]]


def switching_matrix(stay_probability: float, n_models: int) -> np.ndarray:
    """The paper's J: J_d on the diagonal, (1 - J_d)/(N - 1) elsewhere (§5.1)."""
    off = (1.0 - stay_probability) / (n_models - 1)
    return np.full((n_models, n_models), off) + (stay_probability - off) * np.eye(n_models)


def check_switching_matrix(J: np.ndarray) -> np.ndarray:
    J = np.asarray(J, dtype=float)
    if J.ndim != 2 or J.shape[0] != J.shape[1]:
        raise ValueError(f"switching matrix must be square, got shape {J.shape}")
    if np.any(J < 0) or not np.allclose(J.sum(axis=1), 1.0, atol=1e-12):
        raise ValueError(
            "switching matrix: rows must be probabilities summing to 1 (J[i, j] = i -> j)"
        )
    return J


@dataclass
class Innovation:
    """Per track and model: ν (..., M, m), H, R (..., 1, m, m), H P, S⁻¹, and NIS and
    log-likelihood (..., M)."""

    y: np.ndarray
    H: np.ndarray
    R: np.ndarray
    HP: np.ndarray
    S_inv: np.ndarray
    nis: np.ndarray
    log_likelihood: np.ndarray

    def rows(self, keep: np.ndarray) -> Innovation:
        """The tracks where `keep` (K,) is True."""
        return Innovation(*(a[keep] for a in vars(self).values()))


def _angle_spread(
    w: np.ndarray, angle: np.ndarray, reference: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """d = wrap(angle - reference) (..., I) and the weighted mean Σ_i w_i d_i (...)."""
    d = wrap_angle(angle - reference)
    return d, (w[..., None, :] @ d[..., :, None])[..., 0, 0]


def mix(
    mu: np.ndarray, J: np.ndarray, x: np.ndarray, P: np.ndarray, angle_index: int | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """§5 step 1: returns c̄ (N, M), x0 (N, M, n), P0 (N, M, n, n).

    The angle of model j is mixed about its own, x0_j = θ_j + Σ_i ω_ij wrap(θ_i - θ_j), and
    left unwrapped (the motion model that follows wraps it).
    """
    cbar = mu @ J  # c̄_j = Σ_i μ_i J_ij
    omega_t = J.T * (mu[..., None, :] / cbar[..., :, None])  # ω_ij stored as [j, i]
    x0 = omega_t @ x  # x0_j = Σ_i ω_ij x_i
    D = x[..., None, :, :] - x0[..., :, None, :]  # [j, i] = x_i - x0_j
    if angle_index is not None:
        th = x[..., angle_index]
        d, spread = _angle_spread(omega_t, th[..., None, :], th[..., :, None])  # [j, i]
        x0[..., angle_index] = th + spread
        D[..., angle_index] = wrap_angle(d - spread[..., None])
    n = x.shape[-1]
    P0 = (omega_t @ P.reshape(*P.shape[:-2], n * n)).reshape(P.shape)
    P0 += (D.mT * omega_t[..., None, :]) @ D  # Σ_i ω_ij D_ij D_ijᵀ
    return cbar, x0, P0


def combine(
    mu: np.ndarray, x: np.ndarray, P: np.ndarray, angle_index: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """§5 step 4: the moment-matched output (x (N, n), P (N, n, n)); the angle is averaged
    about the most likely model's, so that π-ε and -π+ε combine to π."""
    xc = (mu[..., None, :] @ x)[..., 0, :]
    D = x - xc[..., None, :]  # (N, M, n)
    if angle_index is not None:
        th = x[..., angle_index]
        reference = np.take_along_axis(th, np.argmax(mu, axis=-1)[..., None], axis=-1)
        d, spread = _angle_spread(mu, th, reference)
        xc[..., angle_index] = wrap_angle(reference[..., 0] + spread)
        D[..., angle_index] = wrap_angle(d - spread[..., None])
    n = x.shape[-1]
    Pc = (mu[..., None, :] @ P.reshape(*P.shape[:-2], n * n)).reshape((*xc.shape, n))
    Pc += (D.mT * mu[..., None, :]) @ D
    return xc, Pc


def posterior(prior: np.ndarray, log_likelihood: np.ndarray) -> np.ndarray:
    """prior · exp(log_likelihood), normalised over the last axis (§5 step 3).

    The likelihoods are scaled by their largest, which cannot underflow unless the most likely
    model has prior 0 (a switching matrix with zeros); then the sum is taken in logarithms.
    """
    w = prior * np.exp(log_likelihood - log_likelihood.max(axis=-1, keepdims=True))
    total = w.sum(axis=-1, keepdims=True)
    if not every(total):
        with np.errstate(divide="ignore"):
            log_w = np.log(prior) + log_likelihood
        w = np.exp(log_w - log_w.max(axis=-1, keepdims=True))
        total = w.sum(axis=-1, keepdims=True)
    w /= total
    return w


@dataclass
class ImmFilter:
    """IMM state for N tracks and M models, with the cycle split so the caller can gate.

    `predict` (mix + model-conditioned predict, μ <- c̄), then `innovate`, then `correct` for the
    tracks that pass the gate. Arrays are public: x (N, M, n), P (N, M, n, n), mu (N, M).
    `idx` selects tracks: a slice (the fast case: views, written in place) or an index array.
    """

    models: MotionModels
    J: np.ndarray
    measure: MeasurementFunction
    x: np.ndarray
    P: np.ndarray
    mu: np.ndarray
    angle_index: int | None = None

    @classmethod
    def empty(
        cls,
        models: MotionModels,
        J: np.ndarray,
        measure: MeasurementFunction,
        n_tracks: int,
        state_dim: int,
        angle_index: int | None = None,
    ) -> ImmFilter:
        M = len(models.names)
        J = check_switching_matrix(J)
        if J.shape != (M, M):
            raise ValueError(f"switching matrix is {J.shape}, expected ({M}, {M})")
        return cls(
            models,
            J,
            measure,
            np.zeros((n_tracks, M, state_dim)),
            np.tile(np.eye(state_dim), (n_tracks, M, 1, 1)),
            np.full((n_tracks, M), 1.0 / M),
            angle_index,
        )

    def predict(self, idx: slice | np.ndarray, dt: np.ndarray) -> None:
        """Steps 1-2 (predict) for the tracks idx over dt (len(idx),); μ becomes c̄."""
        cbar, x0, P0 = mix(self.mu[idx], self.J, self.x[idx], self.P[idx], self.angle_index)
        x1, F, Q = self.models.propagate(x0, dt)
        self.x[idx] = x1
        self.P[idx] = predict_covariance(P0, F, Q)
        self.mu[idx] = cbar

    def innovate(self, idx: slice | np.ndarray, z: np.ndarray, R: np.ndarray) -> Innovation:
        """ν = z - h(x(k+1|k)), S, NIS and log N(ν; 0, S) per model; z (K, m), R (K, m, m)."""
        h, H = self.measure(self.x[idx], z.shape[-1])
        y = z[:, None, :] - h
        R = R[:, None]  # the same R for every model
        HP, S = innovation_covariance(self.P[idx], H, R)
        S_inv, nis, log_likelihood = gaussian_terms(y, S)
        return Innovation(y, H, R, HP, S_inv, nis, log_likelihood)

    def correct(self, idx: slice | np.ndarray, innovation: Innovation) -> None:
        """Step 2's update and step 3 for the tracks idx (the rows of `innovation`)."""
        i = innovation
        x, P = joseph_update(self.x[idx], self.P[idx], i.y, i.H, i.R, i.HP, i.S_inv)
        if self.angle_index is not None:
            heading = x[..., self.angle_index]
            wrap_angle(heading, out=heading)
        self.x[idx] = x
        self.P[idx] = P
        self.mu[idx] = posterior(self.mu[idx], i.log_likelihood)

    def combined(self, idx: slice | np.ndarray = slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """Step 4 for the tracks idx."""
        return combine(self.mu[idx], self.x[idx], self.P[idx], self.angle_index)
