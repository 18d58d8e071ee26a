"""Maneuver events: the most likely model changed (seed 000 §7, the "motion signature").

Each track's history is cut into segments of constant most-likely model; when a segment ends,
one event reports the new model, when it started, and the duration and the mean ṡ and θ̇ of
the segment that ended.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ManeuverEvent:
    """The most likely model of `track` became `model` at `t_start_s`."""

    track: int
    model: str
    previous_model: str
    t_start_s: float
    previous_start_s: float
    previous_duration_s: float
    previous_steps: int
    mean_s_dot_m_s2: float
    mean_theta_dot_rad_s: float


class ManeuverTracker:
    """Segments of constant most-likely model for N tracks."""

    def __init__(self, n_tracks: int, model_names: tuple[str, ...]) -> None:
        self.model_names = model_names
        self.model = np.full(n_tracks, -1)
        self.start_s = np.zeros(n_tracks)
        self.steps = np.zeros(n_tracks, dtype=np.int64)
        self.sum_s_dot = np.zeros(n_tracks)
        self.sum_theta_dot = np.zeros(n_tracks)
        self.pending: list[ManeuverEvent] = []

    def reset(self, idx: slice | np.ndarray) -> None:
        """Forget the current segments (the track restarted); no event."""
        self.model[idx] = -1

    def observe(
        self,
        idx: np.ndarray,
        t_s: np.ndarray,
        model: np.ndarray,
        s_dot_m_s2: np.ndarray,
        theta_dot_rad_s: np.ndarray,
    ) -> None:
        """One step of the tracks idx (index array) at t_s with their most likely model."""
        changed = (model != self.model[idx]) & (self.model[idx] >= 0)
        for k in np.flatnonzero(changed):
            track = int(idx[k])
            steps = int(self.steps[track])
            self.pending.append(
                ManeuverEvent(
                    track=track,
                    model=self.model_names[model[k]],
                    previous_model=self.model_names[self.model[track]],
                    t_start_s=float(t_s[k]),
                    previous_start_s=float(self.start_s[track]),
                    previous_duration_s=float(t_s[k] - self.start_s[track]),
                    previous_steps=steps,
                    mean_s_dot_m_s2=float(self.sum_s_dot[track] / steps),
                    mean_theta_dot_rad_s=float(self.sum_theta_dot[track] / steps),
                )
            )
        new = model != self.model[idx]
        fresh = idx[new]
        self.model[fresh] = model[new]
        self.start_s[fresh] = t_s[new]
        self.steps[fresh] = 0
        self.sum_s_dot[fresh] = 0.0
        self.sum_theta_dot[fresh] = 0.0
        self.steps[idx] += 1
        self.sum_s_dot[idx] += s_dot_m_s2
        self.sum_theta_dot[idx] += theta_dot_rad_s

    def drain(self) -> list[ManeuverEvent]:
        events, self.pending = self.pending, []
        return events
