"""A camera calibrated by Tsai's model, as PETS and many surveillance data sets publish it.

Tsai's model (R. Y. Tsai, "A versatile camera calibration technique for high-accuracy 3D
machine vision metrology using off-the-shelf TV cameras and lenses", IEEE J. Robotics and
Automation 3(4), 1987; the parameter names and the rotation's Euler order follow R. Willson's
reference implementation, whose XML files PETS 2009 ships):

- world -> camera: `X_c = R X_w + T`, `R = Rz(rz) · Ry(ry) · Rx(rx)`, T in millimetres;
- perspective onto the sensor: `X_u = f x_c / z_c`, `Y_u = f y_c / z_c` (mm);
- radial distortion, undistorted from distorted: `X_u = X_d (1 + κ1 r_d²)`, `r_d² = X_d² + Y_d²`;
- sensor -> pixel: `u = sx X_d / dpx + cx`, `v = Y_d / dpy + cy`.

The camera frame is OpenCV's (x right, y down, z forward). `TsaiCamera` projects world points to
pixels and pixels back to a world plane exactly, and converts itself into what a rig holds:
pinhole intrinsics, OpenCV distortion coefficients fitted to the κ1 lens over the image, the
ground homography of gazed's frontal plane for a head turning about the camera's centre, and
the camera's position.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from gazed.geometry.kinematics import FLIP_Y

MM_PER_M = 1000.0
NEWTON_ITERATIONS = 8  # the distortion's cubic: converges to round-off for any real lens in a few
FIT_GRID = 41  # points along each image axis for the OpenCV distortion fit


class TsaiError(ValueError):
    """A calibration file that cannot be read, naming the file and what is wrong."""


@dataclass(frozen=True)
class TsaiCamera:
    """One camera's Tsai calibration, for images `width_px` x `height_px`."""

    width_px: int
    height_px: int
    focal_mm: float
    kappa1_per_mm2: float
    cx_px: float
    cy_px: float
    sx: float
    dpx_mm: float
    dpy_mm: float
    rotation: np.ndarray  # world -> camera, 3x3
    translation_m: np.ndarray  # world -> camera, (3,)

    @classmethod
    def from_xml(cls, path: str | Path) -> TsaiCamera:
        """Read a Willson/PETS XML file: `<Geometry width height dpx dpy>`, `<Intrinsic focal
        kappa1 cx cy sx>`, `<Extrinsic tx ty tz rx ry rz>`."""
        path = Path(path)
        try:
            root = ET.parse(path).getroot()
        except (OSError, ET.ParseError) as exc:
            raise TsaiError(f"{path}: cannot read the calibration ({exc})") from exc

        def number(element: str, name: str) -> float:
            node = root.find(element)
            if node is None:
                raise TsaiError(f"{path}: <{element}> missing (expected a Tsai calibration)")
            text = node.get(name)
            try:
                value = float(text) if text is not None else math.nan
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                raise TsaiError(f"{path}: <{element} {name}=…> missing or not a finite number")
            return value

        rx, ry, rz = (number("Extrinsic", n) for n in ("rx", "ry", "rz"))
        translation_mm = np.array([number("Extrinsic", n) for n in ("tx", "ty", "tz")])
        camera = cls(
            width_px=int(number("Geometry", "width")),
            height_px=int(number("Geometry", "height")),
            focal_mm=number("Intrinsic", "focal"),
            kappa1_per_mm2=number("Intrinsic", "kappa1"),
            cx_px=number("Intrinsic", "cx"),
            cy_px=number("Intrinsic", "cy"),
            sx=number("Intrinsic", "sx"),
            dpx_mm=number("Geometry", "dpx"),
            dpy_mm=number("Geometry", "dpy"),
            rotation=tsai_rotation(rx, ry, rz),
            translation_m=translation_mm / MM_PER_M,
        )
        if min(camera.width_px, camera.height_px, camera.focal_mm, camera.dpx_mm) <= 0:
            raise TsaiError(f"{path}: width, height, focal and dpx must be positive")
        if camera.dpy_mm <= 0 or camera.sx <= 0:
            raise TsaiError(f"{path}: dpy and sx must be positive")
        return camera

    def scaled(self, width_px: int, height_px: int) -> TsaiCamera:
        """The same camera seen in a resized video (pixel coordinates scaled by the size ratio,
        as the annotations of a resized video are)."""
        scale_u = width_px / self.width_px
        scale_v = height_px / self.height_px
        return replace(
            self,
            width_px=width_px,
            height_px=height_px,
            cx_px=self.cx_px * scale_u,
            cy_px=self.cy_px * scale_v,
            dpx_mm=self.dpx_mm / scale_u,
            dpy_mm=self.dpy_mm / scale_v,
        )

    # --- intrinsics ------------------------------------------------------------------------

    @property
    def fx_px(self) -> float:
        return self.focal_mm * self.sx / self.dpx_mm

    @property
    def fy_px(self) -> float:
        return self.focal_mm / self.dpy_mm

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx_px, 0.0, self.cx_px], [0.0, self.fy_px, self.cy_px], [0, 0, 1]])

    @property
    def camera_xyz_m(self) -> np.ndarray:
        """The camera's centre in the world frame: `-R^T T`."""
        return -self.rotation.T @ self.translation_m

    # --- projection --------------------------------------------------------------------------

    def pixel_from_world(self, xyz_m: np.ndarray) -> np.ndarray:
        """World points (N, 3) in metres -> pixels (N, 2), with the lens's distortion."""
        xyz_c = np.atleast_2d(xyz_m) @ self.rotation.T + self.translation_m
        undistorted = self.focal_mm * xyz_c[:, :2] / xyz_c[:, 2:3]
        return self._pixel_from_sensor(self._distorted(undistorted))

    def world_from_pixel(self, uv_px: np.ndarray, z_m: float = 0.0) -> np.ndarray:
        """Pixels (N, 2) -> the world points (N, 3) where their rays meet the plane z = z_m."""
        rays_c = self.rays(uv_px)
        centre = self.camera_xyz_m
        rays_w = rays_c @ self.rotation  # R^T applied to each row
        depth = (z_m - centre[2]) / rays_w[:, 2]
        return centre + depth[:, None] * rays_w

    def rays(self, uv_px: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) -> ray directions (N, 3) in the camera frame, z = 1."""
        distorted = self._sensor_from_pixel(np.atleast_2d(uv_px))
        r2 = np.sum(distorted**2, axis=1, keepdims=True)
        undistorted = distorted * (1.0 + self.kappa1_per_mm2 * r2)
        return np.column_stack([undistorted / self.focal_mm, np.ones(len(undistorted))])

    def pinhole_pixels(self, uv_px: np.ndarray) -> np.ndarray:
        """The lens's pixels (N, 2) -> where the ideal pinhole camera with `K` sees them."""
        rays = self.rays(uv_px)
        return rays[:, :2] * [self.fx_px, self.fy_px] + [self.cx_px, self.cy_px]

    def _sensor_from_pixel(self, uv_px: np.ndarray) -> np.ndarray:
        return np.column_stack(
            [
                (uv_px[:, 0] - self.cx_px) * self.dpx_mm / self.sx,
                (uv_px[:, 1] - self.cy_px) * self.dpy_mm,
            ]
        )

    def _pixel_from_sensor(self, sensor_mm: np.ndarray) -> np.ndarray:
        return np.column_stack(
            [
                sensor_mm[:, 0] * self.sx / self.dpx_mm + self.cx_px,
                sensor_mm[:, 1] / self.dpy_mm + self.cy_px,
            ]
        )

    def _distorted(self, undistorted_mm: np.ndarray) -> np.ndarray:
        """Solve `r_u = r_d (1 + κ1 r_d²)` for r_d by Newton's method; scale each point."""
        r_u = np.hypot(undistorted_mm[:, 0], undistorted_mm[:, 1])
        r_d = r_u.copy()
        kappa = self.kappa1_per_mm2
        for _ in range(NEWTON_ITERATIONS):
            r_d -= (r_d + kappa * r_d**3 - r_u) / (1.0 + 3.0 * kappa * r_d**2)
        scale = np.divide(r_d, r_u, out=np.ones_like(r_u), where=r_u > 0)
        return undistorted_mm * scale[:, None]

    # --- what a rig holds ---------------------------------------------------------------------

    def opencv_distortion(self) -> tuple[tuple[float, float, float, float, float], float]:
        """OpenCV's (k1, k2, p1, p2, k3) for this lens with the pinhole `K`, fitted by linear
        least squares over a grid across the image, and the fit's largest error in pixels.

        OpenCV distorts undistorted normalised points, `x_d = x_u (1 + k1 r² + k2 r⁴ + k3 r⁶)`,
        where Tsai undistorts distorted ones; the inverse of Tsai's cubic is not a polynomial,
        so it is fitted. A radial lens has no tangential terms."""
        u, v = np.meshgrid(
            np.linspace(0, self.width_px - 1, FIT_GRID),
            np.linspace(0, self.height_px - 1, FIT_GRID),
        )
        pixels = np.column_stack([u.ravel(), v.ravel()])
        distorted_n = (pixels - [self.cx_px, self.cy_px]) / [self.fx_px, self.fy_px]
        undistorted_n = self.rays(pixels)[:, :2]
        r2 = np.sum(undistorted_n**2, axis=1)
        # x_d - x_u = x_u (k1 r² + k2 r⁴ + k3 r⁶), both coordinates stacked
        basis = np.stack([r2, r2**2, r2**3], axis=1)
        design = np.concatenate([undistorted_n[:, :1] * basis, undistorted_n[:, 1:] * basis])
        target = np.concatenate(
            [
                distorted_n[:, 0] - undistorted_n[:, 0],
                distorted_n[:, 1] - undistorted_n[:, 1],
            ]
        )
        (k1, k2, k3), *_ = np.linalg.lstsq(design, target, rcond=None)
        fitted = undistorted_n * (1.0 + basis @ [k1, k2, k3])[:, None]
        error_px = np.hypot(*((fitted - distorted_n) * [self.fx_px, self.fy_px]).T)
        return (float(k1), float(k2), 0.0, 0.0, float(k3)), float(error_px.max())

    def ground_homography(self) -> np.ndarray:
        """M (3x3, M33 = 1) mapping gazed's frontal-plane points of a head that turns about this
        camera's centre, at rest along its optical axis, to ground points on z = 0:
        `(X, Y, 1) ≃ M (x, y, 1)`.

        A ground point projects to the camera ray `[r1 r2 T] (X, Y, 1)`; gazed's frame has y up
        (`FLIP_Y`), so `M ≃ [r1 r2 T]^-1 · FLIP_Y`."""
        columns = np.column_stack([self.rotation[:, 0], self.rotation[:, 1], self.translation_m])
        M = np.linalg.inv(columns) @ FLIP_Y
        if abs(M[2, 2]) < 1e-12:
            raise TsaiError("the camera's optical axis is parallel to the ground")
        return M / M[2, 2]


def tsai_rotation(rx_rad: float, ry_rad: float, rz_rad: float) -> np.ndarray:
    """Willson's world -> camera rotation, `Rz(rz) · Ry(ry) · Rx(rx)`."""
    sa, ca = math.sin(rx_rad), math.cos(rx_rad)
    sb, cb = math.sin(ry_rad), math.cos(ry_rad)
    sg, cg = math.sin(rz_rad), math.cos(rz_rad)
    return np.array(
        [
            [cb * cg, cg * sa * sb - ca * sg, sg * sa + ca * cg * sb],
            [cb * sg, sa * sb * sg + ca * cg, ca * sb * sg - cg * sa],
            [-sb, cb * sa, ca * cb],
        ]
    )
