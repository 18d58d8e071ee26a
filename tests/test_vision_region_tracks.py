"""A frame's regions matched to the previous frame's: the slope of their recent centroids is
their velocity; a region without a track of its own (first seen, merged, split) has none."""

from __future__ import annotations

import numpy as np
import pytest

from gazed.vision.ego_motion import HeadStep
from gazed.vision.region_tracks import RegionTracks

RATE_HZ = 7.0
STILL = HeadStep(np.eye(3), np.zeros(3), 1.0 / RATE_HZ, np.eye(3))  # the head does not turn
RADIUS_PX = 20.0
AREA_PX = 300.0


def run(
    tracks: RegionTracks,
    frames: list[list[tuple[float, float]]],
    last_areas_px: list[float] | None = None,
) -> list:
    """Each frame's centroids in turn, each region of AREA_PX but the last frame's (their own
    areas where given); the velocities of the last frame."""
    velocities: list = []
    for k, centroids in enumerate(frames):
        areas = [AREA_PX] * len(centroids)
        if k == len(frames) - 1 and last_areas_px is not None:
            areas = last_areas_px
        radii = [RADIUS_PX] * len(centroids)
        velocities = tracks.update(STILL, centroids, radii, areas, k / RATE_HZ)
    return velocities


def walk(u0: float, du_px_s: float, frames: int) -> list[tuple[float, float]]:
    return [(u0 + du_px_s * k / RATE_HZ, 100.0) for k in range(frames)]


def test_a_region_seen_for_the_first_time_has_no_velocity() -> None:
    assert run(RegionTracks(6), [[(50.0, 100.0)]]) == [None]


def test_a_region_followed_over_frames_has_its_velocity() -> None:
    velocities = run(RegionTracks(6), [[p] for p in walk(50.0, 14.0, 8)])
    assert velocities[0] == pytest.approx((14.0, 0.0))


def test_two_regions_that_merge_have_no_velocity() -> None:
    """Two walkers 30 px apart in opposite directions, then one region of both their areas at
    their middle: its centroid moved by the merge, not by a walk, so it says nothing of anyone's
    velocity."""
    left, right = walk(50.0, 14.0, 5), walk(80.0, -14.0, 5)
    frames = [[a, b] for a, b in zip(left, right, strict=True)]
    middle = [((left[-1][0] + right[-1][0]) / 2.0, 100.0)]
    assert run(RegionTracks(6), [*frames, middle], [2 * AREA_PX]) == [None]
    # one walker not seen while the other keeps its own area is no merge: its velocity stays
    (velocity,) = run(RegionTracks(6), [*frames, [(left[-1][0] + 2.0, 100.0)]], [AREA_PX])
    assert velocity is not None and velocity[0] == pytest.approx(14.0, abs=1.0)


def test_a_region_that_splits_has_no_velocity() -> None:
    """One region, then two, each with half its area: the part that keeps its track has a
    centroid moved by the split; a small flicker beside it takes nothing from it."""
    frames = [[p] for p in walk(60.0, 14.0, 5)]
    last = frames[-1][0][0]
    parts = [(last - 8.0, 100.0), (last + 12.0, 100.0)]
    assert run(RegionTracks(6), [*frames, parts], [AREA_PX / 2] * 2) == [None, None]
    beside = [(last + 2.0, 100.0), (last + 12.0, 100.0)]
    velocity, flicker = run(RegionTracks(6), [*frames, beside], [AREA_PX, 9.0])
    assert velocity is not None and velocity[0] == pytest.approx(14.0, abs=1.0)
    assert flicker is None


def test_a_flicker_beside_a_region_whose_area_varies_leaves_it_its_velocity() -> None:
    """A walker's region changes its area from frame to frame; a small flicker comes and goes
    beside it. Neither is a merge or a split: the region keeps its velocity throughout."""
    rng = np.random.default_rng(7)
    tracks, area_px, velocities = RegionTracks(6), 3000.0, []
    for k, (u, v) in enumerate(walk(100.0, 14.0, 200)):
        centroids, areas = [(u, v)], [area_px * (1.0 + 0.03 * rng.standard_normal())]
        if k % 2:
            centroids.append((u + 35.0, v))
            areas.append(float(rng.uniform(20.0, 60.0)))
        velocities.append(
            tracks.update(STILL, centroids, [40.0] * len(areas), areas, k / RATE_HZ)[0]
        )
    assert all(velocity is not None for velocity in velocities[1:])
