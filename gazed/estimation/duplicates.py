"""Whether two tracks are one person: what their own detections say, before their states.

Two tracks that took two movers in the same frame saw two things there. They are one person
only where the two movers can be one person's parts: the difference of their positions, `δ`,
lies inside the χ² gate against the sum of the two measurements' own covariances and twice a
person's extent (each mover may be another part of the person). Where the noise model is a
scale mixture (`scale_mixture`) the covariance is its tail's, the wider: a mask that splits
shows parts of one person whose points lie that far apart, and two tracks are told to be two
people only where even the tail cannot make their movers one. Over the `n` latest frames in
which both took a mover, the sum of those d² is tested against the gate of `2 n` dimensions:
the evidence of several frames is pooled, so one noisy frame neither makes nor breaks the
case, and people who walk side by side at one pace, whose states agree within their (possibly
wide) covariances, are still told apart by where their detections are, frame after frame.

How often both took a mover counts as well. One person gives two movers that two tracks may
each take (a part, a shadow or a ghost beside them) in a frame with the detector's
`split_probability` q, and once they have, again in the next with `split_continues_probability`
r (a split persists: r is well above q), both `[estimator]`, measured by
tests/bench/pets_movers.py. So `n` such frames are about q r^(n-1) likely for one person (a run
of splits; frames further apart are taken as if they were one run, the likelier case). The two
are one person only where that, times the distances' upper tail (the χ² of `2 n` dimensions
above their summed d²), is at least 1 - `gate_probability`: a score, the product of the count's
chance and the distances' tail, not the error rate of a test at that level. With q = r = 1 the
count says nothing and the distances decide as a gate at `gate_probability`.

Without such frames (one of the tracks is new, or they never saw movers at the same time) the
detections say nothing, and the track-to-track test of the states (`association.same_target`)
decides alone.

The track that took a detection where the other coasts must have taken a mover of its own: a
blob's share (`association.member_measurement`) is the blob less the other member's
prediction, a position the track's own prediction made, not a detection of it.
"""

from __future__ import annotations

import math
from collections import Counter, deque
from typing import TYPE_CHECKING

import numpy as np

from gazed.config import EstimatorSection
from gazed.estimation.association import same_target
from gazed.estimation.chi_square import log_upper_tail
from gazed.estimation.measurement import Measurement
from gazed.estimation.results import PredictedState

if TYPE_CHECKING:
    from gazed.estimation.tracks import PersonTrack

TAKES_KEPT = 8  # the latest detections a track remembers for this test
PERSON_WIDTH_M = 0.5  # a detector may report any part of a person this wide (shoulder width)
# the covariance of a point spread evenly across a person (w²/12 on each ground axis)
PERSON_EXTENT_COV_M2 = np.eye(2) * PERSON_WIDTH_M**2 / 12.0


class Takes:
    """A track's latest detections: capture time, position and the position's own covariance."""

    def __init__(self) -> None:
        self.latest: deque[tuple[float, np.ndarray, np.ndarray]] = deque(maxlen=TAKES_KEPT)

    def add(self, measurement: Measurement, covariance: np.ndarray) -> None:
        """A detection the track took, with its position's widest covariance (the mixture's
        tail, else its own); a blob's share is none: it is not a mover of its own."""
        self.latest.append((measurement.t_s, measurement.position, covariance))

    def clear(self) -> None:
        self.latest.clear()


def seen_apart(
    a: Takes,
    b: Takes,
    extent_cov: np.ndarray,
    probability: float,
    split_probability: float = 1.0,
    split_continues_probability: float = 1.0,
) -> bool:
    """Whether the movers two tracks took in the same frames are two people's (module doc):
    the chance of a run of as many frames with two movers (the first `split_probability`
    likely, each after it `split_continues_probability`), times their distances' upper tail,
    below 1 - `probability`."""
    times_b = {t: (z, R) for t, z, R in b.latest}
    d2, n = 0.0, 0
    for t, z, R in a.latest:
        other = times_b.get(t)
        if other is None:
            continue
        delta = z - other[0]
        C = R + other[1] + 2.0 * extent_cov
        d2 += float(delta @ np.linalg.solve(C, delta))
        n += 1
    if n == 0:
        return False
    log_run = math.log(split_probability) + (n - 1) * math.log(split_continues_probability)
    log_same = log_run + log_upper_tail(d2, 2 * n)
    return log_same < math.log1p(-probability)


class Merging:
    """The merge of duplicate tracks, for `tracks.TrackSet` (module doc)."""

    section: EstimatorSection
    tracks: list[PersonTrack]
    counts: Counter[str]
    ended_health: Counter[str]
    duplicate_d2: float

    def _merge_duplicates(self, t_s: float, shares: set[int]) -> None:
        """Each coasting track that is a duplicate (`same_target`, `seen_apart`) of a confirmed
        one that took a mover this frame (not a blob's share: `shares`, their ids) becomes one
        track with it (`_merge`), once."""
        seen = [t for t in self.tracks if t.confirmed and not t.coasting and t.id not in shares]
        ended: set[int] = set()
        for lost in [track for track in self.tracks if track.coasting]:
            a = lost.estimator.predict(t_s)
            if a is None:  # a filter without a state (stopped) is no duplicate of anything
                continue
            twin = next(
                (f for f in seen if f.id not in ended and self._duplicates(lost, a, f, t_s)),
                None,
            )
            if twin is not None:
                ended.add(self._merge(lost, twin))
        if ended:
            self.tracks = [track for track in self.tracks if track.id not in ended]

    def _duplicates(
        self, lost: PersonTrack, state: PredictedState, found: PersonTrack, t_s: float
    ) -> bool:
        """Whether coasting `lost` (its `state` at t_s) and `found` are one person."""
        b = found.estimator.predict(t_s)  # None: restarted, waiting for a velocity
        if b is None or not same_target(state, b, self.duplicate_d2, PERSON_EXTENT_COV_M2):
            return False
        section = self.section
        return not seen_apart(
            lost.takes,
            found.takes,
            PERSON_EXTENT_COV_M2,
            section.gate_probability,
            section.split_probability,
            section.split_continues_probability,
        )

    def _merge(self, lost: PersonTrack, found: PersonTrack) -> int:
        """`found` took a detection where `lost` coasts: the older id lives on with `found`'s
        filter and what it saw; the younger ends. Returns the id that ends."""
        self.counts["tracks_merged"] += 1
        self.counts["tracks_ended"] += 1
        self.ended_health.update(lost.estimator.health())
        if found.id < lost.id:
            return lost.id
        lost.estimator, lost.coasting = found.estimator, False
        lost.hits += found.hits
        lost.last_hit_s, lost.confirmed = found.last_hit_s, True
        lost.box_height_px, lost.appearance, lost.takes = (
            found.box_height_px,
            found.appearance,
            found.takes,
        )
        return found.id
