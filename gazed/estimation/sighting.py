"""One mover of a frame as the tracks see it: its measurement, what association compares, and
the measurement a track's filter takes from it (`taken`, `scale_mixture`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gazed.estimation.measurement import Measurement
from gazed.estimation.results import PredictedState
from gazed.estimation.scale_mixture import expected_precision


@dataclass(frozen=True)
class Sighting:
    """One mover of a frame as a filter measurement, with what association compares."""

    measurement: Measurement  # its position's covariance: the mixture's core where it has one
    appearance: np.ndarray | None = None  # (B,) normalised colour histogram
    box_height_px: float = 0.0
    box_px: np.ndarray | None = None  # (u0, v0, u1, v1) its box can cover (`silhouette_reach`)
    tail_cov: np.ndarray | None = None  # (2, 2) the position's tail covariance (`scale_mixture`)
    tail_weight: float = 0.0  # the tail's prior weight (0: the measurement's covariance alone)

    @property
    def tail_or_core(self) -> np.ndarray:
        """(2, 2): the tail's position covariance, the core's without a tail."""
        return self.measurement.position_cov if self.tail_cov is None else self.tail_cov

    def taken(self, predicted: PredictedState | None, gate_d2: float = math.inf) -> Measurement:
        """The measurement as a track predicted to `predicted` takes it (None: a new track),
        at the precision the mixture's posterior expects (`scale_mixture.expected_precision`);
        its velocity left out where it lies outside the prediction's gate `gate_d2` (a mover's
        velocity is its mask's shift, which jumps where the mask splits, merges or changes
        shape: its position still tells where the person is)."""
        z = self.measurement
        if predicted is not None and gate_d2 < math.inf:
            d2 = z.velocity_d2(predicted.velocity, predicted.covariance[2:, 2:])
            if d2 is not None and d2 > gate_d2:
                z = z.position_only()
        return expected_precision(z, self.tail_cov, self.tail_weight, predicted)
