"""Wire schemas: every message on the bus is one of these pydantic models, sent as JSON with the
zenoh encoding `application/json;gazed.<Name>/<version>`.

Every message carries `t_capture_ns` (when the light hit the sensor, or the source time of the
data it derives from; wall clock, integer ns) and `stamps`, a list of `(stage, t_ns)` pairs that
each process appends as the data passes through it. `gazed latency` reads them.

Angles are radians, positions metres, rates per second. Non-finite numbers are refused at
validation, so a NaN never crosses the bus.
"""

from __future__ import annotations

import time
from typing import ClassVar, Literal, Self

from pydantic import BaseModel, ConfigDict, Field, model_validator

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
    and every mover the frame shows. Version 2 adds `movers`, version 3 the head's `zoom`."""

    SCHEMA: ClassVar[str] = "gazed.Detection"
    VERSION: ClassVar[int] = 3
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


class TraceResult(Message):
    """The gaze samples collected along one traced edge, and why the trace ended."""

    SCHEMA: ClassVar[str] = "gazed.TraceResult"
    request_id: str
    samples_rad: tuple[tuple[float, float], ...] = Field(
        description="(pan, tilt) of each edge point."
    )
    reason: str


class Track(BaseModel):
    """One person the estimator follows, at the frame's capture."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)
    id: int = Field(ge=0, description="Stable for the track's life; never reused.")
    confirmed: bool = Field(description="Seen often enough to be a person, not clutter.")
    pan_rad: float = Field(description="The head angles that centre it in the fovea.")
    tilt_rad: float
    ground_xy_m: tuple[float, float] | None = None
    ground_velocity_m_s: tuple[float, float] | None = None
    ground_cov_m2: tuple[tuple[float, float], tuple[float, float]] | None = None
    age_s: float = Field(ge=0, description="Since the track began.")
    hits: int = Field(ge=0, description="Detections it has taken.")
    coasting: bool = Field(False, description="No detection of it in this frame.")
    box_height_px: float = Field(0.0, ge=0, description="Its last box's height.")
    most_likely: str = ""


class EstimatorState(Message):
    """The filter after a detection or a coasting step: combined state, covariance, model
    probabilities and the target on the ground (the chosen track's, `target_id`), and every
    track. Version 2 adds `tracks` and `target_id`."""

    SCHEMA: ClassVar[str] = "gazed.EstimatorState"
    VERSION: ClassVar[int] = 2
    filter: str
    x: tuple[float, ...] = Field(
        description="Combined state vector (its layout depends on the filter)."
    )
    P: tuple[tuple[float, ...], ...] = Field(description="Its covariance.")
    model_probabilities: dict[str, float] = Field(default_factory=dict)
    most_likely: str = ""
    ground_xy_m: tuple[float, float] | None = None
    ground_velocity_m_s: tuple[float, float] | None = None
    coasting: bool = False
    target_id: int | None = Field(None, ge=0, description="The track described above.")
    tracks: tuple[Track, ...] = Field(default=(), max_length=256)


class Prediction(Message):
    """Where the target will be when the next demand takes effect. Version 2 adds `track_id`."""

    SCHEMA: ClassVar[str] = "gazed.Prediction"
    VERSION: ClassVar[int] = 2
    filter: str
    t_effect_ns: int = Field(ge=0, description="The instant the prediction is for.")
    horizon_s: float = Field(ge=-60, le=60)
    pan_rad: float
    tilt_rad: float
    pan_rate_rad_s: float
    tilt_rate_rad_s: float
    ground_xy_m: tuple[float, float] | None = None
    ground_velocity_m_s: tuple[float, float] | None = None
    position_cov_m2: tuple[tuple[float, float], tuple[float, float]] | None = None
    visual_latency_s: float = Field(ge=0, le=60)
    actuation_latency_s: float = Field(ge=0, le=60)
    coasting: bool = False
    track_id: int | None = Field(None, ge=0, description="The track predicted; None: the only one.")


class ManeuverEvent(Message):
    """The most likely motion model changed: the motion signature of the segment that ended."""

    SCHEMA: ClassVar[str] = "gazed.ManeuverEvent"
    model: str
    previous_model: str
    t_start_ns: int = Field(ge=0)
    previous_duration_s: float = Field(ge=0)
    mean_s_dot_m_s2: float
    mean_theta_dot_rad_s: float


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


class Health(Message):
    """About once a second from every process. Version 2 adds `subscribes` and `publishes`."""

    SCHEMA: ClassVar[str] = "gazed.Health"
    VERSION: ClassVar[int] = 2
    process: str
    pid: int = Field(ge=0)
    uptime_s: float = Field(ge=0)
    counters: dict[str, int] = Field(
        default_factory=dict, description="dropped, malformed, … since start."
    )
    rates_hz: dict[str, float] = Field(
        default_factory=dict, description="Messages per second received by key."
    )
    stage_ms: dict[str, float] = Field(
        default_factory=dict, description="Time spent in this process's stage."
    )
    notes: dict[str, str] = Field(default_factory=dict, description="State worth a person's eye.")
    subscribes: tuple[str, ...] = Field(
        default=(), description="Key suffixes the process subscribes (below gazed/<rig>/)."
    )
    publishes: tuple[str, ...] = Field(
        default=(), description="Key suffixes the process declares publishers for."
    )


class ProcessStatus(BaseModel):
    """One process as its supervisor sees it."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)
    name: str
    state: Literal["starting", "running", "backoff", "stopped", "missing", "disabled", "failed"]
    pid: int | None = None
    alive: bool = False
    restarts: int = Field(0, ge=0)
    last_exit: int | None = None
    message: str = ""


class SupervisorStatus(Message):
    """Every process's state and restarts, once a second and on every change."""

    SCHEMA: ClassVar[str] = "gazed.SupervisorStatus"
    state: Literal["starting", "running", "reloading", "stopping", "failed"]
    host: str = Field("", description="Host of this supervisor (a rig may span several).")
    rig_path: str
    processes: tuple[ProcessStatus, ...] = ()
    message: str = ""
