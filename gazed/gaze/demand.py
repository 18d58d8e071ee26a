"""The gaze's demand message, and the limits every demand passes before it goes out: the joint
and rate limits (counted), and for pursuit, feed-forward rates that change by at most the
acceleration limit per tick; and the hold, which stays where it began."""

from __future__ import annotations

from typing import Literal

from gazed.config import HeadSection
from gazed.gaze import STAGE
from gazed.messages import Detection, GazeDemand, Odometry, Prediction, Stamp
from gazed.servo.limits import DemandLimiter

DemandKind = Literal["position", "pursuit", "hold", "park"]


def make_demand(
    kind: DemandKind,
    pan_rad: float,
    tilt_rad: float,
    wall_ns: int,
    source: Prediction | Detection | None = None,
    rates_rad_s: tuple[float, float] = (0.0, 0.0),
) -> GazeDemand:
    """A demand stamped by the gaze at `wall_ns`; with a `source`, it carries that message's
    capture time and stamps, so that the latency of the whole chain can be read from it."""
    stamps: tuple[Stamp, ...] = source.stamps if source is not None else ()
    return GazeDemand(
        t_capture_ns=source.t_capture_ns if source is not None else wall_ns,
        stamps=(*stamps, (STAGE, wall_ns)),
        kind=kind,
        pan_rad=pan_rad,
        tilt_rad=tilt_rad,
        pan_rate_rad_s=rates_rad_s[0],
        tilt_rate_rad_s=rates_rad_s[1],
    )


class DemandShaper:
    """Brings each demand inside the head's limits; remembers the last pursuit rates so that
    the next may differ by at most the acceleration limit over the tick."""

    def __init__(self, head: HeadSection) -> None:
        self.limiter = DemandLimiter(head)
        self.accel_max_rad_s2 = head.accel_max_rad_s2
        self.last_rates = (0.0, 0.0)

    @property
    def clamps(self) -> int:
        return self.limiter.clamps

    @property
    def refused(self) -> int:
        return self.limiter.refused

    def shape(self, demand: GazeDemand, dt_s: float) -> GazeDemand | None:
        """The demand within the limits, or None (counted) for one with a non-finite number."""
        target = self.limiter.limit(demand)
        if target is None:
            self.last_rates = (0.0, 0.0)
            return None
        rates = (target.pan_rate_rad_s, target.tilt_rate_rad_s)
        if demand.kind == "pursuit":
            rates = tuple(
                last + max(-a * dt_s, min(a * dt_s, r - last))
                for r, last, a in zip(rates, self.last_rates, self.accel_max_rad_s2, strict=True)
            )
        self.last_rates = rates if demand.kind == "pursuit" else (0.0, 0.0)
        return demand.model_copy(
            update={
                "pan_rad": target.pan_rad,
                "tilt_rad": target.tilt_rad,
                "pan_rate_rad_s": rates[0],
                "tilt_rate_rad_s": rates[1],
            }
        )


class Hold:
    """Stay where the head was when the hold began: chasing each new reading instead would
    close a loop through the odometry's delay and the encoder's step, and the head would hunt
    by a step every poll (which the detectors see as motion)."""

    def __init__(self) -> None:
        self.at_rad: tuple[float, float] | None = None

    def release(self) -> None:
        """The hold is over: the next one starts where the head is then."""
        self.at_rad = None

    def demand(self, odometry: Odometry | None, wall_ns: int) -> GazeDemand | None:
        """Hold where the head is now, or where this hold began; None without odometry."""
        if self.at_rad is None:
            if odometry is None:
                return None
            self.at_rad = (odometry.pan_rad, odometry.tilt_rad)
        return make_demand("hold", *self.at_rad, wall_ns)
