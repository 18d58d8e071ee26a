"""Whether two tracks are one person: what their own detections say, before their states.

Two tracks that took two movers in the same frame saw two things there. They are one person
only where the two movers can be one person's parts: the difference of their positions, `δ`,
lies inside the χ² gate against the sum of the two measurements' own covariances and twice a
person's extent (each mover may be another part of the person). Where the noise model is a
scale mixture (`scale_mixture`) the covariance is its tail's, the wider: a mask that splits
shows parts of one person whose points lie that far apart, and two tracks are told to be two
people only where even the tail cannot make their movers one. Over the `n` latest frames in which both took a
mover, the sum of those d² is tested against the gate of `2 n` dimensions: the evidence of
several frames is pooled, so one noisy frame neither makes nor breaks the case, and people who
walk side by side at a pace, whose states agree within their (possibly wide) covariances,
are still told apart by where their detections are, frame after frame.

Without such frames (one of the tracks is new, or they never saw movers at the same time) the
detections say nothing, and the track-to-track test of the states (`association.same_target`)
decides alone.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from gazed.estimation.chi_square import chi2_quantile
from gazed.estimation.measurement import Measurement

TAKES_KEPT = 8  # the latest detections a track remembers for this test


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


def seen_apart(a: Takes, b: Takes, extent_cov: np.ndarray, probability: float) -> bool:
    """Whether the movers two tracks took in the same frames are two people's (module doc)."""
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
    return n > 0 and d2 > chi2_quantile(probability, 2 * n)
