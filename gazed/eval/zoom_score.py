"""Scores of the zoom control in a closed-loop run (`[gaze] zoom_control`).

- the target's height in the frame: per truth frame, the height of the box around its body as
  the renderer draws it (an upright rectangle facing the camera, `[sim] target_width_m` wide),
  seen through the lens at the head's true zoom then (`SimTruth.head`), as a fraction of the
  frame's height (a head panned far from its base's axis sees the body rolled, and its box is
  taller than the body); from acquisition on, the share of frames within ±`TOLERANCE` of
  `zoom_target_height`, and the median and the 5th and 95th percentiles of the fraction;
- losses: entries into `lost` from pursuit after acquisition (`loss_times_s`: each one's time
  from the first frame, whether it came while the zoom moved, and whether the target stood),
  and those while the zoom moved (by more than `MOVING_ZOOM` over the `MOVING_WINDOW_S` before
  the gaze left the target: the first of the frames with the target outside the fovea that run
  up to the loss, or the loss itself where the target was still in the fovea; `lost` is
  declared later, while the gaze follows something else and the zoom sizes it);
- of those, the ones of a target that walked (`losses_while_zooming_walking`). `lost` comes
  `lost_after_ms` after the last detection of the target; where the target stood still (true
  ground speed under `STANDING_M_S`) for at least half of that gap, a motion detector does not
  see it whatever the lens does: a fixed lens loses such a target too, if not always as often
  as a zoomed one, so the flag says what the loss was, not that the zoom had no part in it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gazed.config import Rig
from gazed.geometry.pose import CameraPose
from gazed.geometry.zoom import ZoomLens
from gazed.messages import GazeState, SimTruth

TOLERANCE = 0.2  # a height within this fraction of the setpoint counts as held
MOVING_ZOOM = 0.01  # the zoom moved: by more than this (of its range) ...
MOVING_WINDOW_S = 1.0  # ... over this long before a loss
STANDING_M_S = 0.1  # a target slower than this stands still: a tenth of a walking pace


def zoom_scoring(rig: Rig) -> ZoomScoring | None:
    """The rig's zoom scoring; None where its gaze does not control a zoom."""
    if not rig.gaze.zoom_control:
        return None
    lens = ZoomLens.from_section(rig.camera)
    pose = CameraPose.from_rig(rig)
    return ZoomScoring(
        lens,
        pose,
        rig.gaze.zoom_target_height,
        rig.sim.target_width_m,
        rig.gaze.lost_after_ms / 1000.0,
    )


@dataclass(frozen=True)
class ZoomScoring:
    """What the zoom of one rig is scored against: its lens, its setpoint, the true pose, the
    target's width, and how long the gaze goes without a detection before it is lost."""

    lens: ZoomLens
    pose: CameraPose
    setpoint: float
    width_m: float
    lost_after_s: float

    def heights(self, truth: list[SimTruth]) -> np.ndarray:
        """Per truth frame: the target's height in the frame, as a fraction of its height."""
        fractions = []
        for t in truth:
            camera = self.lens.at_pose(t.head)
            directions = self.pose.camera_directions(
                self._corners_m(t), t.head.pan_rad, t.head.tilt_rad
            )
            if np.any(directions[:, 2] <= 0):
                fractions.append(np.nan)  # behind the camera
                continue
            rows = camera.pixel(directions)[:, 1]
            fractions.append(float(rows.max() - rows.min()) / camera.height_px)
        return np.asarray(fractions)

    def _corners_m(self, t: SimTruth) -> np.ndarray:
        """The body's four corners (4, 3), facing the camera as the renderer draws it."""
        x, y = t.target_xy_m
        dx, dy = x - self.pose.centre_m[0], y - self.pose.centre_m[1]
        norm = max(float(np.hypot(dx, dy)), 1e-9)
        right = np.array([dy, -dx, 0.0]) / norm * self.width_m / 2.0
        foot, top = np.array([x, y, 0.0]), np.array([x, y, t.target_height_m])
        return np.array([top - right, top + right, foot + right, foot - right])

    def score(
        self,
        truth: list[SimTruth],
        states: list[GazeState],
        start: int | None,
        in_fovea: np.ndarray | None = None,
    ) -> dict[str, object]:
        """The zoom's scores from truth frame `start` (acquisition) on (module docstring);
        `in_fovea`: per truth frame, the target within the fovea (None: losses at `lost`)."""
        if start is None:
            return {
                "height_within_fraction": 0.0,
                "losses": None,
                "losses_while_zooming": None,
                "losses_while_zooming_walking": None,
            }
        heights = self.heights(truth[start:])
        held = np.abs(heights / self.setpoint - 1.0) <= TOLERANCE
        p5, p50, p95 = np.nanpercentile(heights, [5, 50, 95])
        times_ns = np.array([t.t_capture_ns for t in truth])
        zooms = np.array([t.head.zoom if t.head.zoom is not None else 0.0 for t in truth])
        losses = [
            s.t_capture_ns
            for s in states
            if s.state == "lost"
            and s.previous == "pursuit"
            and s.t_capture_ns >= truth[start].t_capture_ns
        ]
        while_zooming = []
        for t_ns in losses:
            left_ns = _left_ns(times_ns, in_fovea, t_ns) if in_fovea is not None else t_ns
            window = (times_ns >= left_ns - MOVING_WINDOW_S * 1e9) & (times_ns <= left_ns)
            while_zooming.append(bool(window.any() and np.ptp(zooms[window]) > MOVING_ZOOM))
        standing = [stood_before(truth, t_ns, self.lost_after_s) for t_ns in losses]
        return {
            "setpoint": self.setpoint,
            "height_within_fraction": round(float(np.mean(held)), 4),
            "frames": len(held),
            "height_fraction": {
                "p5": round(float(p5), 4),
                "p50": round(float(p50), 4),
                "p95": round(float(p95), 4),
            },
            "losses": len(losses),
            "losses_while_zooming": sum(while_zooming),
            "losses_while_zooming_walking": sum(
                zooming and not stood
                for zooming, stood in zip(while_zooming, standing, strict=True)
            ),
            "loss_times_s": [
                [round(float(t_ns - times_ns[0]) / 1e9, 2), zooming, stood]
                for t_ns, zooming, stood in zip(losses, while_zooming, standing, strict=True)
            ],
        }


def stood_before(truth: list[SimTruth], lost_ns: int, lost_after_s: float) -> bool:
    """Whether the target stood still (true ground speed under `STANDING_M_S`) in at least half
    of the truth frames of the `lost_after_s` before a loss at `lost_ns`: the gap without a
    detection that `lost` ends."""
    speeds = [
        float(np.hypot(*t.target_velocity_m_s))
        for t in truth
        if lost_ns - lost_after_s * 1e9 <= t.t_capture_ns <= lost_ns
    ]
    return bool(speeds) and np.mean(np.array(speeds) < STANDING_M_S) >= 0.5


def _left_ns(times_ns: np.ndarray, in_fovea: np.ndarray, lost_ns: int) -> int:
    """When the gaze left the target before a loss at `lost_ns`: the first frame of the run of
    frames outside the fovea up to it; `lost_ns` where the last frame before it is inside."""
    k = int(np.searchsorted(times_ns, lost_ns, "right")) - 1
    if k < 0 or in_fovea[k]:
        return lost_ns
    while k > 0 and not in_fovea[k - 1]:
        k -= 1
    return int(times_ns[k])
