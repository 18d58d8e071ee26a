"""A person's size in a calibrated wide camera, and the silhouettes judged against it:

- the PETS rig's calibration gives a person's pixel height near the annotated boxes' heights,
  larger nearer the camera, and nothing where a pixel does not see the ground;
- a blob at least two people wide is cut into as many, even with no valley between them; one
  person's blob stays whole however its columns vary;
- background subtraction holds a walker who stops out of the background for as long as the model
  remembers, then learns them.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import REPO

from gazed.config import load_rig
from gazed.vision.digital_camera import wide_camera
from gazed.vision.movers import Blob, split_blob
from gazed.vision.person_size import PersonSize
from gazed.vision.silhouettes import SilhouetteModel


@pytest.fixture(scope="module")
def pets_person() -> PersonSize:
    rig = load_rig(REPO / "configs" / "pets.toml")
    person = PersonSize.from_rig(rig, wide_camera(rig.wide))
    assert person is not None
    return person


def test_a_persons_height_where_they_stand(pets_person: PersonSize) -> None:
    # two annotated PETS people's foot points and box heights (480x360 pixels)
    for (u, v), box_h in (((243.5, 160.7), 47.3), ((433.1, 229.9), 71.5)):
        width, height = pets_person.at(u, v)
        assert 0.8 * box_h <= height <= 1.05 * box_h  # the box holds the whole person
        assert 0.2 <= width / height <= 0.4  # 0.5 m across, 1.7 m tall
    assert pets_person.at(240, 300)[1] > pets_person.at(240, 150)[1]  # nearer, larger
    assert pets_person.at(240, -500) is None  # above the horizon


def test_no_person_size_without_a_ground_geometry() -> None:
    rig = load_rig(REPO / "configs" / "pets.toml")
    rig = rig.model_copy(
        update={"calibration": rig.calibration.model_copy(update={"homography": None})}
    )
    assert PersonSize.from_rig(rig, wide_camera(rig.wide)) is None


def test_a_blob_two_people_wide_is_cut_in_two_without_a_valley() -> None:
    solid = Blob(5, 7, np.ones((40, 25), bool))  # two 12 px wide people shoulder to shoulder
    parts = split_blob(solid, person_width=12.0)
    assert len(parts) == 2 and sum(p.width for p in parts) == 25
    assert all(abs(p.width - 12.5) <= 6 for p in parts)
    three = split_blob(Blob(0, 0, np.ones((40, 36), bool)), person_width=12.0)
    assert [p.width for p in three] == [12, 12, 12]
    assert split_blob(solid, person_width=13.0) == [solid]  # less than two people wide


def test_one_persons_blob_stays_whole() -> None:
    mask = np.ones((30, 20), bool)
    mask[:, 9:11] = False  # a gap between the legs, as deep as any between two people
    mask[:10, 9:11] = True
    blob = Blob(0, 0, mask)
    assert split_blob(blob, person_width=12.0) == [blob]
    assert len(split_blob(blob)) == 2  # the width model alone cuts it at the gap


def test_a_walker_who_stops_stays_foreground_while_the_model_remembers() -> None:
    history = 30
    model = SilhouetteModel(
        level=0, history_frames=history, threshold=16.0, min_area_px=50, learning_frames=5
    )
    rng = np.random.default_rng(3)

    def frame(walker: bool) -> np.ndarray:
        gray = (100 + rng.normal(0, 2, (60, 80))).clip(0, 255).astype(np.uint8)
        if walker:
            gray[20:50, 30:40] = 200
        return gray

    for _ in range(10):
        model.segment(frame(False))
    standing = [model.segment(frame(True)) for _ in range(history)]
    assert all(f is not None and len(f.found) == 1 for f in standing)  # still there
    for _ in range(3 * history):
        last = model.segment(frame(True))
    assert last is not None and not last.found  # learnt once the model's memory is past
