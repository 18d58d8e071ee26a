"""Each frame's capture stamp moved back from its arrival to its exposure by the camera's delay.

The delay is the rig's `[camera] delay_ms`, or, with `[camera] delay_estimate`, the online
estimate of `camera_delay` that starts from it: every frame's global shift from the one before
(phase correlation on a small grey copy) and every odometry sample feed it. Until its first fit,
a frame's pose is known where the head stood still over every exposure time the lag grid allows
(`still_before`), and, after such a frame, while the image has moved less than a pixel since
it: the background still where it was, the frame was exposed before the head moved, at the
still pose, whenever it arrives (the head's first move shows in the image a delay after it
begins, and the frames of that delay are the ones that see the target before the move). A
digital head's views carry the pose they were rendered at and are stamped at their exposure:
they pass as they are.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from gazed.config import CameraSection
from gazed.geometry.camera import CameraModel
from gazed.latency import LatencyWindow
from gazed.messages import Odometry
from gazed.vision.camera_delay import CameraDelayEstimator, ImageShift
from gazed.vision.frames import CapturedFrame

TIMING_WINDOW = 100  # frames over which the shift's cost is reported
# a fit is taken when the lags that explain the shifts as well lie within this share of a frame
# period of it: a margin on the stamps' tolerance of a frame, as the spread is the least the
# lag is uncertain by (camera_delay)
SPREAD_PER_FRAME = 0.25
STILL_SHIFT_PX = 1.0  # the image moved less than this since a still frame: the same pose


class CaptureStampCorrection:
    def __init__(self, camera: CameraSection) -> None:
        self.online = camera.delay_estimate
        self.estimator = CameraDelayEstimator(
            camera.delay_ms * 1e-3, max_spread_s=SPREAD_PER_FRAME * camera.frame_period_s
        )
        self.shift = ImageShift(camera.width_px, camera.height_px)
        self.shift_time = LatencyWindow(default_s=0.0, size=TIMING_WINDOW)
        self.fit_time = LatencyWindow(default_s=0.0, size=TIMING_WINDOW)
        self._last_arrival_s: float | None = None
        # a pixel's angle: a pose known to within it is as good as exact for the detectors
        self.pixel_rad = 1.0 / CameraModel.from_section(camera).focal_px
        self.pose_known = True
        # where the head's pose at the last frame's exposure is read (None: at its stamp)
        self.pose_ns: int | None = None
        self.applied_ms = 0.0  # the delay the last frame's stamp was moved back by
        # the last frame known exposed with the head still (its arrival), and the image's
        # motion since it
        self._still_ns: int | None = None
        self._moved_px = (0.0, 0.0)

    def add_odometry(self, odometry: Odometry) -> None:
        if self.online:
            self.estimator.add_odometry(
                odometry.t_capture_ns * 1e-9, odometry.pan_rad, odometry.tilt_rad
            )

    def frame(self, frame: CapturedFrame, gray: np.ndarray) -> CapturedFrame:
        """The frame stamped at its exposure; `gray` (its grey pixels) feeds the estimate.
        `pose_known` then says whether the head's pose at that exposure is known: not while the
        online estimate has no fit yet and the head moved over the exposure times it allows,
        unless the image has not moved since a frame exposed with the head still; `pose_ns`
        says where that pose is read."""
        self.pose_known = True
        self.pose_ns = None
        self.applied_ms = 0.0
        if frame.head is not None:
            return frame
        arrival_s = frame.t_capture_ns * 1e-9
        if self.online:
            started = time.perf_counter()
            shift = self.shift.update(gray)
            if shift is not None and self._last_arrival_s is not None:
                self.estimator.add_shift(self._last_arrival_s, arrival_s, *shift)
            self._last_arrival_s = arrival_s
            fitting = time.perf_counter()
            self.shift_time.add(fitting - started)
            if self.estimator.fit_due(arrival_s):
                self.estimator.update(arrival_s)
                self.fit_time.add(time.perf_counter() - fitting)
            self._know_pose(frame.t_capture_ns, shift)
        delay_ns = round(self.estimator.delay_s * 1e9)
        self.applied_ms = delay_ns * 1e-6
        return dataclasses.replace(frame, t_capture_ns=frame.t_capture_ns - delay_ns)

    def _know_pose(self, arrival_ns: int, shift: tuple[float, float, float] | None) -> None:
        """`pose_known` and `pose_ns` for a frame that arrived at `arrival_ns`, its image
        shifted by `shift` from the frame before."""
        if self.estimator.fits:
            self._still_ns = None
            return
        if self.estimator.still_before(arrival_ns * 1e-9, self.pixel_rad):
            self._still_ns, self._moved_px = arrival_ns, (0.0, 0.0)
            return
        if self._still_ns is not None and shift is not None:
            du, dv, response = shift
            self._moved_px = (self._moved_px[0] + du, self._moved_px[1] + dv)
            steady = math.hypot(*self._moved_px) < STILL_SHIFT_PX
            if steady and response >= self.estimator.min_response:
                self.pose_ns = self._still_ns  # the head stood still there, as it did here
                return
        self._still_ns = None
        self.pose_known = False

    def note(self) -> str:
        """The delay applied, and where it comes from."""
        applied_ms = self.estimator.delay_s * 1e3
        if not self.online:
            return f"{applied_ms:.1f} ms ([camera] delay_ms; online estimate off)"
        fit = self.estimator.last_fit
        if fit is None:
            return f"{applied_ms:.1f} ms (not estimated yet: the head has not moved enough)"
        return (
            f"{applied_ms:.1f} ms (online: {self.estimator.fits} fits, last "
            f"{fit.lag_s * 1e3:.1f} ms explaining {fit.explained:.0%} of the image's motion)"
        )

    def stage_ms(self) -> dict[str, float]:
        """The delay applied, the shift's median cost per frame and the fit's (on every frame
        until the first fit, then twice a second)."""
        times = {"camera_delay": round(self.estimator.delay_s * 1e3, 3)}
        if self.shift_time.count:
            times["camera_delay_shift_median"] = round(self.shift_time.median_s * 1e3, 3)
        if self.fit_time.count:
            times["camera_delay_fit_median"] = round(self.fit_time.median_s * 1e3, 3)
        return times
