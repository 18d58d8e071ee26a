"""Small measures shared by the evaluations: segments of a label sequence, switch delays,
error summaries."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Segment:
    """Steps [start, stop) with the same label."""

    label: str
    start: int
    stop: int

    @property
    def length(self) -> int:
        return self.stop - self.start


def segments(labels: Sequence[str]) -> list[Segment]:
    """Runs of equal labels, in order."""
    out: list[Segment] = []
    start = 0
    for k in range(1, len(labels) + 1):
        if k == len(labels) or labels[k] != labels[start]:
            out.append(Segment(str(labels[start]), start, k))
            start = k
    return out


def switch_delays(truth: Sequence[str], estimate: Sequence[str]) -> list[int]:
    """For every change of the true label, the steps until the estimate first shows the new
    label (within that true segment; a switch never detected counts the segment's length)."""
    delays = []
    for segment in segments(truth)[1:]:
        hit = [k for k in range(segment.start, segment.stop) if estimate[k] == segment.label]
        delays.append(hit[0] - segment.start if hit else segment.length)
    return delays


def error_summary(errors: np.ndarray) -> dict[str, float]:
    """mean, median, 90th percentile and count of a set of errors."""
    if len(errors) == 0:
        return {"mean": float("nan"), "median": float("nan"), "p90": float("nan"), "n": 0}
    return {
        "mean": float(np.mean(errors)),
        "median": float(np.median(errors)),
        "p90": float(np.percentile(errors, 90)),
        "n": len(errors),
    }
