"""A blob's members lie inside the mover's box: the image test that keeps a detection between two
tracks far apart from being taken as the blob of both (`silhouette_reach`)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import REPO

from gazed.config import load_rig
from gazed.estimation.measurement import Measurement
from gazed.estimation.silhouette_reach import held, reach_box
from gazed.estimation.tracks import Sighting, TrackSet

SIM_RIG = REPO / "configs" / "sim.toml"
PX_PER_M = 100.0  # the test camera: a ground metre is 100 pixels on both axes


def to_pixel(x_m: float, y_m: float) -> np.ndarray:
    if y_m < -5.0:
        raise ValueError("behind the camera")
    return np.array([PX_PER_M * x_m, PX_PER_M * y_m])


def test_a_box_bounds_its_point_on_every_side() -> None:
    assert reach_box(100.0, 50.0, 0.0, 40.0) is None  # a mover without a box
    box = reach_box(100.0, 50.0, 20.0, 40.0)
    assert box is not None and box.tolist() == [80.0, 10.0, 120.0, 90.0]


def test_a_track_is_held_where_its_prediction_can_lie_in_the_box() -> None:
    predicted = np.array([[1.0, 0.5], [3.0, 0.5], [3.0, 0.5], [0.0, -6.0]])
    sure, unsure = np.eye(2) * 1e-4, np.eye(2) * 4.0  # 1 cm and 2 m std
    P = np.array([sure, sure, unsure, sure])
    boxes = [reach_box(100.0, 50.0, 20.0, 40.0), None]
    inside = held(predicted, P, boxes, to_pixel, 4.0, 13.8)
    # in the box; 1.8 m off it and sure; as far but unsure; behind the camera. No box: any.
    assert inside[:, 0].tolist() == [True, False, True, False]
    assert inside[:, 1].all()


def walking(t_s: float, xy: tuple[float, float], box_px: np.ndarray | None = None) -> Sighting:
    """A mover walking at 1 m/s along x."""
    cov = np.eye(2) * 0.0004
    measurement = Measurement.ground(t_s, xy, cov, (1.0, 0.0), np.eye(2) * 0.01)
    return Sighting(measurement, box_px=box_px)


@pytest.mark.parametrize(("apart_m", "blobs"), [(0.6, 30), (3.0, 0)])
def test_only_people_inside_one_box_are_its_blob(apart_m: float, blobs: int) -> None:
    """Two people walk side by side; from 0.6 s one mover, one person wide (0.5 m), lies
    between them: the blob of both where both fit its box, someone else's where they do not."""
    tracks = TrackSet(load_rig(SIM_RIG).estimator)
    for k in range(50):
        t = k * 0.04
        people = [walking(t, (t, 1.0)), walking(t, (t, 1.0 + apart_m))]
        middle = (t, 1.0 + apart_m / 2)
        size_px = 0.5 * PX_PER_M if apart_m > 1.0 else (apart_m + 0.5) * PX_PER_M
        box = reach_box(*to_pixel(*middle), size_px, size_px)
        seen = people if k < 15 or k >= 45 else [walking(t, middle, box)]
        tracks.step(t, seen, to_pixel)
    assert tracks.counts["group_updates"] == blobs
