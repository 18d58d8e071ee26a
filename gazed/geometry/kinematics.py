"""Head kinematics: joint angles -> camera orientation -> gaze rays and frontal-plane points.

Conventions (stated once, used everywhere):

- Head base frame: x to the right, y up, z along the rest gaze (pan = tilt = 0).
- Joint angles are gazed's, not the device's: pan > 0 turns the gaze to the right (towards +x),
  tilt > 0 raises it (towards +y). `device_from_joint` / `joint_from_device` apply the rig's
  `[head]` signs and zero offsets at the servo edge; everything on the bus is in joint angles.
- `pan-tilt` heads have pan as the outer axis: R = Ry(pan) · Rx(-tilt).
  `tilt-pan` heads have tilt as the outer axis: R = Rx(-tilt) · Ry(pan).
  R maps directions from the rotated camera's frame (x right, y up, z forward) to the base frame.
- Frontal plane: z = 1 in the base frame. The gaze meets it at
  pan-tilt: (tan p, tan t · sec p, 1); tilt-pan: (tan p · sec t, tan t, 1)   (DESIGN §4).
- A pixel's ray: base = R · diag(1, -1, 1) · K^-1 (u, v, 1) (the camera's y axis points down).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from gazed.config import HeadSection

Kinematics = Literal["pan-tilt", "tilt-pan"]

# OpenCV camera frame (y down) -> gazed camera frame (y up).
FLIP_Y = np.diag([1.0, -1.0, 1.0])


def rot_x(angle_rad: float) -> np.ndarray:
    return np.array(_rot_x_rows(math.cos(angle_rad), math.sin(angle_rad)))


def rot_y(angle_rad: float) -> np.ndarray:
    return np.array(_rot_y_rows(math.cos(angle_rad), math.sin(angle_rad)))


def rot_z(angle_rad: float) -> np.ndarray:
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rot_x_derivative(angle_rad: float) -> np.ndarray:
    """d rot_x / d angle."""
    return np.array(_rot_x_derivative_rows(math.cos(angle_rad), math.sin(angle_rad)))


def _rot_y_derivative(angle_rad: float) -> np.ndarray:
    """d rot_y / d angle."""
    return np.array(_rot_y_derivative_rows(math.cos(angle_rad), math.sin(angle_rad)))


# The rotations and their derivatives by the angle, from its cosine c and sine s, as rows.
def _rot_x_rows(c: float, s: float) -> list[list[float]]:
    return [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]


def _rot_y_rows(c: float, s: float) -> list[list[float]]:
    return [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]


def _rot_x_derivative_rows(c: float, s: float) -> list[list[float]]:
    return [[0.0, 0.0, 0.0], [0.0, -s, -c], [0.0, c, -s]]


def _rot_y_derivative_rows(c: float, s: float) -> list[list[float]]:
    return [[-s, 0.0, c], [0.0, 0.0, 0.0], [-c, 0.0, -s]]


@dataclass(frozen=True)
class HeadKinematics:
    """The two-axis head: rotations, frontal-plane mapping and its inverse, with Jacobians."""

    kinematics: Kinematics = "pan-tilt"

    @classmethod
    def from_section(cls, head: HeadSection) -> HeadKinematics:
        return cls(head.kinematics)

    def rotation(self, pan_rad: float, tilt_rad: float) -> np.ndarray:
        """R: camera frame (x right, y up, z forward) -> head base frame."""
        if self.kinematics == "pan-tilt":
            return rot_y(pan_rad) @ rot_x(-tilt_rad)
        return rot_x(-tilt_rad) @ rot_y(pan_rad)

    def rotation_derivatives(
        self, pan_rad: float, tilt_rad: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """(dR/dpan, dR/dtilt) of `rotation`, each 3x3."""
        _, d_pan, d_tilt = self.rotation_with_derivatives(pan_rad, tilt_rad)
        return d_pan, d_tilt

    def rotation_with_derivatives(self, pan_rad: float, tilt_rad: float) -> np.ndarray:
        """R, dR/dpan and dR/dtilt of `rotation`, stacked (3, 3, 3): one product of the
        stacked factors (pan-tilt: Ry(p) Rx(-t), Ry'(p) Rx(-t), Ry(p) · -Rx'(-t))."""
        y = _rot_y_rows(math.cos(pan_rad), math.sin(pan_rad))
        y_d = _rot_y_derivative_rows(math.cos(pan_rad), math.sin(pan_rad))
        c, s = math.cos(-tilt_rad), math.sin(-tilt_rad)
        x = _rot_x_rows(c, s)
        x_d = _rot_x_derivative_rows(c, s)
        x_d_tilt = [[-e for e in row] for row in x_d]  # d Rx(-t) / dt = -Rx'(-t)
        if self.kinematics == "pan-tilt":
            return np.array([y, y_d, y]) @ np.array([x, x, x_d_tilt])
        return np.array([x, x, x_d_tilt]) @ np.array([y, y_d, y])

    def camera_to_base(self, pan_rad: float, tilt_rad: float) -> np.ndarray:
        """Directions in the OpenCV camera frame (y down) -> head base frame."""
        return self.rotation(pan_rad, tilt_rad) @ FLIP_Y

    def gaze(self, pan_rad: float, tilt_rad: float) -> np.ndarray:
        """Unit optical-axis direction in the base frame."""
        return self.rotation(pan_rad, tilt_rad)[:, 2].copy()

    def frontal_from_angles(self, pan_rad: float, tilt_rad: float) -> tuple[float, float]:
        """Where the optical axis meets the frontal plane z = 1."""
        if math.cos(pan_rad) <= 1e-12 or math.cos(tilt_rad) <= 1e-12:
            raise ValueError("gaze does not meet the frontal plane (|pan| or |tilt| >= 90°)")
        if self.kinematics == "pan-tilt":
            return math.tan(pan_rad), math.tan(tilt_rad) / math.cos(pan_rad)
        return math.tan(pan_rad) / math.cos(tilt_rad), math.tan(tilt_rad)

    def frontal_jacobian(self, pan_rad: float, tilt_rad: float) -> np.ndarray:
        """d(x, y)/d(pan, tilt) of `frontal_from_angles`, 2x2."""
        p, t = pan_rad, tilt_rad
        sec_p, sec_t = 1.0 / math.cos(p), 1.0 / math.cos(t)
        if self.kinematics == "pan-tilt":
            # x = tan p, y = tan t sec p
            return np.array(
                [[sec_p**2, 0.0], [math.tan(t) * sec_p * math.tan(p), sec_t**2 * sec_p]]
            )
        # x = tan p sec t, y = tan t
        return np.array([[sec_p**2 * sec_t, math.tan(p) * sec_t * math.tan(t)], [0.0, sec_t**2]])

    def angles_from_frontal(self, x: float, y: float) -> tuple[float, float]:
        """Joint angles that centre the frontal-plane point (x, y) (the inverse of the above)."""
        pan, tilt = self.angles_from_direction(np.array([x, y, 1.0]))
        return float(pan), float(tilt)

    def angles_jacobian(self, x: float, y: float) -> np.ndarray:
        """d(pan, tilt)/d(x, y) of `angles_from_frontal`, 2x2 (angular rates from frontal rates)."""
        return self.direction_angles_jacobian(np.array([x, y, 1.0]))[:, :2]

    def angles_from_direction(self, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles that point the optical axis along base-frame direction(s) (..., 3).

        Any length and any direction, also behind the frontal plane (z <= 0):
        pan-tilt: pan = atan2(x, z), tilt = atan2(y, hypot(x, z)), tilt in [-90°, 90°];
        tilt-pan: tilt = atan2(y, z), pan = atan2(x, hypot(y, z)), pan in [-90°, 90°].
        For z = 1 these are `angles_from_frontal` (seed 000 §3, inverse of its eq. for x)."""
        d = np.asarray(direction, dtype=float)
        x, y, z = d[..., 0], d[..., 1], d[..., 2]
        if self.kinematics == "pan-tilt":
            return np.arctan2(x, z), np.arctan2(y, np.hypot(x, z))
        return np.arctan2(x, np.hypot(y, z)), np.arctan2(y, z)

    def direction_angles_jacobian(self, direction: np.ndarray) -> np.ndarray:
        """d(pan, tilt)/d(direction) of `angles_from_direction` for one direction, 2x3."""
        x, y, z = (float(c) for c in direction)
        if self.kinematics == "pan-tilt":
            # pan = atan2(x, z); tilt = atan2(y, r), r = hypot(x, z)
            r2 = x * x + z * z
            r = math.sqrt(r2)
            n2 = r2 + y * y
            return np.array(
                [[z / r2, 0.0, -x / r2], [-y * x / (r * n2), r / n2, -y * z / (r * n2)]]
            )
        # tilt = atan2(y, z); pan = atan2(x, r), r = hypot(y, z)
        r2 = y * y + z * z
        r = math.sqrt(r2)
        n2 = r2 + x * x
        return np.array([[r / n2, -x * y / (r * n2), -x * z / (r * n2)], [0.0, z / r2, -y / r2]])


def joint_from_device(
    head: HeadSection, pan_device_rad: float, tilt_device_rad: float
) -> tuple[float, float]:
    """Device angles (as the protocol reports them) -> gazed joint angles."""
    pan = head.pan_sign * (pan_device_rad - math.radians(head.pan_zero_deg))
    tilt = head.tilt_sign * (tilt_device_rad - math.radians(head.tilt_zero_deg))
    return pan, tilt


def device_from_joint(head: HeadSection, pan_rad: float, tilt_rad: float) -> tuple[float, float]:
    """gazed joint angles -> device angles (the inverse of `joint_from_device`)."""
    pan = head.pan_sign * pan_rad + math.radians(head.pan_zero_deg)
    tilt = head.tilt_sign * tilt_rad + math.radians(head.tilt_zero_deg)
    return pan, tilt
