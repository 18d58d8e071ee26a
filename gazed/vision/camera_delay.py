"""The camera's delay from exposure to arrival, estimated from the image's global motion against
the head's odometry.

A camera pipeline (encoder, network, decoder) stamps a frame when it arrives, a delay after the
light hit the sensor. Between two consecutive frames the background shifts by the head's
rotation between their exposures. `ImageShift` measures that shift by phase correlation on a
small grey copy of each frame. `fit_lag` finds the lag tau for which the odometry's rotation
between (a - tau) and (b - tau), a and b the two frames' arrival stamps, explains the shifts
best: for each lag on a grid, the least-squares map from the rotation (pan, tilt) to the shift
(u, v) in which pan moves the image along one axis and tilt along the other, each by its own
gain (u from pan and v from tilt, or swapped for a camera turned a quarter), and its residual.
Signs and scales are fitted, so no axis direction or focal length is assumed, and each axis
has its own scale because pan's falls with the cosine of the tilt. A free 2x2 map could be
near singular and hide one direction of the head's motion (pan = -tilt, say), and a similarity
could turn the motion to any direction: either lets a lag that maps a few moving frames onto
the wrong part of a move explain them as well as the true one. This map hides a direction only
by dropping a whole axis, which the image's motion along that axis contradicts, and it keeps
the motion on its axes; a camera rolled on its mount leaves the small cross term in the
residual. The best grid lag is refined by a parabola through its neighbours, and the lags
whose residual exceeds the best one's by less than a likelihood-ratio test's threshold (99 %,
one degree of freedom, the residual's own variance) give the fit's spread: how closely the
data identify the lag. Shifts far from the fit (three robust standard deviations, from the
median absolute residual) — a failed correlation, the target filling the frame — are dropped
and the fit repeated. A residual under
a fifth of the large shifts never counts as far: with the head still half the time, the median
residual alone would call every moving frame an outlier. A fit counts only when the head's
rates varied over the window at some lag (a still head, or one turning at a constant rate,
shows no lag) and the rotation explains most of the shifts.

`CameraDelayEstimator` keeps a sliding window of shifts and odometry and takes the median of
the recent fits whose spread is within `max_spread_s` as its estimate: the window need not span
the lag grid, since one motion onset seen in both the odometry and the image identifies the lag,
and a stretch that several lags explain alike (a short, slow or noisy one, where the fitted gain
trades against the lag) shows as a wide spread. The spread is the least the lag is uncertain by
(a short window's residuals are not independent: neighbouring shifts share a frame, and the
model's mismatch lasts), so the gate asks for a fraction of the error the stamps may keep. It
fits on every frame until the first fit succeeds, then every `fit_every_s`: until the first fit
the stamps are wrong by the whole delay, and the frames that make the first fit possible (the
head's first saccade, seen a delay later) are the ones to use at once; a frame pair counts as
soon as the odometry reaches its arrival (a frame arrives after its exposure), so the first fit
comes with the first frames that show the move. Each frame's stamp
moves back by the estimate as it stands (`correction_s`), with no ramp: stamps wrong by an
error e pair each frame with the head's pose e later, so the target
appears displaced along the head's motion and the loop drives the head further that way, and a
ramp keeps them wrong longer while it also shrinks every frame interval on its way (the
detectors' velocities and ego-motion). A jump back by more than a frame interval costs instead
one restart of the detectors (a stamp not after the previous one); each detection carries the
delay applied to it, and the estimator moves its tracks' times by a change of it, so that they
stay those of the frames' exposures.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import cv2
import numpy as np

GRID_WIDTH_PX = 160  # width of the grey copy the shift is measured on
MAD_TO_SIGMA = 1.4826  # median absolute deviation -> standard deviation of a normal
OUTLIER_SIGMAS = 3.0
SHIFT_PRECISION_PX = 0.25  # residuals below this are never outliers
SHIFT_FRACTION = (
    0.2  # nor those below this share of the large shifts (the head still half the time)
)
CHI2_1DOF_99 = 6.635  # chi-square, one degree of freedom: a likelihood-ratio test at 99 %


class ImageShift:
    """The global shift (full-frame pixels) of each grey frame from the one before."""

    def __init__(self, width_px: int, height_px: int, grid_width_px: int = GRID_WIDTH_PX) -> None:
        grid_width_px = min(grid_width_px, width_px)
        grid_height_px = max(16, round(height_px * grid_width_px / width_px))
        self.size = (grid_width_px, grid_height_px)
        self.scale = (width_px / grid_width_px, height_px / grid_height_px)
        self.window = cv2.createHanningWindow(self.size, cv2.CV_32F)
        self._previous: np.ndarray | None = None

    def reset(self) -> None:
        self._previous = None

    def update(self, gray: np.ndarray) -> tuple[float, float, float] | None:
        """(du_px, dv_px, response) from the previous frame to `gray`; None for the first.
        The response (0-1) is the correlation peak's height: near 0 the shift is noise."""
        small = cv2.resize(gray, self.size, interpolation=cv2.INTER_AREA).astype(np.float32)
        previous, self._previous = self._previous, small
        if previous is None:
            return None
        (du, dv), response = cv2.phaseCorrelate(previous, small, self.window)
        return du * self.scale[0], dv * self.scale[1], float(response)


