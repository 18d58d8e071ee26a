"""The head's recent odometry, and its pose at any instant in between (a frame's capture time).

Odometry arrives as `servo/odometry` samples (angles and rates, stamped when they were read);
frames arrive later and are stamped when they were captured. `pose_at(t)` interpolates angles
and rates linearly between the two samples around `t`; after the newest sample it extrapolates
with the newest rates. Either only across gaps of at most `max_gap_s`: beyond that, or before
the oldest sample, there is no pose (and no ego-motion compensation).
"""

from __future__ import annotations

import bisect

from gazed.messages import HeadPose, Odometry


class OdometryHistory:
    def __init__(self, span_s: float, max_gap_s: float) -> None:
        self.span_ns = int(span_s * 1e9)
        self.max_gap_ns = int(max_gap_s * 1e9)
        self._times: list[int] = []
        self._samples: list[Odometry] = []

    def __len__(self) -> int:
        return len(self._samples)

    def add(self, odometry: Odometry, now_ns: int | None = None) -> bool:
        """Insert in time order (a repeated time replaces); forget what is older than the span.

        Live, with `now_ns` (the local wall clock): a sample stamped more than `max_gap_s` after
        it is refused (False), since one bogus future stamp would otherwise push every real
        sample out of the span."""
        t = odometry.t_capture_ns
        if now_ns is not None and t - now_ns > self.max_gap_ns:
            return False
        i = bisect.bisect_left(self._times, t)
        if i < len(self._times) and self._times[i] == t:
            self._samples[i] = odometry
        else:
            self._times.insert(i, t)
            self._samples.insert(i, odometry)
        cut = bisect.bisect_left(self._times, self._times[-1] - self.span_ns)
        del self._times[:cut], self._samples[:cut]
        return True

    def newest_ns(self) -> int | None:
        return self._times[-1] if self._times else None

    def pose_at(self, t_ns: int) -> HeadPose | None:
        """Angles and rates at `t_ns`; None when odometry does not cover it."""
        if not self._times:
            return None
        i = bisect.bisect_right(self._times, t_ns)
        if i == 0:
            return None
        before = self._samples[i - 1]
        if i == len(self._times):
            gap = t_ns - self._times[-1]
            if gap > self.max_gap_ns:
                return None
            dt_s = gap * 1e-9
            return HeadPose(
                pan_rad=before.pan_rad + before.pan_rate_rad_s * dt_s,
                tilt_rad=before.tilt_rad + before.tilt_rate_rad_s * dt_s,
                pan_rate_rad_s=before.pan_rate_rad_s,
                tilt_rate_rad_s=before.tilt_rate_rad_s,
            )
        after = self._samples[i]
        span = self._times[i] - self._times[i - 1]
        if span > self.max_gap_ns:
            return None
        a = (t_ns - self._times[i - 1]) / span
        return HeadPose(
            pan_rad=before.pan_rad + a * (after.pan_rad - before.pan_rad),
            tilt_rad=before.tilt_rad + a * (after.tilt_rad - before.tilt_rad),
            pan_rate_rad_s=before.pan_rate_rad_s
            + a * (after.pan_rate_rad_s - before.pan_rate_rad_s),
            tilt_rate_rad_s=before.tilt_rate_rad_s
            + a * (after.tilt_rate_rad_s - before.tilt_rate_rad_s),
        )

    def clear(self) -> None:
        self._times.clear()
        self._samples.clear()
