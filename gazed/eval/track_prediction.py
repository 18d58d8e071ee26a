"""Prediction errors on recorded pedestrian tracks.

Every track of a file is filtered causally (position only, with optional added noise); at each
step the prediction to each horizon is compared with the recorded position then.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from gazed.config import EstimatorSection
from gazed.estimation import build_estimator
from gazed.eval.metrics import error_summary
from gazed.eval.pedestrians import Track, read_tracks

DATA_FILTERS = ("imm", "cv", "ca", "alphabeta", "innovation")


def track_errors(
    section: EstimatorSection,
    tracks: list[Track],
    mode: str,
    horizons_s: list[float],
    noise_m: float,
    seed: int,
) -> dict[str, Any]:
    """All tracks filtered at once (one batch row per track, aligned by their step index)."""
    n = len(tracks)
    estimator = build_estimator(section, n_tracks=n, mode=mode)
    rng = np.random.default_rng(seed)
    length = np.array([len(tr.t_s) for tr in tracks])
    steps = int(length.max())
    t = np.full((n, steps), np.nan)
    xy = np.full((n, steps, 2), np.nan)
    for i, tr in enumerate(tracks):
        t[i, : length[i]] = tr.t_s
        xy[i, : length[i]] = tr.xy_m
    z = xy + rng.normal(0.0, noise_m, xy.shape) if noise_m > 0 else xy
    R = np.broadcast_to(np.eye(2) * (section.position_noise_m**2 + noise_m**2), (n, 2, 2))
    errors: dict[float, list[np.ndarray]] = {h: [] for h in horizons_s}
    for k in range(steps):
        present = k < length
        estimator.step(t[:, k], np.nan_to_num(z[:, k]), R, present)
        if k == 0:
            continue
        for h in horizons_s:
            target_t = t[:, k] + h
            truth, known = _recorded(t, xy, length, target_t)
            use = (
                present
                & known
                & estimator.forecast(np.where(present, target_t, estimator.t_s)).valid
            )
            if not use.any():
                continue
            f = estimator.forecast(
                np.where(use, target_t, np.where(np.isfinite(estimator.t_s), estimator.t_s, 0.0))
            )
            errors[h].append(np.linalg.norm(f.position[use] - truth[use], axis=-1))
    return {
        "filter": mode,
        "tracks": n,
        "points": int(length.sum()),
        "error_m": {
            f"{h:g}": error_summary(np.concatenate(errors[h]) if errors[h] else np.array([]))
            for h in horizons_s
        },
    }


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


def data_report(
    section: EstimatorSection,
    path: Path,
    mode: str,
    horizons_s: list[float],
    noise_m: float,
    seed: int,
) -> dict[str, Any]:
    tracks = read_tracks(path)
    if mode == "all":
        results = {
            m: track_errors(section, tracks, m, horizons_s, noise_m, seed) for m in DATA_FILTERS
        }
        return {"data": str(path), "noise_m": noise_m, "tracks": len(tracks), "filters": results}
    return {
        "data": str(path),
        "noise_m": noise_m,
        **track_errors(section, tracks, mode, horizons_s, noise_m, seed),
    }
