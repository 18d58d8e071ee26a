"""What a `TrackEstimator` returns: the outcome of a step for each track, and its predictions.

`PredictedState` is one track at one instant; `Forecast` is the same for N tracks at once.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np


class Outcome(IntEnum):
    """What one step did to one track."""

    IDLE = 0  # nothing to do (no measurement and no track, or a coast into the past)
    PENDING = 1  # first position held until a second gives a velocity
    INITIALISED = 2
    ACCEPTED = 3
    COASTED = 4  # predict-only step
    NONFINITE = 5  # measurement rejected: not finite or covariance not positive definite
    OUT_OF_ORDER = 6  # measurement not later than the track's state: dropped
    GATED = 7  # outlier: outside the chi-square gate of every model
    REINITIALISED = 8  # restarted after `reinit_after_misses` outliers in a row
    DROPPED = 9  # coasted longer than coast_max_s: track forgotten


COUNTED = (
    Outcome.ACCEPTED,
    Outcome.COASTED,
    Outcome.NONFINITE,
    Outcome.OUT_OF_ORDER,
    Outcome.GATED,
    Outcome.REINITIALISED,
    Outcome.DROPPED,
)


@dataclass(frozen=True)
class PredictedState:
    """Position, velocity and the covariance of [p, v] at `t_s` (one track)."""

    t_s: float
    position: np.ndarray  # (2,) m (ground) or rad (gaze)
    velocity: np.ndarray  # (2,) per second
    covariance: np.ndarray  # (4, 4) over [px, py, vx, vy]


@dataclass(frozen=True)
class Forecast:
    """`PredictedState` for N tracks; rows of tracks that do not exist are NaN, valid False."""

    t_s: np.ndarray  # (N,)
    position: np.ndarray  # (N, 2)
    velocity: np.ndarray  # (N, 2)
    covariance: np.ndarray  # (N, 4, 4)
    valid: np.ndarray  # (N,) bool
