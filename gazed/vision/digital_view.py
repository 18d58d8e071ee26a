"""The view of a digital pan/tilt head: a pinhole camera turning about a fixed wide camera's
centre, rendered from the wide camera's frames.

A view pixel's ray, turned by the head's rotation, is a ray of the wide camera; for rotation
about the centre the map between the two images is the homography

    H = K_wide · F · R(pan, tilt) · F · K_view⁻¹        (F = diag(1, -1, 1): gazed's y is up)

exactly, from view pixels to the wide camera's ideal (pinhole) pixels. The wide lens's
distortion is one more fixed map, from ideal pixels to the lens's own, tabulated once over the
ideal image of the whole frame. Each render computes H and the table on a coarse grid of view
pixels, interpolates that source map to every pixel (`resize`) and samples the frame there
(`remap`).

A digital zoom narrows the view: at zoom z the view's K is the `ZoomLens`'s camera at z (the
rig's `[camera] zoom_focal_px`), so the same view pixels span a smaller angle of the wide frame.

At rest (pan = tilt = 0) the view looks along the wide camera's optical axis, so the head's
joint angles are the wide camera's own pan and tilt, and a ground homography for the wide
camera (`gazed.geometry.tsai`) is the head's.

The wide camera's field, as joint angles (`wide_field_rad`), is where the head must be able to
turn to centre anything the wide camera sees: the extremes of the angles that centre the pixels
of the frame's border. A head with those limits sees past the frame's edge near them, and the
render fills what lies past it (black).
"""

from __future__ import annotations

import cv2
import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import FLIP_Y, HeadKinematics
from gazed.geometry.zoom import ZoomLens

FAR_PX = -1e6  # the source of a ray past the lens table: remap draws black there
MAP_STEP_PX = 8  # the source map is exact every this many view pixels, bilinear between
MIN_DEPTH = 1e-6  # a view ray with less depth along the wide camera's axis misses it
TABLE_MARGIN_CELLS = 2  # the lens table reaches this many coarse cells past the frame's edge


