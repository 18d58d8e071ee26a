"""The rig description: one TOML file, one pydantic model per section.

`load_rig(path)` returns a validated, frozen `Rig` or raises `RigError` carrying every problem
found, each as `FILE: KEY.PATH: what was wrong (expected …)`. Unknown keys are errors with a
"did you mean" suggestion; TOML syntax errors carry line and column.

Units are in the key names (`_deg`, `_m`, `_ms`, `_hz`); the `Rig` keeps them as written, and
the properties that end in `_rad` / `_s` give SI values to the code inside.
"""

from __future__ import annotations

import difflib
import math
import re
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal, get_args, get_origin

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    model_validator,
)
from pydantic.fields import FieldInfo

__all__ = [
    "SERVICE_NAMES",
    "Rig",
    "RigError",
    "load_rig",
    "parse_rig",
    "sections_read_by",
]

ENDPOINT_PATTERN = r"^(tcp|udp|tls|quic|ws|unixsock-stream)/.+$"


def _has_port(endpoint: str) -> str:
    """A network endpoint ends in a port that exists (zenoh refuses one only at start-up)."""
    protocol, _, address = endpoint.partition("/")
    port = address.split("#", 1)[0].rpartition(":")[2]
    if protocol != "unixsock-stream" and not (port.isdigit() and int(port) <= 65535):
        raise ValueError(f"{endpoint!r} has no port 0-65535 (expected e.g. tcp/127.0.0.1:7447)")
    return endpoint


Endpoint = Annotated[str, Field(pattern=ENDPOINT_PATTERN), AfterValidator(_has_port)]
LOOPBACK_HOSTS = ("127.0.0.1", "[::1]", "localhost")


def _loopback(endpoint: str) -> bool:
    """A tcp/udp endpoint on this machine's loopback."""
    protocol, _, address = endpoint.partition("/")
    return protocol in ("tcp", "udp") and address.rsplit(":", 1)[0] in LOOPBACK_HOSTS


class Section(BaseModel):
    """Base of every section: unknown keys are errors, values are frozen after loading."""

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


class RigSection(Section):
    name: str = Field(
        pattern=r"^[A-Za-z0-9_-]+$",
        description="Rig name; every bus key is gazed/<name>/..., so two rigs can share a bus.",
    )
    description: str = Field(
        "", description="Free text for people: where the rig is, what it watches."
    )


class BusSection(Section):
    listen: list[Endpoint] = Field(
        default_factory=lambda: ["tcp/127.0.0.1:7447"],
        description="zenoh endpoints the supervisor's router listens on. Loopback only by default.",
    )
    connect: list[Endpoint] = Field(
        default_factory=list,
        description="Endpoints the processes and tools connect to; empty means the listen endpoints.",
    )
    router: bool = Field(
        True,
        description="The supervisor hosts the zenoh router. False when a router runs elsewhere "
        "(multi-host rigs); processes then connect to `connect`.",
    )
    lease_ms: int = Field(
        1000,
        ge=100,
        le=60000,
        description="zenoh link lease: a frozen process is declared dead after ~3/4 of it.",
    )
    zenoh_config_path: Path | None = Field(
        None,
        description="JSON5 zenoh config merged under gazed's settings (user/password, TLS, access "
        "control) for rigs that span hosts. Relative paths are from the rig file.",
    )
    credentials_path: Path | None = Field(
        None,
        description="File of NAME:PASSWORD lines (zenoh's user/password dictionary, not readable by "
        "other users): every process authenticates as its own name (supervisor, sim, servo, "
        "vision, estimator, gaze; bus tools as 'tools') and the supervisor's router checks each "
        "against it. Relative paths are from the rig file.",
    )

    peer_links: bool = Field(
        True,
        description="The rig's own processes also link to each other directly, as zenoh peers "
        "on loopback (one hop instead of two through the router). "
        "Only where the bus is the supervisor's router on loopback with neither credentials nor "
        "a zenoh config: elsewhere the router's authentication and access control see every "
        "message, and the processes stay its clients.",
    )

    @property
    def direct(self) -> bool:
        """Whether the rig's processes link to each other directly (see `peer_links`)."""
        return (
            self.peer_links
            and self.router
            and self.credentials_path is None
            and self.zenoh_config_path is None
            and all(_loopback(e) for e in (*self.listen, *self.client_endpoints))
        )

    @property
    def peer_listen(self) -> str:
        """Where a process listens for its peers: the loopback of the router's first endpoint,
        on a port the system chooses."""
        protocol, _, address = self.client_endpoints[0].partition("/")
        host = address.rsplit(":", 1)[0]
        return f"{protocol}/{host}:0"

    @model_validator(mode="after")
    def _connectable(self) -> BusSection:
        if not self.router and not self.connect:
            raise ValueError(
                "connect: must name the router's endpoint(s) when router = false (expected a list of endpoints)"
            )
        return self

    @property
    def client_endpoints(self) -> list[str]:
        """Where processes and tools connect: `connect`, or the router's listen endpoints with
        unspecified addresses replaced by loopback."""
        if self.connect:
            return list(self.connect)
        return [e.replace("0.0.0.0", "127.0.0.1").replace("[::]", "[::1]") for e in self.listen]


