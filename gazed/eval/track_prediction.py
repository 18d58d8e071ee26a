"""Prediction errors on recorded pedestrian tracks.

Every track of a file is filtered causally (position only, with optional added noise); at each
step the prediction to each horizon is compared with the recorded position then.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from gazed.config import EstimatorSection
from gazed.estimation import build_estimator
from gazed.eval.baselines import (
    ConstantPosition,
    ConstantVelocity,
    Positions,
    TwoPoint,
    fit_constant_velocity,
)
from gazed.eval.metrics import error_summary
from gazed.eval.pedestrians import Track, TrackFileError, read_tracks
from gazed.eval.progress import Steps, no_progress

DATA_FILTERS = ("imm", "cv", "ca", "alphabeta", "innovation")
BASELINES = ("constant-position", "two-point", "cv-ml")
# the coarsest rounding of the positions in the files read (the ETH/UCY files are written to the
# centimetre, the annotated truth finer): its variance, step²/12, is the floor under the noise an
# adapting filter learns (its prior is `position_noise_m`)
RESOLUTION_M = 0.01


class Predictor(Protocol):
    """What the error loop needs of a filter or a baseline: a batch of tracks stepped at once."""

    t_s: np.ndarray

    def step(self, t_s: np.ndarray, z: np.ndarray, present: np.ndarray) -> None: ...

    def forecast(self, t_s: np.ndarray) -> Positions: ...


class _Estimator:
    """A gazed estimator seen as a `Predictor`: every measurement with the covariance R."""

    def __init__(self, section: EstimatorSection, n: int, mode: str, R: np.ndarray) -> None:
        self._estimator = build_estimator(section, n_tracks=n, mode=mode)
        self._R = R

    @property
    def t_s(self) -> np.ndarray:
        return self._estimator.t_s

    def step(self, t_s: np.ndarray, z: np.ndarray, present: np.ndarray) -> None:
        self._estimator.step(t_s, z, self._R, present)

    def forecast(self, t_s: np.ndarray) -> Positions:
        f = self._estimator.forecast(t_s)
        return Positions(f.position, f.valid)


@dataclass(frozen=True)
class _Aligned:
    """The tracks of a file aligned by step index, NaN-padded: times (N, K), recorded positions
    and measurements (N, K, 2), lengths (N,)."""

    t: np.ndarray
    xy: np.ndarray
    z: np.ndarray
    length: np.ndarray


def _align(tracks: list[Track], noise_m: float, seed: int) -> _Aligned:
    n = len(tracks)
    length = np.array([len(tr.t_s) for tr in tracks])
    steps = int(length.max())
    t = np.full((n, steps), np.nan)
    xy = np.full((n, steps, 2), np.nan)
    for i, tr in enumerate(tracks):
        t[i, : length[i]] = tr.t_s
        xy[i, : length[i]] = tr.xy_m
    rng = np.random.default_rng(seed)
    z = xy + rng.normal(0.0, noise_m, xy.shape) if noise_m > 0 else xy
    return _Aligned(t, xy, z, length)


def _prediction_errors(
    predictor: Predictor,
    data: _Aligned,
    horizons_s: list[float],
    steps: Iterable[int] | None = None,
) -> dict[str, Any]:
    """Each track stepped causally (`steps`: the step indices, 0 to the longest track's
    length, by default a plain range); from its second measurement on, its forecast to every
    horizon the track still covers against the recorded position then."""
    t, xy, length = data.t, data.xy, data.length
    errors: dict[float, list[np.ndarray]] = {h: [] for h in horizons_s}
    for k in range(t.shape[1]) if steps is None else steps:
        present = k < length
        predictor.step(t[:, k], np.nan_to_num(data.z[:, k]), present)
        if k == 0:
            continue
        held = np.where(np.isfinite(predictor.t_s), predictor.t_s, 0.0)
        for h in horizons_s:
            target_t = t[:, k] + h
            truth, known = _recorded(t, xy, length, target_t)
            f = predictor.forecast(np.where(present, target_t, held))
            use = present & known & f.valid
            if use.any():
                errors[h].append(np.linalg.norm(f.position[use] - truth[use], axis=-1))
    return {
        "tracks": len(length),
        "points": int(length.sum()),
        "error_m": {
            f"{h:g}": error_summary(np.concatenate(errors[h]) if errors[h] else np.array([]))
            for h in horizons_s
        },
    }


def track_errors(
    section: EstimatorSection,
    tracks: list[Track],
    mode: str,
    horizons_s: list[float],
    noise_m: float,
    seed: int,
    steps: Steps = no_progress,
) -> dict[str, Any]:
    """All tracks filtered at once (one batch row per track, aligned by their step index)."""
    data = _align(tracks, noise_m, seed)
    n = len(tracks)
    known_m2 = noise_m**2 + RESOLUTION_M**2 / 12.0  # what is known of each measurement
    adapts = mode == "imm" and section.adapt_noise
    assumed_m2 = known_m2 if adapts else section.position_noise_m**2 + noise_m**2
    R = np.broadcast_to(np.eye(2) * assumed_m2, (n, 2, 2))
    estimator = _Estimator(section, n, mode, R)
    count = data.t.shape[1]
    return {"filter": mode, **_prediction_errors(estimator, data, horizons_s, steps(mode, count))}


def baseline_errors(
    tracks: list[Track],
    horizons_s: list[float],
    noise_m: float,
    seed: int,
    steps: Steps = no_progress,
    fit_tracks: list[Track] | None = None,
) -> dict[str, dict[str, Any]]:
    """The baselines on the same measurements, horizons and errors as the filters; `cv-ml`
    carries the q (m²/s³) and r (m²) fitted to `fit_tracks` (default: the scored tracks), with
    the same added noise."""
    data = _align(tracks, noise_m, seed)
    n = len(tracks)
    fit = data if fit_tracks is None else _align(fit_tracks, noise_m, seed + 1)
    q, r = fit_constant_velocity(fit.t, np.nan_to_num(fit.z), fit.length)
    predictors: dict[str, Predictor] = {
        "constant-position": ConstantPosition(n),
        "two-point": TwoPoint(n),
        "cv-ml": ConstantVelocity(n, q, r),
    }
    count = data.t.shape[1]
    results = {
        name: _prediction_errors(p, data, horizons_s, steps(name, count))
        for name, p in predictors.items()
    }
    results["cv-ml"].update(q=q, r=r)
    return results


def _recorded(
    t: np.ndarray, xy: np.ndarray, length: np.ndarray, target_t: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The recorded position of each track at target_t (linear between samples; rows of t are
    sorted, NaN-padded) and whether the track covers that time."""
    rows = np.arange(len(length))
    with np.errstate(invalid="ignore"):
        after = np.minimum(
            (t <= target_t[:, None] + 1e-9).sum(axis=1), length - 1
        )  # right neighbour
        before = np.maximum(after - 1, 0)
        t0, t1 = t[rows, before], t[rows, after]
        known = (t[:, 0] <= target_t) & (target_t <= t[rows, length - 1] + 1e-9)
        w = np.where(t1 > t0, (target_t - t0) / np.where(t1 > t0, t1 - t0, 1.0), 1.0)
    w = np.clip(np.nan_to_num(w), 0.0, 1.0)[:, None]
    return (1.0 - w) * xy[rows, before] + w * xy[rows, after], known


