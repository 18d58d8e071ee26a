"""Lens distortion: frames remapped to the ideal pinhole, results mapped back.

The ego-motion model (the warp K R K^-1, the rotational flow of seed 004 eq. 11) holds for an
ideal pinhole camera. For a camera with distortion coefficients (`[camera] distortion`), each
grey frame is first remapped to the image the ideal pinhole with the same K would see (one
`cv2.remap` with maps computed once), the detectors run there, and their positions — and
velocities, through the local Jacobian of the mapping — are mapped back to the camera's own
pixels, the ones `CameraModel.ray` expects.
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.vision.candidates import MotionRegion
from gazed.vision.detector import DetectorOutput
from gazed.vision.movers import MoverRegion

JACOBIAN_STEP_PX = 0.5


class Undistortion:
    def __init__(self, camera: CameraModel) -> None:
        self.camera = camera
        size = (camera.width_px, camera.height_px)
        self._maps = cv2.initUndistortRectifyMap(
            camera.K, camera.distortion, None, camera.K, size, cv2.CV_16SC2
        )
        self._K_inv = camera.K_inv

    def frame(self, gray: np.ndarray) -> np.ndarray:
        """The frame as the ideal pinhole camera with the same K sees it."""
        return cv2.remap(gray, *self._maps, cv2.INTER_LINEAR)

    def pixel(self, u_px: float, v_px: float) -> tuple[float, float]:
        """Ideal pixel -> the camera's own (distorted) pixel."""
        ray = self._K_inv @ np.array([u_px, v_px, 1.0])
        u, v = self.camera.pixel(ray)
        return float(u), float(v)

    def velocity(
        self, u_px: float, v_px: float, du_px_s: float, dv_px_s: float
    ) -> tuple[float, float]:
        """An ideal-image velocity at ideal pixel (u, v) in the camera's own pixels per second."""
        h = JACOBIAN_STEP_PX
        columns = [
            (np.array(self.pixel(u_px + h, v_px)) - self.pixel(u_px - h, v_px)) / (2 * h),
            (np.array(self.pixel(u_px, v_px + h)) - self.pixel(u_px, v_px - h)) / (2 * h),
        ]
        du, dv = np.column_stack(columns) @ np.array([du_px_s, dv_px_s])
        return float(du), float(dv)

    def box(self, box: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
        """An ideal-image box (x, y, width, height) as its corners' box in the camera's own
        pixels."""
        x, y, w, h = box
        corners = np.array([self.pixel(cx, cy) for cx in (x, x + w) for cy in (y, y + h)])
        x0, y0 = np.floor(corners.min(axis=0))
        x1, y1 = np.ceil(corners.max(axis=0))
        return float(x0), float(y0), float(x1 - x0), float(y1 - y0)

    def output(self, out: DetectorOutput) -> DetectorOutput:
        """A detector's answer in the camera's own pixels (the window: its corners' box)."""
        window = out.window
        if window is not None:
            window = tuple(int(x) for x in self.box(window))
        if not out.found:
            return dataclasses.replace(out, window=window)
        u, v = self.pixel(out.u_px, out.v_px)
        du, dv = self.velocity(out.u_px, out.v_px, out.du_px_s, out.dv_px_s)
        return dataclasses.replace(
            out,
            u_px=u,
            v_px=v,
            du_px_s=du,
            dv_px_s=dv,
            window=window,
            movers=tuple(self.mover(m) for m in out.movers),
        )

    def mover(self, mover: MoverRegion) -> MoverRegion:
        u, v = self.pixel(mover.u_px, mover.v_px)
        du, dv = self.velocity(mover.u_px, mover.v_px, mover.du_px_s, mover.dv_px_s)
        return dataclasses.replace(
            mover, u_px=u, v_px=v, du_px_s=du, dv_px_s=dv, box=self.box(mover.box)
        )

    def region(self, region: MotionRegion) -> MotionRegion:
        u, v = self.pixel(region.u_px, region.v_px)
        du, dv = self.velocity(region.u_px, region.v_px, region.du_px_s, region.dv_px_s)
        return dataclasses.replace(region, u_px=u, v_px=v, du_px_s=du, dv_px_s=dv)
