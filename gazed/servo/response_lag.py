"""How late the head follows its set-points, measured from its own position reports.

The servo writes a set-point trajectory s(t); the head follows it late: the device's command
latency, the hold between two writes, and its own position loop (a position-mode servo closes
the gap only as fast as its gain and acceleration let it). That lag is part of the actuation
latency the estimator predicts over: the command bytes leave a few ms after a prediction, the
head gets there a response lag later. Only the head can say how long that is, and it differs
from one device to the next.

For a set-point moving at a steady rate ṡ, a head that follows it τ late reports
p(t) = s(t - τ) = s(t) - ṡ τ, so one position report gives τ = (s(t) - p(t)) / ṡ per axis. A
report counts for an axis whose set-point moves at `MIN_RATE_RAD_S` or more and whose rate
changed by less than `STEADY_FRACTION` of itself since the previous report (a saccade's ramps,
a reversal, the start of a pursuit are not a steady rate). The lag is the median of the last
`WINDOW` samples of both axes, from `MIN_SAMPLES` samples on, and never below 0 (each sample is
clipped at 0 before it enters the median, which clips the median the same way). A sample
beyond `MAX_LAG_S` (a stall, a joint limit, a slipping clutch) is left out and counted.
"""

from __future__ import annotations

import math

from gazed.latency import LatencyWindow

MIN_RATE_RAD_S = math.radians(3.0)  # below this an encoder step is too many ms of lag
STEADY_FRACTION = 0.1
MAX_LAG_S = 1.0
WINDOW = 128
MIN_SAMPLES = 16


class ResponseLag:
    """The head's lag behind its set-points (seconds), from position reports while it moves."""

    def __init__(self) -> None:
        self.outliers = 0
        self.reset()

    def reset(self) -> None:
        """Forget the samples (a reconnected link may be another head); outliers stay counted."""
        self._window = LatencyWindow(default_s=0.0, size=WINDOW)
        self._previous_rates: tuple[float, float] | None = None

    def observe(
        self,
        setpoint_rad: tuple[float, float],
        setpoint_rate_rad_s: tuple[float, float],
        reported_rad: tuple[float, float],
    ) -> None:
        """One position report (pan, tilt) and the set-point and its rates at the same instant."""
        previous, self._previous_rates = self._previous_rates, setpoint_rate_rad_s
        if previous is None:
            return
        for s, rate, p, rate_before in zip(
            setpoint_rad, setpoint_rate_rad_s, reported_rad, previous, strict=True
        ):
            if abs(rate) < MIN_RATE_RAD_S or abs(rate - rate_before) > STEADY_FRACTION * abs(rate):
                continue
            lag_s = math.remainder(s - p, 2.0 * math.pi) / rate  # a pan that wraps: the short way
            if abs(lag_s) > MAX_LAG_S:
                self.outliers += 1
                continue
            self._window.add(max(lag_s, 0.0))

    @property
    def lag_s(self) -> float | None:
        """The median lag, or None before `MIN_SAMPLES` samples."""
        return self._window.median_s if self._window.count >= MIN_SAMPLES else None
