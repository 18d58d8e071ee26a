"""The whole rig description: `[rig]` and one model per section."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import Field, PrivateAttr, model_validator

from gazed.config.bus import BusSection
from gazed.config.calibration import CalibrationSection
from gazed.config.camera import CameraSection
from gazed.config.estimator import EstimatorSection
from gazed.config.gaze import GazeSection
from gazed.config.head import HeadSection
from gazed.config.section import Section
from gazed.config.services import ServicesSection
from gazed.config.servo import SERVO_LINK_KEYS, PelcoDServo, ServoSection
from gazed.config.sim import SimSection
from gazed.config.view import ViewSection
from gazed.config.vision import VisionSection
from gazed.config.wide import WideSection


class RigSection(Section):
    name: str = Field(
        pattern=r"^[A-Za-z0-9_-]+$",
        description="Rig name; every bus key is gazed/<name>/..., so two rigs can share a bus.",
    )
    description: str = Field(
        "", description="Free text for people: where the rig is, what it watches."
    )


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
    wide: WideSection = Field(default_factory=WideSection)
    view: ViewSection = Field(default_factory=ViewSection)

    _source_path: Path | None = PrivateAttr(None)

    @model_validator(mode="after")
    def _zoom_control_needs_a_zoom_lens(self) -> Rig:
        if self.gaze.zoom_control and not self.camera.zoom_focal_px:
            raise ValueError("gaze.zoom_control: needs a zoom lens ([camera] zoom_focal_px)")
        return self

    @property
    def source_path(self) -> Path | None:
        """The file this rig was loaded from (None for a rig built in code)."""
        return self._source_path

    @property
    def wide_source(self) -> str | None:
        """`[wide] source` with a relative file path taken from the rig file's folder."""
        folder = self.source_path.parent if self.source_path is not None else Path.cwd()
        return self.wide.source_in(folder)

    @property
    def pose_noise_rad(self) -> float:
        """The std of the head pose a frame is registered through: `[head] angle_noise_deg`,
        none for a digital head (its view is rendered at the pose it reports)."""
        return 0.0 if self.servo.protocol == "digital" else self.head.angle_noise_rad

    @property
    def serves_view(self) -> bool:
        """The file has a `[view]`: `gazed run` serves the live view."""
        return "view" in self.model_fields_set

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
