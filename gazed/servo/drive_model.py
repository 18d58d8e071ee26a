"""The model of a head driven by speed that speed mode predicts it with: each rate it was told
acts `latency_s` after the command was sent and is reached at the axis's acceleration limit.
Run from the model's state at the last position reading, it says how far each axis has moved
since (`SpeedHead.where` adds that to the reading)."""

from __future__ import annotations

import math

Pair = tuple[float, float]


def ramp(
    rate_rad_s: float, target_rad_s: float, accel_rad_s2: float, dt_s: float
) -> tuple[float, float]:
    """An axis heading from `rate_rad_s` for `target_rad_s` at `accel_rad_s2` for `dt_s`: how
    far it moves and its rate at the end."""
    ramp_s = abs(target_rad_s - rate_rad_s) / accel_rad_s2
    if dt_s >= ramp_s:
        moved_rad = (rate_rad_s + target_rad_s) / 2.0 * ramp_s + target_rad_s * (dt_s - ramp_s)
        return moved_rad, target_rad_s
    end_rad_s = rate_rad_s + math.copysign(accel_rad_s2 * dt_s, target_rad_s - rate_rad_s)
    return (rate_rad_s + end_rad_s) / 2.0 * dt_s, end_rad_s


class DriveModel:
    """Both axes of a speed-driven head, at rest at `t_s`, with `accel_rad_s2` per axis."""

    def __init__(self, latency_s: float, accel_rad_s2: Pair, t_s: float) -> None:
        self.latency_s = latency_s
        self.accel_rad_s2 = accel_rad_s2
        # at the last reading: when, each axis's rate and the rate it is heading for
        self._base: tuple[float, Pair, Pair] = (t_s, (0.0, 0.0), (0.0, 0.0))
        self._told: list[tuple[float, float, float]] = []  # since: from when, the rates

    def tell(self, sent_s: float, pan_rate_rad_s: float, tilt_rate_rad_s: float) -> None:
        """A command went out at `sent_s`: its rates act from `latency_s` on."""
        self._told.append((sent_s + self.latency_s, pan_rate_rad_s, tilt_rate_rad_s))

    def read(self, read_s: float) -> float:
        """The head was read at `read_s` (no earlier than the last reading): the model runs on
        from there; when that is."""
        read_s = max(read_s, self._base[0])
        _, rates, targets = self.run(read_s)
        self._base = (read_s, rates, targets)
        self._told = [told for told in self._told if told[0] > read_s]
        return read_s

    def run(self, t_s: float) -> tuple[Pair, Pair, Pair]:
        """From the last reading to `t_s`: how far each axis has moved, its rate and the rate
        it is heading for at `t_s`."""
        at_s, base_rates, base_targets = self._base
        moved, rates, targets = [0.0, 0.0], list(base_rates), list(base_targets)
        for from_s, *told in [*self._told, (math.inf, *targets)]:
            until_s = min(from_s, t_s)
            if until_s > at_s:
                for axis in (0, 1):
                    step_rad, rates[axis] = ramp(
                        rates[axis], targets[axis], self.accel_rad_s2[axis], until_s - at_s
                    )
                    moved[axis] += step_rad
                at_s = until_s
            if from_s > t_s:
                break
            targets = told
        return (moved[0], moved[1]), (rates[0], rates[1]), (targets[0], targets[1])