class CameraSection(Section):
    source: str = Field(
        "sim",
        description="'sim' (frames from the simulator on the bus), a device index such as '0', "
        "a video file path, or an rtsp:// / http:// URL.",
    )
    width_px: int = Field(640, ge=16, le=8192, description="Image width in pixels.")
    height_px: int = Field(480, ge=16, le=8192, description="Image height in pixels.")
    rate_hz: float = Field(25.0, gt=0, le=1000, description="Frame rate the camera delivers.")
    hfov_deg: float | None = Field(
        60.0,
        gt=0,
        lt=180,
        description="Horizontal field of view; used when fx_px/fy_px are not given.",
    )
    fx_px: float | None = Field(
        None, gt=0, description="Focal length along u in pixels (overrides hfov_deg)."
    )
    fy_px: float | None = Field(
        None, gt=0, description="Focal length along v in pixels (defaults to fx_px)."
    )
    cx_px: float | None = Field(
        None, description="Principal point u in pixels (default: image centre)."
    )
    cy_px: float | None = Field(
        None, description="Principal point v in pixels (default: image centre)."
    )
    distortion: list[float] = Field(
        default_factory=list,
        max_length=8,
        description="OpenCV distortion coefficients k1, k2, p1, p2[, k3…]; empty for none.",
    )
    reopen_max_s: float = Field(
        10.0,
        gt=0,
        le=600,
        description="Longest wait before reopening a failed camera, stream or file (the wait "
        "starts at 0.5 s and doubles).",
    )
    timeout_ms: float = Field(
        5000.0,
        gt=0,
        le=60000,
        description="How long a source may stay silent: the open/read timeout of streams and "
        "files; no simulator frame for this long reports the link down.",
    )

    @model_validator(mode="after")
    def _focal_length(self) -> CameraSection:
        if self.fx_px is None and self.hfov_deg is None:
            raise ValueError("hfov_deg: missing (expected hfov_deg or fx_px, the focal length)")
        if self.fy_px is not None and self.fx_px is None:
            raise ValueError("fx_px: missing (expected fx_px whenever fy_px is given)")
        return self

    @property
    def frame_period_s(self) -> float:
        return 1.0 / self.rate_hz


class HeadSection(Section):
    kinematics: Literal["pan-tilt", "tilt-pan"] = Field(
        "pan-tilt",
        description="'pan-tilt': pan is the outer axis (most PTUs and PTZ cameras); "
        "'tilt-pan': tilt is the outer axis (the paper's head).",
    )
    pan_sign: Literal[1, -1] = Field(
        1, description="+1 if the device's pan grows to the right, -1 if to the left."
    )
    tilt_sign: Literal[1, -1] = Field(
        1, description="+1 if the device's tilt grows upwards, -1 if downwards."
    )
    pan_zero_deg: float = Field(
        0.0, ge=-180, le=180, description="Device pan reading when the gaze is at rest."
    )
    tilt_zero_deg: float = Field(
        0.0, ge=-90, le=90, description="Device tilt reading when the gaze is level."
    )
    pan_min_deg: float = Field(
        -170.0, ge=-360, le=360, description="Lowest pan the head may be sent to."
    )
    pan_max_deg: float = Field(
        170.0, ge=-360, le=360, description="Highest pan the head may be sent to."
    )
    tilt_min_deg: float = Field(
        -90.0, ge=-180, le=180, description="Lowest tilt (down) the head may be sent to."
    )
    tilt_max_deg: float = Field(
        30.0, ge=-180, le=180, description="Highest tilt (up) the head may be sent to."
    )
    pan_rate_max_deg_s: float = Field(120.0, gt=0, le=3600, description="Pan speed limit.")
    tilt_rate_max_deg_s: float = Field(90.0, gt=0, le=3600, description="Tilt speed limit.")
    pan_accel_max_deg_s2: float = Field(600.0, gt=0, le=1e6, description="Pan acceleration limit.")
    tilt_accel_max_deg_s2: float = Field(
        600.0, gt=0, le=1e6, description="Tilt acceleration limit."
    )
    park_pan_deg: float = Field(0.0, description="Pan the head returns to when parked.")
    park_tilt_deg: float = Field(0.0, description="Tilt the head returns to when parked.")
    angle_noise_deg: float = Field(
        0.05,
        gt=0,
        le=10,
        description="Std of the joint angles the head reports (encoder resolution, backlash); "
        "propagated to the ground-plane measurement's covariance.",
    )
    angle_rate_noise_deg_s: float = Field(
        0.5,
        gt=0,
        le=100,
        description="Std of the joint rates at capture time (odometry differenced and "
        "interpolated); propagated to the ground-plane velocity's covariance.",
    )

    @model_validator(mode="after")
    def _limits(self) -> HeadSection:
        if self.pan_min_deg >= self.pan_max_deg:
            raise ValueError(
                "pan_max_deg: must be above pan_min_deg (expected pan_min_deg < pan_max_deg)"
            )
        if self.tilt_min_deg >= self.tilt_max_deg:
            raise ValueError(
                "tilt_max_deg: must be above tilt_min_deg (expected tilt_min_deg < tilt_max_deg)"
            )
        if not self.pan_min_deg <= self.park_pan_deg <= self.pan_max_deg:
            raise ValueError(
                "park_pan_deg: outside the pan limits (expected pan_min_deg <= park_pan_deg <= pan_max_deg)"
            )
        if not self.tilt_min_deg <= self.park_tilt_deg <= self.tilt_max_deg:
            raise ValueError(
                "park_tilt_deg: outside the tilt limits (expected tilt_min_deg <= park_tilt_deg <= tilt_max_deg)"
            )
        return self

    @property
    def pan_limits_rad(self) -> tuple[float, float]:
        return math.radians(self.pan_min_deg), math.radians(self.pan_max_deg)

    @property
    def tilt_limits_rad(self) -> tuple[float, float]:
        return math.radians(self.tilt_min_deg), math.radians(self.tilt_max_deg)

    @property
    def rate_max_rad_s(self) -> tuple[float, float]:
        return math.radians(self.pan_rate_max_deg_s), math.radians(self.tilt_rate_max_deg_s)

    @property
    def accel_max_rad_s2(self) -> tuple[float, float]:
        return math.radians(self.pan_accel_max_deg_s2), math.radians(self.tilt_accel_max_deg_s2)

    @property
    def park_rad(self) -> tuple[float, float]:
        return math.radians(self.park_pan_deg), math.radians(self.park_tilt_deg)

    @property
    def angle_noise_rad(self) -> float:
        return math.radians(self.angle_noise_deg)

    @property
    def angle_rate_noise_rad_s(self) -> float:
        return math.radians(self.angle_rate_noise_deg_s)


