"""The plain data the figures are drawn from: one run's series, in seconds from its start.

Every field is optional but the title: a source fills what it has (an estimator scenario has no
gaze and no latency; a recording of a real rig has no truth), and only the figures with data
are drawn.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class RunSeries:
    """One run, as arrays of plain numbers. Times are seconds from the run's first message.

    truth_xy_m (N, 2), estimate_xy_m (M, 2) and prediction_xy_m (K, 2) are ground points;
    error_t_s/error_deg the gaze error (the angle from the optical axis to the target);
    saccade_t_s the starts of saccades; state_changes (t_s, new state) the gaze's transitions;
    model_t_s with model_probabilities {model: (L,)}; hops_ms {stage: latencies in ms}.
    """

    title: str
    truth_xy_m: np.ndarray | None = None
    estimate_xy_m: np.ndarray | None = None
    prediction_xy_m: np.ndarray | None = None
    prediction_horizon_s: float | None = None
    error_t_s: np.ndarray | None = None
    error_deg: np.ndarray | None = None
    fovea_half_deg: float | None = None
    saccade_t_s: list[float] = field(default_factory=list)
    state_changes: list[tuple[float, str]] = field(default_factory=list)
    model_t_s: np.ndarray | None = None
    model_probabilities: dict[str, np.ndarray] = field(default_factory=dict)
    hops_ms: dict[str, list[float]] = field(default_factory=dict)


def points(xy: list[tuple[float, float]]) -> np.ndarray | None:
    """Ground points as an (N, 2) array; None for none."""
    return np.asarray(xy, dtype=float).reshape(-1, 2) if xy else None
