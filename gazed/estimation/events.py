"""Maneuver events: the most likely model changed (seed 000 §7, the "motion signature").

Each track's history is cut into segments of constant most-likely model; when a segment ends,
one event reports the new model, when it started, and the duration and the mean ṡ and θ̇ of
the segment that ended.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gazed.estimation.masks import some


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
    """Segments of constant most-likely model for N tracks.

    `observe` is vectorised: the segments that end are stored as arrays and turned into
    `ManeuverEvent`s only when drained, so a batch of thousands of tracks stays cheap.
    """

    def __init__(self, n_tracks: int, model_names: tuple[str, ...]) -> None:
        self.model_names = model_names
        self.model = np.full(n_tracks, -1)
        self.start_s = np.zeros(n_tracks)
        self.steps = np.zeros(n_tracks, dtype=np.int64)
        self.sum_rates = np.zeros((n_tracks, 2))  # Σ ṡ, Σ θ̇ over the segment
        self._ended: list[tuple[np.ndarray, ...]] = []

    def reset(self, idx: slice | np.ndarray) -> None:
        """Forget the current segments (the track restarted); no event."""
        self.model[idx] = -1

    def observe(
        self,
        idx: slice | np.ndarray,
        t_s: np.ndarray,
        model: np.ndarray,
        rates: np.ndarray,
    ) -> None:
        """One step of the tracks idx (a slice or an index array) at t_s with their most
        likely model and its (ṡ m/s², θ̇ rad/s), rates (K, 2)."""
        previous = self.model[idx]
        new = model != previous
        if some(new):
            if isinstance(idx, slice):
                idx = np.arange(len(self.model))[idx]
            ended = new & (previous >= 0)
            if some(ended):
                tracks = idx[ended]
                self._ended.append(
                    (
                        tracks,
                        model[ended],
                        previous[ended],
                        t_s[ended],
                        self.start_s[tracks],
                        self.steps[tracks],
                        self.sum_rates[tracks],
                    )
                )
            fresh = idx[new]
            self.model[fresh] = model[new]
            self.start_s[fresh] = t_s[new]
            self.steps[fresh] = 0
            self.sum_rates[fresh] = 0.0
        self.steps[idx] += 1
        self.sum_rates[idx] += rates

    def drain(self) -> list[ManeuverEvent]:
        """The events since the last call, oldest first."""
        events = []
        for tracks, model, previous, t_s, start_s, steps, sum_rates in self._ended:
            for k in range(len(tracks)):
                n = int(steps[k])
                events.append(
                    ManeuverEvent(
                        track=int(tracks[k]),
                        model=self.model_names[int(model[k])],
                        previous_model=self.model_names[int(previous[k])],
                        t_start_s=float(t_s[k]),
                        previous_start_s=float(start_s[k]),
                        previous_duration_s=float(t_s[k] - start_s[k]),
                        previous_steps=n,
                        mean_s_dot_m_s2=float(sum_rates[k, 0] / n),
                        mean_theta_dot_rad_s=float(sum_rates[k, 1] / n),
                    )
                )
        self._ended = []
        return events