def halves(tracks: list[Track], half: int) -> tuple[list[Track], list[Track]]:
    """(half 1 or 2 of the tracks, the other half): the file's tracks in their order of first
    appearance taken alternately, so that both halves span the whole recording and share no
    walker."""
    if half not in (1, 2):
        raise ValueError(f"half must be 1 or 2, got {half}")
    return tracks[half - 1 :: 2], tracks[2 - half :: 2]


def data_report(
    section: EstimatorSection,
    path: Path,
    mode: str,
    horizons_s: list[float],
    noise_m: float,
    seed: int,
    steps: Steps = no_progress,
    half: int | None = None,
) -> dict[str, Any]:
    """The filter (or all of them, under "filters") scored on a file, with the baselines beside
    them under "baselines"; `steps` counts each predictor's steps (`progress`). With `half`
    (1 or 2) only that half of the tracks (`halves`) is scored and cv-ml is fitted to the other
    half: nothing fitted has seen the walkers scored."""
    tracks = read_tracks(path)
    head: dict[str, Any] = {"data": str(path), "noise_m": noise_m}
    fit_tracks = None
    if half is not None:
        tracks, fit_tracks = halves(tracks, half)
        if not tracks or not fit_tracks:
            raise TrackFileError(f"{path}: {len(tracks) + len(fit_tracks)} track(s), no halves")
        head["half"] = half
    fitted = baseline_errors(tracks, horizons_s, noise_m, seed, steps, fit_tracks)
    fitted["cv-ml"]["fitted_on"] = "the file" if half is None else "the other half"
    baselines = {"baselines": fitted}
    modes = DATA_FILTERS if mode == "all" else (mode,)
    results = {m: track_errors(section, tracks, m, horizons_s, noise_m, seed, steps) for m in modes}
    if mode == "all":
        return {**head, "tracks": len(tracks), "filters": results, **baselines}
    return {**head, **results[mode], **baselines}
