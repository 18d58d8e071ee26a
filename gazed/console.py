"""What `gazed run` shows a person: in a terminal, one live status line (gaze state, the target on
the ground, the most likely motion model, the loop's processing latency, processes up); under
systemd (or any non-terminal), a log line per gaze state change instead of a line per frame.
"""

from __future__ import annotations

import logging
import os
import sys
from collections import deque
from typing import TextIO

import numpy as np

from gazed.bus import Bus
from gazed.latency import processing_s
from gazed.topics import ESTIMATOR_STATE, GAZE_STATE, SERVO_COMMAND

REFRESH_S = 0.5

log = logging.getLogger("gazed.run")


def interactive(stream: TextIO = sys.stderr) -> bool:
    """A terminal a person watches (not systemd's journal, which sets JOURNAL_STREAM)."""
    return stream.isatty() and "JOURNAL_STREAM" not in os.environ


class LiveStatus:
    """Follows the rig's loop on the bus; `refresh(now_s, up, total)` redraws or logs."""

    def __init__(self, bus: Bus, stream: TextIO = sys.stderr, live: bool | None = None) -> None:
        self.stream = stream
        self.live = interactive(stream) if live is None else live
        self._states = bus.subscribe(GAZE_STATE, capacity=64)
        # the live line's other figures: followed only when a person watches
        self._estimates = bus.subscribe(ESTIMATOR_STATE, capacity=64) if self.live else None
        self._commands = bus.subscribe(SERVO_COMMAND, capacity=256) if self.live else None
        self.gaze = "-"
        self.target: tuple[float, float] | None = None
        self.model = "-"
        self._processing_ms: deque[float] = deque(maxlen=100)
        self._seen_captures: deque[int] = deque(maxlen=100)
        self._next_s = 0.0

    def refresh(self, now_s: float, up: int, total: int) -> None:
        for state in self._states.take():
            self.gaze = state.state
            if self.live:
                self._clear()
            log.info("gaze %s -> %s: %s", state.previous, state.state, state.reason)
        if self._estimates is None or self._commands is None:
            return
        for estimate in self._estimates.take():
            self.target = estimate.ground_xy_m
            self.model = estimate.most_likely or "-"
        for command in self._commands.take():
            gap = processing_s(command)
            if gap is not None and command.t_capture_ns not in self._seen_captures:
                self._seen_captures.append(command.t_capture_ns)  # the first write of a capture
                self._processing_ms.append(gap * 1e3)
        if now_s >= self._next_s:
            self._next_s = now_s + REFRESH_S
            self.stream.write("\r" + self.line(up, total) + "\x1b[K")
            self.stream.flush()

    def line(self, up: int, total: int) -> str:
        target = f"({self.target[0]:+.2f}, {self.target[1]:+.2f}) m" if self.target else "-"
        latency = f"{np.median(self._processing_ms):.1f} ms" if self._processing_ms else "-"
        return (
            f"gaze {self.gaze:<8} target {target:<20} model {self.model:<4} "
            f"latency p50 {latency:<9} up {up}/{total}"
        )

    def close(self) -> None:
        if self.live:
            self._clear()

    def _clear(self) -> None:
        self.stream.write("\r\x1b[K")
        self.stream.flush()
