"""How full the serial line is: the share of each second it carried bytes, both ways.

The transport adds up the line's time of every byte written and read (`SerialTransport.line_s`).
Once a `period_s` the meter takes the share of it that time grew by. Past `LINE_LOAD_WARN` the
line is full: set-points wait for it and replies come late, because the odometry and command
rates ask more than the baud rate carries. Each such period is counted, and the turn to full is
warned about once. A link without a baud rate (`socket://`, `loop://`) has no load.
"""

from __future__ import annotations

import logging
from typing import Protocol

LINE_LOAD_WARN = 0.95  # share of a period on the line past which it is full
PERIOD_S = 1.0

log = logging.getLogger("gazed.servo")


class Line(Protocol):
    """What the meter reads of a transport (`SerialTransport`)."""

    url: str
    baud: int
    byte_time_s: float
    line_s: float


class LineLoadMeter:
    """The share of the last period the line carried bytes (`load`, None before a period has
    passed) and the periods it was full (`overloaded_s`)."""

    def __init__(self, period_s: float = PERIOD_S) -> None:
        self.period_s = period_s
        self.load: float | None = None
        self.overloaded_s = 0
        self._mark = (0.0, 0.0)  # (monotonic s, the line's time) at the last measurement

    def reset(self, mono_s: float, line: Line) -> None:
        """Start measuring afresh at `mono_s` (the link was just opened)."""
        self._mark = (mono_s, line.line_s)
        self.load = None

    def measure(self, mono_s: float, line: Line) -> None:
        """Once a period: the line's share of it; a warning when the line turns full."""
        mark_s, mark_line_s = self._mark
        elapsed_s = mono_s - mark_s
        if elapsed_s < self.period_s:
            return
        self._mark = (mono_s, line.line_s)
        if line.byte_time_s == 0.0:
            return
        load = (line.line_s - mark_line_s) / elapsed_s
        if load > LINE_LOAD_WARN:
            self.overloaded_s += 1
            if self.load is None or self.load <= LINE_LOAD_WARN:
                log.warning(
                    "the line to %s at %d baud was %.0f%% busy over the last second: "
                    "set-points wait for it and replies come late; lower odometry_rate_hz "
                    "or command_rate_hz, or raise the baud rate",
                    line.url,
                    line.baud,
                    100.0 * load,
                )
        self.load = load
