"""Pinhole camera with optional radial/tangential distortion (OpenCV's model).

Image coordinates: u to the right, v down, origin at the top-left pixel's centre, so the image
centre is ((w-1)/2, (h-1)/2). Camera frame (OpenCV): x right, y down, z along the optical axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from types import ModuleType

import numpy as np

from gazed.config import CameraSection

# Iterate the undistortion to round-off: OpenCV's default of 5 iterations leaves a visible error
# at the corners of a strongly distorted lens.
UNDISTORT_ITERATIONS = 100  # cv2.undistortPointsIter: stop after this many, or at this change
UNDISTORT_EPSILON = 1e-12


def _cv2() -> ModuleType:
    """OpenCV, imported on first use: only a lens with distortion needs it, and the processes
    that never meet one start faster without it."""
    import cv2

    return cv2


@dataclass(frozen=True)
class CameraModel:
    """Intrinsics `K` (3x3) and distortion coefficients of one camera."""

    width_px: int
    height_px: int
    K: np.ndarray
    distortion: np.ndarray

    @classmethod
    def from_fov(cls, width_px: int, height_px: int, hfov_rad: float) -> CameraModel:
        """Square pixels, principal point at the image centre, focal length from the horizontal
        field of view: fx = (w/2) / tan(hfov/2)."""
        f = (width_px / 2.0) / math.tan(hfov_rad / 2.0)
        return cls.from_intrinsics(
            width_px, height_px, f, f, (width_px - 1) / 2.0, (height_px - 1) / 2.0
        )

    @classmethod
    def from_intrinsics(
        cls,
        width_px: int,
        height_px: int,
        fx_px: float,
        fy_px: float,
        cx_px: float,
        cy_px: float,
        distortion: tuple[float, ...] = (),
    ) -> CameraModel:
        K = np.array([[fx_px, 0.0, cx_px], [0.0, fy_px, cy_px], [0.0, 0.0, 1.0]])
        return cls(width_px, height_px, K, np.asarray(distortion, dtype=float))

    @classmethod
    def from_section(cls, camera: CameraSection) -> CameraModel:
        """From the rig's [camera]: fx/fy/cx/cy when given, else the horizontal field of view."""
        w, h = camera.width_px, camera.height_px
        if camera.fx_px is not None:
            fx = camera.fx_px
            fy = camera.fy_px if camera.fy_px is not None else fx
        else:
            assert camera.hfov_deg is not None  # the section's validator guarantees one of them
            fx = fy = (w / 2.0) / math.tan(math.radians(camera.hfov_deg) / 2.0)
        cx = camera.cx_px if camera.cx_px is not None else (w - 1) / 2.0
        cy = camera.cy_px if camera.cy_px is not None else (h - 1) / 2.0
        return cls.from_intrinsics(w, h, fx, fy, cx, cy, tuple(camera.distortion))

    @cached_property
    def K_inv(self) -> np.ndarray:
        return np.linalg.inv(self.K)

    @property
    def focal_px(self) -> float:
        """Mean focal length in pixels (rotational flow scale)."""
        return float((self.K[0, 0] + self.K[1, 1]) / 2.0)

    @cached_property
    def has_distortion(self) -> bool:
        return bool(np.any(self.distortion != 0.0))

    def undistort(
        self, u_px: np.ndarray | float, v_px: np.ndarray | float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates as an ideal pinhole camera with the same K would have seen them."""
        u = np.asarray(u_px, dtype=float)
        v = np.asarray(v_px, dtype=float)
        if not self.has_distortion:
            return u, v
        points = np.stack([u.ravel(), v.ravel()], axis=-1).reshape(-1, 1, 2)
        cv2 = _cv2()
        criteria = (
            cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS,
            UNDISTORT_ITERATIONS,
            UNDISTORT_EPSILON,
        )
        if hasattr(cv2, "undistortPointsIter"):  # OpenCV 4.x
            ideal = cv2.undistortPointsIter(
                points, self.K, self.distortion, np.eye(3), self.K, criteria
            )
        else:  # OpenCV 5 takes the criteria in undistortPoints
            ideal = cv2.undistortPoints(
                points, self.K, self.distortion, R=np.eye(3), P=self.K, criteria=criteria
            )
        ideal = ideal.reshape(-1, 2)
        return ideal[:, 0].reshape(u.shape), ideal[:, 1].reshape(v.shape)

    def ray(self, u_px: np.ndarray | float, v_px: np.ndarray | float) -> np.ndarray:
        """Camera-frame direction (x right, y down, z forward; z = 1) through pixel(s);
        shape (..., 3)."""
        u, v = self.undistort(u_px, v_px)
        K = self.K
        ray = np.empty((*np.shape(u), 3))
        ray[..., 0] = (u - K[0, 2]) / K[0, 0]
        ray[..., 1] = (v - K[1, 2]) / K[1, 1]
        ray[..., 2] = 1.0
        return ray

    def ray_with_jacobian(self, u_px: float, v_px: float) -> tuple[np.ndarray, np.ndarray]:
        """`ray` at one pixel (3,) and its derivative d(ray)/d(u, v), 3x2 (the third row is
        zero: the ray has z = 1), from one undistortion.

        Without distortion the derivative is diag(1/fx, 1/fy); with distortion, the inverse of
        the projection's Jacobian d(u, v)/d(x, y) at the undistorted ray (from
        cv2.projectPoints, whose derivative by the translation is the derivative by the point)."""
        ray = self.ray(u_px, v_px)
        if not self.has_distortion:
            return ray, self._pinhole_ray_derivative
        _, jacobian = _cv2().projectPoints(
            ray[None, :], np.zeros(3), np.zeros(3), self.K, self.distortion
        )
        derivative = np.zeros((3, 2))
        derivative[:2] = np.linalg.inv(jacobian[:, 3:5])
        return ray, derivative

    @cached_property
    def _pinhole_ray_derivative(self) -> np.ndarray:
        """d(ray)/d(u, v) without distortion: diag(1/fx, 1/fy) over a zero row (read-only)."""
        derivative = np.zeros((3, 2))
        derivative[0, 0], derivative[1, 1] = 1.0 / self.K[0, 0], 1.0 / self.K[1, 1]
        derivative.flags.writeable = False
        return derivative

    def pixel(self, ray_camera: np.ndarray) -> np.ndarray:
        """Pixel(s) (u, v) of camera-frame direction(s) in front of the camera; shape (..., 2).

        Raises ValueError for a direction at or behind the image plane (z <= 0)."""
        ray_camera = np.asarray(ray_camera, dtype=float)
        z = ray_camera[..., 2]
        if np.any(z <= 1e-12):
            raise ValueError("direction is behind the camera: it has no pixel")
        xy = ray_camera[..., :2] / z[..., None]
        if self.has_distortion:
            points = np.concatenate([xy.reshape(-1, 2), np.ones((xy.size // 2, 1))], axis=1)
            uv, _ = _cv2().projectPoints(points, np.zeros(3), np.zeros(3), self.K, self.distortion)
            return uv.reshape(xy.shape)
        K = self.K
        return np.stack([K[0, 0] * xy[..., 0] + K[0, 2], K[1, 1] * xy[..., 1] + K[1, 2]], axis=-1)
