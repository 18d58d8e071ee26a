"""Where annotated people are in a digital head's view: each person's box centre in the wide
frame, taken through the view's own geometry (`DigitalView.homography`, the wide lens's
`undistort`) into the view at the head's pose.

For one rendered frame and the people annotated in its footage frame it tells, per person:
- in the wide view: the box centre lies within the wide frame;
- the angle between the view's optical axis and the ray through the box centre (the gaze error);
- held: the box, in the wide frame, holds the pixel the view's centre sees;
- reachable: the joint angles that centre the box centre lie within the head's field of regard
  (`FieldOfRegard.for_scoring`: its limits widened by the fovea; `DigitalView.angles_of`
  gives the angles).
The person the gaze is on is the held one nearest the optical axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.sim.reach import FieldOfRegard
from gazed.vision.digital_view import DigitalView


@dataclass(frozen=True)
class PeopleInView:
    """Per person of one frame (rows in the order given)."""

    in_wide: np.ndarray  # (N,) bool
    error_rad: np.ndarray  # (N,)
    held: np.ndarray  # (N,) bool
    reachable: np.ndarray  # (N,) bool

    def gaze_on(self) -> int | None:
        """The row of the person the gaze is on, or None."""
        candidates = np.flatnonzero(self.held & self.in_wide)
        if not len(candidates):
            return None
        return int(candidates[np.argmin(self.error_rad[candidates])])


class ViewPeople:
    """People's boxes against `view`'s image at a head pose; with a `reach`, whether the head
    can foveate each (else every one counts as reachable)."""

    def __init__(self, view: DigitalView, reach: FieldOfRegard | None = None) -> None:
        self.view = view
        self.reach = reach

    def at_pose(
        self, boxes_px: np.ndarray, pan_rad: float, tilt_rad: float, zoom: float | None = None
    ) -> PeopleInView:
        """`boxes_px` (N, 4): centre u, centre v, width, height in the wide frame's pixels; the
        view at zoom position `zoom` (None: the rig's view)."""
        boxes = np.asarray(boxes_px, dtype=float).reshape(-1, 4)
        if not len(boxes):
            nobody = np.zeros(0, bool)
            return PeopleInView(nobody, np.zeros(0), nobody, nobody)
        wide = self.view.wide
        u, v = boxes[:, 0], boxes[:, 1]
        in_wide = (u >= 0) & (u <= wide.width_px - 1) & (v >= 0) & (v <= wide.height_px - 1)
        camera = self.view.lens.camera_at(zoom)
        H = self.view.homography(pan_rad, tilt_rad, zoom)  # view pixel -> the wide's ideal pixel
        ideal = np.stack([*wide.undistort(u, v), np.ones_like(u)])
        ray = camera.K_inv @ np.linalg.solve(H, ideal)  # the view's frame, z its axis
        error = np.arctan2(np.hypot(ray[0], ray[1]), ray[2])
        centre_u, centre_v = self._centre_in_wide(H, camera)
        held = (np.abs(centre_u - u) <= boxes[:, 2] / 2) & (np.abs(centre_v - v) <= boxes[:, 3] / 2)
        reachable = np.ones(len(boxes), bool)
        if self.reach is not None:
            reachable = self.reach.contains_angles(*self.view.angles_of(u, v))
        return PeopleInView(in_wide, error, held, reachable)

    def _centre_in_wide(self, H: np.ndarray, camera: CameraModel) -> tuple[float, float]:
        """The wide frame's pixel (through its lens) that the view's principal point sees."""
        ideal = H @ np.array([camera.K[0, 2], camera.K[1, 2], 1.0])
        wide = self.view.wide
        pixel = wide.pixel(wide.K_inv @ (ideal / ideal[2]))
        return float(pixel[0]), float(pixel[1])