class ServoLink(Section):
    """Keys shared by every protocol: the serial link and the servo process's timing."""

    port: str = Field(
        "/tmp/gazed-sim-head",
        description="pyserial URL: /dev/ttyUSB0, a pty path, socket://host:port, spy://…, loop://.",
    )
    baud: int = Field(9600, gt=0, description="Serial speed in baud.")
    timeout_ms: float = Field(100.0, gt=0, le=10000, description="How long to wait for a reply.")
    command_timeout_ms: float = Field(
        500.0,
        gt=0,
        le=60000,
        description="No fresh demand for this long -> the servo process holds position.",
    )
    odometry_rate_hz: float = Field(
        50.0, gt=0, le=1000, description="How often the head's position is polled."
    )
    command_rate_hz: float = Field(
        50.0,
        gt=0,
        le=1000,
        description="Most set-points per second while a move is under way (a fresh demand is "
        "written at once).",
    )
    reconnect_max_s: float = Field(
        10.0, gt=0, le=600, description="Longest wait between reconnection attempts."
    )


class PelcoDServo(ServoLink):
    protocol: Literal["pelco-d"] = Field(
        description="Pelco-D over RS-485 with extended position commands."
    )
    address: int = Field(1, ge=1, le=255, description="Receiver address of the camera.")
    position_feedback: bool = Field(
        True,
        description="The unit answers the 0x51/0x53 position queries; otherwise odometry is dead-reckoned.",
    )
    pan_speed_max_deg_s: float = Field(
        120.0, gt=0, le=3600, description="Pan rate of drive speed 0x3F (speeds map linearly)."
    )
    tilt_speed_max_deg_s: float = Field(
        90.0, gt=0, le=3600, description="Tilt rate of drive speed 0x3F (speeds map linearly)."
    )


class ViscaServo(ServoLink):
    protocol: Literal["visca"] = Field(description="Sony VISCA over RS-232/422.")
    address: int = Field(1, ge=1, le=7, description="Camera address on the VISCA chain.")
    pan_deg_per_unit: float = Field(0.075, gt=0, description="Degrees per VISCA pan position unit.")
    tilt_deg_per_unit: float = Field(
        0.075, gt=0, description="Degrees per VISCA tilt position unit."
    )
    pan_speed: int = Field(24, ge=1, le=24, description="Pan speed byte of absolute moves (1-24).")
    tilt_speed: int = Field(
        20, ge=1, le=20, description="Tilt speed byte of absolute moves (1-20)."
    )
    pan_speed_max_deg_s: float = Field(
        120.0, gt=0, le=3600, description="Pan rate of speed byte 0x18 (speeds map linearly)."
    )
    tilt_speed_max_deg_s: float = Field(
        90.0, gt=0, le=3600, description="Tilt rate of speed byte 0x14 (speeds map linearly)."
    )


class FlirPtuServo(ServoLink):
    protocol: Literal["flir-ptu"] = Field(
        description="FLIR / Directed Perception PTU ASCII protocol."
    )
    pan_arcsec_per_position: float = Field(
        46.2857, gt=0, description="Pan resolution (arc seconds per position)."
    )
    tilt_arcsec_per_position: float = Field(
        46.2857, gt=0, description="Tilt resolution (arc seconds per position)."
    )


class DynamixelServo(ServoLink):
    protocol: Literal["dynamixel"] = Field(description="Two Dynamixel X servos, protocol 2.0.")
    pan_id: int = Field(1, ge=0, le=252, description="Dynamixel ID of the pan servo.")
    tilt_id: int = Field(2, ge=0, le=252, description="Dynamixel ID of the tilt servo.")
    center: int = Field(2048, ge=0, description="Position value of the joint's zero.")
    units_per_rev: int = Field(4096, gt=0, description="Position units per revolution.")

    @model_validator(mode="after")
    def _distinct_ids(self) -> DynamixelServo:
        if self.pan_id == self.tilt_id:
            raise ValueError("tilt_id: same as pan_id (expected two distinct servo IDs)")
        return self


ServoSection = Annotated[
    PelcoDServo | ViscaServo | FlirPtuServo | DynamixelServo, Field(discriminator="protocol")
]
SERVO_LINK_KEYS = frozenset(ServoLink.model_fields)


class CalibrationSection(Section):
    homography: list[Annotated[list[float], Field(min_length=3, max_length=3)]] | None = Field(
        None,
        min_length=3,
        max_length=3,
        description="3x3 matrix M (rows) mapping frontal-plane points to ground XY (metres), "
        "M33 = 1 when the rest gaze points below the horizon, else a unit third row; lambda = "
        "(M x)_3 > 0 below the horizon. Written by `gazed calibrate points|lines FILE --write RIG`.",
    )
    camera_xyz_m: tuple[float, float, float] | None = Field(
        None,
        description="Camera rotation centre on the ground plane (X, Y) and its height Z, for height correction.",
    )
    target_height_m: float = Field(
        0.0,
        ge=0,
        le=100,
        description="Height above the ground of the tracked point (a torso: about 1 m).",
    )

    @model_validator(mode="after")
    def _homography(self) -> CalibrationSection:
        if self.homography is not None:
            values = [v for row in self.homography for v in row]
            if not all(math.isfinite(v) for v in values):
                raise ValueError("homography: not finite (expected 3 rows of 3 finite numbers)")
            (a, b, c), (d, e, f), (g, h, i) = self.homography
            determinant = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
            scale = math.sqrt(sum(v * v for v in values))
            if abs(determinant) <= 1e-12 * scale**3:
                raise ValueError(
                    "homography: singular (expected an invertible matrix, as `gazed calibrate` writes)"
                )
        if self.camera_xyz_m is not None and self.target_height_m >= self.camera_xyz_m[2]:
            raise ValueError(
                "target_height_m: not below the camera (expected target_height_m < camera_xyz_m[2])"
            )
        if self.target_height_m > 0 and self.camera_xyz_m is None:
            raise ValueError(
                "camera_xyz_m: missing (expected [X, Y, Z] when target_height_m > 0, for the height correction)"
            )
        return self


