"""The interface every filter mode shares, and the track bookkeeping they have in common.

A `TrackEstimator` holds N independent tracks (N = 1 for the live process). It takes
timestamped measurements — a position and optionally a velocity, each with its covariance, on
the ground plane (metres) or, for `image-cv`, in gaze angles (radians) — and does for every mode:

- validation: a non-finite time, value or covariance, or a covariance that is not positive
  definite, is rejected and counted (the track coasts to that time if the time is usable);
- ordering: a measurement not later than the track's state is dropped and counted;
- initiation: a measurement with velocity starts a track at once; a position alone is held
  until the next one gives a velocity by differencing (two-point initiation);
- predict-only steps (`coast`) for missing data, and a track that has coasted longer than
  `coast_max_s` is dropped;
- chi-square gating: a measurement outside the gate of every model is an outlier, counted,
  and the track coasts; after `reinit_after_misses` outliers in a row the track restarts
  from the latest measurement;
- maneuver events when the most likely model changes (see `events`).

Subclasses implement the filter (`mode_filter`): `_initialise`, `_predict`, `_innovate`,
`_correct`, `_forecast`, `_probabilities` and, with more than one model, `_signature`.
The single-track calls (`update`, `coast`, `predict`, ...) act on track 0; the batch calls
(`step`, `forecast`) take one row per track.
"""

from __future__ import annotations

import math
from typing import ClassVar, Literal

import numpy as np

from gazed.estimation.chi_square import chi2_quantile
from gazed.estimation.events import ManeuverEvent, ManeuverTracker
from gazed.estimation.masks import every, some
from gazed.estimation.measurement import Measurement
from gazed.estimation.mode_filter import ModeFilter
from gazed.estimation.results import COUNTED, Forecast, Outcome, PredictedState
from gazed.estimation.small_matrices import positive_definite

Space = Literal["ground", "gaze"]

EMPTY, PENDING, TRACKING = 0, 1, 2


def _select(mask: np.ndarray) -> slice | np.ndarray:
    """Index of the True rows: a slice when it is all of them (views, no copies)."""
    return slice(None) if every(mask) else np.flatnonzero(mask)


def _rows(idx: slice | np.ndarray, n: int) -> np.ndarray:
    """The track numbers of an index (a slice or an index array) into n tracks."""
    return np.arange(n)[idx] if isinstance(idx, slice) else idx


