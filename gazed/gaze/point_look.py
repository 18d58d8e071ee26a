"""The look at an operator's held point: a ground point chosen outside the head's view.

An operator points at a person the moment they see them, often in a wider view than the head's
(the live page's wide frame, a map). While no track explains the point (`target_choice` holds
it), nobody there can get a track unless the head's view shows them: so the gaze turns to the
point. Where the held point lies outside the current view (its pixel, through the camera at the
head's pose, off the image), the controller saccades to it from any state that follows or
seeks a target (park, search, pursuit, lost), with no rate: the person walked from the point in
a direction nobody measured, and the point is the middle of where they can be (the region that
widens with the walk allowed since the request, `walk_gate`). The point stays held and open to
the first track that explains it, as before. Each request is looked at once: once the head has
turned to it, the detections there take the person up as any others, and a later move away
(the person taken up, or another's detection) is not undone. A rig without a ground calibration
has no ground points to look at.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from gazed.config import Rig
from gazed.gaze.aim import Aim
from gazed.geometry.ground import GroundGeometry, MissingCalibrationError
from gazed.messages import GazeDemand, GazeSelect, Odometry

if TYPE_CHECKING:
    from gazed.gaze.controller import GazeController

LOOKING_STATES = ("park", "search", "pursuit", "lost")  # the states a look at a point leaves


def point_aim(
    geometry: GroundGeometry, select: GazeSelect, odometry: Odometry, wall_ns: int
) -> Aim | None:
    """The head's angles that centre the request's ground point, if the point lies outside the
    view at the head's pose now; None where it is in view (or cannot be seen)."""
    if select.ground_xy_m is None:
        return None
    x_m, y_m = select.ground_xy_m
    try:
        u_px, v_px = geometry.pixel_from_ground(x_m, y_m, odometry.pan_rad, odometry.tilt_rad)
        pan_rad, tilt_rad = geometry.gaze_from_ground(x_m, y_m)
    except ValueError:  # behind the camera or above the horizon: outside the view, but no aim
        return None
    camera = geometry.camera
    if 0.0 <= u_px <= camera.width_px - 1 and 0.0 <= v_px <= camera.height_px - 1:
        return None
    return Aim(wall_ns, pan_rad, tilt_rad)


class PointLook:
    """Turns one controller's head to its choice's held point (module docstring)."""

    def __init__(self, controller: GazeController, rig: Rig) -> None:
        self.controller = controller
        try:
            self.geometry: GroundGeometry | None = GroundGeometry.from_rig(rig)
        except MissingCalibrationError:
            self.geometry = None
        self.looked: GazeSelect | None = None  # the last request looked at

    def handler(self, wall_ns: int) -> Callable[[int, float], GazeDemand | None] | None:
        """The saccade to the held point as the tick's handler, when the point is due its look
        and lies outside the view; None otherwise."""
        c = self.controller
        held = c.choice.pending
        if (
            self.geometry is None
            or held is None
            or held is self.looked
            or c.state not in LOOKING_STATES
            or c.odometry is None
        ):
            return None
        self.looked = held
        aim = point_aim(self.geometry, held, c.odometry, wall_ns)
        if aim is None:
            return None
        reason = "operator's point outside the view"
        return lambda now_ns, mono_s: c.start_saccade(aim, reason, now_ns, mono_s)
