"""The base of the wire schemas: every message on the bus is one of these pydantic models, sent
as JSON with the zenoh encoding `application/json;gazed.<Name>/<version>`.

Every message carries `t_capture_ns` (when the light hit the sensor, or the source time of the
data it derives from; wall clock, integer ns) and `stamps`, a list of `(stage, t_ns)` pairs that
each process appends as the data passes through it. `gazed latency` reads them.

Angles are radians, positions metres, rates per second. Non-finite numbers are refused at
validation, so a NaN never crosses the bus.
"""

from __future__ import annotations

import time
from typing import ClassVar, Self

from pydantic import BaseModel, ConfigDict, Field

Stamp = tuple[str, int]

# The stamp a frame source adds when a frame reaches `vision` (the bus delivered it, or the
# camera's read returned it): where the loop's processing latency starts.
ARRIVAL_STAGE = "vision.arrival"


class Message(BaseModel):
    """Base of every wire message."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)
    SCHEMA: ClassVar[str] = "gazed.Message"
    VERSION: ClassVar[int] = 1

    t_capture_ns: int = Field(ge=0, description="Source time of the data (wall clock ns).")
    stamps: tuple[Stamp, ...] = Field(
        default=(), description="(stage, t_ns) appended at every hop."
    )

    @classmethod
    def schema_id(cls) -> str:
        """`gazed.Detection/3`: the schema part of the zenoh encoding."""
        return f"{cls.SCHEMA}/{cls.VERSION}"

    def stamped(self, stage: str, t_ns: int | None = None) -> Self:
        """A copy with `(stage, t_ns)` appended (now if not given)."""
        t = time.time_ns() if t_ns is None else t_ns
        return self.model_copy(update={"stamps": (*self.stamps, (stage, t))})

    def to_json(self) -> bytes:
        return self.model_dump_json().encode()


class HeadPose(BaseModel):
    """Head joint angles and rates at one instant."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)
    pan_rad: float
    tilt_rad: float
    pan_rate_rad_s: float = 0.0
    tilt_rate_rad_s: float = 0.0
    zoom: float | None = Field(
        None,
        ge=0,
        le=1,
        description="Zoom position, 0 widest to 1 longest ([camera] zoom_focal_px gives its "
        "focal length); None for a fixed lens.",
    )
