"""The `background` detector: background subtraction for a head at rest (seed 003 §IV).

OpenCV's Gaussian-mixture background model (MOG2) learns the still scene; the largest
foreground blob is the target, and the bottom of the blob — where a walker's feet meet the
ground — is reported as its ground contact point (`point = "ground-contact"`), which the
geometry maps to the ground plane with no height correction.

The model only holds while the head is still: when the head's rotation since the model was
started moves the image centre by more than `still_px`, the model is dropped and relearnt
(`learning_frames` frames with no detection). The model runs `level` pyramid levels down
(level 1: half resolution) to keep within the frame budget; positions are in full-resolution
pixels. The velocity is the least-squares slope of the last contact points.

Every blob is also reported as movers (`gazed.vision.movers`): split into the walkers it holds
side by side, each with its own ground contact point, box and velocity (the slope of its own
recent contact points, `RegionTracks`); the one under the target's point comes first.
"""

from __future__ import annotations

import cv2
import numpy as np

from gazed.vision.detector import DetectorOutput, FramePair
from gazed.vision.ego_motion import apply_homography
from gazed.vision.movers import Blob, MoverRegion, blobs
from gazed.vision.position_history import PositionHistory
from gazed.vision.region_tracks import RegionTracks

VELOCITY_POINTS = 6


class BackgroundDetector:
    name = "background"
    needs_energy = False

    def __init__(
        self,
        *,
        level: int,
        history_frames: int,
        threshold: float,
        min_area_px: int,
        learning_frames: int,
        still_px: float,
    ) -> None:
        self.level = level
        self.history_frames = history_frames
        self.threshold = threshold
        self.min_area_px = min_area_px
        self.learning_frames = learning_frames
        self.still_px = still_px
        self.resets = 0
        self._model: cv2.BackgroundSubtractorMOG2 | None = None
        self._learned = 0
        self._drift = np.eye(3)  # the head's rotation since the model was started
        self._history = PositionHistory(VELOCITY_POINTS)
        self._tracks = RegionTracks(VELOCITY_POINTS)

    def reset(self) -> None:
        self._model = None
        self._history.clear()
        self._tracks.reset()

    def detect(self, pair: FramePair) -> DetectorOutput:
        if self._model is not None and self._head_moved(pair):
            self.reset()
        if self._model is None:
            self._model = cv2.createBackgroundSubtractorMOG2(
                history=self.history_frames, varThreshold=self.threshold, detectShadows=False
            )
            self._learned = 0
            self._drift = np.eye(3)
            self.resets += 1
        small = pair.gray
        for _ in range(self.level):
            small = cv2.pyrDown(small)
        mask = self._model.apply(small)
        self._learned += 1
        if self._learned <= self.learning_frames:
            return DetectorOutput.nothing()
        return self._largest_blob(mask, pair)

    def _head_moved(self, pair: FramePair) -> bool:
        """Has the image centre moved by more than `still_px` since the model started?"""
        self._drift = pair.step.H @ self._drift
        h, w = pair.gray.shape
        cu, cv = (w - 1) / 2.0, (h - 1) / 2.0
        u, v = apply_homography(self._drift, cu, cv)
        step_u, step_v = apply_homography(pair.step.H, cu, cv)
        moved = max(np.hypot(u - cu, v - cv), np.hypot(step_u - cu, step_v - cv))
        return bool(moved > self.still_px)

    def _largest_blob(self, mask: np.ndarray, pair: FramePair) -> DetectorOutput:
        kernel = np.ones((3, 3), np.uint8)
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
        mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8))
        scale = 1 << self.level
        found = blobs(mask, self.min_area_px / (scale * scale), split=True)
        if not found:
            self._history.clear()
            self._tracks.reset()
            return DetectorOutput.nothing()
        total = float(np.count_nonzero(mask)) * scale * scale
        largest, _ = found[0]
        u, v = self._full_resolution(largest.ground_contact())
        area = float(largest.area * scale * scale)
        self._history.add(pair.t_s, u, v, gate_px=0.5 * scale * max(largest.width, largest.height))
        du, dv = self._history.velocity() or (0.0, 0.0)
        return DetectorOutput(
            found=True,
            u_px=u,
            v_px=v,
            du_px_s=du,
            dv_px_s=dv,
            area_px=area,
            confidence=area / total,
            point="ground-contact",
            window=tuple(int(x) for x in largest.box_at(scale)),
            movers=self._movers(found, u, pair, total),
        )

    def _full_resolution(self, point: tuple[float, float]) -> tuple[float, float]:
        """A model-level ground contact point in level-0 pixels: level-k pixel i is centred on
        level-0 pixel scale*i and spans scale pixels."""
        scale = 1 << self.level
        return point[0] * scale, point[1] * scale + (scale - 1) / 2.0

    def _movers(
        self, found: list[tuple[Blob, list[Blob]]], target_u: float, pair: FramePair, total: float
    ) -> tuple[MoverRegion, ...]:
        """Every body of every blob, the one of the largest blob under the target's point
        first, with velocities from their tracks."""
        scale = 1 << self.level
        bodies = [body for _, parts in found for body in parts]
        first = min(
            range(len(found[0][1])),
            key=lambda i: abs((bodies[i].x + bodies[i].width / 2.0) * scale - target_u),
        )
        bodies.insert(0, bodies.pop(first))
        points = [self._full_resolution(body.ground_contact()) for body in bodies]
        boxes = [body.box_at(scale) for body in bodies]
        velocities = self._tracks.update(
            pair.step, points, [0.5 * max(box[2], box[3]) for box in boxes], pair.t_s
        )
        movers = []
        for body, (u, v), (du, dv), box in zip(bodies, points, velocities, boxes, strict=True):
            area = float(body.area * scale * scale)
            movers.append(MoverRegion(u, v, du, dv, box, area, min(1.0, area / total)))
        return tuple(movers)
