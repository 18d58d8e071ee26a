"""One factory: the rig's `[estimator]` section -> the filter of its mode.

Modes of the rig: `imm`, `innovation`, `alphabeta`, `image-cv`. For evaluation, `cv` and `ca`
build the innovation mode's single linear filters on their own.
"""

from __future__ import annotations

from typing import Any

from gazed.config import EstimatorSection
from gazed.estimation.alphabeta import AlphaBetaEstimator
from gazed.estimation.estimator import TrackEstimator
from gazed.estimation.ground_imm import ImmEstimator
from gazed.estimation.ground_models import cd, cs, csd
from gazed.estimation.imm import switching_matrix
from gazed.estimation.kinematic_estimator import KinematicEstimator
from gazed.estimation.kinematic_models import kinematic_model
from gazed.estimation.noise_adaptation import NoiseAdaptation

FILTER_MODES = ("imm", "innovation", "alphabeta", "image-cv", "cv", "ca")


def noise_adaptation(section: EstimatorSection, n_tracks: int) -> NoiseAdaptation:
    """The IMM's per-track noise adaptation of the section, for n_tracks tracks."""
    return NoiseAdaptation(
        n_tracks,
        prior_variance_m2=section.position_noise_m**2,
        prior_obs=section.noise_prior_obs,
        window_obs=section.noise_window_obs,
        scale_max=section.process_noise_scale_max,
    )


def build_estimator(
    section: EstimatorSection, n_tracks: int = 1, mode: str | None = None
) -> TrackEstimator:
    """The estimator of `mode` (default: the section's `filter`) for n_tracks tracks."""
    mode = section.filter if mode is None else mode
    e = section
    track: dict[str, Any] = {
        "gate_probability": e.gate_probability,
        "reinit_after_misses": e.reinit_after_misses,
        "coast_max_s": e.coast_max_ms / 1000.0,
        "initial_speed_std": e.initial_speed_std_m_s,
    }
    if mode == "imm":
        models = (
            csd(e.csd_speed_rate_noise_m_s2**2, e.csd_turn_rate_noise_rad_s**2),
            cs(e.cs_speed_rate_noise_m_s2**2, e.cs_turn_accel_noise_rad_s2**2),
            cd(e.cd_jerk_noise_m_s3**2, e.cd_turn_rate_noise_rad_s**2),
        )
        return ImmEstimator(
            models,
            switching_matrix(e.stay_probability, len(models)),
            n_tracks,
            initial_rate_std=(e.csd_speed_rate_noise_m_s2, e.csd_turn_rate_noise_rad_s),
            adaptation=noise_adaptation(e, n_tracks) if e.adapt_noise else None,
            **track,
        )
    if mode == "alphabeta":
        return AlphaBetaEstimator(n_tracks, smoothing=e.alphabeta_smoothing, **track)
    kinematic = {
        "CP": kinematic_model("CP", e.cp_velocity_noise_m_s**2),
        "CV": kinematic_model("CV", e.cv_accel_noise_m_s2**2),
        "CA": kinematic_model("CA", e.ca_jerk_noise_m_s3**2),
    }
    if mode == "innovation":
        return KinematicEstimator(
            tuple(kinematic.values()),
            n_tracks,
            filter_name=mode,
            initial_acceleration_std=e.cv_accel_noise_m_s2,
            selection_window=e.selection_window,
            consistency_probability=e.consistency_probability,
            **track,
        )
    if mode in ("cv", "ca"):
        return KinematicEstimator(
            (kinematic[mode.upper()],),
            n_tracks,
            filter_name=mode,
            initial_acceleration_std=e.cv_accel_noise_m_s2,
            **track,
        )
    if mode == "image-cv":
        return KinematicEstimator(
            (kinematic_model("CV", e.image_cv_accel_noise_rad_s2**2),),
            n_tracks,
            filter_name=mode,
            space="gaze",
            **track,
        )
    raise ValueError(f"unknown filter mode {mode!r} (expected one of {', '.join(FILTER_MODES)})")
