"""The simulator's truth, for scoring the loop."""

from __future__ import annotations

from typing import ClassVar

from pydantic import Field

from gazed.messages.base import HeadPose, Message


class SimTruth(Message):
    """What the simulator knows at a frame's capture: the target on the ground and the true
    head pose, for scoring the loop. Version 2 adds the head's `zoom`."""

    SCHEMA: ClassVar[str] = "gazed.SimTruth"
    VERSION: ClassVar[int] = 2
    seq: int = Field(ge=0)
    target_xy_m: tuple[float, float]
    target_velocity_m_s: tuple[float, float]
    target_height_m: float = Field(ge=0)
    head: HeadPose
