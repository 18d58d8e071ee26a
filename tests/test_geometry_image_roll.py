"""The image's roll at a head pose, from the calibration alone, against the simulator's true
pose: the image of a world-vertical segment through the frame's centre; and the box of a rolled
upright body against the projected corners of one."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gazed.geometry.camera import CameraModel
from gazed.geometry.image_roll import image_roll_rad, rolled_box, upright_body
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.pose import CameraPose

CAMERA = CameraModel.from_fov(640, 480, math.radians(30.0))
DEG = math.radians(1.0)


def pose(pitch_deg: float, roll_deg: float = 0.0, kinematics: str = "pan-tilt") -> CameraPose:
    """The zoom rig's head: 3 m up, 5 m behind the origin, looking along +Y."""
    return CameraPose(
        np.array([0.0, -5.0, 3.0]),
        90 * DEG,
        pitch_deg * DEG,
        roll_deg * DEG,
        head=HeadKinematics(kinematics),  # type: ignore[arg-type]
    )


def centred_point(p: CameraPose, pan_rad: float, tilt_rad: float, range_m: float) -> np.ndarray:
    """The world point `range_m` along the optical axis at (pan, tilt)."""
    axis_world = p.base_to_world @ p.head.gaze(pan_rad, tilt_rad)
    return p.centre_m + range_m * axis_world


def seen_roll_rad(p: CameraPose, pan_rad: float, tilt_rad: float) -> float:
    """The image angle of a short world-vertical segment centred on the optical axis."""
    middle = centred_point(p, pan_rad, tilt_rad, 4.0)
    lift = np.array([0.0, 0.0, 1e-3])
    ends = np.array([middle - lift, middle + lift])
    (u0, v0), (u1, v1) = p.pixels(ends, pan_rad, tilt_rad, CAMERA)  # foot, head
    lean = math.atan2(u1 - u0, v0 - v1)
    return lean - math.pi * round(lean / math.pi)  # a line's lean: (-π/2, π/2]


@pytest.mark.parametrize(("pitch_deg", "roll_deg"), [(-25.0, 0.0), (-40.0, 5.0), (10.0, -8.0)])
@pytest.mark.parametrize("kinematics", ["pan-tilt", "tilt-pan"])
def test_the_roll_from_the_calibration_is_the_lean_of_a_vertical_in_the_image(
    pitch_deg: float, roll_deg: float, kinematics: str
) -> None:
    p = pose(pitch_deg, roll_deg, kinematics)
    homography = p.frontal_to_ground()
    rolls = []
    for pan_deg, tilt_deg in [(0, 0), (20, -33), (-20, -33), (45, -10), (-60, 15), (5, -60)]:
        pan, tilt = pan_deg * DEG, tilt_deg * DEG
        roll = image_roll_rad(homography, p.head, pan, tilt)
        assert roll == pytest.approx(seen_roll_rad(p, pan, tilt), abs=1e-6)
        rolls.append(roll)
    assert max(abs(r) for r in rolls) > 5 * DEG  # the mount's tilt rolls the image


def test_a_level_pan_tilt_head_never_rolls_the_frames_centre() -> None:
    p = pose(0.0)
    homography = p.frontal_to_ground()
    for pan_deg, tilt_deg in [(0, -5), (30, -40), (-70, -20), (120, -60)]:
        assert image_roll_rad(homography, p.head, pan_deg * DEG, tilt_deg * DEG) == pytest.approx(
            0.0, abs=1e-9
        )


def test_a_rolled_upright_bodys_box_is_its_projected_corners_and_inverts() -> None:
    """The simulator draws a body as an upright rectangle facing the camera; seen at the
    frame's centre rolled by ρ, its box is that of the rectangle's image, whose sides are the
    body's angular height and width."""
    p = pose(-25.0)
    homography = p.frontal_to_ground()
    pan, tilt = 20 * DEG, -33 * DEG
    middle = centred_point(p, pan, tilt, 2.5)
    height_m, width_m = 0.4, 0.4
    toward = p.centre_m[:2] - middle[:2]
    right = np.array([toward[1], -toward[0], 0.0]) / np.linalg.norm(toward) * width_m / 2
    up = np.array([0.0, 0.0, height_m / 2])
    corners = np.array(
        [middle - up - right, middle - up + right, middle + up + right, middle + up - right]
    )
    pixels = p.pixels(corners, pan, tilt, CAMERA)
    box_h, box_w = np.ptp(pixels[:, 1]), np.ptp(pixels[:, 0])
    roll = image_roll_rad(homography, p.head, pan, tilt)
    assert abs(roll) > 10 * DEG
    # the body's sides in pixels, from the projected corners (a trapezoid seen from above:
    # the mean of its opposite sides): its upright height and width
    side_h = (
        float(np.linalg.norm(pixels[2] - pixels[1]) + np.linalg.norm(pixels[3] - pixels[0])) / 2
    )
    side_w = (
        float(np.linalg.norm(pixels[1] - pixels[0]) + np.linalg.norm(pixels[2] - pixels[3])) / 2
    )
    assert rolled_box(side_h, side_w, roll) == pytest.approx((box_h, box_w), rel=0.02)
    assert upright_body(box_h, box_w, roll) == pytest.approx((side_h, side_w), rel=0.05)
    assert upright_body(*rolled_box(3.0, 1.0, 0.3), 0.3) == pytest.approx((3.0, 1.0))
    with pytest.raises(ValueError, match="45°"):
        upright_body(2.0, 2.0, math.pi / 4)
