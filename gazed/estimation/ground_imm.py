"""The `imm` mode: CSD, CS and CD extended Kalman filters in an IMM (seed 000 §4-5).

State [X, Y, s, θ, ṡ, θ̇] on the ground plane; measurements [X, Y] or [X, Y, Ẋ, Ẏ]. With a
`NoiseAdaptation`, each track learns its position noise and its process-noise scale from its
own innovations (`noise_adaptation`).
"""

from __future__ import annotations

import math

import numpy as np

from gazed.estimation import kalman
from gazed.estimation.estimator import TrackEstimator
from gazed.estimation.ground_models import (
    HEADING_INDEX,
    IS,
    ISD,
    ITD,
    ITH,
    STATE_DIM,
    GroundModel,
    GroundModelBank,
)
from gazed.estimation.imm import ImmFilter
from gazed.estimation.kalman import Innovation
from gazed.estimation.noise_adaptation import NoiseAdaptation


class ImmEstimator(TrackEstimator):
    """CSD / CS / CD in an IMM with switching matrix J (J[i, j] = P(i -> j), see `imm`)."""

    filter_name = "imm"

    def __init__(
        self,
        models: tuple[GroundModel, ...],
        J: np.ndarray,
        n_tracks: int = 1,
        *,
        initial_rate_std: tuple[float, float] = (0.5, 0.5),
        adaptation: NoiseAdaptation | None = None,
        **track_options: float,
    ) -> None:
        bank = GroundModelBank(models)
        super().__init__(bank.names, n_tracks, **track_options)
        self.imm = ImmFilter.empty(bank, J, n_tracks, STATE_DIM, HEADING_INDEX)
        self.initial_rate_var = np.square(initial_rate_std)
        if adaptation is not None and len(adaptation.alpha) != n_tracks:
            raise ValueError(f"noise adaptation for {len(adaptation.alpha)} tracks, not {n_tracks}")
        self.adaptation = adaptation

    def _initialise(
        self, idx: np.ndarray, zv: np.ndarray, Rv: np.ndarray, interval_s: np.ndarray
    ) -> None:
        """Polar state from position and velocity: s = |v|, θ = atan2(vy, vx), with
        cov = T Rv Tᵀ, T the Jacobian of (v -> s, θ); ṡ, θ̇ start at 0. With adaptation, Rv
        holds the prior position noise where it exceeds the measurements' own."""
        if self.adaptation is not None:
            self.adaptation.reset(idx)
            Rv = self.adaptation.start_cov(Rv, interval_s)
        vx, vy = zv[:, 2], zv[:, 3]
        s = np.hypot(vx, vy)
        s_safe = np.maximum(s, 1e-9)
        T = np.zeros((len(idx), 4, 4))
        T[:, 0, 0] = T[:, 1, 1] = 1.0
        T[:, 2, 2], T[:, 2, 3] = vx / s_safe, vy / s_safe
        T[:, 3, 2], T[:, 3, 3] = -vy / s_safe**2, vx / s_safe**2
        x = np.zeros((len(idx), STATE_DIM))
        x[:, :2] = zv[:, :2]
        x[:, IS] = s
        x[:, ITH] = np.arctan2(vy, vx)
        P = np.zeros((len(idx), STATE_DIM, STATE_DIM))
        P[:, :4, :4] = T @ Rv @ T.mT
        # direction unknown when still: the heading's std is capped at π, its row and column
        # scaled together (D P D keeps P positive semi-definite, clipping the variance alone
        # does not)
        scale = np.sqrt(np.minimum(1.0, math.pi**2 / np.maximum(P[:, ITH, ITH], 1e-300)))
        P[:, ITH, :] *= scale[:, None]
        P[:, :, ITH] *= scale[:, None]
        P[:, ISD, ISD], P[:, ITD, ITD] = self.initial_rate_var
        M = len(self.model_names)
        self.imm.x[idx] = x[:, None, :]
        self.imm.P[idx] = P[:, None]
        self.imm.mu[idx] = 1.0 / M

    def _q_scale(self, idx: slice | np.ndarray) -> np.ndarray | None:
        return None if self.adaptation is None else self.adaptation.q_scale(idx)

    def _predict(self, idx: slice | np.ndarray, dt: np.ndarray) -> None:
        self.imm.predict(idx, dt, self._q_scale(idx))

    def _innovate(
        self, idx: slice | np.ndarray, z: np.ndarray, R: np.ndarray
    ) -> tuple[np.ndarray, tuple[Innovation, np.ndarray | None, np.ndarray | None]]:
        """With adaptation, R is the adapted one, and the handle carries the combined position
        innovation and tr H P⁻ Hᵀ for the noise estimates of the tracks the gate accepts."""
        if self.adaptation is None:
            innovation = self.imm.innovate(idx, z, R)
            return innovation.nis.min(axis=-1), (innovation, None, None)
        R = self.adaptation.measurement_cov(idx, R)
        innovation = self.imm.innovate(idx, z, R)
        x, P = self.imm.combined(idx)
        position = z[:, :2] - x[:, :2]
        return innovation.nis.min(axis=-1), (innovation, position, P[:, 0, 0] + P[:, 1, 1])

    def _correct(
        self,
        idx: slice | np.ndarray,
        handle: tuple[Innovation, np.ndarray | None, np.ndarray | None],
        inside: np.ndarray | None,
    ) -> None:
        innovation, position, predicted_m2 = handle
        if inside is not None:
            idx = np.arange(self.n_tracks)[idx][inside]
            innovation = innovation.rows(inside)
            if position is not None and predicted_m2 is not None:
                position, predicted_m2 = position[inside], predicted_m2[inside]
        self.imm.correct(idx, innovation)  # a negative speed comes out positive, heading turned
        if self.adaptation is not None and position is not None and predicted_m2 is not None:
            self.adaptation.observe(idx, position, predicted_m2)

    def _forecast(self, idx: slice | np.ndarray, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each model predicted dt ahead without mixing, mapped to [X, Y, s cos θ, s sin θ]
        through its Jacobian, then the μ-weighted mixture moments. At dt = 0 (the state at
        its own time, as the estimator publishes it) the propagation is the identity."""
        imm = self.imm
        return kalman.forecast(
            imm.x, imm.P, imm.mu, idx, dt, imm.models.parameters, self._q_scale(idx)
        )

    def _probabilities(self, idx: slice | np.ndarray) -> np.ndarray:
        return self.imm.mu[idx]

    def _signature(self, idx: slice | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The most likely model and the (ṡ, θ̇) of its own estimate: the motion signature of
        a segment is the rates of the model that explains it (the combined state, §5 step 4,
        dilutes a turn rate by the probability of the models that hold θ̇ at 0)."""
        best = self.imm.mu[idx].argmax(axis=-1)
        rates = self.imm.x[idx, :, ISD:][self._track_numbers[: len(best)], best]
        return best, rates

    def model_rates(self, idx: slice | np.ndarray = slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """(ṡ, θ̇) of each track's most likely model, 2 x (K,)."""
        rates = self._signature(idx)[1]
        return rates[:, 0], rates[:, 1]

    def combined_state(self) -> tuple[np.ndarray, np.ndarray]:
        """The IMM output x (N, 6), P (N, 6, 6) (§5 step 4, heading averaged as an angle)."""
        return self.imm.combined()
