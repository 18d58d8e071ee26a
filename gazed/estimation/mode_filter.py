"""The filter part of a mode: the steps `TrackEstimator` calls and each mode implements.

`TrackEstimator` (in `estimator`) does the bookkeeping every mode shares and calls these on the
tracks `idx` it selects (a slice of all of them, or an index array of K tracks).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numpy as np


class ModeFilter(ABC):
    """The filter of one mode over the tracks of its estimator."""

    @abstractmethod
    def _initialise(
        self, idx: np.ndarray, zv: np.ndarray, Rv: np.ndarray, interval_s: np.ndarray
    ) -> None:
        """Start the tracks idx from position and velocity zv (K, 4) with covariance Rv;
        interval_s (K,) is the two-point interval the velocity came from (NaN: measured)."""

    @abstractmethod
    def _predict(self, idx: slice | np.ndarray, dt: np.ndarray) -> None:
        """Predict-only step of the tracks idx over dt (K,) > 0, in place."""

    @abstractmethod
    def _innovate(
        self, idx: slice | np.ndarray, z: np.ndarray, R: np.ndarray
    ) -> tuple[np.ndarray, Any]:
        """Gate statistic (K,) (the smallest NIS over models) and what `_correct` needs."""

    @abstractmethod
    def _correct(self, idx: slice | np.ndarray, handle: Any, inside: np.ndarray | None) -> None:
        """Update the tracks idx[inside] (all of idx: None) with the innovations computed by
        `_innovate`."""

    @abstractmethod
    def _forecast(self, idx: slice | np.ndarray, dt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean [p, v] (K, 4) and covariance (K, 4, 4) of the tracks idx, dt (K,) >= 0 ahead."""

    @abstractmethod
    def _probabilities(self, idx: slice | np.ndarray) -> np.ndarray:
        """(K, M) model probabilities of running tracks."""

    def _signature(self, idx: slice | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The most likely model (K,) of the tracks idx and its (ṡ m/s², θ̇ rad/s) (K, 2), for
        the maneuver events."""
        raise NotImplementedError(f"{type(self).__name__} has one model and no maneuver events")
