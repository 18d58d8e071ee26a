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
    """Per track and model: ν (..., M, m), H, R, S, S⁻¹, NIS and log-likelihood (..., M)."""

    y: np.ndarray
    H: np.ndarray
    R: np.ndarray
    S: np.ndarray
    S_inv: np.ndarray
    nis: np.ndarray
    log_likelihood: np.ndarray


def _difference(a: np.ndarray, b: np.ndarray, angle_index: int | None) -> np.ndarray:
    d = a - b
    if angle_index is not None:
        d[..., angle_index] = wrap_angle(d[..., angle_index])
    return d


def weighted_mean(
    w: np.ndarray, x: np.ndarray, reference: np.ndarray, angle_index: int | None
) -> np.ndarray:
    """Σ_i w_i x_i over axis -2 of x (..., I, n) with weights w (..., I); an angle component is
    averaged as reference + Σ_i w_i wrap(x_i - reference) so that π-ε and -π+ε mix to π."""
    mean = (w[..., None, :] @ x)[..., 0, :]
    if angle_index is not None:
        ref = reference[..., angle_index]
        d = wrap_angle(x[..., angle_index] - ref[..., None])
        mean[..., angle_index] = wrap_angle(ref + (w * d).sum(axis=-1))
    return mean


def mix(
    mu: np.ndarray, J: np.ndarray, x: np.ndarray, P: np.ndarray, angle_index: int | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """§5 step 1: returns c̄ (N, M), x0 (N, M, n), P0 (N, M, n, n)."""
    cbar = mu @ J  # c̄_j = Σ_i μ_i J_ij
    omega_t = (J.T * mu[..., None, :]) / cbar[..., :, None]  # ω_ij stored as [j, i]
    x0 = omega_t @ x  # x0_j = Σ_i ω_ij x_i
    if angle_index is not None:  # ... with the heading wrapped about model j's own
        th = x[..., angle_index]
        d = wrap_angle(th[..., None, :] - th[..., :, None])  # [j, i] = θ_i - θ_j
        x0[..., angle_index] = wrap_angle(th + (omega_t * d).sum(axis=-1))
    D = _difference(x[..., None, :, :], x0[..., :, None, :], angle_index)  # [j, i] = x_i - x0_j
    n = x.shape[-1]
    P0 = (omega_t @ P.reshape(*P.shape[:-2], n * n)).reshape(P.shape)
    P0 += (D.mT * omega_t[..., None, :]) @ D  # Σ_i ω_ij D_ij D_ijᵀ
    return cbar, x0, P0


def combine(
    mu: np.ndarray, x: np.ndarray, P: np.ndarray, angle_index: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """§5 step 4: the moment-matched output (x (N, n), P (N, n, n)); the angle is averaged about
    the most likely model's."""
    best = np.argmax(mu, axis=-1)
    reference = np.take_along_axis(x, best[..., None, None], axis=-2)[..., 0, :]
    xc = weighted_mean(mu, x, reference, angle_index)
    D = _difference(x, xc[..., None, :], angle_index)  # (N, M, n)
    n = x.shape[-1]
    Pc = (mu[..., None, :] @ P.reshape(*P.shape[:-2], n * n))[..., 0, :].reshape((*xc.shape, n))
    return xc, Pc + (D.mT * mu[..., None, :]) @ D


def normalise_log(log_w: np.ndarray) -> np.ndarray:
    """exp(log_w) / Σ exp(log_w) over the last axis, without underflow."""
    top = np.max(log_w, axis=-1, keepdims=True)
    w = np.exp(log_w - top)
    return w / w.sum(axis=-1, keepdims=True)


@dataclass
class ImmFilter:
    """IMM state for N tracks and M models, with the cycle split so the caller can gate.

    `predict` (mix + model-conditioned predict, μ <- c̄), then `innovate`, then `correct` for the
    tracks that pass the gate. Arrays are public: x (N, M, n), P (N, M, n, n), mu (N, M).
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
        Rm = np.broadcast_to(R[:, None], H.shape[:-2] + R.shape[-2:])
        S = innovation_covariance(self.P[idx], H, Rm)
        S_inv, nis, log_lik = gaussian_terms(y, S)
        return Innovation(y, H, Rm, S, S_inv, nis, log_lik)

    def correct(self, idx: slice | np.ndarray, innovation: Innovation) -> None:
        """Step 2's update and step 3 for the tracks idx (the rows of `innovation`)."""
        i = innovation
        x, P = joseph_update(self.x[idx], self.P[idx], i.y, i.H, i.R, i.S_inv)
        if self.angle_index is not None:
            x[..., self.angle_index] = wrap_angle(x[..., self.angle_index])
        self.x[idx] = x
        self.P[idx] = P
        with np.errstate(divide="ignore"):
            self.mu[idx] = normalise_log(np.log(self.mu[idx]) + i.log_likelihood)

    def combined(self, idx: slice | np.ndarray = slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """Step 4 for the tracks idx."""
        return combine(self.mu[idx], self.x[idx], self.P[idx], self.angle_index)
