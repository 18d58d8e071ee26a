"""The velocities of a frame's regions, from their recent centroids matched frame to frame.

Each region of a frame is matched to the nearest region of the previous frame (whose centroids
are first moved by the head's rotation, `PositionHistory.transport`) and inherits its recent
centroids; the least-squares slope of those, over up to `points` frames, is its independent
image velocity. A centroid wobbles by a pixel or two from frame to frame, so a velocity from the
last two frames alone is far off; the slope over several is not. A region seen for the first
time, or whose centroid jumped off its track (two regions merged, one split), has no velocity
yet: None, not zero, which would say it stands still.
"""

from __future__ import annotations

import numpy as np

from gazed.vision.ego_motion import HeadStep
from gazed.vision.position_history import PositionHistory

# a region merged with or split from another only where that other is at least this share of
# the whole (the merged region, or the one before it split): a region's area changes from frame
# to frame (a walker's stride, the mask's edge), and a fragment or flicker smaller than that
# change cannot be told from it (nor does it move the centroid much)
PART_SHARE = 0.25


class RegionTracks:
    """The recent centroids of the previous frame's regions, each with the radius it reaches and
    its area."""

    def __init__(self, points: int) -> None:
        self.points = points
        self._previous: list[tuple[PositionHistory, float, float]] = []

    def reset(self) -> None:
        self._previous = []

    def update(
        self,
        step: HeadStep,
        centroids: list[tuple[float, float]],
        radii_px: list[float],
        areas_px: list[float],
        t_s: float,
    ) -> list[tuple[float, float] | None]:
        """The velocity (px/s) of each of this frame's regions, given their centroids, radii
        and areas; None for one with a single point on its track (seen for the first time, or
        started afresh). The regions become the previous ones for the next frame."""
        for history, _, _ in self._previous:
            history.transport(step)
        histories = self._tracks(centroids, areas_px, t_s)
        self._previous = list(zip(histories, radii_px, areas_px, strict=True))
        return [history.velocity() for history in histories]

    def _tracks(
        self, centroids: list[tuple[float, float]], areas_px: list[float], t_s: float
    ) -> list[PositionHistory]:
        """Each region's recent centroids, its own added: the previous regions' tracks, nearest
        pair first, a track going to the region within twice its radius (one each); a new track
        for a region none is that near. A centroid further than that radius from where its
        track predicts it starts the track afresh, and so does the centroid of a region whose
        mask took in another or lost a part, which moved by the change of its mask, not by its
        motion: a merge, where a previous region within its reach went to no region and it
        gained at least half that region's area; a split, where a new region is within its
        previous region's reach and it lost at least half the new region's area. Either other
        region is at least `PART_SHARE` of the whole (the merged region, or the one that split):
        a flicker beside a region, or a fragment, is not told from the change of its area."""
        matched: dict[int, PositionHistory] = {}
        if self._previous and centroids:
            ends = np.array([history.last()[1:] for history, _, _ in self._previous])
            radii = np.array([radius for _, radius, _ in self._previous])
            before = np.array([area for _, _, area in self._previous])
            offsets = np.array(centroids)[:, None, :] - ends[None, :, :]
            distance = np.hypot(offsets[..., 0], offsets[..., 1])
            within = distance <= 2.0 * radii[None, :]  # (current, previous) pairs within reach
            taken = np.zeros(len(self._previous), bool)
            source: dict[int, int] = {}
            near = np.flatnonzero(within)
            for k in near[np.argsort(distance.ravel()[near], kind="stable")]:
                i, j = divmod(int(k), len(self._previous))
                if i in matched or taken[j]:
                    continue
                history, radius, _ = self._previous[j]
                history.add(t_s, *centroids[i], gate_px=radius)
                matched[i], taken[j], source[i] = history, True, j
            new = np.array([i for i in range(len(centroids)) if i not in matched], int)
            areas = np.asarray(areas_px, float)
            for i, j in source.items():
                change = areas[i] - before[j]
                own_px = PART_SHARE * max(areas[i], before[j])
                absorbed = before[within[i] & ~taken]
                absorbed = absorbed[absorbed >= own_px]
                parted = areas[new[within[new, j]]]
                parted = parted[parted >= own_px]
                merged = bool((change >= 0.5 * absorbed).any())
                split = bool((-change >= 0.5 * parted).any())
                if merged or split:
                    matched[i].clear()
                    matched[i].add(t_s, *centroids[i])
        tracks = []
        for i, (u, v) in enumerate(centroids):
            if i not in matched:
                matched[i] = PositionHistory(self.points)
                matched[i].add(t_s, u, v)
            tracks.append(matched[i])
        return tracks
