"""The search for a lost target around the estimator's prediction (DESIGN §7, state `lost`).

The search region is a circle around the prediction whose radius grows with the prediction's
position covariance seen from the camera, or with time where the prediction carries none.
While the region fits in the fovea, the fovea stays on the prediction. Past that, the fovea
tours the region's edge (a ring of radius region - fovea around the prediction) in stops a
fovea apart, so that neighbouring views touch. Each stop is held for the move to it, the
settling, `reacquire_detections` frames and the visual latency of their reports; detections
captured before the head settled at a stop come from the move (a turning head's compensation
residue looks like motion) and are ignored. A region wider than `lost_search_max_deg` says too
little to search: the controller goes back to watching the whole frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gazed.config import GazeSection
from gazed.gaze.aim import MoveLimits
from gazed.messages import Prediction

MAX_STEP_RAD = 2.0 * math.pi / 3.0  # at least three stops round even a small ring


@dataclass(frozen=True)
class ScanStop:
    """One stop of the fovea's tour of the search region's edge."""

    phase_rad: float  # where on the ring around the prediction
    ring_rad: float  # the ring's radius when the stop began
    look_from_ns: int  # detections captured earlier come from the move here
    next_s: float  # when to move on to the next stop (monotonic)

    @property
    def offset_rad(self) -> tuple[float, float]:
        """The stop's (pan, tilt) offset from the prediction."""
        return (
            self.ring_rad * math.cos(self.phase_rad),
            self.ring_rad * math.sin(self.phase_rad),
        )


class LostSearch:
    """The search region's radius, and the current stop of the tour of its edge."""

    def __init__(
        self,
        gaze: GazeSection,
        fovea_rad: float,
        camera_xyz_m: tuple[float, float, float] | None,
        limits: MoveLimits,
        frame_period_s: float,
    ) -> None:
        self.growth_rad_s = math.radians(gaze.lost_search_growth_deg_s)
        self.max_radius_rad = math.radians(gaze.lost_search_max_deg)
        self.fovea_rad = fovea_rad
        self.camera_xyz_m = camera_xyz_m
        self.limits = limits
        self.settle_s = gaze.settle_ms / 1000.0
        self.look_frames_s = (gaze.reacquire_detections + 1) * frame_period_s
        self.scan: ScanStop | None = None

    def reset(self) -> None:
        """A new search: the tour starts again at its first stop."""
        self.scan = None

    def from_the_move(self, t_capture_ns: int) -> bool:
        """Was a frame captured at `t_capture_ns` taken on the way to the current stop?"""
        return self.scan is not None and t_capture_ns < self.scan.look_from_ns

    def radius_rad(self, prediction: Prediction | None, lost_s: float) -> float:
        """Grows with the prediction's position covariance seen from the camera (its largest
        standard deviation over the distance), or with time, whichever is larger."""
        p = prediction
        grow = self.growth_rad_s * lost_s
        camera = self.camera_xyz_m
        if (
            p is not None
            and p.position_cov_m2 is not None
            and p.ground_xy_m is not None
            and camera is not None
        ):
            (a, b), (c, d) = p.position_cov_m2
            sigma_m = math.sqrt(max(0.5 * (a + d + math.hypot(a - d, b + c)), 0.0))
            distance_m = math.hypot(
                p.ground_xy_m[0] - camera[0], p.ground_xy_m[1] - camera[1], camera[2]
            )
            grow = max(grow, sigma_m / distance_m)
        return grow

    def stop(
        self, region_rad: float, visual_latency_s: float, wall_ns: int, mono_s: float
    ) -> tuple[ScanStop | None, bool]:
        """The stop to look from, None while the region fits in the fovea; and whether it has
        just begun (the look there starts a new run of detections)."""
        ring_rad = max(region_rad - self.fovea_rad, 0.0)
        if ring_rad == 0.0:
            return None, False
        stop = self.scan
        if stop is not None and mono_s < stop.next_s:
            return stop, False
        if stop is None:
            phase_rad, move_pan, move_tilt = 0.0, ring_rad, 0.0
        else:
            phase_rad = stop.phase_rad + min(MAX_STEP_RAD, 2.0 * self.fovea_rad / ring_rad)
            move_pan = ring_rad * math.cos(phase_rad) - stop.ring_rad * math.cos(stop.phase_rad)
            move_tilt = ring_rad * math.sin(phase_rad) - stop.ring_rad * math.sin(stop.phase_rad)
        look_s = self.limits.duration_s(move_pan, move_tilt) + self.settle_s
        self.scan = ScanStop(
            phase_rad,
            ring_rad,
            wall_ns + round(look_s * 1e9),
            mono_s + look_s + self.look_frames_s + visual_latency_s,
        )
        return self.scan, True
