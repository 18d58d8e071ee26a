"""A zoom lens: the camera's intrinsics as a function of the zoom position.

The zoom position is normalised, 0 at the widest and 1 at the longest focal length; each driver
maps it to its device's units. `[camera] zoom_focal_px` tabulates the focal length (and, where
the optical axis wanders as the lens zooms, the principal point) at a few positions, and the
lens interpolates linearly between them. A rig without the table has a fixed lens: every zoom
gives the camera of `[camera]`. The distortion stays the fixed lens's (a zoom lens's distortion
changes with zoom too, but the table does not model it).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from gazed.config import CameraSection
from gazed.geometry.camera import CameraModel
from gazed.messages import HeadPose

# Zoom positions closer than this share a camera (cache key): far below any lens's repeatability.
ZOOM_RESOLUTION = 1e-4


class ZoomLens:
    """The camera at each zoom position of one lens."""

    def __init__(self, base: CameraModel, table: list[list[float]]) -> None:
        self.base = base
        self.zooms = np.array([row[0] for row in table], dtype=float)
        self.fx_px = np.array([row[1] for row in table], dtype=float)
        self.cx_px = np.array([row[2] if len(row) == 4 else base.K[0, 2] for row in table])
        self.cy_px = np.array([row[3] if len(row) == 4 else base.K[1, 2] for row in table])
        self._at = lru_cache(maxsize=256)(self._camera)

    @classmethod
    def from_section(cls, camera: CameraSection) -> ZoomLens:
        return cls(CameraModel.from_section(camera), camera.zoom_focal_px)

    @classmethod
    def fixed(cls, camera: CameraModel) -> ZoomLens:
        """A fixed lens: `camera` at every zoom."""
        return cls(camera, [])

    @property
    def zooms_lens(self) -> bool:
        """True for a zoom lens (the rig tabulates one); False for a fixed lens."""
        return len(self.zooms) > 0

    def camera_at(self, zoom: float | None) -> CameraModel:
        """The camera at zoom position `zoom` (None, or a fixed lens: the rig's camera)."""
        if zoom is None or not self.zooms_lens:
            return self.base
        return self._at(round(min(max(zoom, 0.0), 1.0) / ZOOM_RESOLUTION))

    def at_pose(self, head: HeadPose | None) -> CameraModel:
        """The camera a frame captured at head pose `head` was taken with (the rig's camera
        without a pose)."""
        return self.camera_at(None if head is None else head.zoom)

    def focal_px(self, zoom: float | None) -> float:
        """The mean focal length at `zoom`, in pixels."""
        return self.camera_at(zoom).focal_px

    def zoom_for_focal(self, focal_px: float) -> float:
        """The zoom position whose fx is `focal_px`, clamped to the table's range (the table's fx
        must increase with zoom, as every zoom lens's does)."""
        if not self.zooms_lens:
            return 0.0
        return float(np.interp(focal_px, self.fx_px, self.zooms))

    def _camera(self, key: int) -> CameraModel:
        zoom = key * ZOOM_RESOLUTION
        fx = float(np.interp(zoom, self.zooms, self.fx_px))
        aspect = self.base.K[1, 1] / self.base.K[0, 0]
        return CameraModel.from_intrinsics(
            self.base.width_px,
            self.base.height_px,
            fx,
            fx * aspect,
            float(np.interp(zoom, self.zooms, self.cx_px)),
            float(np.interp(zoom, self.zooms, self.cy_px)),
            tuple(self.base.distortion),
        )