class DigitalView:
    """Renders the view of `view` (its size and K, at each zoom of `lens` where given) at a pose
    from frames of `wide`."""

    def __init__(
        self,
        wide: CameraModel,
        view: CameraModel,
        kinematics: HeadKinematics | None = None,
        lens: ZoomLens | None = None,
    ) -> None:
        self.wide = wide
        self.view = view
        self.lens = lens or ZoomLens(view, [])
        self.kinematics = kinematics or HeadKinematics()
        self._lens_table: np.ndarray | None = None
        self._table_origin = np.zeros(2, np.float32)
        if wide.has_distortion:
            # a view cell spans about MAP_STEP_PX · f_wide / f_view ideal pixels
            zoom = max(1.0, wide.focal_px / view.focal_px)
            margin_px = TABLE_MARGIN_CELLS * MAP_STEP_PX * zoom
            self._lens_table, self._table_origin = _lens_table(wide, margin_px)
        # the coarse grid: one sample every MAP_STEP_PX view pixels, one cell of margin on each
        # side, placed where `cv2.resize` by MAP_STEP_PX interpolates linearly between samples
        step = MAP_STEP_PX
        self._grid_size = (view.width_px // step + 2, view.height_px // step + 2)
        origin = (step - 1) / 2.0 - step
        self._grid_to_view = np.array([[step, 0.0, origin], [0.0, step, origin], [0.0, 0.0, 1.0]])
        u, v = np.meshgrid(
            np.arange(self._grid_size[0], dtype=float), np.arange(self._grid_size[1], dtype=float)
        )
        self._grid = np.stack([u.ravel(), v.ravel(), np.ones(u.size)], axis=1)

    def homography(self, pan_rad: float, tilt_rad: float, zoom: float | None = None) -> np.ndarray:
        """View pixel -> the wide camera's ideal pixel, 3x3, at zoom position `zoom`."""
        R = self.kinematics.rotation(pan_rad, tilt_rad)
        return self.wide.K @ FLIP_Y @ R @ FLIP_Y @ self.lens.camera_at(zoom).K_inv

    def angles_of(self, u_px: np.ndarray, v_px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The joint angles (pan, tilt) that centre the view on the wide frame's pixels (u, v)
        (through its lens)."""
        ideal_u, ideal_v = self.wide.undistort(np.asarray(u_px, float), np.asarray(v_px, float))
        rays = self.wide.K_inv @ np.stack([ideal_u, ideal_v, np.ones_like(ideal_u)])
        return self.kinematics.angles_from_direction((FLIP_Y @ rays).T)

    def wide_field_rad(self) -> tuple[float, float, float, float]:
        """pan min, pan max, tilt min, tilt max: the extremes of the joint angles that centre
        the wide frame's border pixels (the module docstring)."""
        w, h = self.wide.width_px, self.wide.height_px
        u = np.concatenate([np.arange(w), np.arange(w), np.zeros(h), np.full(h, w - 1)])
        v = np.concatenate([np.zeros(w), np.full(w, h - 1), np.arange(h), np.arange(h)])
        pan, tilt = self.angles_of(u, v)
        return float(pan.min()), float(pan.max()), float(tilt.min()), float(tilt.max())

    def source_pixels(
        self, pan_rad: float, tilt_rad: float, zoom: float | None = None
    ) -> np.ndarray:
        """For every view pixel, the wide frame's pixel it samples: (h, w, 2) float32, outside
        the frame where its ray misses it. Exact on a grid every MAP_STEP_PX pixels, bilinear
        between (the map is smooth: the interpolation adds hundredths of a pixel)."""
        H = self.homography(pan_rad, tilt_rad, zoom) @ self._grid_to_view
        ideal = self._grid @ H.T
        behind = ideal[:, 2] <= MIN_DEPTH  # a ray turned away from the wide camera
        ideal = ideal[:, :2] / np.where(behind, 1.0, ideal[:, 2])[:, None]
        ideal[behind] = FAR_PX
        coarse = ideal.astype(np.float32).reshape(self._grid_size[1], self._grid_size[0], 2)
        if self._lens_table is not None:
            coarse = cv2.remap(
                self._lens_table,
                coarse - self._table_origin,
                None,
                cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=(FAR_PX, FAR_PX, 0, 0),
            )
        step = MAP_STEP_PX
        size = (self._grid_size[0] * step, self._grid_size[1] * step)
        fine = cv2.resize(coarse, size, interpolation=cv2.INTER_LINEAR)
        return fine[step : step + self.view.height_px, step : step + self.view.width_px]

    def render(
        self, wide_frame: np.ndarray, pan_rad: float, tilt_rad: float, zoom: float | None = None
    ) -> np.ndarray:
        """The view at (pan, tilt, zoom) from one wide frame; black where it sees past the
        frame."""
        return cv2.remap(
            wide_frame,
            self.source_pixels(pan_rad, tilt_rad, zoom),
            None,
            cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
        )


def _lens_table(wide: CameraModel, margin_px: float) -> tuple[np.ndarray, np.ndarray]:
    """The lens's pixel of every ideal pixel over the ideal image of the whole frame and
    `margin_px` around it, (h, w, 2) float32, and the ideal pixel of the table's first entry.

    The ideal image of a distorted frame is not the frame's rectangle (barrel distortion pushes
    its corners out), so the table spans the ideal positions of the frame's border, one pixel
    a step; the margin lets the coarse source map interpolate across the frame's edge. Where the
    lens polynomial stops growing with the radius it would fold back into the frame, so from
    there on the table goes straight on outwards, away from the frame."""
    w, h = wide.width_px, wide.height_px
    border = np.concatenate(
        [
            np.stack([np.arange(w), np.zeros(w)], axis=1),
            np.stack([np.arange(w), np.full(w, h - 1)], axis=1),
            np.stack([np.zeros(h), np.arange(h)], axis=1),
            np.stack([np.full(h, w - 1), np.arange(h)], axis=1),
        ]
    )
    ideal_u, ideal_v = wide.undistort(border[:, 0], border[:, 1])
    u0, v0 = np.floor(ideal_u.min() - margin_px), np.floor(ideal_v.min() - margin_px)
    u1, v1 = np.ceil(ideal_u.max() + margin_px), np.ceil(ideal_v.max() + margin_px)
    u, v = np.meshgrid(np.arange(u0, u1 + 1), np.arange(v0, v1 + 1))
    rays = wide.K_inv @ np.stack([u.ravel(), v.ravel(), np.ones(u.size)])
    radius = np.hypot(rays[0], rays[1])
    limit = _monotonic_radius(wide, float(radius.max()))
    within = rays.copy()
    within[:2] *= np.minimum(1.0, limit / np.maximum(radius, 1e-12))
    lens = wide.pixel(within.T)
    # past the limit, straight on outwards from where the lens leaves off
    lens += (rays[:2] - within[:2]).T * [wide.K[0, 0], wide.K[1, 1]]
    lens = lens.reshape(*u.shape, 2).astype(np.float32)
    return lens, np.array([u0, v0], np.float32)


def _monotonic_radius(wide: CameraModel, up_to: float) -> float:
    """The first ideal radius (normalised) at which the lens's radial polynomial stops growing,
    or `up_to` if it grows all the way."""
    k = np.zeros(5)
    k[: min(5, len(wide.distortion))] = wide.distortion[:5]
    k1, k2, k3 = k[0], k[1], k[4]
    r = np.linspace(0.0, up_to, 4096)
    r2 = r * r
    slope = 1 + 3 * k1 * r2 + 5 * k2 * r2**2 + 7 * k3 * r2**3  # d(r (1 + k1 r² + …)) / dr
    falling = np.flatnonzero(slope <= 0)
    return float(r[falling[0]]) if len(falling) else up_to
