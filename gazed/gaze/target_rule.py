"""Which track the rig's rule picks, and which track is nearest an operator's pixel.

The rule (`[gaze] select_rule`) picks among the confirmed tracks, only those inside the ground
zone (`select_zone_xy_m`) where the rig gives one:

- `first`: the one that appeared first (the lowest id: ids count up and are never reused);
- `nearest-centre`: the one nearest the optical axis of the head's current pose;
- `largest`: the tallest box in the image (the nearest person, or the most visible);
- `longest-seen`: the one with the most detections.

Ties go to the lower id, so the same tracks always give the same pick.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gazed.config.gaze import SelectRule
from gazed.gaze.aim import angle_between
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import Track


class GroundZone:
    """A polygon on the ground (metres); a track is inside when its ground position is."""

    def __init__(self, vertices_xy_m: Sequence[Sequence[float]]) -> None:
        import cv2  # only a rig with a zone pays for OpenCV here

        self._cv2 = cv2
        self.contour = np.asarray(vertices_xy_m, dtype=np.float32).reshape(-1, 1, 2)

    def holds(self, track: Track) -> bool:
        """Inside or on the edge; a track without a ground position (image-cv) is not."""
        if track.ground_xy_m is None:
            return False
        point = (float(track.ground_xy_m[0]), float(track.ground_xy_m[1]))
        return self._cv2.pointPolygonTest(self.contour, point, False) >= 0


def rule_pick(
    rule: SelectRule,
    tracks: Sequence[Track],
    kinematics: HeadKinematics,
    head_rad: tuple[float, float] | None = None,
    zone: GroundZone | None = None,
) -> Track | None:
    """The confirmed track the rule picks (None: none qualifies). `nearest-centre` needs the
    head's pose `head_rad` (pan, tilt); without it, it picks as `first` does."""
    candidates = sorted(
        (t for t in tracks if t.confirmed and (zone is None or zone.holds(t))), key=lambda t: t.id
    )
    if not candidates:
        return None
    if rule == "nearest-centre" and head_rad is not None:
        pan, tilt = head_rad
        return min(
            candidates,
            key=lambda t: angle_between(t.pan_rad, t.tilt_rad, pan, tilt, kinematics),
        )
    if rule == "largest":
        return max(candidates, key=lambda t: (t.box_height_px, -t.id))
    if rule == "longest-seen":
        return max(candidates, key=lambda t: (t.hits, -t.id))
    return candidates[0]


def nearest_by_angle(
    tracks: Sequence[Track], pan_rad: float, tilt_rad: float, kinematics: HeadKinematics
) -> Track | None:
    """The track whose gaze direction is nearest (pan, tilt) (None: no tracks)."""
    if not tracks:
        return None
    return min(
        tracks, key=lambda t: angle_between(t.pan_rad, t.tilt_rad, pan_rad, tilt_rad, kinematics)
    )
