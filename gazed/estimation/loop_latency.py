"""The loop's latencies as the estimator measures them live, from stamps (DESIGN §3).

- visual: from a frame's capture to its detection's arrival at the estimator;
- actuation: from the estimator's stamp on a prediction to the servo's write stamp on the
  command made from it (`servo/command`), plus the time the head then takes to get where it
  was told (the response lag the servo measures from the head's position reports and
  publishes on `servo/status`; 0 until measured, and for a head that cannot report its
  position).

Each stamped latency is the median of its recent samples (`LatencyWindow`), robust to the odd
late message.
"""

from __future__ import annotations

from gazed.latency import LatencyWindow, stage_gap_s
from gazed.messages import Message


class LoopLatency:
    """Visual and actuation latency; `stage` is the estimator's name in the stamps."""

    def __init__(self, stage: str, actuation_default_s: float) -> None:
        self.stage = stage
        self.visual = LatencyWindow(default_s=0.0)
        self.write = LatencyWindow(default_s=actuation_default_s)
        self.head_response_s = 0.0

    def detection_arrived(self, t_capture_ns: int, now_ns: int) -> None:
        """A detection of the frame captured at `t_capture_ns` arrived at `now_ns`."""
        self.visual.add((now_ns - t_capture_ns) / 1e9)

    def command_written(self, command: Message) -> None:
        """A command as the servo wrote it: its stamps give the write gap (none: ignored)."""
        gap_s = stage_gap_s(command, self.stage, "servo")
        if gap_s is not None:
            self.write.add(gap_s)

    def head_responds(self, response_lag_s: float | None) -> None:
        """The head's response lag as the servo last reported it (None: not measured)."""
        self.head_response_s = response_lag_s or 0.0

    @property
    def visual_s(self) -> float:
        return self.visual.median_s

    @property
    def actuation_s(self) -> float:
        """From the estimator's stamp until the head is where the demand told it to be."""
        return self.write.median_s + self.head_response_s
