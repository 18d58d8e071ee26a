"""The head's recent odometry, and its pose at any instant in between (a frame's capture time).

Odometry arrives as `servo/odometry` samples (angles and rates, stamped when they were read);
frames arrive later and are stamped when they were captured. `pose_at(t)` interpolates angles
and rates linearly between the two samples around `t`, across gaps of at most `max_gap_s`.
After the newest sample it extrapolates with the newest rates, but only by two of the stream's
own periods (the median interval between its recent samples; at most `max_gap_s`): a stream
that has fallen further behind has stalled — a servo process killed, a link lost — and its
head has most likely stopped rather than kept turning at its last rate. Beyond that, or before
the oldest sample, there is no pose (and no ego-motion compensation). The zoom, where the
head reports one, is interpolated the same way and held past the newest sample.
"""

from __future__ import annotations

import bisect
import statistics
from collections import deque

from gazed.messages import HeadPose, Odometry

EXTRAPOLATION_PERIODS = 2  # how far past the newest sample, in the stream's own periods
INTERVALS_KEPT = 16  # recent intervals between samples whose median is the period


class OdometryHistory:
    def __init__(self, span_s: float, max_gap_s: float) -> None:
        self.span_ns = int(span_s * 1e9)
        self.max_gap_ns = int(max_gap_s * 1e9)
        self._times: list[int] = []
        self._samples: list[Odometry] = []
        self._intervals: deque[int] = deque(maxlen=INTERVALS_KEPT)

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
        if self._times and t > self._times[-1]:
            self._intervals.append(t - self._times[-1])
        i = bisect.bisect_left(self._times, t)
        if i < len(self._times) and self._times[i] == t:
            self._samples[i] = odometry
        else:
            self._times.insert(i, t)
            self._samples.insert(i, odometry)
        cut = bisect.bisect_left(self._times, self._times[-1] - self.span_ns)
        del self._times[:cut], self._samples[:cut]
        return True

    def extrapolation_ns(self) -> int:
        """How far past the newest sample a pose is still given."""
        if not self._intervals:
            return self.max_gap_ns
        period_ns = statistics.median_low(self._intervals)
        return min(self.max_gap_ns, EXTRAPOLATION_PERIODS * period_ns)

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
            if gap > self.extrapolation_ns():
                return None
            dt_s = gap * 1e-9
            return HeadPose(
                pan_rad=before.pan_rad + before.pan_rate_rad_s * dt_s,
                tilt_rad=before.tilt_rad + before.tilt_rate_rad_s * dt_s,
                pan_rate_rad_s=before.pan_rate_rad_s,
                tilt_rate_rad_s=before.tilt_rate_rad_s,
                zoom=before.zoom,
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
            zoom=_between(before.zoom, after.zoom, a),
        )


def _between(before: float | None, after: float | None, a: float) -> float | None:
    """The zoom a fraction `a` of the way between two readings (None unless both have one)."""
    if before is None or after is None:
        return None
    return before + a * (after - before)
