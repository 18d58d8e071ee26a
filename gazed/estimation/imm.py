"""The Interacting Multiple Model of seed 000 §5, batched over tracks.

Switching matrix convention (stated here, tested with an asymmetric matrix):
    J[i, j] = P(model j at step k+1 | model i at step k); every row sums to 1.
The paper's text says "J(ij) is switching from i to j" but prints Σ_j J(ij) p(j), which mixes
the two conventions (and filterpy's `IMMEstimator` docstring says j -> i while its code does
i -> j); the code follows the statement, which is also what filterpy's code computes.

One cycle, for N tracks and M models (x (N, M, n), P (N, M, n, n), mu (N, M)):
1. c̄_j = Σ_i J_ij μ_i; ω_ij = J_ij μ_i / c̄_j                     (§5 step 1)
   x0_j = Σ_i ω_ij x_i;  P0_j = Σ_i ω_ij (P_i + (x_i - x0_j)(x_i - x0_j)ᵀ)
2. each model's (E)KF predict from (x0_j, P0_j), then update        (§5 step 2)
3. μ_j ∝ c̄_j N(ν_j; 0, S_j)                                         (§5 step 3)
4. x = Σ_j μ_j x_j,  P = Σ_j μ_j (P_j + (x_j - x)(x_j - x)ᵀ)         (§5 step 4)
A predict-only cycle (missing data) stops after step 2's predict with μ = c̄.
Heading (DESIGN §10): with `angle_index` set, that component is averaged as an angle — each
model's differences to the mean are wrapped to (-π, π] — in mixing and in combination.
The arithmetic is the compiled kernel's (`kalman`, `_kalman.c`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from gazed.estimation import _kalman, kalman
from gazed.estimation.ground_models import GroundModelBank
from gazed.estimation.kalman import Index, Innovation, angle_code, floats


class LinearModels(Protocol):
    """A bank of M linear models on a common state: F, Q (..., M, n, n) for intervals dt (...)."""

    @property
    def names(self) -> tuple[str, ...]: ...

    def matrices(self, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


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
    return np.ascontiguousarray(J)


def mix(
    mu: np.ndarray, J: np.ndarray, x: np.ndarray, P: np.ndarray, angle_index: int | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """§5 step 1 on its own (the kernel's, which `ImmFilter.predict` runs fused with the
    motion step; here for the tests and for analysis): c̄ (K, M), x0 (K, M, n),
    P0 (K, M, n, n) for mu (K, M). A model nobody can switch to (c̄_j = 0) keeps its own state.

    The angle of model j is mixed about its own, x0_j = θ_j + Σ_i ω_ij wrap(θ_i - θ_j), and
    left unwrapped (the motion model that follows wraps it).
    """
    K, M, n = x.shape
    cbar, x0, P0 = np.empty((K, M)), np.empty((K, M, n)), np.empty((K, M, n, n))
    _kalman.mix(
        K, M, n, floats(mu), floats(J), floats(x), floats(P), angle_code(angle_index), cbar, x0, P0
    )
    return cbar, x0, P0


def combine(
    mu: np.ndarray, x: np.ndarray, P: np.ndarray, angle_index: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """§5 step 4: the moment-matched output x (K, n), P (K, n, n); the angle averaged about
    the most likely model's, so that π-ε and -π+ε combine to π."""
    K, M, n = x.shape
    xc, Pc = np.empty((K, n)), np.empty((K, n, n))
    _kalman.combine(K, M, n, floats(mu), floats(x), floats(P), angle_code(angle_index), xc, Pc)
    return xc, Pc


def posterior(prior: np.ndarray, log_likelihood: np.ndarray) -> np.ndarray:
    """§5 step 3 on its own (fused into `ImmFilter.correct`; here for the tests and for
    analysis): prior · exp(ℓ) normalised over the models (K, M), scaled by the largest
    likelihood; when the most likely model has prior 0 (a switching matrix with zeros) the sum
    is taken in logarithms, so the probabilities stay finite."""
    prior = floats(np.atleast_2d(prior))
    K, M = prior.shape
    mu = np.empty((K, M))
    _kalman.posterior(K, M, prior, floats(log_likelihood), mu)
    return mu


