"""Peripheral candidates: where else in the frame something moves, for the gaze's saccades.

Seed 000 §2 (after [3]): "a similar motion process running at coarse scale across the entire
image [that] distinguishes between different regions using magnitude of motion, direction of
motion, and area of the moving region". Here: the ego-compensated motion-energy pyramid (see
`motion_energy`) at a coarse level, its active pixels grouped into 8-connected regions, each
region's centroid, area and energy (summed |L0| in grey levels, per level-0 pixel), and its
velocity, the slope of its recent centroids over up to `VELOCITY_POINTS` frames, matched frame
to frame (`RegionTracks`). A saccade aims with it over the visual latency and the move, and
misses by its error times their duration (`tests/bench/saccade_aim.py` measures the aim).

The interest value is hand-coded, as in the paper: each region's share of the frame's total
energy, area and speed, averaged — `score = (e/Σe + a/Σa + s/Σs) / 3` over the terms with a
non-zero total — so scores rank the regions of one frame and sum to at most 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from gazed.vision.detector import FramePair
from gazed.vision.motion_energy import UNITS_PER_GREY
from gazed.vision.region_tracks import RegionTracks

VELOCITY_POINTS = 6  # a region's centroids its velocity is fitted to


@dataclass(frozen=True)
class MotionRegion:
    """One candidate (level-0 pixels, px/s)."""

    u_px: float
    v_px: float
    du_px_s: float
    dv_px_s: float
    area_px: float
    energy: float
    score: float

    @property
    def speed_px_s(self) -> float:
        return float(np.hypot(self.du_px_s, self.dv_px_s))


class CandidateFinder:
    def __init__(
        self, *, level: int, energy_threshold: float, min_area_px: float, max_count: int
    ) -> None:
        self.level = level
        self.energy_threshold = energy_threshold * UNITS_PER_GREY  # in the pyramid's units
        self.min_area_px = min_area_px
        self.max_count = max_count
        self._tracks = RegionTracks(VELOCITY_POINTS)

    def reset(self) -> None:
        self._tracks.reset()

    def find(self, pair: FramePair) -> list[MotionRegion]:
        """The frame's moving regions, best first (at most `max_count`)."""
        if pair.energy is None:
            self.reset()
            return []
        level = min(self.level, len(pair.energy) - 1)
        energy = pair.energy[level]
        scale = 1 << level
        active = (energy > self.energy_threshold).astype(np.uint8)
        count, labels, stats, _ = cv2.connectedComponentsWithStats(active, connectivity=8)
        if count <= 1:
            self.reset()
            return []
        sums = np.bincount(labels.ravel(), weights=energy.ravel(), minlength=count)
        ys, xs = np.indices(energy.shape)
        su = np.bincount(labels.ravel(), weights=(energy * xs).ravel(), minlength=count)
        sv = np.bincount(labels.ravel(), weights=(energy * ys).ravel(), minlength=count)
        found = []
        for i in range(1, count):
            area = float(stats[i, cv2.CC_STAT_AREA] * scale * scale)
            if area < self.min_area_px:
                continue
            u, v = su[i] / sums[i] * scale, sv[i] / sums[i] * scale
            found.append((u, v, area, float(sums[i] * scale * scale) / UNITS_PER_GREY))
        tracked = self._tracks.update(
            pair.step,
            [(u, v) for u, v, _, _ in found],
            [max(np.sqrt(a), 2.0 * scale) for _, _, a, _ in found],
            [a for _, _, a, _ in found],
            pair.t_s,
        )
        velocities = [velocity or (0.0, 0.0) for velocity in tracked]  # none yet: no speed
        speeds = [float(np.hypot(*d)) for d in velocities]
        totals = (
            sum(f[3] for f in found),
            sum(f[2] for f in found),
            sum(speeds),
        )
        regions = []
        for (u, v, area, e), (du, dv), speed in zip(found, velocities, speeds, strict=True):
            shares = [x / t for x, t in zip((e, area, speed), totals, strict=True) if t > 0]
            score = sum(shares) / len(shares) if shares else 0.0
            regions.append(MotionRegion(u, v, du, dv, area, e, score))
        regions.sort(key=lambda r: r.score, reverse=True)
        return regions[: self.max_count]
