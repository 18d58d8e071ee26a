"""The set of people the estimator follows: one filter per track, association of each frame's
movers with the tracks, and track management (Blackman & Popoli, "Design and Analysis of Modern
Tracking Systems", 1999, §3.2 and §6.2; Bar-Shalom, Willett & Tian, "Tracking and Data Fusion",
2011, §3.3).

Every frame (one detection message, with any number of movers):

1. each track is predicted to the frame's capture; its predicted position and covariance P give
   `S = P + R_d` with each mover's own noise R_d, a two-Gaussian scale mixture where the rig
   gives one (`scale_mixture`: the cost, the gate and the update weigh both components);
2. movers and tracks are assigned jointly inside the Mahalanobis gate, the appearance deciding
   where positions are ambiguous (`association`), on the position alone (a mover's velocity is
   too noisy to tell people apart); the filter then takes the full measurement and gates it,
   its velocity left out where that alone lies outside its gate (`Sighting.taken`);
3. a confirmed track left without a mover may be one of two people the detector saw as one
   blob: where the blob hypothesis costs less than the one-person one (`association.find_blobs`)
   and both can lie in the mover's box seen through the frame's camera (`silhouette_reach`),
   both tracks take the blob as a measurement of each (the centroid less the other's
   prediction, its noise widened accordingly), keep their ids and are not ended while the blob
   holds them; the blob does not change their appearance templates;
4. a track that takes a mover is updated, and its appearance model learns the mover's
   histogram (`appearance_model`); a track left without one coasts (predict-only) and ends
   once it has coasted past `coast_max_ms`;
5. a mover left without a track starts a new, tentative track, from its velocity where that
   differs from zero (`Measurement.moving`), else from two points. A tentative track is confirmed
   once it has `confirm_hits` detections within its first `confirm_frames` frames (M of N); one
   that cannot is dropped as clutter. Where one track and one mover are all there is, the mover
   is the track's, inside its gate or not: outside it, it is an outlier the track's filter
   counts, and the filter restarts at it (same id) after `reinit_after_misses` of them in a
   row, as a single-target estimator does when its target jumps (the detector latched onto
   another part of it, or the head lost it and found it again). Tentative tracks do not count
   here: one confirmed track and one mover is the same case (a detector that splits one
   person into parts, or reports the leftovers of the head's own motion, starts tentative
   tracks beside a person whose filter may have gated out its own detections);
6. two tracks on one person are merged: a track that coasts while another takes a detection
   where it is, moving as it moves, is that one's duplicate. A detector can split one person
   into parts, or report a part off the track's gate (a filter grown too sure of itself gates
   out its own person), and the part starts a second track that then takes the person's
   detections from the first. The test is the track-to-track one (Bar-Shalom, "On the
   track-to-track correlation problem", IEEE TAC 26(2), 1981): the difference of the two
   states' position and velocity, `Δ`, against the sum of their covariances and a person's
   extent (`PERSON_WIDTH_M`: each track may follow another part of the person),
   `Δᵀ (P₁ + P₂ + 2E)⁻¹ Δ` inside the χ² gate of four dimensions, against a confirmed track only
   (a person, with a velocity of its own), and only where the movers the two took in the same
   frames can be one person's, by where they lie and by how many frames there were
   (`duplicates.seen_apart`). The merged track keeps the older id
   (the person's, and so the gaze's choice) and takes the filter that took the detection.
   People who cross or pass move apart in velocity, and people who walk side by side are seen
   apart, and so neither are merged where one hides the other.

Ids count up from 0 and are never reused, so a track's id names one person for its whole life;
a person lost for longer than `coast_max_ms` comes back as a new track with a new id.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from gazed.config import EstimatorSection
from gazed.estimation.appearance_model import TrackAppearance, fits
from gazed.estimation.association import (
    associate,
    find_blobs,
    gate_threshold,
    load_solver,
    member_measurement,
)
from gazed.estimation.duplicates import Merging, Takes
from gazed.estimation.estimator import TRACKING, TrackEstimator
from gazed.estimation.factory import build_estimator
from gazed.estimation.results import Outcome, PredictedState
from gazed.estimation.scale_mixture import mixture_costs
from gazed.estimation.sighting import Sighting
from gazed.estimation.silhouette_reach import ToPixel, held

MAX_TRACKS = 256  # an EstimatorState carries at most this many
# a first velocity that does not differ from zero at this level gives a track no heading
MOVING_PROBABILITY = 0.95
TAKEN = (Outcome.ACCEPTED, Outcome.INITIALISED, Outcome.PENDING, Outcome.REINITIALISED)


@dataclass
class PersonTrack:
    """One track: its filter (a single-track `TrackEstimator`) and its bookkeeping."""

    id: int
    estimator: TrackEstimator
    first_s: float
    last_hit_s: float
    hits: int = 1
    frames: int = 1  # frames since its first detection, that one included
    confirmed: bool = False
    coasting: bool = False
    box_height_px: float = 0.0
    appearance: TrackAppearance | None = None
    takes: Takes = field(default_factory=Takes)  # its latest movers (`duplicates`)

    def take_appearance(self, histogram: np.ndarray | None) -> None:
        """Learn a mover's histogram (`appearance_model`); the first, or one of another length,
        starts the template afresh."""
        if histogram is None:
            return
        if self.appearance is None or len(self.appearance.template) != len(histogram):
            self.appearance = TrackAppearance(histogram)
            return
        self.appearance.take(histogram)


@dataclass
class TrackSet(Merging):
    """Every track of one filter mode; `step` once per frame with that frame's sightings."""

    section: EstimatorSection
    mode: str | None = None  # default: the section's filter
    tracks: list[PersonTrack] = field(default_factory=list)
    next_id: int = 0
    counts: Counter[str] = field(default_factory=Counter)
    ended_health: Counter[str] = field(default_factory=Counter)  # the ended tracks' filter counts

    def __post_init__(self) -> None:
        self.gate_d2 = gate_threshold(self.section.gate_probability, 2)
        self.duplicate_d2 = gate_threshold(self.section.gate_probability, 4)
        self.moving_d2 = gate_threshold(MOVING_PROBABILITY, 2)
        self.coast_max_s = self.section.coast_max_ms / 1000.0
        load_solver()  # imported before several tracks first compete (`association`)

    def get(self, track_id: int) -> PersonTrack | None:
        for track in self.tracks:
            if track.id == track_id:
                return track
        return None

    def step(self, t_s: float, sightings: list[Sighting], to_pixel: ToPixel | None = None) -> None:
        """One frame captured at t_s: associate, update, coast, start and end tracks. A frame
        older than a track's state (out of order) changes nothing and is counted. `to_pixel`
        (the frame's camera) lets a mover's box bound its blob (`silhouette_reach`)."""
        if any(t_s <= _state_time(track.estimator) for track in self.tracks):
            self.counts["late_frames"] += 1
            return
        lone = self._lone_track()
        if lone is not None and len(sightings) == 1:
            # one person, one mover: the mover is the person's, inside its gate or not (an
            # outlier its filter counts, restarting there after reinit_after_misses in a row,
            # as a single-target estimator does when its target jumps)
            pairs, lone_sightings, members = {lone: 0}, (), {}
        else:
            states = self._predicted(t_s)
            predicted, P = _stacked(states)
            looks = self._appearances(sightings)
            pairs, lone_sightings, costs = self._assign(predicted, P, sightings, looks)
            members, taken = self._groups(
                states, predicted, P, sightings, pairs, costs, looks, to_pixel
            )
            pairs = {r: c for r, c in pairs.items() if r not in members and c not in taken}
            lone_sightings = tuple(c for c in lone_sightings if c not in taken)
        for row, track in enumerate(self.tracks):
            track.frames += 1
            if row in members:
                self._take(track, members[row], t_s)
                continue
            column = pairs.get(row)
            if column is None:
                track.coasting = True
                track.estimator.coast(t_s)
            else:
                self._take(track, sightings[column], t_s)
                if not track.coasting:
                    track.takes.add(sightings[column].measurement, sightings[column].tail_or_core)
        for column in lone_sightings:
            self._start(sightings[column], t_s)
        self._merge_duplicates(t_s, {self.tracks[row].id for row in members})
        self._end(t_s)

    def retime(self, shift_s: float) -> None:
        """Every track's times moved by `shift_s`: the stamps it was built on were off by it."""
        for track in self.tracks:
            track.first_s, track.last_hit_s = track.first_s + shift_s, track.last_hit_s + shift_s
            track.estimator.retime(shift_s)

    def health(self) -> dict[str, int]:
        """Track counts, and the filters' counters over every track, ended ones included."""
        totals = Counter(self.ended_health)
        for track in self.tracks:
            totals.update(track.estimator.health())
        totals.update(self.counts)
        totals["tracks"] = len(self.tracks)
        return dict(totals)

    # -------------------------------------------------------------------------------- internals

    def _lone_track(self) -> int | None:
        """The row of the one person there is: the only track, else the only confirmed one
        (tentative tracks are not people yet); None where there are several or none."""
        if len(self.tracks) == 1:
            return 0
        confirmed = [row for row, track in enumerate(self.tracks) if track.confirmed]
        return confirmed[0] if len(confirmed) == 1 else None

    def _predicted(self, t_s: float) -> list[PredictedState]:
        states = []
        for track in self.tracks:
            state = track.estimator.predict(t_s)
            assert state is not None  # a track whose filter stops is ended at once (`_end`)
            states.append(state)
        return states

    def _assign(
        self,
        predicted: np.ndarray,
        P: np.ndarray,
        sightings: list[Sighting],
        looks: tuple[np.ndarray, ...],
    ) -> tuple[dict[int, int], tuple[int, ...], np.ndarray]:
        """Track row -> sighting column, the sightings no track took, and the (T, D) costs, of
        the predictions (T, 2) with covariances P (T, 2, 2); `looks` from `_appearances`."""
        if not sightings or not len(predicted):
            costs = np.full((len(predicted), len(sightings)), np.inf)
            return {}, tuple(range(len(sightings))), costs
        measured = np.array([s.measurement.position for s in sightings])  # (D, 2)
        R = np.array([s.measurement.position_cov for s in sightings])  # (D, 2, 2)
        tails = np.array([s.tail_or_core for s in sightings])
        weights = np.array([s.tail_weight for s in sightings])
        costs = mixture_costs(predicted, P, measured, R, tails, weights, self.gate_d2, *looks)
        result = associate(costs)
        return dict(result.pairs), result.lone_detections, costs

    def _groups(
        self,
        states: list[PredictedState],
        predicted: np.ndarray,
        P: np.ndarray,
        sightings: list[Sighting],
        pairs: dict[int, int],
        costs: np.ndarray,
        looks: tuple[np.ndarray, ...],
        to_pixel: ToPixel | None,
    ) -> tuple[dict[int, Sighting], set[int]]:
        """Row -> its measurement from a blob that holds it and another confirmed track
        (`association.find_blobs`, inside the mover's box where the frame's camera is known),
        and the blobs' sighting columns."""
        if not sightings or all(r in pairs for r in range(len(self.tracks))):
            return {}, set()
        confirmed = np.array([t.confirmed for t in self.tracks])
        measured = [s.measurement for s in sightings]
        inside = None
        if to_pixel is not None:
            boxes = [s.box_px for s in sightings]
            pixel_var = self.section.pixel_noise_px**2
            inside = held(predicted, P, boxes, to_pixel, pixel_var, self.gate_d2)
        blobs = find_blobs(
            predicted, P, confirmed, measured, pairs, costs, self.gate_d2, looks, inside
        )
        members: dict[int, Sighting] = {}
        for blob in blobs:
            z = measured[blob.column]
            states_in = [states[row] for row in blob.rows]
            for k, row in enumerate(blob.rows):
                measurement = member_measurement(z, k, states_in)
                members[row] = Sighting(measurement, None, self.tracks[row].box_height_px)
            self.counts["group_updates"] += 1
        return members, {blob.column for blob in blobs}

    def _appearances(self, sightings: list[Sighting]) -> tuple[np.ndarray, ...]:
        """(track templates, sighting histograms, track means, track shapes) where both sides
        have some of one length, NaN rows for those without (`appearance_model.fits`); ()
        otherwise."""
        bins = {len(s.appearance) for s in sightings if s.appearance is not None}
        bins |= {len(t.appearance.template) for t in self.tracks if t.appearance is not None}
        if len(bins) != 1:
            return ()
        (b,) = bins
        templates, means, shapes = fits([t.appearance for t in self.tracks], b)
        seen = np.full((len(sightings), b), math.nan)
        for k, s in enumerate(sightings):
            if s.appearance is not None:
                seen[k] = s.appearance
        if np.isnan(templates).all() or np.isnan(seen).all():
            return ()
        return templates, seen, means, shapes

    def _take(self, track: PersonTrack, sighting: Sighting, t_s: float) -> None:
        # a velocity is gated against the track's own (none while it waits for a second point)
        tracking = track.estimator.status[0] == TRACKING
        gate_d2 = self.gate_d2 if tracking else math.inf
        predicted = track.estimator.predict(t_s) if tracking or sighting.tail_weight > 0 else None
        outcome = track.estimator.update(sighting.taken(predicted, gate_d2))
        track.coasting = outcome not in TAKEN
        if track.coasting:
            return
        track.hits += 1
        track.last_hit_s = t_s
        track.box_height_px = sighting.box_height_px
        track.take_appearance(sighting.appearance)
        if not track.confirmed and track.hits >= self.section.confirm_hits:
            track.confirmed = True  # within confirm_frames: a track that cannot is ended
            self.counts["tracks_confirmed"] += 1

    def _start(self, sighting: Sighting, t_s: float) -> None:
        if len(self.tracks) >= MAX_TRACKS:
            self.counts["tracks_not_started"] += 1
            return
        estimator = build_estimator(self.section, mode=self.mode)
        first = sighting.taken(None).moving(self.moving_d2)  # else: two-point initiation
        if estimator.update(first) not in TAKEN:
            return  # not usable: `usable` refused it
        track = PersonTrack(
            self.next_id,
            estimator,
            t_s,
            t_s,
            box_height_px=sighting.box_height_px,
        )
        track.take_appearance(sighting.appearance)
        track.confirmed = self.section.confirm_hits <= 1
        track.takes.add(sighting.measurement, sighting.tail_or_core)
        self.next_id += 1
        self.tracks.append(track)
        self.counts["tracks_started"] += 1
        self.counts["tracks_confirmed"] += int(track.confirmed)

    def _end(self, t_s: float) -> None:
        """Drop the tracks that coasted past coast_max_s, and the tentative ones that can no
        longer reach confirm_hits within confirm_frames."""
        m, n = self.section.confirm_hits, self.section.confirm_frames
        kept = []
        for track in self.tracks:
            stale = t_s - track.last_hit_s > self.coast_max_s or not track.estimator.tracking
            hopeless = not track.confirmed and track.hits + max(0, n - track.frames) < m
            if stale or hopeless:
                self.ended_health.update(track.estimator.health())
                self.counts["tracks_ended"] += 1
            else:
                kept.append(track)
        self.tracks = kept


def _state_time(estimator: TrackEstimator) -> float:
    """The time of a single-track filter's state (of its held position while it is pending)."""
    running = estimator.status[0] == TRACKING
    return float(estimator.t_s[0] if running else estimator.t_measured_s[0])


def _stacked(states: list[PredictedState]) -> tuple[np.ndarray, np.ndarray]:
    """The predicted positions (T, 2) and their covariances (T, 2, 2), once per frame for the
    assignment and the blobs alike."""
    if not states:
        return np.zeros((0, 2)), np.zeros((0, 2, 2))
    return np.array([s.position for s in states]), np.array([s.covariance[:2, :2] for s in states])