class TrackEstimator(ModeFilter):
    """N tracks of one filter mode; see the module docstring for what every mode does."""

    filter_name: ClassVar[str]
    space: ClassVar[Space] = "ground"

    def __init__(
        self,
        model_names: tuple[str, ...],
        n_tracks: int = 1,
        *,
        gate_probability: float = 0.999,
        reinit_after_misses: int = 5,
        coast_max_s: float = 2.0,
        initial_speed_std: float = 2.0,
    ) -> None:
        if n_tracks < 1:
            raise ValueError(f"n_tracks must be >= 1, got {n_tracks}")
        self.model_names = model_names
        self.n_tracks = n_tracks
        self.reinit_after_misses = reinit_after_misses
        self.coast_max_s = coast_max_s
        self.initial_speed_std = initial_speed_std
        self._gate = {m: chi2_quantile(gate_probability, m) for m in (2, 4)}
        self.status = np.zeros(n_tracks, dtype=np.int8)
        self.t_s = np.full(n_tracks, math.nan)  # time of the filter state
        self.t_measured_s = np.full(n_tracks, math.nan)  # last accepted measurement
        self.misses = np.zeros(n_tracks, dtype=np.int64)
        self._pending_z = np.zeros((n_tracks, 2))
        self._pending_R = np.zeros((n_tracks, 2, 2))
        self.counts = np.zeros((n_tracks, len(Outcome)), dtype=np.int64)
        self._maneuvers = ManeuverTracker(n_tracks, model_names)
        self._track_numbers = np.arange(n_tracks)
        self._all_accepted = np.full(n_tracks, Outcome.ACCEPTED, dtype=np.int64)

    # ----------------------------------------------------------------- single track (track 0)

    def update(self, measurement: Measurement) -> Outcome:
        """Filter one measurement of track 0."""
        m = measurement
        t = np.array([m.t_s])
        if self.n_tracks == 1 and self._ready(m):  # `_step`'s common case, checked in floats
            return Outcome(self._step_all(t, m.z[None], m.R[None], t - self.t_s)[0])
        good = np.array([m.usable])  # the checks of `step`, on the 2x2 blocks
        return Outcome(self._step(t, m.z[None], m.R[None], None, good)[0])

    def _ready(self, m: Measurement) -> bool:
        """A single track that is running takes a usable measurement later than its state,
        within coast_max_s of the last one: the condition of `_step`'s common case."""
        t_s, t_measured_s = float(self.t_s[0]), float(self.t_measured_s[0])
        return (
            self.status[0] == TRACKING
            and m.t_s > t_s
            and m.t_s - t_measured_s <= self.coast_max_s
            and m.usable
        )

    def coast(self, t_s: float) -> Outcome:
        """Predict-only step of track 0 to t_s (a frame without a detection)."""
        return Outcome(self.step(np.array([t_s]), _NO_Z, _NO_R, _ABSENT)[0])

    def predict(self, t_s: float) -> PredictedState | None:
        """Track 0 predicted to t_s (>= its state time), or None if there is no track."""
        dt = t_s - float(self.t_s[0])
        if self.n_tracks == 1 and self.status[0] == TRACKING and 0.0 <= dt < math.inf:
            mean, covariance = self._forecast(slice(None), np.array([dt]))  # `forecast`'s usual
            return PredictedState(float(t_s), mean[0, :2], mean[0, 2:], covariance[0])
        f = self.forecast(np.array([t_s]))
        if not f.valid[0]:
            return None
        return PredictedState(float(t_s), f.position[0], f.velocity[0], f.covariance[0])

    def model_probabilities(self) -> dict[str, float]:
        """Track 0's probability of each model (one-hot where the mode selects, not weighs)."""
        return dict(zip(self.model_names, map(float, self.probabilities[0]), strict=True))

    def most_likely(self) -> str:
        return self.model_names[int(self.most_likely_index[0])]

    def retime(self, shift_s: float) -> None:
        """Every time the filter holds moved by `shift_s` (the stamps it was fed were off by it)."""
        self.t_s += shift_s
        self.t_measured_s += shift_s
        self._maneuvers.start_s += shift_s

    def drain_events(self) -> list[ManeuverEvent]:
        """Maneuver events since the last call (all tracks)."""
        return self._maneuvers.drain()

    def health(self) -> dict[str, int]:
        """Counters over all tracks: accepted, coasted, nonfinite, out_of_order, gated, ..."""
        totals = self.counts.sum(axis=0)
        return {o.name.lower(): int(totals[o]) for o in COUNTED}

    @property
    def tracking(self) -> bool:
        return bool(self.status[0] != EMPTY)

    # --------------------------------------------------------------------------------- batch

    @property
    def probabilities(self) -> np.ndarray:
        """(N, M) model probabilities; uniform for tracks that are not running."""
        p = np.full((self.n_tracks, len(self.model_names)), 1.0 / len(self.model_names))
        running = self.status == TRACKING
        if some(running):
            idx = _select(running)
            p[idx] = self._probabilities(idx)
        return p

    @property
    def most_likely_index(self) -> np.ndarray:
        return self.probabilities.argmax(axis=-1)

    def step(
        self,
        t_s: np.ndarray,
        z: np.ndarray,
        R: np.ndarray,
        present: np.ndarray | None = None,
    ) -> np.ndarray:
        """One step of every track: a measurement where `present` (default all), else coast.

        t_s (N,); z (N, m) with m = 2 (position) or 4 (position, velocity); R (N, m, m).
        Returns the `Outcome` of each track (N,) int.
        """
        n = self.n_tracks
        t = _times(t_s, n)
        z = np.asarray(z, dtype=float)
        R = np.asarray(R, dtype=float)
        m = z.shape[-1]
        if z.shape != (n, m) or m not in (2, 4) or R.shape != (n, m, m):
            raise ValueError(
                f"expected z (N, 2|4) and R (N, m, m) for N = {n}, got {z.shape}, {R.shape}"
            )
        good = np.isfinite(t) & np.isfinite(z).all(axis=-1) & positive_definite(R)
        if present is not None:
            present = np.asarray(present, bool)
            good &= present
        return self._step(t, z, R, present, good)

    def _step(
        self,
        t: np.ndarray,
        z: np.ndarray,
        R: np.ndarray,
        present: np.ndarray | None,
        good: np.ndarray,
    ) -> np.ndarray:
        """`step` after validation: good (N,) marks the present, usable measurements."""
        n = self.n_tracks
        dt = t - self.t_s  # NaN for tracks without a state: every comparison below is False
        if every(
            good
            & (self.status == TRACKING)
            & (dt > 0)
            & (t - self.t_measured_s <= self.coast_max_s)
        ):
            return self._step_all(t, z, R, dt)  # the common case: every track updates
        if present is None:
            present = np.ones(n, bool)
        outcome = np.full(n, Outcome.IDLE, dtype=np.int64)
        outcome[present & ~good] = Outcome.NONFINITE
        running = self.status != EMPTY
        reference_s = np.where(self.status == TRACKING, self.t_s, self.t_measured_s)
        with np.errstate(invalid="ignore"):
            late = running & ~(t > reference_s)
            stale = running & ~late & (t - self.t_measured_s > self.coast_max_s)
        outcome[good & late] = Outcome.OUT_OF_ORDER
        good &= ~late

        finite_t = np.isfinite(t)
        dropped = stale & ~good & finite_t
        if some(dropped):
            outcome[dropped] = Outcome.DROPPED
            self._forget(np.flatnonzero(dropped))
        if some(stale & good):  # a measurement after a long gap starts afresh
            self.counts[np.flatnonzero(stale & good), Outcome.DROPPED] += 1
            self._forget(np.flatnonzero(stale & good))

        coasting = (~good) & finite_t & (self.status == TRACKING) & ~late
        tracked = good & (self.status == TRACKING)
        moving = coasting | tracked
        if some(moving):
            idx = _select(moving)
            self._predict(idx, t[idx] - self.t_s[idx])
            self.t_s[idx] = t[idx]
            outcome[coasting & ~present] = Outcome.COASTED
        if some(tracked):
            self._filter(_select(tracked), t, z, R, outcome)
        starting = good & (self.status != TRACKING) & ~tracked
        if some(starting):
            self._start(np.flatnonzero(starting), t, z, R, outcome)

        self.counts[self._track_numbers, outcome] += 1
        rejected = present & ~good & ~late & (outcome != Outcome.NONFINITE)
        self.counts[rejected, Outcome.NONFINITE] += 1  # rejected, then dropped by the coast
        stepped = (self.status == TRACKING) & (outcome != Outcome.IDLE)
        if some(stepped):
            self._observe_maneuvers(_select(stepped), t)
        return outcome

    def _step_all(self, t: np.ndarray, z: np.ndarray, R: np.ndarray, dt: np.ndarray) -> np.ndarray:
        """`step` when every track is running and has a usable, later measurement."""
        outcome = self._all_accepted.copy()
        every_track = slice(None)
        self._predict(every_track, dt)
        accepted = self._filter(every_track, t, z, R, outcome)
        self.t_s[:] = t
        if accepted:  # the common case: one column of counts, every track still running
            self.counts[:, Outcome.ACCEPTED] += 1
            self._observe_maneuvers(slice(None), t)
            return outcome
        self.counts[self._track_numbers, outcome] += 1
        tracking = self.status == TRACKING  # a track restarted from one position is pending
        self._observe_maneuvers(_select(tracking), t)
        return outcome

    def _observe_maneuvers(self, idx: slice | np.ndarray, t: np.ndarray) -> None:
        """The most likely model and its rates of the tracks idx, which just stepped to t."""
        if len(self.model_names) > 1:
            self._maneuvers.observe(idx, t[idx], *self._signature(idx))

    def forecast(self, t_s: np.ndarray) -> Forecast:
        """Every track predicted to t_s (N,) without changing it: [p, v] and its covariance.

        A track holding a single position predicts it unmoved, with the initial speed
        uncertainty. Raises ValueError for a time before a track's state.
        """
        n = self.n_tracks
        t = _times(t_s, n)
        mean = np.empty((n, 4))  # [p, v]
        covariance = np.empty((n, 4, 4))
        mean.fill(math.nan)
        covariance.fill(math.nan)
        tracking = self.status == TRACKING
        if some(tracking):
            idx = _select(tracking)
            dt = t[idx] - self.t_s[idx]
            if not every((dt >= 0.0) & (dt < math.inf)):
                raise ValueError("cannot forecast to a time before a track's state (or not finite)")
            mean[idx], covariance[idx] = self._forecast(idx, dt)
        position, velocity = mean[:, :2], mean[:, 2:]
        pending = self.status == PENDING
        if some(pending):
            position[pending] = self._pending_z[pending]
            velocity[pending] = 0.0
            covariance[pending] = 0.0
            covariance[pending, :2, :2] = self._pending_R[pending]
            covariance[pending, 2, 2] = covariance[pending, 3, 3] = self.initial_speed_std**2
        return Forecast(t.copy(), position, velocity, covariance, self.status != EMPTY)

    # ------------------------------------------------------------------------------ internals

    def _forget(self, idx: np.ndarray) -> None:
        self.status[idx] = EMPTY
        self.misses[idx] = 0
        self._maneuvers.reset(idx)

    def _filter(
        self,
        idx: slice | np.ndarray,
        t: np.ndarray,
        z: np.ndarray,
        R: np.ndarray,
        outcome: np.ndarray,
    ) -> bool:
        """Gate and update the tracks idx (a slice or an index array), already predicted to t;
        True when every one was accepted."""
        statistic, handle = self._innovate(idx, z[idx], R[idx])
        inside = statistic <= self._gate[z.shape[-1]]
        if every(inside):  # the common case, on views when idx is a slice
            self._correct(idx, handle, None)
            outcome[idx] = Outcome.ACCEPTED
            self.misses[idx] = 0
            self.t_measured_s[idx] = t[idx]
            return True
        rows = _rows(idx, self.n_tracks)
        if some(inside):
            self._correct(idx, handle, inside)
            ok = rows[inside]
            outcome[ok] = Outcome.ACCEPTED
            self.misses[ok] = 0
            self.t_measured_s[ok] = t[ok]
        outside = rows[~inside]
        outcome[outside] = Outcome.GATED
        self.misses[outside] += 1
        restart = outside[self.misses[outside] >= self.reinit_after_misses]
        if len(restart):
            self.counts[restart, Outcome.GATED] += 1
            self._forget(restart)
            self._start(restart, t, z, R, outcome)
            outcome[restart] = Outcome.REINITIALISED
        return False

    def _start(
        self, idx: np.ndarray, t: np.ndarray, z: np.ndarray, R: np.ndarray, outcome: np.ndarray
    ) -> None:
        """Initiate the tracks idx from this measurement (and a held one, if any)."""
        m = z.shape[-1]
        if m == 4:  # velocity measured: start at once
            self._begin(idx, t[idx], z[idx], R[idx], np.full(len(idx), math.nan))
            outcome[idx] = Outcome.INITIALISED
            return
        second = idx[self.status[idx] == PENDING]
        first = idx[self.status[idx] != PENDING]
        if len(second):  # two-point initiation: v = (z1 - z0) / dt
            dt = (t[second] - self.t_measured_s[second])[:, None]
            z0, R0, z1, R1 = self._pending_z[second], self._pending_R[second], z[second], R[second]
            zv = np.concatenate([z1, (z1 - z0) / dt], axis=-1)
            Rv = np.zeros((len(second), 4, 4))
            Rv[:, :2, :2] = R1
            Rv[:, :2, 2:] = Rv[:, 2:, :2] = R1 / dt[:, :, None]
            Rv[:, 2:, 2:] = (R0 + R1) / (dt * dt)[:, :, None]
            self._begin(second, t[second], zv, Rv, dt[:, 0])
            outcome[second] = Outcome.INITIALISED
        if len(first):
            self.status[first] = PENDING
            self.t_measured_s[first] = t[first]
            self._pending_z[first] = z[first]
            self._pending_R[first] = R[first]
            outcome[first] = Outcome.PENDING

    def _begin(
        self, idx: np.ndarray, t: np.ndarray, zv: np.ndarray, Rv: np.ndarray, interval_s: np.ndarray
    ) -> None:
        self._maneuvers.reset(idx)
        self._initialise(idx, zv, Rv, interval_s)
        self.status[idx] = TRACKING
        self.t_s[idx] = t
        self.t_measured_s[idx] = t
        self.misses[idx] = 0


def _times(t_s: np.ndarray | float, n: int) -> np.ndarray:
    """t_s as (n,) float seconds (a scalar is every track's time)."""
    t = np.asarray(t_s, dtype=float)
    return t if t.shape == (n,) else np.broadcast_to(t, (n,))


# a coast of one track: no measurement
_NO_Z, _NO_R, _ABSENT = np.zeros((1, 2)), np.eye(2)[None], np.zeros(1, bool)