class VisionSection(Section):
    detector: Literal["flow", "pyramid", "background"] = Field(
        "flow",
        description="'flow' foveal normal flow, 'pyramid' motion-energy pyramid, 'background' subtraction.",
    )
    fovea_deg: float = Field(
        6.0, gt=0, le=90, description="Side of the square foveal window (the paper's ~6°)."
    )
    candidates: bool = Field(
        True, description="Publish whole-frame motion candidates for saccades."
    )
    compensate_ego_motion: bool = Field(
        True,
        description="Remove the head's own rotation (from odometry) before detecting motion; "
        "off only to diagnose odometry.",
    )
    odometry_history_ms: float = Field(
        2000.0,
        gt=0,
        le=60000,
        description="Odometry kept to find the head pose at a frame's capture time (longer "
        "than the visual latency).",
    )
    odometry_max_gap_ms: float = Field(
        200.0,
        gt=0,
        le=10000,
        description="Interpolate odometry across gaps up to this; extrapolate past the "
        "newest sample by two of the stream's periods, at most this; beyond, a frame gets no "
        "pose and no compensation.",
    )
    frame_gap_max_ms: float = Field(
        500.0,
        gt=0,
        le=10000,
        description="Frames further apart than this are not compared: the detectors restart.",
    )
    flow_noise_px: float = Field(
        0.5,
        gt=0,
        le=10,
        description="flow: background is where the ego-compensated normal flow is within this "
        "many pixels per frame.",
    )
    flow_min_gradient: float = Field(
        3.0,
        gt=0,
        le=255,
        description="flow: grey levels per pixel of image gradient below which a pixel's "
        "normal flow is not used.",
    )
    flow_min_area_px: int = Field(
        20, ge=1, description="flow: smallest moving region kept, in pixels."
    )
    pyramid_search: Literal["full", "predictive"] = Field(
        "predictive",
        description="pyramid: 'full' 5-level coarse-to-fine search every frame, or "
        "'predictive' 2-level search around the prediction with bootstrapping (seed 004 §3).",
    )
    pyramid_levels: int = Field(
        5,
        ge=3,
        le=8,
        description="pyramid: levels of the motion-energy pyramid; the search starts on the "
        "coarsest.",
    )
    pyramid_window_px: int = Field(
        16, ge=4, le=128, description="pyramid: side of the search window at every level."
    )
    pyramid_fill_fraction: float = Field(
        0.25,
        gt=0,
        le=1,
        description="pyramid: the search stops refining at the level where this fraction of "
        "the window is active (the object is about as large as the window).",
    )
    energy_threshold: float = Field(
        3.0,
        gt=0,
        le=255,
        description="pyramid and candidates: motion energy (grey levels of the level-0 "
        "Laplacian of the frame difference) above which a pixel counts as moving.",
    )
    background_level: int = Field(
        1,
        ge=0,
        le=3,
        description="background: pyramid level the background model runs at (1 = half "
        "resolution, 4x cheaper).",
    )
    background_history_frames: int = Field(
        200, ge=2, le=100000, description="background: frames the background model remembers."
    )
    background_threshold: float = Field(
        16.0,
        gt=0,
        description="background: squared Mahalanobis distance from the background model "
        "above which a pixel is foreground (MOG2 varThreshold).",
    )
    background_min_area_px: int = Field(
        200, ge=1, description="background: smallest blob reported, in full-resolution pixels."
    )
    background_learning_frames: int = Field(
        10,
        ge=0,
        le=10000,
        description="background: frames learnt after a reset before anything is reported.",
    )
    background_still_px: float = Field(
        1.0,
        gt=0,
        description="background: the model is relearnt when the head's rotation moves the "
        "image centre by more than this many pixels.",
    )
    candidates_level: int = Field(
        3,
        ge=0,
        le=7,
        description="candidates: pyramid level of the whole-frame motion energy (3 = 1/8 "
        "resolution).",
    )
    candidates_max: int = Field(
        8, ge=1, le=64, description="candidates: most regions published per frame."
    )
    candidate_min_area_px: float = Field(
        64.0, ge=0, description="candidates: smallest region published, in full-resolution pixels."
    )

    edge_step_px: int = Field(
        12,
        ge=2,
        le=200,
        description="Line tracing: step along the edge to the next gaze point, in pixels.",
    )
    edge_canny_low: float = Field(
        60.0,
        gt=0,
        description="Line tracing: Canny's low hysteresis threshold (gradient magnitude).",
    )
    edge_canny_high: float = Field(
        150.0,
        gt=0,
        description="Line tracing: Canny's high hysteresis threshold (gradient magnitude).",
    )

    @model_validator(mode="after")
    def _levels(self) -> VisionSection:
        if self.candidates_level >= self.pyramid_levels:
            raise ValueError(
                "candidates_level: beyond the pyramid (expected candidates_level < pyramid_levels)"
            )
        return self

    @property
    def fovea_rad(self) -> float:
        return math.radians(self.fovea_deg)


