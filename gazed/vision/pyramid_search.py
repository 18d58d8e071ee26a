"""The `pyramid` detector: coarse-to-fine window search in the motion-energy pyramid (seed 004 §3).

The energy pyramid (see `motion_energy`) is searched with small square windows (16x16 in the
paper). A pixel is *active* when its energy exceeds `energy_threshold`; a window's position is
the mean position of its active pixels ("the positions of local energy change are integrated to
find the object center") — of those of its strongest connected region when there are several,
one object being assumed. The confidence is the window's share of the level's active energy.

- `full` — the 5-level search (seed 004 §2.1, §3, Fig. 6): the whole coarsest level is examined,
  its strongest region centres a window one level finer, and so on towards level 0 until a
  window holds at least `fill_fraction` of active pixels (the object is as large as the window
  there, so a finer window would cut it).
- `predictive` — the 2-level search (seed 004 §3, Fig. 7-8): while tracking an object of level
  ℓ, one window at level ℓ+1 around the predicted position, then one at level ℓ around what it
  found. Bootstrapping (no track yet, or lost): any energy at the coarsest level puts the next
  window two levels finer, where the number of active pixels sets the object level ℓ (the
  paper's up-leveling threshold at level 2, generalised: each level down quadruples the count).
  ℓ moves one level coarser when the level-(ℓ+1) window is filled, one finer when the level-ℓ
  window is less than half filled.

The difference image holds the target at both captures, so a centroid is the target's position
at mid-interval; it is moved to the capture time with the tracked velocity (`+ v dt / 2`). The
velocity is the least-squares slope of the last centroids, kept in current-frame coordinates
(see `position_history`).

The regions of the final window are its movers (`gazed.vision.movers`): the target's own first,
the others with the velocity of their recent centroids (`RegionTracks`). The window is small:
the movers are those it covers.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from gazed.vision.detector import DetectorOutput, FramePair
from gazed.vision.motion_energy import UNITS_PER_GREY
from gazed.vision.movers import MoverRegion, trimmed
from gazed.vision.position_history import PositionHistory
from gazed.vision.region_tracks import RegionTracks

SearchMode = Literal["full", "predictive"]

# Centroids used for the velocity fit (seed 004 §4 leaves filtering to the estimator; this
# only smooths the centroid jitter of a single frame difference).
VELOCITY_POINTS = 6


@dataclass(frozen=True)
class WindowLook:
    """What one window at one pyramid level shows (positions in level-0 pixels)."""

    level: int
    x0: int
    y0: int
    size: int
    active: int
    energy: float
    u_px: float
    v_px: float

    @property
    def rect(self) -> tuple[int, int, int, int]:
        """The window in level-0 pixels (x, y, width, height)."""
        scale = 1 << self.level
        return (self.x0 * scale, self.y0 * scale, self.size * scale, self.size * scale)


def look(
    energy: np.ndarray, level: int, u_px: float, v_px: float, size: int, threshold: float
) -> WindowLook:
    """Examine the `size` x `size` window of level `level` centred nearest level-0 (u, v)."""
    scale = 1 << level
    h, w = energy.shape
    x0 = min(max(round(u_px / scale - (size - 1) / 2.0), 0), max(w - size, 0))
    y0 = min(max(round(v_px / scale - (size - 1) / 2.0), 0), max(h - size, 0))
    window = energy[y0 : y0 + size, x0 : x0 + size]
    return _centroid(window, level, x0, y0, size, threshold)


def _centroid(
    window: np.ndarray, level: int, x0: int, y0: int, size: int, threshold: float
) -> WindowLook:
    """Seed 004 §3: the positions of the active pixels integrated (their mean) -> the centre.
    One object is assumed: when the active pixels form several regions (8-connected, across
    one-pixel gaps), only the one with the most energy counts."""
    active = window > threshold
    if not active.any():
        return WindowLook(level, x0, y0, size, 0, 0.0, math.nan, math.nan)
    joined = cv2.dilate(active.astype(np.uint8), np.ones((3, 3), np.uint8))
    count, labels = cv2.connectedComponents(joined, connectivity=8)
    if count > 2:
        sums = np.bincount(labels[active], weights=window[active], minlength=count)
        active &= labels == int(np.argmax(sums))
    ys, xs = np.nonzero(active)
    scale = 1 << level
    u = (x0 + float(xs.mean())) * scale
    v = (y0 + float(ys.mean())) * scale
    return WindowLook(level, x0, y0, size, len(xs), float(window[active].sum()), u, v)


def strongest_region(energy: np.ndarray, level: int, threshold: float) -> WindowLook | None:
    """Scan a whole (coarse) level: the connected active region with the most energy."""
    if not (energy > threshold).any():
        return None
    h, w = energy.shape
    return _centroid(energy, level, 0, 0, max(h, w), threshold)


class PyramidDetector:
    """Seed 004 §3: 5-level (`full`) or predictive 2-level search with bootstrapping."""

    name = "pyramid"
    needs_energy = True

    def __init__(
        self,
        search: SearchMode,
        *,
        window_px: int,
        energy_threshold: float,
        fill_fraction: float,
    ) -> None:
        self.search = search
        self.window_px = window_px
        self.energy_threshold = energy_threshold * UNITS_PER_GREY  # in the pyramid's units
        self.fill_count = fill_fraction * window_px * window_px
        self.level: int | None = None  # the tracked object's level ℓ (predictive search)
        self._history = PositionHistory(VELOCITY_POINTS)
        self._tracks = RegionTracks(VELOCITY_POINTS)

    def reset(self) -> None:
        self.level = None
        self._history.clear()
        self._tracks.reset()

    def detect(self, pair: FramePair) -> DetectorOutput:
        pyramid = pair.energy
        if pyramid is None:
            self.reset()
            return DetectorOutput.nothing()
        self._history.transport(pair.step)
        if self.search == "full":
            final = self._five_level(pyramid)
        else:
            final = self._two_level(pyramid, pair.step.dt_s)
        if final is None:
            self.reset()
            return DetectorOutput.nothing()
        self._history.add(
            pair.t_s - pair.step.dt_s / 2.0, final.u_px, final.v_px, gate_px=final.rect[2] / 2.0
        )
        velocity = self._history.velocity()
        du, dv = velocity or (0.0, 0.0)
        half_dt = pair.step.dt_s / 2.0
        level = pyramid[final.level]
        level_energy = float(level[level > self.energy_threshold].sum())
        own = MoverRegion(
            u_px=final.u_px + du * half_dt,
            v_px=final.v_px + dv * half_dt,
            du_px_s=du,
            dv_px_s=dv,
            box=(0.0, 0.0, 0.0, 0.0),
            area_px=float(final.active << (2 * final.level)),
            confidence=min(1.0, final.energy / level_energy) if level_energy > 0 else 0.0,
            velocity_known=velocity is not None,
        )
        return DetectorOutput(
            found=True,
            u_px=own.u_px,
            v_px=own.v_px,
            du_px_s=du,
            dv_px_s=dv,
            area_px=own.area_px,
            confidence=own.confidence,
            window=final.rect,
            movers=self._movers(pyramid, final, own, pair),
        )

    def _movers(
        self, pyramid: list[np.ndarray], final: WindowLook, own: MoverRegion, pair: FramePair
    ) -> tuple[MoverRegion, ...]:
        """The regions of the final window (joined across one-pixel gaps, as `_centroid` groups
        them): the target's own first, with its box, then the others, each with the velocity of
        its recent centroids."""
        scale = 1 << final.level
        window = pyramid[final.level][
            final.y0 : final.y0 + final.size, final.x0 : final.x0 + final.size
        ]
        active = window > self.energy_threshold
        joined = cv2.dilate(active.astype(np.uint8), np.ones((3, 3), np.uint8))
        count, labels = cv2.connectedComponents(joined, connectivity=8)
        energies = np.bincount(labels[active], weights=window[active], minlength=count)
        strongest = int(np.argmax(energies))
        regions = [strongest] + [i for i in range(1, count) if i != strongest and energies[i] > 0]
        blobs = [trimmed(final.x0, final.y0, active & (labels == i)) for i in regions]
        if len(blobs) == 1:  # the target alone: no other track to keep
            self._tracks.reset()
            return (dataclasses.replace(own, box=blobs[0].box_at(scale)),)
        centroids = [(final.u_px, final.v_px)]
        centroids += [(cu * scale, cv * scale) for cu, cv in (b.centroid() for b in blobs[1:])]
        boxes = [b.box_at(scale) for b in blobs]
        radii = [0.5 * max(b[2], b[3]) for b in boxes]
        areas = [float(blob.area * scale * scale) for blob in blobs]
        velocities = self._tracks.update(pair.step, centroids, radii, areas, pair.t_s)
        total = float(energies.sum())
        half_dt = pair.step.dt_s / 2.0  # a centroid is at mid-interval, as the target's
        movers = [dataclasses.replace(own, box=boxes[0])]
        for i, (u, v), velocity, box, blob in zip(
            regions[1:], centroids[1:], velocities[1:], boxes[1:], blobs[1:], strict=True
        ):
            area = float(blob.area * scale * scale)
            du, dv = velocity or (0.0, 0.0)
            u, v = u + du * half_dt, v + dv * half_dt
            energy = float(energies[i]) / total
            movers.append(MoverRegion.tracked(u, v, velocity, box, area, energy))
        return tuple(movers)

    def _coarsest(self, pyramid: list[np.ndarray]) -> WindowLook | None:
        top = len(pyramid) - 1
        return strongest_region(pyramid[top], top, self.energy_threshold)

    def _five_level(self, pyramid: list[np.ndarray]) -> WindowLook | None:
        """Seed 004 §2.1: refine from the coarsest level until a window is filled."""
        found = self._coarsest(pyramid)
        if found is None:
            return None
        for level in range(len(pyramid) - 2, -1, -1):
            if found.active >= self.fill_count:
                break
            finer = self._look(pyramid, level, found.u_px, found.v_px)
            if finer.active == 0:
                break
            found = finer
        return found

    def _two_level(self, pyramid: list[np.ndarray], dt_s: float) -> WindowLook | None:
        """Seed 004 §3: two windows around the prediction; bootstrap when there is no track."""
        last = self._history.last()
        if self.level is None or last is None:
            return self._bootstrap(pyramid)
        du, dv = self._history.velocity() or (0.0, 0.0)
        # the last centroid was at mid-interval: one frame interval later for the next one
        u, v = last[1] + du * dt_s, last[2] + dv * dt_s
        top = len(pyramid) - 1
        coarse = self._look(pyramid, min(self.level + 1, top), u, v)
        if coarse.active == 0:
            return self._bootstrap(pyramid)
        fine = self._look(pyramid, self.level, coarse.u_px, coarse.v_px)
        if fine.active == 0:
            fine = coarse
        if coarse.active >= self.fill_count and coarse.level > self.level:
            self.level = min(self.level + 1, top - 1)
        elif fine.active < self.fill_count / 2 and self.level > 0:
            self.level -= 1
        return fine

    def _bootstrap(self, pyramid: list[np.ndarray]) -> WindowLook | None:
        """Energy at the coarsest level -> a window two levels finer -> the object level."""
        self._history.clear()
        found = self._coarsest(pyramid)
        if found is None:
            self.level = None
            return None
        level = max(len(pyramid) - 3, 0)
        window = self._look(pyramid, level, found.u_px, found.v_px)
        if window.active == 0:
            self.level = None
            return None
        # each level finer quadruples the active count: the coarsest level the object fills
        self.level = level
        count = float(window.active)
        while self.level > 0 and count < self.fill_count:
            self.level -= 1
            count *= 4.0
        return window

    def _look(self, pyramid: list[np.ndarray], level: int, u: float, v: float) -> WindowLook:
        return look(pyramid[level], level, u, v, self.window_px, self.energy_threshold)
