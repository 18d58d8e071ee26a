"""`[head]`: the axis order, the device's angle conventions, the joint limits and the park pose."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, model_validator

from gazed.config.section import Section


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
    zoom_rate_max_s: float = Field(
        0.5,
        gt=0,
        le=100,
        description="Zoom speed limit as a fraction of the zoom range per second (a head with a "
        "zoom lens: [camera] zoom_focal_px).",
    )
    park_pan_deg: float = Field(0.0, description="Pan the head returns to when parked.")
    park_tilt_deg: float = Field(0.0, description="Tilt the head returns to when parked.")
    angle_noise_deg: float = Field(
        0.05,
        gt=0,
        le=10,
        description="Std of the joint angles the head reports (encoder resolution, backlash); "
        "propagated to the ground-plane measurement's covariance, and the misregistration the "
        "flow detector registers its fovea within.",
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
                "park_pan_deg: outside the pan limits "
                "(expected pan_min_deg <= park_pan_deg <= pan_max_deg)"
            )
        if not self.tilt_min_deg <= self.park_tilt_deg <= self.tilt_max_deg:
            raise ValueError(
                "park_tilt_deg: outside the tilt limits "
                "(expected tilt_min_deg <= park_tilt_deg <= tilt_max_deg)"
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
