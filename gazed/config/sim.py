"""`[sim]`: the simulated world: the target's trajectory, the true camera pose, the emulated
head and the rendered frames."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from gazed.config.section import Section

TRAJECTORY_NAMES = ("rounded-square", "oval", "stop-and-go", "figure-eight", "random")


class SimSection(Section):
    seed: int = Field(1, ge=0, description="Seed of everything random in the simulated world.")
    trajectory: str = Field(
        "oval",
        description="rounded-square, oval, stop-and-go, figure-eight, random, "
        "or file:PATH[#ped_id].",
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
    camera_delay_ms: float = Field(
        0.0,
        ge=0,
        le=2000,
        description="Hidden camera pipeline delay, not told to gazed: a frame is stamped when it "
        "arrives, this long after its exposure, then reaches the bus visual_latency_ms later; "
        "sim/truth keeps the exposure time.",
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
        description="Pixels of the published frames: colour, "
        "or grey (a third of the bytes on the bus; the detectors work on grey anyway).",
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
                    f"{key}: unknown trajectory {value!r} "
                    f"(expected one of {names} or file:PATH[#ped_id])"
                )
        return self
