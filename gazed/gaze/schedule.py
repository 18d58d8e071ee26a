"""When the gaze decides: at `[gaze] rate_hz`, at once after each new prediction (the demand
acts on the newest one), and at once after a command.

After a prediction, the next tick is a period later, unless a prediction is due first anyway
(a rate at or below the camera's). Then it waits half a frame longer, so that it fires only
when a prediction is missing, not a moment before the next one: that demand would be stale at
once and keep the servo and this process busy as the prediction arrives.
"""

from __future__ import annotations


class TickSchedule:
    """`due(mono_s, fresh_prediction)` says whether to tick now; `wait_s` how long until the
    next tick is due."""

    def __init__(self, rate_hz: float, frame_period_s: float) -> None:
        self.period_s = 1.0 / rate_hz
        self.after_prediction_s = self.period_s + (
            0.5 * frame_period_s if self.period_s >= frame_period_s else 0.0
        )
        self.next_s = 0.0

    def act_now(self, mono_s: float) -> None:
        """Tick at the next step (a command came)."""
        self.next_s = mono_s

    def due(self, mono_s: float, fresh_prediction: bool) -> bool:
        """Tick now? If so, the next tick is scheduled from now."""
        if not fresh_prediction and mono_s < self.next_s:
            return False
        self.next_s = mono_s + (self.after_prediction_s if fresh_prediction else self.period_s)
        return True

    def wait_s(self, mono_s: float) -> float:
        return max(0.0, self.next_s - mono_s)
