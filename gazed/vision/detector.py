"""What every detector takes and returns.

A detector sees one `FramePair` at a time (the current grey frame, the previous one, and the
head's rotation between them) and returns a `DetectorOutput`: found or not, the target's pixel
and its velocity, the region's area, a confidence, the time spent, and every mover it segmented
(`gazed.vision.movers`).

Velocities are *independent* image velocities: the target's motion against the world, in pixels
per second of the current frame, with the flow of the head's own rotation removed (seed 000 §2,
`ṙ_ind = ṙ - ṙ_rot`). With the head still they are plain image velocities.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Protocol

import numpy as np

from gazed.vision.ego_motion import HeadStep
from gazed.vision.movers import MoverRegion

PointKind = Literal["centroid", "ground-contact"]
BASELINE_FRAMES = 3  # `FramePair.older`: the frame this many intervals back


@dataclass(frozen=True)
class FramePair:
    """The current frame and what the detectors need of the previous one.

    `gray`: uint8 (H, W). `previous`: the previous grey frame or None (first frame, or after a
    gap or reset). `step`: the head's rotation from the previous capture to this one; an
    identity step when compensation is off (no odometry, or switched off in the rig).
    `energy`: the motion-energy pyramid of this pair, level 0 first, int16 in
    `motion_energy.UNITS_PER_GREY` per grey level, when the pipeline computed it. `older`: the
    same frame against the one `BASELINE_FRAMES` back, where the head's odometry reaches it
    (a target too slow to show against the previous frame moves several frames' worth).
    """

    gray: np.ndarray
    t_s: float
    previous: np.ndarray | None
    step: HeadStep
    compensated: bool
    energy: list[np.ndarray] | None = None
    older: FramePair | None = None


@dataclass(frozen=True)
class DetectorOutput:
    """One frame's answer. Pixels: u right, v down, origin at the top-left pixel's centre."""

    found: bool
    u_px: float = 0.0
    v_px: float = 0.0
    du_px_s: float = 0.0
    dv_px_s: float = 0.0
    area_px: float = 0.0
    confidence: float = 0.0
    processing_ms: float = 0.0
    point: PointKind = "centroid"
    window: tuple[int, int, int, int] | None = None
    """The region searched (x, y, width, height) in pixels, for display."""
    movers: tuple[MoverRegion, ...] = ()
    """Every separate mover segmented in the frame, the target's own first when found."""

    @classmethod
    def nothing(cls, window: tuple[int, int, int, int] | None = None) -> DetectorOutput:
        return cls(found=False, window=window)


class Detector(Protocol):
    """A detector keeps its own state between frames (track, model); `reset()` forgets it."""

    name: str
    needs_energy: bool

    def detect(self, pair: FramePair) -> DetectorOutput: ...

    def reset(self) -> None: ...
