"""A run's series from the estimator alone, as `gazed eval estimator` runs it: a seeded scenario
(rounded-square with the IMM, kelly with the innovation mode) or the track of a pedestrian
file that walks furthest, filtered causally; at each step the estimate, the prediction `horizon_s`
ahead and the model probabilities."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gazed.config import EstimatorSection
from gazed.estimation import Measurement, build_estimator
from gazed.eval.pedestrians import read_tracks
from gazed.eval.scenarios import kelly, rounded_square
from gazed.plots.series import RunSeries, points

SCENARIO_MODES = {"rounded-square": "imm", "kelly": "innovation"}


def scenario_series(
    section: EstimatorSection,
    scenario: str,
    seed: int,
    noise_m: float | None,
    velocity_noise_m_s: float | None,
    horizon_s: float,
) -> RunSeries:
    """The series of a seeded scenario, with the measurements `gazed eval estimator` gives it."""
    if scenario == "rounded-square":
        noises = {"position_noise_m": noise_m, "velocity_noise_m_s": velocity_noise_m_s}
        motion = rounded_square(seed, **{k: v for k, v in noises.items() if v is not None})
        velocities = motion.z_velocity
    else:
        motion = kelly(seed, position_noise_m=0.01 if noise_m is None else noise_m)
        velocities = None
    mode = SCENARIO_MODES[scenario]
    return _filtered(
        f"{scenario} ({mode})",
        section,
        mode,
        motion.t_s,
        motion.z_position,
        motion.position_noise_m**2,
        velocities,
        motion.velocity_noise_m_s**2,
        motion.truth[:, :2],
        horizon_s,
    )


def track_file_series(
    section: EstimatorSection, path: Path, mode: str, noise_m: float, seed: int, horizon_s: float
) -> RunSeries:
    """The series of the file's track that walks furthest (position only, `noise_m` of noise
    added)."""
    track = max(
        read_tracks(path),
        key=lambda t: float(np.linalg.norm(np.diff(t.xy_m, axis=0), axis=1).sum()),
    )
    rng = np.random.default_rng(seed)
    z = track.xy_m + rng.normal(0.0, noise_m, track.xy_m.shape) if noise_m > 0 else track.xy_m
    variance = section.position_noise_m**2 + noise_m**2
    title = f"pedestrian {track.ped_id:g} ({mode})"
    return _filtered(title, section, mode, track.t_s, z, variance, None, 0.0, track.xy_m, horizon_s)


def _filtered(
    title: str,
    section: EstimatorSection,
    mode: str,
    t_s: np.ndarray,
    z_m: np.ndarray,
    variance_m2: float,
    velocities_m_s: np.ndarray | None,
    velocity_variance: float,
    truth_xy_m: np.ndarray,
    horizon_s: float,
) -> RunSeries:
    estimator = build_estimator(section, mode=mode)
    R = np.eye(2) * variance_m2
    estimates, predictions, times, probabilities = [], [], [], []
    for k, t in enumerate(t_s):
        velocity = None if velocities_m_s is None else velocities_m_s[k]
        Rv = None if velocity is None else np.eye(2) * velocity_variance
        estimator.update(Measurement.ground(float(t), z_m[k], R, velocity, Rv))
        now = estimator.predict(float(t))
        ahead = estimator.predict(float(t) + horizon_s)
        if now is None or ahead is None:
            continue
        estimates.append(tuple(now.position))
        predictions.append(tuple(ahead.position))
        times.append(float(t - t_s[0]))
        probabilities.append(estimator.model_probabilities())
    run = RunSeries(title, truth_xy_m=np.asarray(truth_xy_m, dtype=float))
    run.estimate_xy_m = points(estimates)
    run.prediction_xy_m = points(predictions)
    run.prediction_horizon_s = horizon_s
    if probabilities:
        run.model_t_s = np.array(times)
        run.model_probabilities = {
            name: np.array([p[name] for p in probabilities]) for name in probabilities[0]
        }
    return run
