"""Latencies measured live from message stamps (DESIGN §3: the stamps are the measure).

`LatencyWindow` keeps the latest samples of one latency (or duration) and gives their median,
robust to the odd late message, and their largest; `stage_gap_s` reads the time between two
stages of one message's stamps, and `processing_s` the loop's own processing latency (frame
arrival at vision -> command written).
"""

from __future__ import annotations

from collections import deque

import numpy as np

from gazed.messages import ARRIVAL_STAGE, Message


class LatencyWindow:
    """The median and the largest of the last `size` samples (seconds); `default_s` until the
    first."""

    def __init__(self, default_s: float, size: int = 50) -> None:
        self.default_s = default_s
        self._samples: deque[float] = deque(maxlen=size)
        self._median_s: float | None = None  # of the samples as they are; None: not yet taken

    def add(self, latency_s: float) -> None:
        if np.isfinite(latency_s) and latency_s >= 0:
            self._samples.append(latency_s)
            self._median_s = None

    @property
    def count(self) -> int:
        return len(self._samples)

    @property
    def median_s(self) -> float:
        if not self._samples:
            return self.default_s
        if self._median_s is None:
            self._median_s = float(np.median(self._samples))
        return self._median_s

    @property
    def max_s(self) -> float:
        return max(self._samples) if self._samples else self.default_s


def processing_s(message: Message) -> float | None:
    """Seconds from the frame's arrival at vision to the command bytes written (a servo/command
    message's `vision.arrival` and `servo` stamps; None if either is absent)."""
    return stage_gap_s(message, ARRIVAL_STAGE, "servo")


def stage_gap_s(message: Message, first: str, last: str) -> float | None:
    """Seconds from stage `first`'s stamp to stage `last`'s in one message (None if absent)."""
    stamps = dict(message.stamps)
    if first not in stamps or last not in stamps:
        return None
    return (stamps[last] - stamps[first]) / 1e9
