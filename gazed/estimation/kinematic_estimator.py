"""Linear kinematic filters: one model (`cv`, `ca`, `image-cv`) or CP/CV/CA side by side with
innovation-based selection (`innovation`, seed 003). Kalman filter of seed 003 eqs. (4)-(10)
on the common state [x, ẋ, ẍ, y, ẏ, ÿ] of Table 2, batched over tracks and models.
"""

from __future__ import annotations

import numpy as np

from gazed.estimation import kalman
from gazed.estimation.estimator import Space, TrackEstimator
from gazed.estimation.kalman import Innovation
from gazed.estimation.kinematic_models import (
    ACCELERATION_INDEX,
    POSITION_INDEX,
    STATE_DIM,
    VELOCITY_INDEX,
    KinematicModel,
    KinematicModelBank,
    measurement_matrix,
)
from gazed.estimation.selection import InnovationSelector, SelectionReport

OUTPUT_INDEX = POSITION_INDEX + VELOCITY_INDEX  # [x, y, ẋ, ẏ]


class KinematicEstimator(TrackEstimator):
    """Kalman filters of the given CP/CV/CA models; with a selector, the innovation mode."""

    def __init__(
        self,
        models: tuple[KinematicModel, ...],
        n_tracks: int = 1,
        *,
        filter_name: str,
        space: Space = "ground",
        initial_acceleration_std: float = 1.0,
        selection_window: int | None = None,
        consistency_probability: float = 0.99,
        **track_options: float,
    ) -> None:
        self.bank = KinematicModelBank(models)
        super().__init__(self.bank.names, n_tracks, **track_options)
        self.filter_name = filter_name
        self.space = space
        M = len(models)
        self.x = np.zeros((n_tracks, M, STATE_DIM))
        self.P = np.tile(np.eye(STATE_DIM), (n_tracks, M, 1, 1))
        self.initial_acceleration_var = initial_acceleration_std**2
        self.selector = (
            InnovationSelector(self.bank.names, n_tracks, selection_window, consistency_probability)
            if selection_window is not None
            else None
        )
        self._H = {m: np.ascontiguousarray(measurement_matrix(m == 4)) for m in (2, 4)}

    def selection_report(self, track: int = 0) -> SelectionReport | None:
        """The innovation statistics behind the current choice (innovation mode only)."""
        return None if self.selector is None else self.selector.report(track)

    def _initialise(
        self, idx: np.ndarray, zv: np.ndarray, Rv: np.ndarray, interval_s: np.ndarray
    ) -> None:
        x = np.zeros((len(idx), STATE_DIM))
        x[:, OUTPUT_INDEX] = zv
        P = np.zeros((len(idx), STATE_DIM, STATE_DIM))
        P[:, np.array(OUTPUT_INDEX)[:, None], np.array(OUTPUT_INDEX)[None, :]] = Rv
        P[:, ACCELERATION_INDEX, ACCELERATION_INDEX] = self.initial_acceleration_var
        self.x[idx] = x[:, None]
        self.P[idx] = P[:, None]
        if self.selector is not None:
            self.selector.reset(idx)

    def _predict(self, idx: slice | np.ndarray, dt: np.ndarray) -> None:
        """x(k+1|k) = Ã x(k|k), P(k+1|k) = Ã P Ãᵀ + Q̃   (seed 003 eqs. 6-7)."""
        F, Q = self.bank.matrices(dt)
        kalman.predict(self.x, self.P, idx, dt, F=F, Q=Q)

    def _innovate(
        self, idx: slice | np.ndarray, z: np.ndarray, R: np.ndarray
    ) -> tuple[np.ndarray, Innovation]:
        """ν = z - H x(k+1|k) and S = H P Hᵀ + R   (seed 003 eqs. 5, 9)."""
        innovation = kalman.innovate(self.x, self.P, idx, z, R, H=self._H[z.shape[-1]])
        return innovation.nis.min(axis=-1), innovation

    def _correct(
        self, idx: slice | np.ndarray, handle: Innovation, inside: np.ndarray | None
    ) -> None:
        """x(k+1|k+1) = x + K ν, P by the Joseph form of eq. 8; the selector records ν, S."""
        i = handle
        rows = np.arange(self.n_tracks)[idx]
        if inside is not None:
            rows = rows[inside]
            i = i.rows(inside)
            idx = rows
        kalman.correct(self.x, self.P, idx, i, H=self._H[i.y.shape[-1]])
        if self.selector is not None:
            self.selector.record(rows, i.y, i.S, i.nis)

    def _chosen(self, idx: slice | np.ndarray) -> np.ndarray:
        rows = np.arange(self.n_tracks)[idx]
        return (
            np.zeros(len(rows), dtype=np.int64)
            if self.selector is None
            else self.selector.selected[rows]
        )

    def _forecast(self, idx: slice | np.ndarray, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The selected model's prediction dt ahead: [x, y, ẋ, ẏ] and its covariance."""
        chosen = self._chosen(idx)
        rows = np.arange(len(chosen))
        x = self.x[idx][rows, chosen]
        P = self.P[idx][rows, chosen]
        F, Q = self.bank.matrices(dt)
        F, Q = F[rows, chosen], Q[rows, chosen]
        x = (F @ x[..., None])[..., 0]
        P = F @ P @ F.mT + Q
        out = np.array(OUTPUT_INDEX)
        return x[:, out], P[:, out[:, None], out[None, :]]

    def _probabilities(self, idx: slice | np.ndarray) -> np.ndarray:
        """One-hot on the selected model: selection is a decision, not a weighting."""
        chosen = self._chosen(idx)
        p = np.zeros((len(chosen), len(self.model_names)))
        p[np.arange(len(chosen)), chosen] = 1.0
        return p

    def _signature(self, idx: slice | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The selected model, and (ṡ, θ̇) of its state: ṡ = v·a/|v|, θ̇ = (v × a)/|v|²."""
        chosen = self._chosen(idx)
        x = self.x[idx][np.arange(len(chosen)), chosen]
        v = x[:, VELOCITY_INDEX]
        a = x[:, ACCELERATION_INDEX]
        speed2 = np.maximum((v * v).sum(axis=-1), 1e-12)
        s_dot = (v * a).sum(axis=-1) / np.sqrt(speed2)
        theta_dot = (v[:, 0] * a[:, 1] - v[:, 1] * a[:, 0]) / speed2
        return chosen, np.column_stack([s_dot, theta_dot])
