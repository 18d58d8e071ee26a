"""Messages of the `vision` process: raw frames, what each frame shows of the target and of every
mover, whole-frame motion regions for saccades, and the edge a trace follows."""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field

from gazed.messages.base import HeadPose, Message


class FrameHeader(Message):
    """Header of a raw frame; travels in the zenoh attachment, pixels in the payload."""

    SCHEMA: ClassVar[str] = "gazed.Frame"
    seq: int = Field(ge=0)
    width: int = Field(gt=0, le=16384)
    height: int = Field(gt=0, le=16384)
    encoding: Literal["gray8", "bgr8", "rgb8"] = "bgr8"

    @property
    def channels(self) -> int:
        return 1 if self.encoding == "gray8" else 3

    @property
    def nbytes(self) -> int:
        return self.width * self.height * self.channels

    @property
    def shape(self) -> tuple[int, ...]:
        return (self.height, self.width) if self.channels == 1 else (self.height, self.width, 3)


class Mover(BaseModel):
    """One moving region in a frame (pixels, image coordinates): its point (`Detection.point`
    says which), its independent image velocity, its box, and what it looks like."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)
    u_px: float
    v_px: float
    du_px_s: float = 0.0
    dv_px_s: float = 0.0
    velocity_known: bool = Field(
        True,
        description="False: the mover has no velocity yet (seen for the first time, or its "
        "region merged or split): du and dv are 0 and say nothing.",
    )
    box_width_px: float = Field(0.0, ge=0)
    box_height_px: float = Field(0.0, ge=0)
    area_px: float = Field(0.0, ge=0)
    confidence: float = Field(0.0, ge=0, le=1)
    appearance: tuple[float, ...] = Field(
        default=(),
        max_length=64,
        description="Normalised colour histogram (gazed.vision.appearance); empty where none.",
    )


class Detection(Message):
    """The target as the detector saw it in one frame (pixels, image coordinates: u right, v down),
    and every mover the frame shows. Version 2 adds `movers`, version 3 the head's `zoom`, version
    4 `delay_ms`, version 5 `Mover.velocity_known`."""

    SCHEMA: ClassVar[str] = "gazed.Detection"
    VERSION: ClassVar[int] = 5
    seq: int = Field(ge=0, description="Frame sequence number.")
    detector: str
    found: bool
    u_px: float = Field(0.0, description="Target pixel, u (origin: the top-left pixel's centre).")
    v_px: float = Field(0.0, description="Target pixel, v.")
    du_px_s: float = Field(
        0.0,
        description="Independent image velocity along u: the target's motion against the world "
        "with the head's own rotational flow removed (seed 000 §2), over the last frame interval.",
    )
    dv_px_s: float = Field(0.0, description="Independent image velocity along v.")
    area_px: float = Field(0.0, ge=0, description="Area of the detected region in pixels.")
    confidence: float = Field(0.0, ge=0, le=1)
    point: Literal["centroid", "ground-contact"] = Field(
        "centroid",
        description="What (u, v) is: the region's centroid, or the bottom of the blob where it "
        "meets the ground (no height correction needed).",
    )
    compensated: bool = Field(
        False, description="The head's rotation was removed (odometry covered both frames)."
    )
    width_px: int = Field(gt=0)
    height_px: int = Field(gt=0)
    processing_ms: float = Field(0.0, ge=0)
    head: HeadPose | None = Field(
        None, description="Head pose at capture time, None without odometry."
    )
    movers: tuple[Mover, ...] = Field(
        default=(),
        max_length=64,
        description="Every mover in the frame, the target's own first when found.",
    )
    delay_ms: float = Field(
        0.0,
        description="The camera delay the frame's stamp was moved back by from its arrival "
        "([camera] delay_ms or the online estimate); when it changes, the earlier frames' stamps "
        "were off by the change.",
    )


class Candidate(BaseModel):
    """One whole-frame motion region: its centroid, image velocity, area, motion energy and its
    interest score among the frame's regions."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)
    u_px: float
    v_px: float
    du_px_s: float = 0.0
    dv_px_s: float = 0.0
    area_px: float = Field(ge=0)
    energy: float = Field(ge=0)
    score: float


class Candidates(Message):
    """Whole-frame motion regions, ranked, for saccades. Version 2 adds the head's `zoom`."""

    SCHEMA: ClassVar[str] = "gazed.Candidates"
    VERSION: ClassVar[int] = 2
    seq: int = Field(ge=0)
    width_px: int = Field(gt=0)
    height_px: int = Field(gt=0)
    candidates: tuple[Candidate, ...] = ()
    head: HeadPose | None = None


class EdgeObservation(Message):
    """The edge nearest the fovea's centre in one frame (image coordinates): the point on it
    nearest the centre, and the points a step ahead and behind along its string. Version 2 adds
    the head's `zoom`."""

    SCHEMA: ClassVar[str] = "gazed.EdgeObservation"
    VERSION: ClassVar[int] = 2
    seq: int = Field(ge=0)
    found: bool
    u_px: float = 0.0
    v_px: float = 0.0
    ahead_px: tuple[float, float] = (0.0, 0.0)
    behind_px: tuple[float, float] = (0.0, 0.0)
    turn_rad: float = Field(0.0, description="Angle between the string's two halves (0: straight).")
    head: HeadPose | None = None
