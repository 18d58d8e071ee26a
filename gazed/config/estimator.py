"""`[estimator]`: the filter mode, its noises, gating and the prediction over the latency."""

from __future__ import annotations

from typing import Literal, Self

from pydantic import Field, field_validator, model_validator

from gazed.config.section import Section


class EstimatorSection(Section):
    filter: Literal["imm", "innovation", "alphabeta", "image-cv"] = Field(
        "imm",
        description="'imm' CSD/CS/CD EKFs on the ground plane; 'innovation' CP/CV/CA selection; "
        "'alphabeta' adaptive alpha-beta; "
        "'image-cv' constant velocity on gaze angles (2D baseline).",
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
        description="Std of a ground-plane position measurement where nothing better is known: "
        "the prior of the IMM's adapted position noise, and the annotation noise assumed by "
        "`gazed eval estimator --data` for the modes that do not adapt.",
    )
    # the IMM's noise adaptation (gazed/estimation/noise_adaptation.py)
    adapt_noise: bool = Field(
        False,
        description="IMM: each track learns its position noise (position_noise_m as the prior, "
        "the measurement's own covariance as a floor) and a common scale on its process noises "
        "from its own innovations. Off by default: it follows clean tracks far better, but in "
        "the closed loop it takes maneuvers for noise (docs/estimation.md).",
    )
    noise_window_obs: float = Field(
        25.0,
        ge=2,
        le=10000,
        description="Noise adaptation: the fading window in observations (a noise estimate from "
        "25 observations of two axes has a relative std near 1/sqrt(25) = 20 %).",
    )
    noise_prior_obs: float = Field(
        5.0,
        gt=0,
        le=10000,
        description="Noise adaptation: the prior's weight in observations.",
    )
    process_noise_scale_max: float = Field(
        10.0,
        ge=1,
        le=1000,
        description="Noise adaptation: the process-noise scale stays within [1/this, this].",
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
    mover_extent_noise: tuple[float, float] = Field(
        (0.0, 0.0),
        description="Std a mover's point adds on each image axis (u, v), as a fraction of its "
        "box's extent on that axis, for most movers (the core of a two-Gaussian scale mixture, "
        "with mover_extent_tail): added in quadrature to pixel_noise_px. 0: the detector's point "
        "is as precise as pixel_noise_px says (the sim's); a rig measures its own walkers' with "
        "tests/bench/mover_extent.py (docs/estimation.md).",
    )
    mover_extent_tail: tuple[float, float] = Field(
        (0.0, 0.0),
        description="The same fraction (u, v) for the few movers whose mask splits, merges or "
        "shows a part of its person (the mixture's tail, of weight mover_extent_tail_weight).",
    )
    mover_extent_tail_weight: float = Field(
        0.0,
        ge=0,
        lt=0.5,
        description="The share of movers whose point is off by the tail's fraction (0: every "
        "mover by mover_extent_noise alone, a single Gaussian).",
    )
    split_probability: float = Field(
        1.0,
        gt=0,
        le=1,
        description="The chance that the detector reports two movers near one person in a frame "
        "(a part, a shadow or a ghost beside them), which two tracks of that person may each "
        "take. Two tracks that took movers in the same n frames are one person only where the "
        "chance of such a run (this, then split_continues_probability for each further frame) "
        "times the chance of their movers lying as far apart is at least 1 - gate_probability. "
        "1 (with split_continues_probability 1): how often they did says nothing; a rig "
        "measures its own with tests/bench/pets_movers.py (docs/estimation.md).",
    )
    split_continues_probability: float = Field(
        1.0,
        gt=0,
        le=1,
        description="The chance that two movers near one person in a frame are followed by two "
        "again in the next (a split persists), measured with split_probability.",
    )
    pixel_rate_noise_px_s: float = Field(
        10.0,
        gt=0,
        le=100000,
        description="Std of a detection's independent image velocity (the flow detector's, "
        "measured against the truth by tests/bench/detection_noise.py; docs/estimation.md).",
    )
    predict_over_latency: bool = Field(
        True,
        description="Predict to the instant the demand acts; "
        "false predicts to the measurement's own time "
        "(no latency compensation: the baseline `gazed eval loop --filter none` compares against).",
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
    # -- several people: track management (Blackman & Popoli 1999, §3.2: M-of-N confirmation)
    confirm_hits: int = Field(
        3,
        ge=1,
        le=100,
        description="A new track is confirmed (a person, not clutter) once it has taken this many "
        "detections within its first `confirm_frames` frames (M of N); a track that cannot is "
        "dropped. Tracks end after coasting past `coast_max_ms`.",
    )
    confirm_frames: int = Field(
        5,
        ge=1,
        le=100,
        description="The window of frames, from a track's first detection, in which it must reach "
        "`confirm_hits`.",
    )

    @field_validator("mover_extent_noise", "mover_extent_tail")
    @classmethod
    def _fractions(cls, value: tuple[float, float]) -> tuple[float, float]:
        if not all(0.0 <= f <= 1.0 for f in value):
            raise ValueError(f"a share of a box's extent lies in [0, 1], got {value}")
        return value

    @model_validator(mode="after")
    def _tail_is_wider(self) -> Self:
        if self.mover_extent_tail_weight > 0 and any(
            t < c for t, c in zip(self.mover_extent_tail, self.mover_extent_noise, strict=True)
        ):
            raise ValueError(
                f"mover_extent_tail {self.mover_extent_tail} is the mixture's wide component: "
                f"at least mover_extent_noise {self.mover_extent_noise} on each axis"
            )
        return self

    @model_validator(mode="after")
    def _confirmation_fits(self) -> Self:
        if self.confirm_hits > self.confirm_frames:
            raise ValueError(
                f"confirm_hits ({self.confirm_hits}) must not exceed confirm_frames "
                f"({self.confirm_frames})"
            )
        return self
