"""A speed-driven head's speed steps: the rate of each of its speed commands, from the rig's
table (`pan_speed_steps_deg_s`, `tilt_speed_steps_deg_s`, which `gazed calibrate speeds`
measures) or even steps up to its fastest, and the step nearest a rate."""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence

from gazed.config import Rig
from gazed.servo.pelco_d import SPEED_MAX as PELCO_SPEED_MAX

DEFAULT_STEPS = 32
CAP_TOLERANCE_RAD_S = 1e-9  # a step at its cap is within it (the cap may be the step itself)


class SpeedSteps:
    """One axis's speed steps: step k (1..N) runs at `rates_rad_s[k-1]`; step 0 is stopped."""

    def __init__(self, rates_rad_s: Sequence[float]) -> None:
        if not rates_rad_s or any(
            b <= a for a, b in zip([0.0, *rates_rad_s], rates_rad_s, strict=False)
        ):
            raise ValueError("speed steps: expected positive rates rising with the step")
        self.rates_rad_s = list(rates_rad_s)

    @classmethod
    def even(cls, rate_max_rad_s: float, steps: int = DEFAULT_STEPS) -> SpeedSteps:
        return cls([rate_max_rad_s * k / steps for k in range(1, steps + 1)])

    @property
    def count(self) -> int:
        return len(self.rates_rad_s)

    def rate_rad_s(self, step: int) -> float:
        return math.copysign(self.rates_rad_s[abs(step) - 1], step) if step else 0.0

    def quantise(self, rate_rad_s: float, cap_rad_s: float = math.inf) -> int:
        """The signed step nearest `rate_rad_s`, none faster than `cap_rad_s`."""
        speed = min(abs(rate_rad_s), cap_rad_s)
        rates = [0.0, *self.rates_rad_s]
        i = bisect.bisect_left(rates, speed)
        if i == len(rates):
            step = len(rates) - 1
        elif i > 0 and speed - rates[i - 1] <= rates[i] - speed:
            step = i - 1
        else:
            step = i
        while step > 0 and rates[step] > cap_rad_s + CAP_TOLERANCE_RAD_S:
            step -= 1
        return int(math.copysign(step, rate_rad_s)) if step else 0


def rig_speed_steps(rig: Rig) -> tuple[SpeedSteps, SpeedSteps]:
    """The rig's tables of rates per step, or even steps up to the fastest speed commands, as
    many as the protocol has speed codes (`DEFAULT_STEPS` for ONVIF, whose speeds are real)."""
    servo = rig.servo
    counts = {
        "visca": (
            getattr(servo, "pan_speed_max_code", 0),
            getattr(servo, "tilt_speed_max_code", 0),
        ),
        "pelco-d": (PELCO_SPEED_MAX, PELCO_SPEED_MAX),
    }.get(servo.protocol, (DEFAULT_STEPS, DEFAULT_STEPS))
    tables = []
    for table, rate_max_deg_s, count in (
        (servo.pan_speed_steps_deg_s, getattr(servo, "pan_speed_max_deg_s", 0.0), counts[0]),
        (servo.tilt_speed_steps_deg_s, getattr(servo, "tilt_speed_max_deg_s", 0.0), counts[1]),
    ):
        if table:
            tables.append(SpeedSteps([math.radians(rate) for rate in table]))
        else:
            tables.append(SpeedSteps.even(math.radians(rate_max_deg_s), count))
    return tables[0], tables[1]