@dataclass
class ImmFilter:
    """IMM state for N tracks and M models, with the cycle split so the caller can gate.

    `predict` (mix + model-conditioned predict, μ <- c̄), then `innovate`, then `correct` for the
    tracks that pass the gate. Arrays are public: x (N, M, n), P (N, M, n, n), mu (N, M).
    The models are ground models (`GroundModelBank`, measured by h of `ground_models`) or
    linear ones measured by `H` {m: (m, n)}. `idx` selects tracks (see `kalman`).
    """

    models: GroundModelBank | LinearModels
    J: np.ndarray
    x: np.ndarray
    P: np.ndarray
    mu: np.ndarray
    angle_index: int | None = None
    H: dict[int, np.ndarray] | None = None

    @classmethod
    def empty(
        cls,
        models: GroundModelBank | LinearModels,
        J: np.ndarray,
        n_tracks: int,
        state_dim: int,
        angle_index: int | None = None,
        H: dict[int, np.ndarray] | None = None,
    ) -> ImmFilter:
        M = len(models.names)
        J = check_switching_matrix(J)
        if J.shape != (M, M):
            raise ValueError(f"switching matrix is {J.shape}, expected ({M}, {M})")
        if (H is None) != isinstance(models, GroundModelBank):
            raise ValueError("ground models are measured by h(x); linear ones need H")
        if not (1 <= M <= _kalman.MAX_MODELS and 1 <= state_dim <= _kalman.MAX_STATES):
            raise ValueError(
                f"{M} models of {state_dim} states: the kernel takes 1 to {_kalman.MAX_MODELS} "
                f"models of 1 to {_kalman.MAX_STATES} states"
            )
        if angle_index is not None and not 0 <= angle_index < state_dim:
            raise ValueError(f"angle index {angle_index} outside the {state_dim}-state")
        for m, matrix in (H or {}).items():
            if not (1 <= m <= _kalman.MAX_MEASURED and np.shape(matrix) == (m, state_dim)):
                raise ValueError(f"H for {m} measured: expected ({m}, {state_dim}) with m <= 4")
        return cls(
            models,
            J,
            np.zeros((n_tracks, M, state_dim)),
            np.tile(np.eye(state_dim), (n_tracks, M, 1, 1)),
            np.full((n_tracks, M), 1.0 / M),
            angle_index,
            None if H is None else {m: floats(h) for m, h in H.items()},
        )

    @property
    def _ground(self) -> np.ndarray | None:
        return self.models.parameters if isinstance(self.models, GroundModelBank) else None

    def predict(self, idx: Index, dt: np.ndarray, q_scale: np.ndarray | None = None) -> None:
        """Steps 1-2 (predict) for the tracks idx over dt (K,); μ becomes c̄. q_scale (K,)
        multiplies each track's ground-model Q (None: 1)."""
        ground = self._ground
        F, Q = (None, None) if ground is not None else self.models.matrices(dt)
        kalman.predict(
            self.x,
            self.P,
            idx,
            dt,
            ground=ground,
            F=F,
            Q=Q,
            mu=self.mu,
            J=self.J,
            angle_index=self.angle_index,
            q_scale=q_scale,
        )

    def innovate(self, idx: Index, z: np.ndarray, R: np.ndarray) -> Innovation:
        """ν = z - h(x(k+1|k)), S, the gain, NIS and log N(ν; 0, S) per model; z (K, m),
        R (K, m, m)."""
        H = None if self.H is None else self.H[z.shape[-1]]
        return kalman.innovate(self.x, self.P, idx, z, R, ground=self._ground, H=H)

    def correct(self, idx: Index, innovation: Innovation) -> None:
        """Step 2's update and step 3 for the tracks idx (the rows of `innovation`)."""
        H = None if self.H is None else self.H[innovation.y.shape[-1]]
        kalman.correct(
            self.x,
            self.P,
            idx,
            innovation,
            ground=self._ground,
            H=H,
            mu=self.mu,
            angle_index=self.angle_index,
        )

    def combined(self, idx: Index = slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """Step 4 for the tracks idx."""
        return combine(self.mu[idx], self.x[idx], self.P[idx], self.angle_index)
