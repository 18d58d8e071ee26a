"""The edge under the fovea: found on the rendered court's sides to a fraction of a pixel, and a
corner shows as a turn."""

from __future__ import annotations

import math

import cv2
import numpy as np

from gazed.config import parse_rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.pose import CameraPose
from gazed.sim.renderer import Renderer
from gazed.vision.edge_trace import EdgeTracer

RIG = parse_rig(
    '[rig]\nname = "e"\n[sim]\ncamera_xyz_m = [0.0, -5.0, 3.0]\n'
    "camera_yaw_deg = 90.0\ncamera_pitch_deg = -25.0\n"
)
CAMERA = CameraModel.from_section(RIG.camera)
POSE = CameraPose.from_rig(RIG)
COURT = (-3.0, -1.5, 3.0, 4.5)


def side_point(side: int, s: float) -> tuple[np.ndarray, np.ndarray]:
    """A point on a court side, and the side's direction."""
    x0, y0, x1, y1 = COURT
    return {
        0: (np.array([x0, y0 + (y1 - y0) * s, 0.0]), np.array([0.0, 1.0, 0.0])),
        1: (np.array([x1, y0 + (y1 - y0) * s, 0.0]), np.array([0.0, 1.0, 0.0])),
        2: (np.array([x0 + (x1 - x0) * s, y0, 0.0]), np.array([1.0, 0.0, 0.0])),
        3: (np.array([x0 + (x1 - x0) * s, y1, 0.0]), np.array([1.0, 0.0, 0.0])),
    }[side]


def test_finds_the_court_sides_to_a_fraction_of_a_pixel() -> None:
    renderer = Renderer(CAMERA, POSE, seed=1, court_m=COURT)
    tracer = EdgeTracer(CAMERA, math.radians(6))
    rng = np.random.default_rng(0)
    errors = []
    for k in range(40):
        point, direction = side_point(k % 4, rng.uniform(0.15, 0.85))
        pan, tilt = (float(a) for a in POSE.gaze_angles(point))
        pan += rng.uniform(-0.01, 0.01)
        tilt += rng.uniform(-0.01, 0.01)
        gray = cv2.cvtColor(renderer.render(k, pan, tilt, []), cv2.COLOR_BGR2GRAY)
        edge = tracer.observe(gray)
        assert edge.found
        a, b = POSE.pixels(np.array([point - direction, point + direction]), pan, tilt, CAMERA)
        normal = np.array([a[1] - b[1], b[0] - a[0]]) / np.hypot(*(b - a))
        errors.append(abs(float((np.array([edge.u_px, edge.v_px]) - a) @ normal)))
        # ahead and behind lie on the same edge, a step apart
        for point_px in (edge.ahead_px, edge.behind_px):
            assert abs(float((np.array(point_px) - a) @ normal)) < 2.0
            assert math.hypot(
                point_px[0] - edge.u_px, point_px[1] - edge.v_px
            ) == tracer.step_px or math.isclose(
                math.hypot(point_px[0] - edge.u_px, point_px[1] - edge.v_px), tracer.step_px
            )
    errors = np.array(errors)
    print(f"edge error px: median {np.median(errors):.3f}, p90 {np.percentile(errors, 90):.3f}")
    assert np.median(errors) < 0.3
    assert np.percentile(errors, 90) < 0.8


def test_a_corner_turns() -> None:
    renderer = Renderer(CAMERA, POSE, seed=1, court_m=COURT)
    tracer = EdgeTracer(CAMERA, math.radians(6))
    turns = []
    for corner in ((-3.0, -1.5), (3.0, -1.5), (-3.0, 4.5), (3.0, 4.5)):
        pan, tilt = (float(a) for a in POSE.gaze_angles(np.array([*corner, 0.0])))
        gray = cv2.cvtColor(renderer.render(0, pan, tilt, []), cv2.COLOR_BGR2GRAY)
        edge = tracer.observe(gray)
        turns.append(math.degrees(edge.turn_rad) if edge.found else 180.0)
    assert min(turns) > 30.0


def test_no_edge_in_an_even_grey() -> None:
    tracer = EdgeTracer(CAMERA, math.radians(6))
    assert not tracer.observe(np.full((480, 640), 120, np.uint8)).found
