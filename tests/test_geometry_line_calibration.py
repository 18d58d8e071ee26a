"""Line calibration (seed 000 §3.2): exact recovery from traced lines with no endpoint
matching, agreement with point calibration, residuals in metres, and every degenerate input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_geometry_pose import RIG_IDS, RIGS, on_ground, synthetic_rig, unit

from gazed.config import HeadSection
from gazed.geometry.calibration import CalibrationError
from gazed.geometry.line_calibration import (
    CalibrationLine,
    calibrate_lines,
    fit_frontal_line,
    ground_line,
)
from gazed.geometry.point_calibration import CalibrationPoint, calibrate_points
from gazed.geometry.pose import CameraPose

SIGMA_RAD = math.radians(0.05)


def traced(
    pose: CameraPose,
    segments: list[tuple[np.ndarray, np.ndarray]],
    samples: int = 9,
    noise_rad: float = 0.0,
    seed: int = 0,
) -> list[CalibrationLine]:
    """Lines along ground segments (a, b), each traced by `samples` gazes between its ends (the
    ends themselves are never used: no endpoint matching)."""
    rng = np.random.default_rng(seed)
    lines = []
    for k, (a, b) in enumerate(segments):
        direction = (b - a) / np.linalg.norm(b - a)
        normal = np.array([-direction[1], direction[0]])
        along = a + (b - a) * np.linspace(0.1, 0.9, samples)[:, None]
        angles = np.column_stack(pose.gaze_angles(on_ground(along)))
        angles = angles + rng.normal(0, noise_rad, angles.shape)
        lines.append(
            CalibrationLine(
                math.atan2(normal[1], normal[0]), float(normal @ a), angles, f"line {k + 1}"
            )
        )
    return lines


def area_segments(ground: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The area's four sides (two pairs of parallel lines) and its two diagonals."""
    a, b, c, d = ground[:4]
    return [(a, b), (b, c), (c, d), (d, a), (a, c), (b, d)]


@pytest.mark.parametrize("rig", RIGS, ids=RIG_IDS)
def test_noise_free_lines_recover_the_homography_and_agree_with_points(rig) -> None:
    pose, ground = synthetic_rig(*rig)
    truth = pose.frontal_to_ground()
    result = calibrate_lines(traced(pose, area_segments(ground)), pose.head, None)
    assert np.abs(unit(result.homography.matrix) - unit(truth.matrix)).max() < 1e-9
    assert result.max_m < 1e-9 * rig[2]
    angles = np.column_stack(pose.gaze_angles(on_ground(ground)))
    points = [
        CalibrationPoint(p, t, x, y, f"point {i}")
        for i, ((p, t), (x, y)) in enumerate(zip(angles, ground, strict=True))
    ]
    from_points = calibrate_points(points, pose.head, None, SIGMA_RAD).homography
    assert np.abs(unit(result.homography.matrix) - unit(from_points.matrix)).max() < 1e-9


def test_a_rectangles_four_sides_suffice_two_pairs_of_parallel_lines() -> None:
    pose, ground = synthetic_rig("tilt-pan", 4.0, 20.0, -20.0, 2)
    result = calibrate_lines(traced(pose, area_segments(ground)[:4]), pose.head, None)
    assert (
        np.abs(unit(result.homography.matrix) - unit(pose.frontal_to_ground().matrix)).max() < 1e-9
    )
    assert result.leave_one_out_m == (None,) * 4


def test_lines_and_points_agree_under_noise() -> None:
    pose, ground = synthetic_rig("pan-tilt", 4.0, 20.0, -20.0, 2)
    rng = np.random.default_rng(21)
    angles = np.column_stack(pose.gaze_angles(on_ground(ground))) + rng.normal(0, SIGMA_RAD, (8, 2))
    points = [
        CalibrationPoint(p, t, x, y, f"point {i}")
        for i, ((p, t), (x, y)) in enumerate(zip(angles, ground, strict=True))
    ]
    from_points = calibrate_points(points, pose.head, None, SIGMA_RAD).homography
    from_lines = calibrate_lines(
        traced(pose, area_segments(ground), noise_rad=SIGMA_RAD, seed=22), pose.head, None
    ).homography
    rays = pose.frontal_to_ground().direction_from_ground(ground)
    difference = np.linalg.norm(
        from_lines.ground_from_direction(rays) - from_points.ground_from_direction(rays), axis=1
    )
    # each is within 5 sqrt(2) sigma (rho² + Zc²) / Zc of the truth
    # (test_geometry_point_calibration)
    rho = np.linalg.norm(ground - pose.centre_m[:2], axis=1)
    scale = math.sqrt(2) * SIGMA_RAD * (rho**2 + 4.0**2) / 4.0
    assert np.all(difference < 2 * 5 * scale)
    assert difference.max() > 0  # the noise did reach both fits