class EstimatorSection(Section):
    filter: Literal["imm", "innovation", "alphabeta", "image-cv"] = Field(
        "imm",
        description="'imm' CSD/CS/CD EKFs on the ground plane; 'innovation' CP/CV/CA selection; "
        "'alphabeta' adaptive alpha-beta; 'image-cv' constant velocity on gaze angles (2D baseline).",
    )
    stay_probability: float = Field(
        0.96, gt=0, lt=1, description="IMM switching matrix diagonal J_d (the paper's 0.96)."
    )
    csd_speed_rate_noise_m_s2: float = Field(
        0.5, gt=0, description="IMM CSD process noise: std of the unmodelled speed rate ṡ."
    )
    csd_turn_rate_noise_rad_s: float = Field(
        0.5, gt=0, description="IMM CSD process noise: std of the unmodelled turn rate θ̇."
    )
    cs_speed_rate_noise_m_s2: float = Field(
        0.5, gt=0, description="IMM CS process noise: std of the unmodelled speed rate ṡ."
    )
    cs_turn_accel_noise_rad_s2: float = Field(
        3.0,
        gt=0,
        description="IMM CS process noise: std of the turn-rate change θ̈ (the paper: 30 rad²/s⁴).",
    )
    cd_jerk_noise_m_s3: float = Field(
        1.0, gt=0, description="IMM CD process noise: std of the speed-rate change s̈."
    )
    cd_turn_rate_noise_rad_s: float = Field(
        0.5, gt=0, description="IMM CD process noise: std of the unmodelled turn rate θ̇."
    )
    cp_velocity_noise_m_s: float = Field(
        0.2, gt=0, description="CP process noise: std of the velocity (seed 003 §IV: 0.04 m²)."
    )
    cv_accel_noise_m_s2: float = Field(
        0.5, gt=0, description="CV process noise: std of the acceleration (seed 003 §IV: 0.25)."
    )
    ca_jerk_noise_m_s3: float = Field(
        0.5, gt=0, description="CA process noise: std of the jerk (seed 003 §IV: 0.25)."
    )
    selection_window: int = Field(
        10, ge=1, le=1000, description="Innovation selection: window length in observations."
    )
    consistency_probability: float = Field(
        0.99,
        gt=0.5,
        lt=1,
        description="Innovation selection: a model is consistent while its windowed innovation "
        "mean and NIS stay inside this chi-square probability.",
    )
    alphabeta_smoothing: float = Field(
        0.2,
        gt=0,
        le=1,
        description="alphabeta: weight of the newest squared error in its running variances "
        "(1 = the instantaneous values of seed 004 eq. 10).",
    )
    image_cv_accel_noise_rad_s2: float = Field(
        0.5, gt=0, description="image-cv process noise: std of the gaze-angle acceleration."
    )
    initial_speed_std_m_s: float = Field(
        2.0,
        gt=0,
        description="Std of the velocity (m/s, or rad/s for image-cv) of a track that has one "
        "position and no velocity yet.",
    )
    position_noise_m: float = Field(
        0.1,
        gt=0,
        description="Std of a ground-plane position measurement where nothing better is known "
        "(also the annotation noise assumed by `gazed eval estimator --data`).",
    )
    velocity_noise_m_s: float = Field(
        0.2, gt=0, description="Std of a ground-plane velocity measurement."
    )
    gate_probability: float = Field(
        0.999, gt=0.5, lt=1, description="Chi-square gate: measurements outside it are outliers."
    )
    reinit_after_misses: int = Field(
        5,
        ge=1,
        le=1000,
        description="Re-initialise the filter after this many consecutive gate failures.",
    )
    pixel_noise_px: float = Field(
        2.0,
        gt=0,
        le=1000,
        description="Std of a detection's target pixel (the live measurement's noise).",
    )
    pixel_rate_noise_px_s: float = Field(
        30.0, gt=0, le=100000, description="Std of a detection's independent image velocity."
    )
    predict_over_latency: bool = Field(
        True,
        description="Predict to the instant the demand acts; false predicts to the measurement's own "
        "time (no latency compensation: the baseline `gazed eval loop --filter none` compares against).",
    )
    actuation_latency_default_ms: float = Field(
        20.0,
        ge=0,
        le=5000,
        description="Actuation latency assumed until servo/command stamps have measured it.",
    )
    coast_max_ms: float = Field(
        2000.0,
        gt=0,
        description="Predict without measurements for at most this long, then drop the track.",
    )


class GazeSection(Section):
    control: Literal["pursuit", "look-and-move"] = Field(
        "pursuit",
        description="'pursuit': continuous smooth pursuit (dynamic look-and-move); 'look-and-move': "
        "move, settle, then look (PTZ cameras that cannot image while moving).",
    )
    rate_hz: float = Field(
        50.0, gt=0, le=1000, description="Rate of the gaze controller's demands."
    )
    fovea_half_angle_deg: float = Field(
        3.0,
        gt=0,
        le=45,
        description="Target within this angle of the optical axis counts as foveated.",
    )
    settle_ms: float = Field(
        80.0, ge=0, description="After a saccade, detections are ignored for this long."
    )
    lost_after_ms: float = Field(
        600.0,
        gt=0,
        description="No detection for this long in pursuit -> lost (coast on prediction).",
    )
    saccade_tolerance_deg: float = Field(
        0.5,
        gt=0,
        le=20,
        description="A saccade has arrived when the head is this close to its goal, at rest.",
    )
    saccade_timeout_ms: float = Field(
        3000.0, gt=0, description="A saccade not settled after this -> search."
    )
    candidate_min_score: float = Field(
        0.0, description="Motion candidates scoring below this do not draw a saccade."
    )
    residual_gain: float = Field(
        0.3,
        ge=0,
        le=1,
        description="Pursuit feedback: share of the smoothed prediction residual added to the demand.",
    )
    residual_smoothing: float = Field(
        0.2,
        gt=0,
        le=1,
        description="Weight of each new residual in its running mean (1: no smoothing).",
    )
    lost_search_growth_deg_s: float = Field(
        2.0,
        ge=0,
        le=180,
        description=(
            "Lost: the search region around the prediction grows this fast at least; once it is"
            " wider than the fovea, the fovea tours its edge, a look at each stop."
        ),
    )
    lost_search_max_deg: float = Field(
        10.0,
        ge=0,
        le=90,
        description=(
            "Lost: largest search radius; a region growing past it (the prediction says too"
            " little) sends the gaze back to search."
        ),
    )
    trace_max_turn_deg: float = Field(
        30.0,
        gt=0,
        le=180,
        description="Line tracing: an edge turning more than this is a corner: the trace ends.",
    )
    trace_line_tolerance_deg: float = Field(
        0.3,
        gt=0,
        le=10,
        description="Line tracing: a sample this far off the line through the earlier ones means the edge turned.",
    )
    trace_misses: int = Field(
        3,
        ge=1,
        le=100,
        description="Line tracing: looks in a row without an edge before the trace ends.",
    )
    search_after_ms: float = Field(
        3000.0, gt=0, description="Lost for this long -> back to search."
    )
    reacquire_detections: int = Field(
        3,
        ge=1,
        le=25,
        description=(
            "Park, search and lost take a detection up only after this many in a row (one per"
            " frame): a lone false detection while the head scans is not the target."
        ),
    )


