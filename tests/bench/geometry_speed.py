"""Microseconds per call of the geometry the estimator, gaze controller and simulator call every
frame, and milliseconds per calibration.

    python tests/bench/geometry_speed.py [--repeats 7]

A tilt-pan head 12 m up over a 60 m area (the synthetic rigs of the tests), a camera with
radial distortion. Each figure is the median over `repeats` batches of the per-call time of a
batch (wall time, one process). Prints one line per operation.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable

import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.geometry.ground import GazeSample, MeasurementNoise
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.line_calibration import CalibrationLine, calibrate_lines
from gazed.geometry.point_calibration import CalibrationPoint, calibrate_points, fit_points
from gazed.geometry.pose import CameraPose

CAMERA = CameraModel.from_intrinsics(
    640, 480, 560.0, 560.0, 322.0, 236.0, (-0.2, 0.05, 0.0, 0.0, 0.0)
)
POSE = CameraPose(
    np.array([-40.0, -40.0, 12.0]),
    math.radians(45.0),
    math.radians(-30.0),
    head=HeadKinematics("tilt-pan"),
)
SIGMA_RAD = math.radians(0.05)


def per_call_s(call: Callable[[], object], number: int, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(number):
            call()
        times.append((time.perf_counter() - start) / number)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    repeats = parser.parse_args().repeats
    rng = np.random.default_rng(1)
    geometry = POSE.ground_geometry(CAMERA, target_height_m=1.0)
    target = np.array([3.0, -5.0, 1.0])
    pan, tilt = (float(a) + 0.02 for a in POSE.gaze_angles(target))
    u, v = POSE.pixels(target, pan, tilt, CAMERA)
    sample = GazeSample(pan, tilt, u, v, 0.1, -0.05, 20.0, -10.0)
    noise = MeasurementNoise(SIGMA_RAD, math.radians(0.5), 1.0, 5.0)
    ground = rng.uniform(-30, 30, (8, 2))
    angles = np.column_stack(POSE.gaze_angles(np.hstack([ground, np.zeros((8, 1))])))
    angles += rng.normal(0, SIGMA_RAD, angles.shape)
    points = [
        CalibrationPoint(p, t, x, y, f"point {i}")
        for i, ((p, t), (x, y)) in enumerate(zip(angles, ground, strict=True))
    ]
    frontal = np.array([POSE.head.frontal_from_angles(p, t) for p, t in angles])
    corners = np.array([[-30.0, -30.0], [30.0, -30.0], [30.0, 30.0], [-30.0, 30.0]])
    lines = []
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        along = a + (b - a) * np.linspace(0.1, 0.9, 9)[:, None]
        traced = np.column_stack(POSE.gaze_angles(np.hstack([along, np.zeros((9, 1))])))
        normal = np.array([a[1] - b[1], b[0] - a[0]]) / np.linalg.norm(b - a)
        lines.append(
            CalibrationLine(
                math.atan2(normal[1], normal[0]), float(normal @ a), traced, f"line {k}"
            )
        )
    world = np.hstack([rng.uniform(-30, 30, (1000, 2)), np.zeros((1000, 1))])
    in_view = world[POSE.camera_directions(world, pan, tilt)[:, 2] > 0]

    figures = [
        (
            "ground_from_gaze (pixel, distortion, height)",
            lambda: geometry.ground_from_gaze(pan, tilt, u, v),
            2000,
            "us",
        ),
        (
            "measure (position, velocity, 4x4 covariance)",
            lambda: geometry.measure(sample, noise),
            300,
            "us",
        ),
        (
            "gaze_from_ground + gaze_rates_from_ground",
            lambda: (
                geometry.gaze_from_ground(3.0, -5.0),
                geometry.gaze_rates_from_ground(3.0, -5.0, 1.0, 0.5),
            ),
            2000,
            "us",
        ),
        (
            "pose.pixels, 1000 world points",
            lambda: POSE.pixels(in_view, pan, tilt, CAMERA),
            50,
            "us",
        ),
        (
            "pose.ground_to_image + horizon_line",
            lambda: (POSE.ground_to_image(pan, tilt, CAMERA), POSE.horizon_line(pan, tilt, CAMERA)),
            2000,
            "us",
        ),
        (
            "fit_points, 8 points (§3.1 least squares)",
            lambda: fit_points(frontal, ground, [p.label for p in points]),
            200,
            "ms",
        ),
        (
            "calibrate_points, 8 points (+ ML refinement, leave-one-out, outlier test)",
            lambda: calibrate_points(points, POSE.head, None, SIGMA_RAD),
            10,
            "ms",
        ),
        (
            "calibrate_lines, 4 lines x 9 samples",
            lambda: calibrate_lines(lines, POSE.head, None),
            50,
            "ms",
        ),
    ]
    for name, call, number, unit in figures:
        seconds = per_call_s(call, number, repeats)
        value = seconds * (1e6 if unit == "us" else 1e3)
        print(f"{name}: {value:.1f} {unit} (median of {repeats} x {number})")


if __name__ == "__main__":
    main()
