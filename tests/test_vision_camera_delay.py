"""The camera-delay estimator on synthetic signals: a known lag between the image's shifts and
the odometry is recovered; a still head or one turning at a constant rate gives no update;
wrong shifts among the good ones do not move the estimate; one motion onset identifies the lag,
a stretch that several lags explain alike is not taken; a map from the head's rotation to
the image's shift that hides a direction of the head's motion is not fitted; the window is
fitted on every frame until the first fit, then every `fit_every_s`. `ImageShift` measures a
known translation of a textured image."""

from __future__ import annotations

import math
from collections.abc import Callable

import cv2
import numpy as np
import pytest

from gazed.vision import camera_delay
from gazed.vision.camera_delay import CameraDelayEstimator, ImageShift, fit_lag

FOCAL_PX = 550.0
PERIOD_S = 0.04
LAGS_S = np.arange(-0.1, 1.0 + 1e-9, 0.005)


def pan_of(t_s: np.ndarray) -> np.ndarray:
    """A head that pans back and forth at changing rates (radians)."""
    return 0.3 * np.sin(1.7 * t_s) + 0.1 * np.sin(4.1 * t_s + 0.5)


def tilt_of(t_s: np.ndarray) -> np.ndarray:
    return 0.05 * np.sin(2.3 * t_s)


def synthetic(
    lag_s: float,
    seconds: float = 4.0,
    noise_px: float = 0.2,
    seed: int = 3,
    pan: Callable[[np.ndarray], np.ndarray] = pan_of,
    tilt: Callable[[np.ndarray], np.ndarray] = tilt_of,
) -> tuple[np.ndarray, np.ndarray]:
    """(shifts, odometry) as `fit_lag` takes them: frames exposed every PERIOD_S and stamped
    `lag_s` later, the image moving opposite the pan; odometry at 100 Hz."""
    rng = np.random.default_rng(seed)
    exposure = np.arange(1.0, 1.0 + seconds, PERIOD_S)
    a, b = exposure[:-1], exposure[1:]
    du = -FOCAL_PX * (pan(b) - pan(a)) + rng.normal(0, noise_px, len(a))
    dv = FOCAL_PX * (tilt(b) - tilt(a)) + rng.normal(0, noise_px, len(a))
    shifts = np.stack([a + lag_s, b + lag_s, du, dv], axis=1)
    t = np.arange(0.0, 1.0 + seconds + lag_s + 0.5, 0.01)
    odometry = np.stack([t, pan(t), tilt(t)], axis=1)
    return shifts, odometry


@pytest.mark.parametrize("lag_s", [0.0, 0.08, 0.15, 0.4])
def test_a_known_lag_is_recovered(lag_s: float) -> None:
    shifts, odometry = synthetic(lag_s)
    fit = fit_lag(shifts, odometry, LAGS_S, math.radians(2.0), 0.6)
    assert fit is not None
    assert fit.lag_s == pytest.approx(lag_s, abs=0.004)
    assert fit.explained > 0.95


def still(t_s: np.ndarray) -> np.ndarray:
    return 0.0 * t_s + 0.2


def test_a_still_head_or_a_constant_rate_gives_no_fit() -> None:
    for pan in (still, lambda t: 0.5 * t):  # still; 29 deg/s throughout
        shifts, odometry = synthetic(0.15, pan=pan, tilt=still)
        assert fit_lag(shifts, odometry, LAGS_S, math.radians(2.0), 0.6) is None


def test_a_still_head_costs_no_grid(monkeypatch: pytest.MonkeyPatch) -> None:
    """Before the first fit every frame is fitted: while the head stands still the odometry's
    rates alone rule every lag out, and the grid is never interpolated."""
    shifts, odometry = synthetic(0.15, pan=still, tilt=still)

    def no_grid(*_: object) -> np.ndarray:
        raise AssertionError("the lag grid was interpolated for a still head")

    monkeypatch.setattr(camera_delay, "_rotations", no_grid)
    assert fit_lag(shifts, odometry, LAGS_S, math.radians(2.0), 0.6) is None