TRAJECTORY_NAMES = ("rounded-square", "oval", "stop-and-go", "figure-eight", "random")


class SimSection(Section):
    seed: int = Field(1, ge=0, description="Seed of everything random in the simulated world.")
    trajectory: str = Field(
        "oval",
        description="rounded-square, oval, stop-and-go, figure-eight, random, or file:PATH[#ped_id].",
    )
    camera_xyz_m: tuple[float, float, float] = Field(
        (0.0, -6.0, 4.0), description="True camera rotation centre (X, Y on the ground, Z height)."
    )
    camera_yaw_deg: float = Field(
        90.0,
        ge=-180,
        le=180,
        description="Ground-plane heading of the head's rest gaze, from +X towards +Y.",
    )
    camera_pitch_deg: float = Field(
        0.0,
        ge=-90,
        le=90,
        description="True pitch of the head's base: the rest gaze's elevation (< 0 looks down).",
    )
    camera_roll_deg: float = Field(
        0.0,
        ge=-45,
        le=45,
        description="True roll of the head's base about the rest gaze (> 0: right side down).",
    )
    visual_latency_ms: float = Field(
        150.0,
        ge=0,
        le=2000,
        description="Delay between capture and a frame reaching the bus (the paper: 100-200).",
    )
    head_latency_ms: float = Field(
        20.0,
        ge=0,
        le=2000,
        description="Emulated head: delay from a command's last byte to the axes acting on it.",
    )
    head_reply_delay_ms: float = Field(
        1.0,
        ge=0,
        le=1000,
        description="Emulated head: delay from a request's last byte to its reply's first.",
    )
    head_encoder_resolution_deg: float = Field(
        0.0,
        ge=0,
        le=10,
        description="Emulated head: step of the reported angles (0: only the protocol's unit).",
    )
    head_backlash_deg: float = Field(
        0.0,
        ge=0,
        le=10,
        description="Emulated head: play between motor (what the encoder reads) and camera.",
    )
    trajectory_speed_m_s: float = Field(
        1.0,
        gt=0,
        le=50,
        description="Target speed of rounded-square, stop-and-go, figure-eight, random.",
    )
    trajectory_scale: float = Field(
        1.0,
        gt=0,
        le=100,
        description="Multiplies the oval's and figure eight's lengths (and the oval's speeds).",
    )
    area_centre_xy_m: tuple[float, float] = Field(
        (0.0, 0.0),
        description="Ground point the trajectory is centred on (recorded tracks are moved there).",
    )
    target_height_m: float = Field(1.7, gt=0, le=20, description="Height of the target's body.")
    target_width_m: float = Field(0.5, gt=0, le=20, description="Width of the target's body.")
    distractor: str = Field(
        "", description="Trajectory of a second mover (same forms as trajectory); empty for none."
    )
    court_m: tuple[float, float, float, float] | None = Field(
        None,
        description="A paved rectangle [X0, Y0, X1, Y1] on the ground: its sides are ground lines "
        "X = X0, X = X1, Y = Y0, Y = Y1 for `gazed calibrate trace`.",
    )
    frame_encoding: Literal["bgr8", "gray8"] = Field(
        "bgr8",
        description="Pixels of the published frames: colour, or grey (a third of the bytes on the bus; "
        "the detectors work on grey anyway).",
    )
    noise_std_levels: float = Field(
        2.0, ge=0, le=64, description="Sensor noise: standard deviation in grey levels (0-255)."
    )
    flicker_amplitude: float = Field(
        0.0,
        ge=0,
        lt=1,
        description="Illumination flicker: relative amplitude of a 2 Hz brightness swing.",
    )
    motion_blur_exposure_ms: float = Field(
        0.0,
        ge=0,
        le=1000,
        description="Exposure over which the head's rotation blurs the frame (0: no blur).",
    )

    @model_validator(mode="after")
    def _trajectories(self) -> SimSection:
        if self.court_m is not None and not (
            self.court_m[0] < self.court_m[2] and self.court_m[1] < self.court_m[3]
        ):
            raise ValueError(
                "court_m: corners out of order (expected [X0, Y0, X1, Y1] with X0 < X1, Y0 < Y1)"
            )
        for key in ("trajectory", "distractor"):
            value = getattr(self, key)
            if key == "distractor" and value == "":
                continue
            if value not in TRAJECTORY_NAMES and not value.startswith("file:"):
                names = ", ".join(TRAJECTORY_NAMES)
                raise ValueError(
                    f"{key}: unknown trajectory {value!r} (expected one of {names} or file:PATH[#ped_id])"
                )
        return self


