"""A person's id kept across a gap longer than a track may coast: the departed tracks.

A confirmed track that coasts past `coast_max_ms` ends: the person was not detected for that
long (hidden behind another, merged into a blob the tracker could not split, out of the
detector's reach). When they are detected again, a new track starts on them, and without a
memory of the ended one it is a new person to the gaze. So each confirmed track that ends is
remembered as it was last predicted, and for as long again it may be reclaimed: when a new
track is confirmed, the departed track whose state, propagated to that instant by a constant
velocity with white-noise acceleration (the rig's `cv_accel_noise_m_s2`; Bar-Shalom, Li &
Kirubarajan, "Estimation with Applications to Tracking and Navigation", 2001, §6.2.2), is one
estimate of the same person with the new track's (`association.same_target`'s test, the person's
extent added) gives the new track its id; the nearest, by that test's distance, where several
could.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gazed.estimation.association import track_distance
from gazed.estimation.results import PredictedState


@dataclass(frozen=True)
class Departed:
    """An ended track's id and its last predicted state."""

    id: int
    state: PredictedState


def propagated(state: PredictedState, t_s: float, accel_noise_m_s2: float) -> PredictedState:
    """`state` carried to `t_s` at constant velocity, its covariance grown by a white-noise
    acceleration of spectral density `accel_noise_m_s2²`."""
    dt = max(0.0, t_s - state.t_s)
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    q = accel_noise_m_s2**2
    Q = np.zeros((4, 4))
    Q[:2, :2] = np.eye(2) * q * dt**3 / 3.0
    Q[:2, 2:] = Q[2:, :2] = np.eye(2) * q * dt**2 / 2.0
    Q[2:, 2:] = np.eye(2) * q * dt
    mean = F @ np.concatenate([state.position, state.velocity])
    return PredictedState(t_s, mean[:2], mean[2:], F @ state.covariance @ F.T + Q)


class Departures:
    """The departed tracks, each kept for `memory_s` after its last state."""

    def __init__(
        self, memory_s: float, accel_noise_m_s2: float, gate_d2: float, extent_cov: np.ndarray
    ) -> None:
        self.memory_s = memory_s
        self.accel_noise_m_s2 = accel_noise_m_s2
        self.gate_d2 = gate_d2
        self.extent_cov = extent_cov
        self.departed: list[Departed] = []

    def leave(self, track_id: int, state: PredictedState) -> None:
        """A confirmed track ended; `state` is its last prediction."""
        self.departed.append(Departed(track_id, state))

    def claim(self, state: PredictedState) -> int | None:
        """The id of the departed track `state` (a newly confirmed track's) continues, which is
        then no longer departed; None where none is one person with it."""
        self.departed = [d for d in self.departed if state.t_s - d.state.t_s <= self.memory_s]
        best, best_d2 = None, np.inf
        for k, d in enumerate(self.departed):
            then = propagated(d.state, state.t_s, self.accel_noise_m_s2)
            d2 = track_distance(then, state, self.extent_cov)
            if d2 <= self.gate_d2 and d2 < best_d2:
                best, best_d2 = k, d2
        if best is None:
            return None
        return self.departed.pop(best).id
