"""Messages of the `estimator` process: the tracks, the chosen target's filter state, its
prediction at the demand's effect, and the motion model's changes."""

from __future__ import annotations

from typing import ClassVar

from pydantic import BaseModel, ConfigDict, Field

from gazed.messages.base import Message


class TrackLook(BaseModel):
    """A track's appearance (gazed.estimation.appearance_model): the template of the colour
    histograms it has taken, and the gamma distribution its own movers' squared Hellinger
    distances h² to it follow."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)
    template: tuple[float, ...] = Field(
        min_length=2, max_length=64, description="Normalised, as a mover's `appearance`."
    )
    h2_mean: float = Field(gt=0, description="The mean h² of its own movers to the template.")
    h2_shape: float = Field(gt=0, description="Their gamma distribution's shape.")


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
    ground_velocity_cov_m2_s2: tuple[tuple[float, float], tuple[float, float]] | None = Field(
        None, description="The velocity's covariance."
    )
    ground_position_velocity_cov_m2_s: tuple[tuple[float, float], tuple[float, float]] | None = (
        Field(None, description="The covariance of position (rows) and velocity (columns).")
    )
    age_s: float = Field(ge=0, description="Since the track began.")
    hits: int = Field(ge=0, description="Detections it has taken.")
    coasting: bool = Field(False, description="No detection of it in this frame.")
    box_height_px: float = Field(0.0, ge=0, description="Its last box's height.")
    most_likely: str = ""
    look: TrackLook | None = Field(None, description="None: no mover of it had an appearance.")


class EstimatorState(Message):
    """The filter after a detection or a coasting step: combined state, covariance, model
    probabilities and the target on the ground (the chosen track's, `target_id`), and every
    track. Version 2 adds `tracks` and `target_id`; version 3 the tracks' velocity covariances;
    version 4 their appearance (`Track.look`)."""

    SCHEMA: ClassVar[str] = "gazed.EstimatorState"
    VERSION: ClassVar[int] = 4
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
