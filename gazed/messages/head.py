"""Messages of the `servo` process: where the head is, and the state of its link."""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import Field

from gazed.messages.base import Message


class Odometry(Message):
    """Head position as read from the device; `t_capture_ns` is when the reply was read.
    Version 2 adds `zoom`."""

    SCHEMA: ClassVar[str] = "gazed.Odometry"
    VERSION: ClassVar[int] = 2
    pan_rad: float
    tilt_rad: float
    pan_rate_rad_s: float = 0.0
    tilt_rate_rad_s: float = 0.0
    dead_reckoned: bool = Field(
        False, description="Computed from commands: the device cannot report position."
    )
    zoom: float | None = Field(
        None, ge=0, le=1, description="Zoom position (0 widest, 1 longest); None: fixed lens."
    )


class ServoStatus(Message):
    """The head link's state and counters, on every change and about once a second."""

    SCHEMA: ClassVar[str] = "gazed.ServoStatus"
    protocol: str
    port: str
    link: Literal["connected", "connecting", "down"]
    holding: bool = Field(False, description="No fresh demand: holding position.")
    errors: int = Field(0, ge=0)
    clamps: int = Field(0, ge=0, description="Demands clamped to joint or rate limits.")
    refused: int = Field(
        0, ge=0, description="Demands refused: non-finite, or malformed on the wire."
    )
    reconnects: int = Field(0, ge=0)
    last_error: str | None = None
    timeouts: int = Field(0, ge=0, description="Requests the head did not answer in time.")
    commands: int = Field(0, ge=0, description="Set-points written to the head.")
    dead_reckoned: bool = Field(
        False, description="Odometry is computed from commands (no position feedback)."
    )
    response_lag_s: float | None = Field(
        None,
        ge=0,
        le=60,
        description="How late the head follows its set-points, measured from its position "
        "reports while it moves; None before it is measured or without position feedback.",
    )
    line_load: float | None = Field(
        None,
        ge=0,
        description="Share of the last second the serial line carried bytes, both ways (near 1: "
        "the line is full, set-points wait and replies come late); None before a second has "
        "passed or on a link without a baud rate (socket://).",
    )
