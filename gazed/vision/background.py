"""The `background` detector: background subtraction for a head at rest (seed 003 §IV).

OpenCV's Gaussian-mixture background model (MOG2) learns the still scene (`silhouettes`); the
largest foreground blob is the target, and the bottom of the blob — where a walker's feet meet the
ground — is reported as its ground contact point (`point = "ground-contact"`), which the
geometry maps to the ground plane with no height correction.

The model only holds while the head is still: when the head's rotation since the model was
started moves the image centre by more than `still_px`, the model is dropped and relearnt
(`learning_frames` frames with no detection). The model runs `level` pyramid levels down
(level 1: half resolution) to keep within the frame budget; positions are in full-resolution
pixels. The velocity is the least-squares slope of the last contact points.

Every blob is also reported as movers: split into the walkers it holds side by side, each with
its own ground contact point, box and velocity (`silhouettes`); the one of the largest blob
nearest the target's point comes first.
"""

from __future__ import annotations

import numpy as np

from gazed.vision.detector import DetectorOutput, FramePair
from gazed.vision.ego_motion import apply_homography
from gazed.vision.position_history import PositionHistory
from gazed.vision.silhouettes import SilhouetteModel

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
        ghosts: bool = True,
    ) -> None:
        self.level = level
        self.min_area_px = min_area_px
        self.still_px = still_px
        self.silhouettes = SilhouetteModel(
            level=level,
            history_frames=history_frames,
            threshold=threshold,
            min_area_px=min_area_px,
            learning_frames=learning_frames,
            ghosts=ghosts,
        )
        self._drift = np.eye(3)  # the head's rotation since the model was started
        self._history = PositionHistory(VELOCITY_POINTS)

    @property
    def resets(self) -> int:
        """How many times the background model was started."""
        return self.silhouettes.resets

    def reset(self) -> None:
        self.silhouettes.reset()
        self._history.clear()

    def detect(self, pair: FramePair) -> DetectorOutput:
        if self.silhouettes.started and self._head_moved(pair):
            self.reset()
        if not self.silhouettes.started:
            self._drift = np.eye(3)
        foreground = self.silhouettes.segment(pair.gray)
        if foreground is None:
            return DetectorOutput.nothing()
        if not foreground.found:
            self._lost()
            return DetectorOutput.nothing()
        largest, _ = foreground.found[0]
        u, v = self.silhouettes.point(largest, "ground-contact")
        scale = 1 << self.level
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
            confidence=area / foreground.total_px,
            point="ground-contact",
            window=tuple(int(x) for x in largest.box_at(scale)),
            movers=self.silhouettes.movers(foreground, "ground-contact", pair.step, pair.t_s, u),
        )

    def _lost(self) -> None:
        """Nothing in view: no track continues."""
        self._history.clear()
        self.silhouettes.reset_tracks()

    def _head_moved(self, pair: FramePair) -> bool:
        """Has the image centre moved by more than `still_px` since the model started?"""
        self._drift = pair.step.H @ self._drift
        h, w = pair.gray.shape
        cu, cv = (w - 1) / 2.0, (h - 1) / 2.0
        u, v = apply_homography(self._drift, cu, cv)
        step_u, step_v = apply_homography(pair.step.H, cu, cv)
        moved = max(np.hypot(u - cu, v - cv), np.hypot(step_u - cu, step_v - cv))
        return bool(moved > self.still_px)
