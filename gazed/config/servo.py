"""`[servo]`: the serial link and, chosen by `protocol`, the protocol's own keys."""

from __future__ import annotations

from typing import Annotated, Literal, get_args

from pydantic import BaseModel, Field, model_validator

from gazed.config.section import Section

SPEED_PROTOCOLS = ("pelco-d", "visca", "onvif")


class ServoLink(Section):
    """Keys shared by every protocol: the serial link and the servo process's timing."""

    port: str = Field(
        "/tmp/gazed-sim-head",
        description="pyserial URL: /dev/ttyUSB0, a pty path, socket://host:port, spy://…, "
        "loop://; or visca-udp://host:52381 (VISCA over IP, protocol visca only); "
        "onvif://host:port (an ONVIF camera, protocol onvif only).",
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
    mode: Literal["position", "speed"] = Field(
        "position",
        description="position: set-points as absolute moves; speed (pelco-d, visca, onvif): "
        "speed commands (Pelco-D drive, VISCA Pan-tiltDrive, ONVIF ContinuousMove) at the "
        "demand's rate plus a term on the position error. An ONVIF camera without absolute "
        "moves is driven by speed whatever this says.",
    )
    pan_speed_steps_deg_s: list[float] = Field(
        default_factory=list,
        description="Speed mode: the pan rate of each speed step 1..N, step k being k/N of the "
        "fastest speed command (`gazed calibrate speeds` measures it); empty: even steps up to "
        "pan_speed_max_deg_s (as many as the protocol's speed codes, 32 for ONVIF).",
    )
    tilt_speed_steps_deg_s: list[float] = Field(
        default_factory=list, description="Speed mode: the tilt rate of each speed step."
    )
    speed_latency_ms: float = Field(
        100.0,
        ge=0,
        le=2000,
        description="Speed mode: how long after a speed command the head acts on it "
        "(`gazed calibrate speeds` measures it; too long costs less than too short).",
    )

    @model_validator(mode="after")
    def _speed_mode(self) -> ServoLink:
        protocol = getattr(self, "protocol", "")
        if self.mode == "speed" and protocol not in SPEED_PROTOCOLS:
            raise ValueError(f"mode: {protocol} heads take no speed commands (position only)")
        for key in ("pan_speed_steps_deg_s", "tilt_speed_steps_deg_s"):
            steps = getattr(self, key)
            if any(b <= a for a, b in zip([0.0, *steps], steps, strict=False)):
                raise ValueError(f"{key}: expected positive rates rising with the step")
        return self

    @model_validator(mode="after")
    def _port_fits_protocol(self) -> ServoLink:
        if self.port.startswith("visca-udp://") and getattr(self, "protocol", "visca") != "visca":
            raise ValueError('port: visca-udp:// carries VISCA only (set protocol = "visca")')
        if self.port.startswith("onvif://") != (getattr(self, "protocol", "") == "onvif"):
            raise ValueError(
                'port: an ONVIF camera takes onvif://host:port with protocol = "onvif"'
            )
        return self


class PelcoDServo(ServoLink):
    protocol: Literal["pelco-d"] = Field(
        description="Pelco-D over RS-485 with extended position commands."
    )
    address: int = Field(1, ge=1, le=255, description="Receiver address of the camera.")
    position_feedback: bool = Field(
        True,
        description="The unit answers the 0x51/0x53 position queries; "
        "otherwise odometry is dead-reckoned.",
    )
    pan_speed_max_deg_s: float = Field(
        120.0, gt=0, le=3600, description="Pan rate of drive speed 0x3F (speeds map linearly)."
    )
    tilt_speed_max_deg_s: float = Field(
        90.0, gt=0, le=3600, description="Tilt rate of drive speed 0x3F (speeds map linearly)."
    )
    zoom_max_units: int = Field(
        65535,
        ge=1,
        le=65535,
        description="Zoom position (0x4F/0x5D) of the longest zoom: 65535 on units that scale "
        "the position to their zoom limit; others count lens steps (see the camera's manual).",
    )


class ViscaServo(ServoLink):
    protocol: Literal["visca"] = Field(description="Sony VISCA over RS-232/422.")
    address: int = Field(1, ge=1, le=7, description="Camera address on the VISCA chain.")
    pan_deg_per_unit: float = Field(0.075, gt=0, description="Degrees per VISCA pan position unit.")
    tilt_deg_per_unit: float = Field(
        0.075, gt=0, description="Degrees per VISCA tilt position unit."
    )
    pan_speed_max_code: int = Field(
        0x18, ge=1, le=0x7F, description="Highest pan speed byte the camera takes (24 = 0x18)."
    )
    tilt_speed_max_code: int = Field(
        0x14,
        ge=1,
        le=0x7F,
        description="Highest tilt speed byte the camera takes (20 = 0x14; Sony SRG-X400 23).",
    )
    pan_speed: int = Field(
        24, ge=1, description="Pan speed byte of absolute moves (1..pan_speed_max_code)."
    )
    tilt_speed: int = Field(
        20, ge=1, description="Tilt speed byte of absolute moves (1..tilt_speed_max_code)."
    )
    pan_speed_max_deg_s: float = Field(
        120.0,
        gt=0,
        le=3600,
        description="Pan rate of the highest speed byte (speeds map linearly).",
    )
    zoom_max_units: int = Field(
        0x4000,
        ge=1,
        le=0x7FFF,
        description="CAM_Zoom position of the longest zoom the rig uses (0 is the widest): "
        "16384 (0x4000) is the optical telephoto end of most Sony models; a camera with digital "
        "zoom goes beyond it (see its manual's zoom table).",
    )
    tilt_speed_max_deg_s: float = Field(
        90.0,
        gt=0,
        le=3600,
        description="Tilt rate of the highest speed byte (speeds map linearly).",
    )

    @model_validator(mode="after")
    def _speeds_in_range(self) -> ViscaServo:
        if self.pan_speed > self.pan_speed_max_code:
            raise ValueError(f"pan_speed: above pan_speed_max_code {self.pan_speed_max_code}")
        if self.tilt_speed > self.tilt_speed_max_code:
            raise ValueError(f"tilt_speed: above tilt_speed_max_code {self.tilt_speed_max_code}")
        return self


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


class DigitalServo(ServoLink):
    protocol: Literal["digital"] = Field(
        description="A digital pan/tilt head: the view of `[camera]` rendered from the fixed "
        "wide camera of `[wide]`; no serial port (port and baud are unused)."
    )
    port: str = Field("digital", description="Unused by the digital head: a name for status.")
    latency_ms: float = Field(
        50.0, ge=0, le=2000, description="How long after a set-point the view starts to move."
    )


class OnvifServo(ServoLink):
    """An ONVIF PTZ camera (Profile S): WS-Security UsernameToken, the password from a file or
    an environment variable, never in the rig."""

    protocol: Literal["onvif"] = Field(description="An ONVIF PTZ camera over HTTP/SOAP.")
    port: str = Field(
        "onvif://127.0.0.1:8899",
        pattern=r"^onvif://[^/:]+:[0-9]+$",
        description="onvif://host:port of the camera's device service.",
    )
    device_path: str = Field(
        "/onvif/device_service", description="Path of the camera's device service."
    )
    username: str = Field("admin", description="ONVIF user (WS-Security UsernameToken).")
    password_file: str | None = Field(
        None, description="File holding the ONVIF password (first line); readable by gazed only."
    )
    password_env: str = Field(
        "GAZED_ONVIF_PASSWORD",
        description="Environment variable holding the password when password_file is not set.",
    )
    profile: str | None = Field(
        None, description="Media profile token to drive (default: the first with a PTZ node)."
    )
    pan_range_deg: tuple[float, float] = Field(
        (-180.0, 180.0),
        description="Pan in degrees at the two ends of the camera's absolute pan range "
        "(its generic space, usually -1 and 1); measure with `gazed servo jog`.",
    )
    tilt_range_deg: tuple[float, float] = Field(
        (-90.0, 90.0),
        description="Tilt in degrees at the two ends of the camera's absolute tilt range.",
    )
    pan_speed_max_deg_s: float = Field(
        120.0, gt=0, le=3600, description="Pan rate at velocity 1 (ContinuousMove)."
    )
    tilt_speed_max_deg_s: float = Field(
        90.0, gt=0, le=3600, description="Tilt rate at velocity 1 (ContinuousMove)."
    )
    park_preset: str | None = Field(
        None, description="Preset token to go to on stop instead of [head] park angles."
    )

    @model_validator(mode="after")
    def _ranges(self) -> OnvifServo:
        for key in ("pan_range_deg", "tilt_range_deg"):
            low, high = getattr(self, key)
            if low == high:
                raise ValueError(f"{key}: both ends are {low} (expected two different angles)")
        return self


ServoSection = Annotated[
    PelcoDServo | ViscaServo | FlirPtuServo | DynamixelServo | DigitalServo | OnvifServo,
    Field(discriminator="protocol"),
]
SERVO_LINK_KEYS = frozenset(ServoLink.model_fields)
# protocol name -> its section model
SERVO_MODELS: dict[str, type[BaseModel]] = {
    get_args(m.model_fields["protocol"].annotation)[0]: m
    for m in get_args(get_args(ServoSection)[0])
}