class ServiceSpec(Section):
    enabled: bool = Field(True, description="Start this process.")
    module: str | None = Field(
        None,
        pattern=r"^[A-Za-z_][A-Za-z0-9_.]*$",
        description="Python module run as `python -m MODULE --rig RIG` (default services.<name>).",
    )


SERVICE_NAMES = ("sim", "servo", "vision", "estimator", "gaze")

# The rig sections each process reads besides [rig] and [bus]: a SIGHUP that changes one of
# them restarts that process only. A process not listed here is restarted on any change.
SECTIONS_READ_BY: dict[str, tuple[str, ...]] = {
    "sim": ("camera", "head", "servo", "sim", "calibration"),
    "servo": ("head", "servo"),
    "vision": ("camera", "head", "vision"),
    "estimator": ("camera", "head", "calibration", "estimator"),
    "gaze": ("camera", "head", "calibration", "gaze"),
}


class ServicesSection(Section):
    sim: ServiceSpec = Field(
        default_factory=ServiceSpec, description="The simulated world and head emulator."
    )
    servo: ServiceSpec = Field(
        default_factory=ServiceSpec, description="The serial link to the head."
    )
    vision: ServiceSpec = Field(
        default_factory=ServiceSpec, description="Camera source and detector."
    )
    estimator: ServiceSpec = Field(
        default_factory=ServiceSpec, description="Ground-plane filter and prediction."
    )
    gaze: ServiceSpec = Field(
        default_factory=ServiceSpec, description="Saccade/pursuit state machine."
    )
    restart_max: int = Field(
        5,
        ge=1,
        le=1000,
        description="Restarts of one process within restart_window_s before the supervisor gives up.",
    )
    restart_window_s: float = Field(60.0, gt=0, description="Window of the restart intensity.")
    backoff_initial_s: float = Field(
        0.1, ge=0, le=60, description="First restart delay; doubles on each restart."
    )
    backoff_max_s: float = Field(10.0, gt=0, le=600, description="Longest restart delay.")
    stop_grace_s: float = Field(
        3.0, gt=0, le=120, description="SIGTERM to SIGKILL grace period on stop."
    )
    ready_timeout_s: float = Field(
        30.0,
        gt=0,
        le=600,
        description="A started process that shows no liveliness within this is restarted.",
    )

    def spec(self, name: str) -> ServiceSpec:
        return getattr(self, name)


class Rig(Section):
    rig: RigSection
    bus: BusSection = Field(default_factory=BusSection)
    camera: CameraSection = Field(default_factory=CameraSection)
    head: HeadSection = Field(default_factory=HeadSection)
    servo: ServoSection = Field(default_factory=lambda: PelcoDServo(protocol="pelco-d"))
    calibration: CalibrationSection = Field(default_factory=CalibrationSection)
    vision: VisionSection = Field(default_factory=VisionSection)
    estimator: EstimatorSection = Field(default_factory=EstimatorSection)
    gaze: GazeSection = Field(default_factory=GazeSection)
    sim: SimSection = Field(default_factory=SimSection)
    services: ServicesSection = Field(default_factory=ServicesSection)

    _source_path: Path | None = PrivateAttr(None)

    @property
    def source_path(self) -> Path | None:
        """The file this rig was loaded from (None for a rig built in code)."""
        return self._source_path

    @property
    def name(self) -> str:
        return self.rig.name

    def servo_params(self) -> dict[str, Any]:
        """The protocol-specific [servo] keys: the keyword arguments of `make_codec`."""
        return {
            k: v
            for k, v in self.servo.model_dump().items()
            if k not in SERVO_LINK_KEYS and k != "protocol"
        }


def sections_read_by(process: str) -> tuple[str, ...] | None:
    """Rig sections a process reads (besides rig/bus), or None if unknown (read everything)."""
    return SECTIONS_READ_BY.get(process)


class RigError(Exception):
    """A rig that cannot be loaded; `problems` holds one `FILE: KEY.PATH: …` line each."""

    def __init__(self, problems: list[str]) -> None:
        super().__init__("\n".join(problems))
        self.problems = problems


