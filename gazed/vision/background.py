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
"""

from __future__ import annotations

import cv2
import numpy as np

from gazed.vision.detector import DetectorOutput, FramePair
from gazed.vision.ego_motion import apply_homography
from gazed.vision.position_history import PositionHistory

VELOCITY_POINTS = 6
FOOT_FRACTION = 0.1  # the bottom tenth of the blob gives the contact point's u


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

    def reset(self) -> None:
        self._model = None
        self._history.clear()

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
        return self._largest_blob(mask, pair.t_s)

    def _head_moved(self, pair: FramePair) -> bool:
        """Has the image centre moved by more than `still_px` since the model started?"""
        self._drift = pair.step.H @ self._drift
        h, w = pair.gray.shape
        cu, cv = (w - 1) / 2.0, (h - 1) / 2.0
        u, v = apply_homography(self._drift, cu, cv)
        step_u, step_v = apply_homography(pair.step.H, cu, cv)
        moved = max(np.hypot(u - cu, v - cv), np.hypot(step_u - cu, step_v - cv))
        return bool(moved > self.still_px)

    def _largest_blob(self, mask: np.ndarray, t_s: float) -> DetectorOutput:
        kernel = np.ones((3, 3), np.uint8)
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
        mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8))
        count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        scale = 1 << self.level
        areas = stats[1:, cv2.CC_STAT_AREA] * scale * scale
        if count <= 1 or areas.max() < self.min_area_px:
            self._history.clear()
            return DetectorOutput.nothing()
        best = 1 + int(np.argmax(areas))
        x, y, w, h = (int(stats[best, i]) for i in range(4))
        bottom = y + h - 1
        foot_rows = max(1, round(h * FOOT_FRACTION))
        feet = labels[bottom - foot_rows + 1 : bottom + 1, x : x + w] == best
        foot_u = x + float(np.nonzero(feet)[1].mean())
        # level-k pixel i is centred on level-0 pixel scale*i and spans scale pixels
        u = foot_u * scale
        v = bottom * scale + (scale - 1) / 2.0
        self._history.add(t_s, u, v, gate_px=0.5 * scale * max(w, h))
        du, dv = self._history.velocity() or (0.0, 0.0)
        return DetectorOutput(
            found=True,
            u_px=u,
            v_px=v,
            du_px_s=du,
            dv_px_s=dv,
            area_px=float(areas[best - 1]),
            confidence=float(areas[best - 1] / areas.sum()),
            point="ground-contact",
            window=(x * scale, y * scale, w * scale, h * scale),
        )
