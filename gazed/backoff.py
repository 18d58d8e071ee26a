"""Delays between attempts to reconnect: a device link, a camera stream, a crashed process."""

from __future__ import annotations


class Backoff:
    """Delays between reopening attempts: `initial_s`, doubling up to `max_s`; `reset()` on
    success."""

    def __init__(self, initial_s: float, max_s: float) -> None:
        self.initial_s = initial_s
        self.max_s = max_s
        self._next_s = initial_s

    def next_delay_s(self) -> float:
        delay = self._next_s
        self._next_s = min(self._next_s * 2.0, self.max_s)
        return delay

    def reset(self) -> None:
        self._next_s = self.initial_s
