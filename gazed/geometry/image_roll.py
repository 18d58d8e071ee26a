"""The image's roll at a head pose, and the box of an upright body seen rolled by it.

A head whose pan axis is tilted from the world's vertical (a pan-tilt unit pitched on its
mount) rolls the image as it pans: a vertical line through the frame's centre then leans in the
image. The world's vertical in the head's base frame is the calibration's -M row 3 (M = the
frontal -> ground homography, whose third row is -b2 times a positive scale; homography.py),
so the roll at any pose needs no more than the calibration and the head's kinematics.

A vertical line through a point on the optical axis, direction v in the camera frame (OpenCV:
x right, y down), leaves the principal point along (v_x, v_y): the roll is the angle from the
image's upward axis (0, -1) to it, positive clockwise in the image.

An upright body of angular height H and width W (as seen at the frame's centre), rolled by ρ,
fills a box of angular height H |cos ρ| + W |sin ρ| and width H |sin ρ| + W |cos ρ|; the two
invert for H and W wherever |ρ| is not 45°.
"""

from __future__ import annotations

import math

import numpy as np

from gazed.geometry.homography import GroundHomography
from gazed.geometry.kinematics import HeadKinematics


def image_roll_rad(
    homography: GroundHomography, kinematics: HeadKinematics, pan_rad: float, tilt_rad: float
) -> float:
    """The lean of the world's vertical through the frame's centre from the image's upward
    axis, in (-π/2, π/2], positive clockwise in the image."""
    up_base = -homography.matrix[2] / np.linalg.norm(homography.matrix[2])
    v = kinematics.camera_to_base(pan_rad, tilt_rad).T @ up_base
    roll = math.atan2(float(v[0]), -float(v[1]))
    if roll > math.pi / 2:
        roll -= math.pi
    elif roll <= -math.pi / 2:
        roll += math.pi
    return roll


def rolled_box(height: float, width: float, roll_rad: float) -> tuple[float, float]:
    """The (height, width) of the box around an upright body of `height` by `width` rolled by
    `roll_rad` (any unit, the same for both)."""
    c, s = abs(math.cos(roll_rad)), abs(math.sin(roll_rad))
    return height * c + width * s, height * s + width * c


def upright_body(box_height: float, box_width: float, roll_rad: float) -> tuple[float, float]:
    """The (height, width) of the upright body whose box, rolled by `roll_rad`, is `box_height`
    by `box_width` (`rolled_box` inverted); ValueError at a roll of 45°, where a box says
    nothing of the body's shape."""
    c, s = abs(math.cos(roll_rad)), abs(math.sin(roll_rad))
    determinant = c * c - s * s
    if abs(determinant) < 1e-9:
        raise ValueError("a box rolled by 45° does not tell a body's height from its width")
    return (
        (box_height * c - box_width * s) / determinant,
        (box_width * c - box_height * s) / determinant,
    )
