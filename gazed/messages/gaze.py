"""Messages to and from the `gaze` process: the demand it sends the head, its state, and an
operator's choices and commands."""

from __future__ import annotations

from typing import ClassVar, Literal, Self

from pydantic import Field, model_validator

from gazed.messages.base import HeadPose, Message


class GazeDemand(Message):
    """Where the head should be: position, plus feed-forward rates for pursuit, and where the
    zoom should go. Version 2 adds `zoom`."""

    SCHEMA: ClassVar[str] = "gazed.GazeDemand"
    VERSION: ClassVar[int] = 2
    kind: Literal["position", "pursuit", "hold", "park"]
    pan_rad: float
    tilt_rad: float
    pan_rate_rad_s: float = 0.0
    tilt_rate_rad_s: float = 0.0
    zoom: float | None = Field(
        None,
        ge=0,
        le=1,
        description="Zoom position to go to (0 widest, 1 longest); None: leave it.",
    )


GazeStateName = Literal["park", "search", "saccade", "pursuit", "lost", "trace", "hold"]


class GazeState(Message):
    """A transition of the gaze controller, or a change of its chosen target, with its reason.
    Version 2 adds `target_id`, version 3 the state `hold` (an operator's)."""

    SCHEMA: ClassVar[str] = "gazed.GazeState"
    VERSION: ClassVar[int] = 3
    state: GazeStateName
    previous: GazeStateName | None = None
    reason: str = ""
    target_id: int | None = Field(
        None, ge=0, description="The estimator track the gaze follows; None before a choice."
    )


class GazeSelect(Message):
    """An operator's choice of target: a track id, a ground point, or a pixel with the head pose
    it was seen at; the nearest track is chosen. None of them hands the choice back to the rig's
    rule. Version 2 adds the head's `zoom`."""

    SCHEMA: ClassVar[str] = "gazed.GazeSelect"
    VERSION: ClassVar[int] = 2
    track_id: int | None = Field(None, ge=0)
    ground_xy_m: tuple[float, float] | None = None
    pixel_px: tuple[float, float] | None = None
    head: HeadPose | None = Field(None, description="The pose `pixel_px` was seen at.")

    @model_validator(mode="after")
    def _one_choice(self) -> Self:
        given = [x is not None for x in (self.track_id, self.ground_xy_m, self.pixel_px)]
        if sum(given) > 1:
            raise ValueError("give one of track_id, ground_xy_m and pixel_px")
        if self.pixel_px is not None and self.head is None:
            raise ValueError("pixel_px needs the head pose it was seen at")
        return self


class GazeCommand(Message):
    """An operator's request to the gaze controller: trace a ground line's image edge from a
    start gaze (line calibration, seed 000 §3.2.1), or stop tracing; park the head, search for a
    target, hold where it is, or resume following. Version 2 adds park, search, hold and
    resume."""

    SCHEMA: ClassVar[str] = "gazed.GazeCommand"
    VERSION: ClassVar[int] = 2
    command: Literal["trace", "stop", "park", "search", "hold", "resume"]
    request_id: str = Field(min_length=1, max_length=64)
    pan_rad: float = 0.0
    tilt_rad: float = 0.0
    max_samples: int = Field(20, ge=2, le=1000)


class TraceResult(Message):
    """The gaze samples collected along one traced edge, and why the trace ended."""

    SCHEMA: ClassVar[str] = "gazed.TraceResult"
    request_id: str
    samples_rad: tuple[tuple[float, float], ...] = Field(
        description="(pan, tilt) of each edge point."
    )
    reason: str