@dataclass(frozen=True)
class LagFit:
    """The lag that explains the shifts best, the share of their energy it explains, how many
    shifts it kept, and how far from it the farthest lag that explains them as well lies
    (`fit_lag`): how closely the data identify the lag."""

    lag_s: float
    explained: float
    inliers: int
    spread_s: float


def fit_lag(
    shifts: np.ndarray,
    odometry: np.ndarray,
    lags_s: np.ndarray,
    min_rate_std_rad_s: float,
    min_explained: float,
) -> LagFit | None:
    """The lag from exposure to arrival. `shifts` (N, 4): a_s, b_s, du_px, dv_px (the arrival
    stamps of a frame pair and the image's shift between them); `odometry` (M, 3): t_s, pan_rad,
    tilt_rad in time order; `lags_s` (K,) the grid, evenly spaced. None when the head's rates
    did not vary enough, the best lag is on the grid's edge, or the fit explains too little."""
    if len(odometry) < 2 or len(shifts) < 4 or len(lags_s) < 3:
        return None
    t, angles = odometry[:, 0], odometry[:, 1:]
    a, b, y = shifts[:, 0], shifts[:, 1], shifts[:, 2:]
    # a pair counts once the odometry reaches its arrival: a frame arrives after its exposure,
    # and a negative lag, on the grid only so that a delay near zero is not on its edge, reads
    # the newest angle for the instants past it
    covered = (a - lags_s[-1] >= t[0]) & (b - max(float(lags_s[0]), 0.0) <= t[-1]) & (b > a)
    a, b, y = a[covered], b[covered], y[covered]
    if len(a) < 4:
        return None
    # the odometry's own rates over every time a lag can map a frame to: frame pairs' rates
    # are averages of them, so where these stay within a band of twice the least deviation
    # asked for, no lag's pairs deviate that much (a still head costs no grid)
    reach = (t[1:] >= a.min() - lags_s[-1]) & (t[:-1] <= b.max() - lags_s[0])
    odometry_rates = np.diff(angles, axis=0)[reach] / np.diff(t)[reach, None]
    if not np.any(np.ptp(odometry_rates, axis=0) >= 2.0 * min_rate_std_rad_s):
        return None
    x = _rotations(t, angles, a, b, lags_s)  # (K, N, 2)
    rates = x / (b - a)[None, :, None]
    if not np.any(rates.std(axis=1) >= min_rate_std_rad_s):
        return None  # at no lag did the head's rates vary over the frame pairs
    keep = np.ones(len(a), dtype=bool)
    floor_px = max(
        SHIFT_PRECISION_PX, SHIFT_FRACTION * float(np.percentile(np.linalg.norm(y, axis=1), 90))
    )
    for _ in range(3):  # fit, drop the shifts far from it, fit again
        if keep.sum() < 4:
            return None
        costs, gains = _costs(x[:, keep], y[keep])
        k = int(np.argmin(costs))
        norms = np.linalg.norm(y - x[k] @ gains[k], axis=1)
        scale = MAD_TO_SIGMA * float(np.median(norms[keep]))
        inliers = norms <= max(OUTLIER_SIGMAS * scale, floor_px)
        if np.array_equal(inliers, keep):
            break
        keep = inliers
    else:
        if keep.sum() < 4:
            return None
        costs, _ = _costs(x[:, keep], y[keep])
        k = int(np.argmin(costs))
    if k == 0 or k == len(lags_s) - 1:
        return None
    explained = 1.0 - costs[k] / max(float(np.sum(y[keep] ** 2)), 1e-12)
    if explained < min_explained:
        return None
    c0, c1, c2 = costs[k - 1], costs[k], costs[k + 1]
    curvature = c0 - 2.0 * c1 + c2
    offset = 0.5 * (c0 - c2) / curvature if curvature > 0 else 0.0
    step_s = float(lags_s[1] - lags_s[0])
    inliers = int(keep.sum())
    # the residual's variance per component (two per shift, two gains fitted); the lags whose
    # residual energy exceeds the best one's by less than the test's threshold times it
    # explain the shifts as well, to the residual's noise
    variance = costs[k] / max(2 * inliers - 2, 1)
    lag_s = float(lags_s[k] + offset * step_s)
    alike = lags_s[costs <= costs[k] + CHI2_1DOF_99 * variance]
    spread_s = float(np.max(np.abs(alike - lag_s))) if alike.size else 0.0
    return LagFit(lag_s, float(explained), inliers, spread_s)


