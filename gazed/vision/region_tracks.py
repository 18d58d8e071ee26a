"""The velocities of a frame's regions, from their recent centroids matched frame to frame.

Each region of a frame is matched to the nearest region of the previous frame (whose centroids
are first moved by the head's rotation, `PositionHistory.transport`) and inherits its recent
centroids; the least-squares slope of those, over up to `points` frames, is its independent
image velocity. A centroid wobbles by a pixel or two from frame to frame, so a velocity from the
last two frames alone is far off; the slope over several is not.
"""

from __future__ import annotations

import numpy as np

from gazed.vision.ego_motion import HeadStep
from gazed.vision.position_history import PositionHistory


class RegionTracks:
    """The recent centroids of the previous frame's regions, each with the radius it reaches."""

    def __init__(self, points: int) -> None:
        self.points = points
        self._previous: list[tuple[PositionHistory, float]] = []

    def reset(self) -> None:
        self._previous = []

    def update(
        self,
        step: HeadStep,
        centroids: list[tuple[float, float]],
        radii_px: list[float],
        t_s: float,
    ) -> list[tuple[float, float]]:
        """The velocity (px/s) of each of this frame's regions, given their centroids and
        radii; (0, 0) for a region seen for the first time. The regions become the previous
        ones for the next frame."""
        for history, _ in self._previous:
            history.transport(step)
        histories = self._tracks(centroids, t_s)
        self._previous = list(zip(histories, radii_px, strict=True))
        return [history.velocity() or (0.0, 0.0) for history in histories]

    def _tracks(self, centroids: list[tuple[float, float]], t_s: float) -> list[PositionHistory]:
        """Each region's recent centroids, its own added: the previous regions' tracks, nearest
        pair first, a track going to the region within twice its radius (one each); a new track
        for a region none is that near. A centroid further than that radius from where its
        track predicts it (two regions merged, one split) starts the track afresh."""
        matched: dict[int, PositionHistory] = {}
        if self._previous and centroids:
            ends = np.array([history.last()[1:] for history, _ in self._previous])
            radii = np.array([radius for _, radius in self._previous])
            offsets = np.array(centroids)[:, None, :] - ends[None, :, :]
            distance = np.hypot(offsets[..., 0], offsets[..., 1])
            taken = np.zeros(len(self._previous), bool)
            near = np.flatnonzero(distance <= 2.0 * radii[None, :])  # the pairs within reach
            for k in near[np.argsort(distance.ravel()[near], kind="stable")]:
                i, j = divmod(int(k), len(self._previous))
                if i in matched or taken[j]:
                    continue
                history, radius = self._previous[j]
                history.add(t_s, *centroids[i], gate_px=radius)
                matched[i], taken[j] = history, True
        tracks = []
        for i, (u, v) in enumerate(centroids):
            if i not in matched:
                matched[i] = PositionHistory(self.points)
                matched[i].add(t_s, u, v)
            tracks.append(matched[i])
        return tracks