def load_rig(path: str | Path) -> Rig:
    """Read and validate a rig file; raises `RigError` listing every problem."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise RigError([f"{path}: cannot read: {exc.strerror or exc}"]) from exc
    except UnicodeDecodeError as exc:
        raise RigError([f"{path}: not UTF-8 text: {exc}"]) from exc
    return parse_rig(text, path)


def parse_rig(text: str, path: str | Path = "<rig>") -> Rig:
    """Validate rig TOML text; `path` names the file in errors and anchors relative paths."""
    path = Path(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RigError([f"{path}: TOML syntax error: {_syntax_message(exc)}"]) from exc
    except (RecursionError, ValueError) as exc:  # nested too deep, an integer too long for int()
        raise RigError([f"{path}: not a valid TOML document: {exc}"]) from exc
    try:
        rig = Rig.model_validate(data)
    except ValidationError as exc:
        raise RigError([f"{path}: {line}" for line in _describe_errors(exc, data)]) from exc
    relative = {
        key: path.parent / value
        for key in ("zenoh_config_path", "credentials_path")
        if (value := getattr(rig.bus, key)) is not None and not value.is_absolute()
    }
    if relative:
        rig = rig.model_copy(update={"bus": rig.bus.model_copy(update=relative)})
    rig._source_path = path
    return rig


def _syntax_message(exc: tomllib.TOMLDecodeError) -> str:
    """tomllib says '… (at line 3, column 7)'; keep that and make sure line/column are present."""
    message = str(exc)
    if re.search(r"line \d+, column \d+", message):
        return message
    lineno = getattr(exc, "lineno", None)
    colno = getattr(exc, "colno", None)
    return f"{message} (at line {lineno}, column {colno})"


def _describe_errors(exc: ValidationError, data: dict[str, Any]) -> list[str]:
    lines = []
    for error in exc.errors(include_url=False):
        loc = _strip_tags(error["loc"])
        kind = error["type"]
        if kind == "value_error":
            # cross-field checks name their key first: "pan_max_deg: must be above …"
            message = str(error["msg"]).removeprefix("Value error, ")
            key, sep, rest = message.partition(": ")
            if sep and re.fullmatch(r"[a-z_0-9]+", key):
                loc, message = (*loc, key), rest
            lines.append(f"{_key_path(loc)}: {message}")
            continue
        field = _field_at(loc, data)
        if kind == "extra_forbidden":
            parent = _model_at(loc[:-1], data)
            known = list(parent.model_fields) if parent is not None else []
            close = difflib.get_close_matches(str(loc[-1]), known, n=1, cutoff=0.6)
            hint = (
                f"did you mean '{close[0]}'?" if close else "expected one of: " + ", ".join(known)
            )
            lines.append(f"{_key_path(loc)}: unknown key ({hint})")
        elif kind == "missing":
            what = "missing item" if isinstance(loc[-1], int) else "missing required key"
            lines.append(f"{_key_path(loc)}: {what} (expected {_expected(field)})")
        elif kind in ("union_tag_invalid", "union_tag_not_found"):
            tags = ", ".join(repr(t) for t in _SERVO_MODELS)
            got = _value_at(data, (*loc, "protocol"))
            what = "missing" if kind == "union_tag_not_found" else f"unknown protocol {got!r}"
            lines.append(f"{_key_path(loc)}.protocol: {what} (expected one of {tags})")
        else:
            message = error["msg"][0].lower() + error["msg"][1:]
            got = error.get("input")
            lines.append(f"{_key_path(loc)}: {message}, got {got!r} (expected {_expected(field)})")
    return lines


def _key_path(loc: tuple[Any, ...]) -> str:
    """('calibration', 'homography', 0) -> 'calibration.homography[0]'."""
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "(top level)"


_SERVO_MODELS: dict[str, type[BaseModel]] = {
    get_args(m.model_fields["protocol"].annotation)[0]: m
    for m in get_args(get_args(ServoSection)[0])
}


def _strip_tags(loc: tuple[Any, ...]) -> tuple[Any, ...]:
    """Drop the discriminator tag pydantic inserts into locations (servo.pelco-d.address)."""
    if len(loc) >= 2 and loc[0] == "servo" and loc[1] in _SERVO_MODELS:
        return (loc[0], *loc[2:])
    return loc


def _model_at(loc: tuple[Any, ...], data: dict[str, Any]) -> type[BaseModel] | None:
    """The section model at a location; the servo union is resolved by the file's protocol."""
    model: Any = Rig
    for depth, part in enumerate(loc):
        if isinstance(part, int):
            continue
        if not (isinstance(model, type) and issubclass(model, BaseModel)):
            return None
        info = model.model_fields.get(str(part))
        if info is None:
            return None
        if model is Rig and part == "servo":
            protocol = _value_at(data, ("servo", "protocol"))
            model = _SERVO_MODELS.get(protocol, PelcoDServo) if depth == len(loc) - 1 else None
            if model is None:
                return None
            continue
        model = _model_of(info.annotation)
    return model if isinstance(model, type) and issubclass(model, BaseModel) else None


def _model_of(annotation: Any) -> Any:
    if get_origin(annotation) is Annotated:
        annotation = get_args(annotation)[0]
    models = [a for a in get_args(annotation) if isinstance(a, type) and issubclass(a, BaseModel)]
    return models[0] if models else annotation


def _field_at(loc: tuple[Any, ...], data: dict[str, Any]) -> FieldInfo | None:
    names = [p for p in loc if not isinstance(p, int)]
    if not names:
        return None
    parent_loc = loc[: len(loc) - loc[::-1].index(names[-1]) - 1]
    parent = _model_at(parent_loc, data)
    return parent.model_fields.get(str(names[-1])) if parent is not None else None


def _expected(field: FieldInfo | None) -> str:
    """A human description of what a field accepts: type, bounds, and its description."""
    if field is None:
        return "a valid value"
    bounds = []
    for meta in field.metadata:
        for attr, sign in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
            value = getattr(meta, attr, None)
            if value is not None:
                bounds.append(f"{sign} {value}")
    text = _type_name(field.annotation)
    if bounds:
        text += " " + " and ".join(bounds)
    if field.description:
        text += f" — {field.description}"
    return text


def _type_name(annotation: Any, plural: bool = False) -> str:
    origin = get_origin(annotation)
    if origin is Annotated:
        return _type_name(get_args(annotation)[0], plural)
    if origin is Literal:
        return "one of " + ", ".join(repr(a) for a in get_args(annotation))
    if origin in (list, tuple):
        args = [a for a in get_args(annotation) if a is not Ellipsis]
        count = f"{len(args)} " if origin is tuple else ""
        inner = _type_name(args[0], plural=True) if args else "values"
        return ("lists of " if plural else "a list of ") + count + inner
    args = get_args(annotation)
    if args:
        names = [_type_name(a, plural) for a in args if a is not type(None)]
        suffix = " (or omitted)" if type(None) in args else ""
        return " or ".join(names) + suffix
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return "tables" if plural else "a table"
    names = {
        bool: "true or false",
        int: "integer",
        float: "number",
        str: "string",
        Path: "file path",
    }
    name = names.get(annotation, getattr(annotation, "__name__", str(annotation)))
    if annotation is bool:
        return name
    return f"{name}s" if plural else f"a{'n' if name[0] in 'aeiou' else ''} {name}"


def _value_at(data: Any, loc: tuple[Any, ...]) -> Any:
    for part in loc:
        if isinstance(data, dict):
            data = data.get(part)
        else:
            return None
    return data
