"""Innovation-based motion-model selection (seed 003 §II-III).

Models run side by side; for each, the last W innovations are kept. A model whose motion
assumption holds has a zero-mean, white innovation sequence with covariance S (seed 003 §II-b,
eq. 15), so over the window:

- bias test: with w_k = L_k⁻¹ ν_k the position innovation whitened by its S_k = L_k L_kᵀ,
  b = ‖Σ_k w_k‖² / W ~ χ²(2); a modelling error shows as an offset in E[ν] (eqs. 16-19,
  Table 3) and fails it;
- NIS test: Σ_k ν_kᵀ S_k⁻¹ ν_k ~ χ²(Σ_k m_k).

A model is consistent when both pass at `probability`; the selected model is the lowest-order
consistent one (CP before CV before CA, the order the models are given in), or, if none is,
the one with the smallest mean NIS per degree of freedom.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gazed.estimation.chi_square import chi2_quantile


@dataclass(frozen=True)
class SelectionReport:
    """The statistics that drove the choice for one track."""

    selected: str
    innovation_mean: dict[str, tuple[float, float]]  # mean position innovation per model
    bias_statistic: dict[str, float]
    bias_threshold: float
    nis_per_dof: dict[str, float]
    nis_threshold_per_dof: float
    consistent: dict[str, bool]
    window: int


class InnovationSelector:
    """Windowed innovation statistics of M models for N tracks."""

    def __init__(
        self, model_names: tuple[str, ...], n_tracks: int, window: int, probability: float
    ):
        if window < 1:
            raise ValueError(f"selection window must be >= 1, got {window}")
        M = len(model_names)
        self.model_names = model_names
        self.window = window
        self.probability = probability
        self.innovation = np.zeros((n_tracks, M, window, 2))
        self.whitened = np.zeros((n_tracks, M, window, 2))
        self.nis = np.zeros((n_tracks, M, window))
        self.dof = np.zeros((n_tracks, window))
        self.count = np.zeros(n_tracks, dtype=np.int64)
        self.selected = np.zeros(n_tracks, dtype=np.int64)
        self._bias_threshold = chi2_quantile(probability, 2)
        # NIS thresholds by degrees of freedom (2 or 4 per innovation), computed when first met
        self._nis_threshold = np.full(4 * window + 1, np.nan)

    def reset(self, idx: slice | np.ndarray) -> None:
        self.count[idx] = 0
        self.selected[idx] = 0

    def record(self, idx: np.ndarray, y: np.ndarray, S: np.ndarray, nis: np.ndarray) -> None:
        """One update of the tracks idx (index array): innovations y (K, M, m) with covariance
        S (K, M, m, m) and NIS (K, M); then re-select."""
        slot = self.count[idx] % self.window
        L = np.linalg.cholesky(S[..., :2, :2])
        w = np.linalg.solve(L, y[..., :2, None])[..., 0]
        self.innovation[idx, :, slot] = y[..., :2]
        self.whitened[idx, :, slot] = w
        self.nis[idx, :, slot] = nis
        self.dof[idx, slot] = y.shape[-1]
        self.count[idx] += 1
        self.selected[idx] = self._choose(idx)[0]

    def latest(self, track: int = 0) -> np.ndarray:
        """The newest position innovation of each model, (M, 2)."""
        return self.innovation[track, :, (self.count[track] - 1) % self.window].copy()

    def _statistics(self, idx: np.ndarray | slice) -> tuple[np.ndarray, ...]:
        n = np.minimum(self.count[idx], self.window)  # (K,)
        filled = np.arange(self.window)[None, :] < n[:, None]  # (K, W)
        mask = filled[:, None, :]
        mean = (self.innovation[idx] * mask[..., None]).sum(axis=2) / n[:, None, None]
        wsum = (self.whitened[idx] * mask[..., None]).sum(axis=2)
        bias = (wsum**2).sum(axis=-1) / n[:, None]
        nis_sum = (self.nis[idx] * mask).sum(axis=-1)
        dof = (self.dof[idx] * filled).sum(axis=-1).astype(int)
        nis_limit = self._nis_threshold[dof]
        if np.isnan(nis_limit).any():
            for d in np.unique(dof[np.isnan(nis_limit)]):
                self._nis_threshold[d] = chi2_quantile(self.probability, int(d))
            nis_limit = self._nis_threshold[dof]
        consistent = (bias <= self._bias_threshold) & (nis_sum <= nis_limit[:, None])
        return mean, bias, nis_sum / dof[:, None], nis_limit / dof, consistent

    def _choose(self, idx: np.ndarray | slice) -> tuple[np.ndarray, ...]:
        mean, bias, nis_per_dof, limit, consistent = self._statistics(idx)
        first = np.argmax(consistent, axis=-1)
        selected = np.where(consistent.any(axis=-1), first, np.argmin(nis_per_dof, axis=-1))
        return selected, mean, bias, nis_per_dof, limit, consistent

    def report(self, track: int = 0) -> SelectionReport | None:
        """The statistics of one track (None before its first update)."""
        if self.count[track] == 0:
            return None
        selected, mean, bias, nis, limit, consistent = (
            a[0] for a in self._choose(np.array([track]))
        )
        names = self.model_names
        return SelectionReport(
            selected=names[int(selected)],
            innovation_mean={
                k: (float(mean[i, 0]), float(mean[i, 1])) for i, k in enumerate(names)
            },
            bias_statistic={k: float(bias[i]) for i, k in enumerate(names)},
            bias_threshold=self._bias_threshold,
            nis_per_dof={k: float(nis[i]) for i, k in enumerate(names)},
            nis_threshold_per_dof=float(limit),
            consistent={k: bool(consistent[i]) for i, k in enumerate(names)},
            window=int(min(self.count[track], self.window)),
        )