def test_residuals_are_ground_distances() -> None:
    pose, ground = synthetic_rig("pan-tilt", 12.0, 60.0, -30.0, 3)
    lines = traced(pose, area_segments(ground))
    shifted = list(lines)
    wrong = lines[4]
    shifted[4] = CalibrationLine(wrong.phi_rad, wrong.d_m + 0.5, wrong.samples_rad, wrong.label)
    result = calibrate_lines(shifted, pose.head, None)
    held_out = np.array(result.leave_one_out_m, dtype=float)
    # the other five are exact, so their homography puts line 5's samples exactly 0.5 m off it
    assert held_out[4] == pytest.approx(0.5, abs=1e-6)
    # (the others' leave-one-out fits include the wrong line, so theirs are off too)
    assert np.all(held_out > 0.1) and 0.05 < result.rms_m < 0.5


def test_total_least_squares_frontal_line() -> None:
    t = np.linspace(-1.0, 2.0, 7)
    points = np.column_stack([0.3 + 0.8 * t, -0.2 + 0.6 * t])
    u = fit_frontal_line(points)
    assert math.hypot(u[0], u[1]) == pytest.approx(1.0)
    assert np.abs(points @ u[:2] + u[2]).max() < 1e-14
    assert ground_line(math.radians(90.0), 7.9) @ np.array([3.0, 7.9, 1.0]) == pytest.approx(0.0)
    assert ground_line(0.0, 2.0) @ np.array([5.0, 1.0, 1.0]) == pytest.approx(3.0)


SIM_POSE = CameraPose(np.array([0.0, -6.0, 4.0]), math.radians(90))


def segment(a: tuple[float, float], b: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    return np.array(a, dtype=float), np.array(b, dtype=float)


SQUARE = [
    segment((-3, 0), (3, 0)),
    segment((3, 0), (3, 6)),
    segment((3, 6), (-3, 6)),
    segment((-3, 6), (-3, 0)),
]


@pytest.mark.parametrize(
    ("segments", "message"),
    [
        (SQUARE[:3], "need at least 4 lines"),
        (
            [
                segment((-3, 0), (-3, 6)),
                segment((0, 0), (0, 6)),
                segment((3, 0), (3, 6)),
                segment((-3, 2), (3, 2)),
            ],
            "line 1, line 2 and line 3 are parallel on the ground",
        ),
        (
            [
                segment((-3, 0), (3, 6)),
                segment((3, 0), (-3, 6)),
                segment((0, 0), (0, 6)),
                segment((-3, 1), (3, 1)),
            ],
            "line 1, line 2 and line 3 meet in one point on the ground",
        ),
        ([*SQUARE, segment((2, 0), (-2, 0))], "line 1 and line 5 are the same line on the ground"),
    ],
)
def test_degenerate_lines_are_refused(segments, message: str) -> None:
    lines = traced(SIM_POSE, segments)
    with pytest.raises(CalibrationError, match=message):
        calibrate_lines(lines, SIM_POSE.head, None)


def test_three_of_six_lines_through_one_point_are_fine() -> None:
    # the square's sides y = 0 and x = 3 and a diagonal all pass through (3, 0)
    lines = traced(SIM_POSE, [*SQUARE, segment((-3, 6), (3, 0)), segment((-2, 0), (1, 3))])
    result = calibrate_lines(lines, SIM_POSE.head, None)
    assert (
        np.abs(unit(result.homography.matrix) - unit(SIM_POSE.frontal_to_ground().matrix)).max()
        < 1e-9
    )


def test_four_of_five_lines_through_one_point_are_refused() -> None:
    through = [segment((0, 3), (x, 8)) for x in (-4.0, -1.0, 2.0, 5.0)]
    lines = traced(SIM_POSE, [*through, segment((-3, 0), (3, 0))])
    with pytest.raises(
        CalibrationError, match="line 1, line 2, line 3 and line 4 meet in one point"
    ):
        calibrate_lines(lines, SIM_POSE.head, None)


def test_bad_samples_are_refused_naming_the_line_and_sample() -> None:
    lines = traced(SIM_POSE, SQUARE)
    one = lines[1]
    single = [
        *lines[:1],
        CalibrationLine(one.phi_rad, one.d_m, one.samples_rad[:1], one.label),
        *lines[2:],
    ]
    with pytest.raises(CalibrationError, match="line 2: needs at least 2 distinct gaze samples"):
        calibrate_lines(single, SIM_POSE.head, None)
    same = np.repeat(one.samples_rad[:1], 5, axis=0)
    repeated = [*lines[:1], CalibrationLine(one.phi_rad, one.d_m, same, one.label), *lines[2:]]
    with pytest.raises(
        CalibrationError,
        match="line 2: needs at least 2 distinct gaze samples to fit its frontal-plane line, got 1",
    ):
        calibrate_lines(repeated, SIM_POSE.head, None)
    nan = lines[0].samples_rad.copy()
    nan[2, 1] = math.nan
    with pytest.raises(CalibrationError, match="line 1 sample 3: angles are not finite"):
        calibrate_lines(
            [CalibrationLine(lines[0].phi_rad, 0.0, nan, "line 1"), *lines[1:]], SIM_POSE.head, None
        )
    with pytest.raises(
        CalibrationError,
        match=r"line 1 sample 1: tilt -31.757 deg "
        r"is outside the head.s tilt limits \[-20, 30\] deg",
    ):
        calibrate_lines(lines, SIM_POSE.head, HeadSection(tilt_min_deg=-20.0))