def test_wrong_shifts_do_not_move_the_estimate() -> None:
    shifts, odometry = synthetic(0.15)
    rng = np.random.default_rng(7)
    wrong = rng.choice(len(shifts), size=len(shifts) // 8, replace=False)
    shifts[wrong, 2:] = rng.uniform(-40.0, 40.0, size=(len(wrong), 2))
    fit = fit_lag(shifts, odometry, LAGS_S, math.radians(2.0), 0.6)
    assert fit is not None
    assert fit.lag_s == pytest.approx(0.15, abs=0.005)
    assert fit.inliers <= len(shifts) - len(wrong)


def test_the_estimator_converges_fitting_each_frame_until_its_first_fit() -> None:
    """The first fit as soon as the shifts identify the lag (well before they span the lag
    grid), right and applied at once."""
    shifts, odometry = synthetic(0.2, seconds=6.0)
    estimator = CameraDelayEstimator(0.0)
    assert estimator.delay_s == 0.0  # nothing known yet: the stamp as it came
    grid_s = estimator.lags_s[-1] - estimator.lags_s[0]
    first: float | None = None
    read = 0
    for a, b, du, dv in shifts:  # the odometry read up to each frame's arrival, as it comes
        while read < len(odometry) and odometry[read, 0] <= b:
            estimator.add_odometry(*odometry[read])
            read += 1
        estimator.add_shift(a, b, du, dv)
        if first is None:  # no fit yet: every frame is tried
            assert estimator.fit_due(b)
        if estimator.update(b) and first is None:
            first = b
            assert estimator.delay_s == pytest.approx(0.2, abs=0.005)  # taken at once
            assert not estimator.fit_due(b + PERIOD_S)  # then every fit_every_s
            assert estimator.fit_due(b + estimator.fit_every_s)
    assert first is not None and first - shifts[0, 0] < grid_s - PERIOD_S
    assert estimator.fits >= 5
    assert estimator.delay_s == pytest.approx(0.2, abs=0.005)


def onset(t_s: np.ndarray) -> np.ndarray:
    """A head still until 1.5 s, then one saccade of 0.3 rad over 0.3 s (minimum jerk)."""
    s = np.clip((t_s - 1.5) / 0.3, 0.0, 1.0)
    return 0.3 * (10 * s**3 - 15 * s**4 + 6 * s**5)


@pytest.mark.parametrize("lag_s", [0.08, 0.2, 0.4])
def test_one_motion_onset_identifies_the_lag(lag_s: float) -> None:
    """The head's first saccade, seen in the image a lag later, is enough: the lags that
    explain the shifts as well lie within a few milliseconds of the fit."""
    shifts, odometry = synthetic(lag_s, seconds=1.0, pan=onset, tilt=still)
    fit = fit_lag(shifts, odometry, LAGS_S, math.radians(2.0), 0.6)
    assert fit is not None
    assert fit.lag_s == pytest.approx(lag_s, abs=0.004)
    assert fit.spread_s < 0.005


@pytest.mark.parametrize("lag_s", [0.0, 0.2, 0.4])
def test_the_first_fit_comes_as_the_odometry_reaches_the_newest_frame(lag_s: float) -> None:
    """Fed as they come (the odometry up to each frame's arrival), the head's first saccade
    gives its fit a few frames after the image first moves: a frame pair counts once the
    odometry reaches its arrival, not a negative lag's span later."""
    shifts, odometry = synthetic(lag_s, seconds=2.0, pan=onset, tilt=still)
    estimator = CameraDelayEstimator(0.0)
    read, first_s = 0, None
    for a, b, du, dv in shifts:
        while read < len(odometry) and odometry[read, 0] <= b:
            estimator.add_odometry(*odometry[read])
            read += 1
        estimator.add_shift(a, b, du, dv)
        if estimator.update(b) and first_s is None:
            first_s = b - lag_s  # the exposure of the frame that gave the first fit
            assert estimator.delay_s == pytest.approx(lag_s, abs=0.004)
    assert first_s is not None and first_s - 1.5 <= 4 * PERIOD_S  # the onset at 1.5 s


# a closed-loop run's window at the frame that first showed the head's first saccade (a hidden
# 200 ms delay): arrival stamps (s), shifts (px), odometry (s, rad); the head's first move runs
# along pan = -tilt, then in tilt alone, and two frames show it
FIRST_SACCADE_ARRIVALS_S = [-0.04, 0.0, 0.04, 0.08, 0.12, 0.16, 0.2, 0.24, 0.28, 0.32, 0.4]
FIRST_SACCADE_ARRIVALS_S += [0.44, 0.48, 0.52, 0.56, 0.6, 0.64, 0.68, 0.72]
FIRST_SACCADE_SHIFTS_PX = [
    [-0.03, -0.12], [0.12, -0.02], [0.12, -0.02], [0.11, -0.01], [0.09, -0.01], [-0.06, -0.01],
    [0.19, -0.03], [-0.08, 0.16], [0.1, 0.07], [1.47, -0.13], [-0.25, 0.09], [0.2, -0.05],
    [-0.31, 0.04], [0.22, -0.06], [-0.07, 0.11], [-0.09, -0.12], [-3.54, -3.43], [-10.6, -11.65],
]  # fmt: skip
FIRST_SACCADE_ODOMETRY = [
    [-1.194, 0.0, 0.0], [0.426, 0.0, 0.0], [0.446, 0.00153, -0.00153],
    [0.466, 0.00307, -0.00307], [0.486, 0.0092, -0.0092], [0.507, 0.01841, -0.01841],
    [0.537, 0.03835, -0.03835], [0.565, 0.05522, -0.05983], [0.58, 0.06443, -0.07517],
    [0.601, 0.0721, -0.09357], [0.621, 0.0767, -0.10891], [0.646, 0.0767, -0.12425],
    [0.667, 0.0767, -0.13499], [0.688, 0.0767, -0.13959], [0.709, 0.0767, -0.14113],
    [0.78, 0.0767, -0.14113], [0.784, 0.0767, -0.14113], [0.81, 0.0767, -0.14113],
    [0.822, 0.0767, -0.14113],
]  # fmt: skip


def test_a_map_that_hides_part_of_the_motion_is_not_fitted() -> None:
    """Two frames show the head's first saccade. A free 2x2 map from the rotation to the shift
    could make the saccade's first part (pan = -tilt) invisible and match its tilt-only end to
    those frames a lag 90 ms short; pan moves a camera's image along one axis and tilt along
    the other, and the fit that allows only such maps finds the true lag."""
    arrivals = np.array(FIRST_SACCADE_ARRIVALS_S)
    shifts = np.column_stack([arrivals[:-1], arrivals[1:], FIRST_SACCADE_SHIFTS_PX])
    fit = fit_lag(shifts, np.array(FIRST_SACCADE_ODOMETRY), LAGS_S, math.radians(2.0), 0.6)
    assert fit is not None
    assert fit.lag_s == pytest.approx(0.2, abs=0.01)


def slow(t_s: np.ndarray) -> np.ndarray:
    return 0.05 * np.sin(1.3 * t_s)


def test_a_lag_that_others_explain_as_well_is_not_taken() -> None:
    """A slow pan under noisy shifts: the best lag's neighbours a frame and more away explain
    the shifts as well, so the fit's spread says so and the estimator keeps its estimate."""
    shifts, odometry = synthetic(0.2, seconds=2.0, noise_px=0.5, pan=slow, tilt=still)
    rate_std_rad_s = math.radians(0.5)
    fit = fit_lag(shifts, odometry, LAGS_S, rate_std_rad_s, 0.6)
    assert fit is not None and fit.spread_s > PERIOD_S
    estimator = CameraDelayEstimator(0.12, min_rate_std_rad_s=rate_std_rad_s)
    for t_s, pan, tilt in odometry:
        estimator.add_odometry(t_s, pan, tilt)
    for a, b, du, dv in shifts:
        estimator.add_shift(a, b, du, dv)
    assert not estimator.update(shifts[-1, 1])
    assert estimator.fits == 0 and estimator.delay_s == 0.12


def test_no_motion_leaves_the_estimate_where_it_was() -> None:
    shifts, odometry = synthetic(0.2, pan=still, tilt=still)
    estimator = CameraDelayEstimator(0.12)
    for t_s, pan, tilt in odometry:
        estimator.add_odometry(t_s, pan, tilt)
    for a, b, du, dv in shifts:
        estimator.add_shift(a, b, du, dv)
        assert not estimator.update(b)
    assert estimator.fits == 0 and estimator.delay_s == 0.12


def test_a_weak_correlation_or_a_gap_is_left_out() -> None:
    estimator = CameraDelayEstimator()
    estimator.add_shift(1.0, 1.04, 3.0, 0.0, response=0.01)
    estimator.add_shift(1.0, 2.0, 3.0, 0.0)
    estimator.add_shift(1.0, 1.04, math.nan, 0.0)
    assert not estimator.update(2.0)
    estimator.add_shift(1.0, 1.04, 3.0, 0.0)
    assert len(estimator._shifts) == 1


def test_image_shift_measures_a_translation() -> None:
    rng = np.random.default_rng(1)
    texture = cv2.GaussianBlur(rng.integers(0, 256, size=(520, 700)).astype(np.uint8), (0, 0), 2)
    shift = ImageShift(640, 480)
    assert shift.update(texture[20:500, 30:670]) is None
    du, dv, response = shift.update(texture[20 + 6 : 500 + 6, 30 - 12 : 670 - 12])
    assert (du, dv) == pytest.approx((12.0, -6.0), abs=1.0)
    assert response > 0.3