def _rotations(
    t: np.ndarray, angles: np.ndarray, a: np.ndarray, b: np.ndarray, lags_s: np.ndarray
) -> np.ndarray:
    """(K, N, 2): the head's rotation (pan, tilt) between a - lag and b - lag, per lag."""
    ta = a[None, :] - lags_s[:, None]
    tb = b[None, :] - lags_s[:, None]
    return np.stack(
        [np.interp(tb, t, angles[:, j]) - np.interp(ta, t, angles[:, j]) for j in (0, 1)],
        axis=-1,
    )


def _costs(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per lag: the residual energy of y (N, 2) ~ x (K, N, 2) @ G, G the map that fits best of
    those where pan moves the image along one axis and tilt along the other (u from pan and v
    from tilt, or swapped), each by its own gain; and G (K, 2, 2). Each axis is a
    one-dimensional least squares: the gain sum(x y) / sum(x^2) explains (sum(x y))^2 / sum(x^2)
    of the axis's energy."""
    pan, tilt = x[..., 0], x[..., 1]
    s_pp = np.sum(pan * pan, axis=1) + 1e-30
    s_tt = np.sum(tilt * tilt, axis=1) + 1e-30
    u_pan, v_tilt = pan @ y[:, 0], tilt @ y[:, 1]
    u_tilt, v_pan = tilt @ y[:, 0], pan @ y[:, 1]
    straight = u_pan**2 / s_pp + v_tilt**2 / s_tt
    swapped = u_tilt**2 / s_tt + v_pan**2 / s_pp
    is_straight = (straight >= swapped)[:, None]
    zero = np.zeros_like(u_pan)
    # rows of G (y_row = x_row @ G): pan's, then tilt's
    pan_row = np.where(
        is_straight, np.stack([u_pan / s_pp, zero], -1), np.stack([zero, v_pan / s_pp], -1)
    )
    tilt_row = np.where(
        is_straight, np.stack([zero, v_tilt / s_tt], -1), np.stack([u_tilt / s_tt, zero], -1)
    )
    gains = np.stack([pan_row, tilt_row], axis=1)
    return float(np.sum(y * y)) - np.maximum(straight, swapped), gains


class CameraDelayEstimator:
    """The camera's delay from exposure to arrival (seconds), from shifts and odometry given
    with their stamps (wall-clock seconds). Starts at `initial_s`, the delay the rig states."""

    def __init__(
        self,
        initial_s: float = 0.0,
        *,
        window_s: float = 4.0,
        min_delay_s: float = -0.1,
        max_delay_s: float = 1.0,
        step_s: float = 0.005,
        fit_every_s: float = 0.5,
        fits_kept: int = 5,
        min_rate_std_rad_s: float = math.radians(2.0),
        min_explained: float = 0.6,
        min_response: float = 0.05,
        max_pair_s: float = 0.25,
        max_spread_s: float = 0.01,
    ) -> None:
        self.delay_s = initial_s
        self.window_s = window_s
        self.lags_s = np.arange(min_delay_s, max_delay_s + step_s / 2, step_s)
        self.fit_every_s = fit_every_s
        self.min_rate_std_rad_s = min_rate_std_rad_s
        self.min_explained = min_explained
        self.min_response = min_response
        self.max_pair_s = max_pair_s
        self.max_spread_s = max_spread_s
        self.fits = 0
        self.last_fit: LagFit | None = None
        self._recent: deque[float] = deque(maxlen=fits_kept)
        self._shifts: deque[tuple[float, float, float, float]] = deque()
        self._odometry: deque[tuple[float, float, float]] = deque()
        self._last_fit_s = -math.inf

    def add_odometry(self, t_s: float, pan_rad: float, tilt_rad: float) -> None:
        if self._odometry and t_s <= self._odometry[-1][0]:
            return  # out of order or repeated: the window stays in time order
        self._odometry.append((t_s, pan_rad, tilt_rad))
        while self._odometry[0][0] < t_s - self.window_s - self.lags_s[-1] - 1.0:
            self._odometry.popleft()

    def add_shift(
        self, t0_s: float, t1_s: float, du_px: float, dv_px: float, response: float = 1.0
    ) -> None:
        """The shift between frames that arrived at `t0_s` and `t1_s`; a weak correlation, a
        non-finite shift or a pair too far apart is left out."""
        if response < self.min_response or not 0.0 < t1_s - t0_s <= self.max_pair_s:
            return
        if not (math.isfinite(du_px) and math.isfinite(dv_px)):
            return
        self._shifts.append((t0_s, t1_s, du_px, dv_px))
        while self._shifts[0][1] < t1_s - self.window_s:
            self._shifts.popleft()

    def still_before(self, arrival_s: float, tolerance_rad: float) -> bool:
        """Whether the head stood still (pan and tilt within `tolerance_rad`) over every
        exposure time the lag grid allows for a frame that arrived at `arrival_s`: then the
        frame's pose is known whatever the delay. A frame arrives after its exposure, so the
        grid's negative lags (there so that a delay near zero is not on the grid's edge) are no
        exposure times: the odometry a frame processed late finds past its arrival (the head's
        first move, commanded from the frames before it) leaves its pose known."""
        if not self._odometry:
            return False
        odometry = np.array(self._odometry)
        t0_s, t1_s = arrival_s - self.lags_s[-1], arrival_s - max(float(self.lags_s[0]), 0.0)
        if odometry[0, 0] > t0_s:
            return False  # the odometry does not reach back that far
        inside = odometry[(odometry[:, 0] >= t0_s) & (odometry[:, 0] <= t1_s), 1:]
        ends = [np.interp(t, odometry[:, 0], odometry[:, j]) for t in (t0_s, t1_s) for j in (1, 2)]
        angles = np.vstack([inside, np.reshape(ends, (2, 2))])
        return bool(np.all(np.ptp(angles, axis=0) <= tolerance_rad))

    def fit_due(self, now_s: float) -> bool:
        """Whether `update(now_s)` would fit the window: there are shifts, and no fit has
        succeeded yet or `fit_every_s` has passed since the last."""
        every_s = self.fit_every_s if self.fits else 0.0
        return bool(self._shifts) and now_s - self._last_fit_s >= every_s

    def update(self, now_s: float) -> bool:
        """Fit the window if due (`fit_due`); whether the estimate took a new fit."""
        if not self.fit_due(now_s):
            return False
        self._last_fit_s = now_s
        fit = fit_lag(
            np.array(self._shifts),
            np.array(self._odometry) if self._odometry else np.empty((0, 3)),
            self.lags_s,
            self.min_rate_std_rad_s,
            self.min_explained,
        )
        if fit is None or fit.spread_s > self.max_spread_s:
            return False  # no lag explains the shifts, or several explain them alike
        self.last_fit = fit
        self.fits += 1
        self._recent.append(fit.lag_s)
        self.delay_s = float(np.median(self._recent))
        return True
