"""`[vision]`: the detector, ego-motion compensation, candidates and line tracing."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, model_validator

from gazed.config.section import Section


class VisionSection(Section):
    detector: Literal["flow", "pyramid", "background"] = Field(
        "flow",
        description="'flow' foveal normal flow, 'pyramid' motion-energy pyramid, "
        "'background' subtraction.",
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
    background_shadows: bool = Field(
        True,
        description="background, on a colour frame (a digital head's wide camera): cast "
        "shadows are left out of the silhouettes (MOG2's shadow test; a shadow pixel is kept "
        "only where it joins a silhouette within its columns). A grey frame keeps them.",
    )
    background_ghosts: bool = Field(
        True,
        description="background: a silhouette (a blob, or each body split from one) whose "
        "outline is an edge of the model's background image rather than of the frame (a "
        "ghost: where someone stood while the model learnt the scene, now bare ground) is left out "
        "of the silhouettes and learnt as the scene rather than held out as a stopped walker is.",
    )
    background_learning_frames: int = Field(
        10,
        ge=0,
        le=10000,
        description="background: frames learnt after a reset before anything is reported; "
        "from 3 of them, the people passing through them are left out (docs/vision.md).",
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
