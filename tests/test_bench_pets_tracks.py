"""The offline PETS bench's truth-free figure: ids born and how long each is held."""

from __future__ import annotations

import numpy as np
import pytest
from bench.pets_tracks import id_lifetimes


def rows(tracks_by_frame: list[list[int]], learning: int = 0) -> list[dict]:
    """Replay rows, the first `learning` of them while the background model learns."""
    return [
        {"frame": f, "learning": f < learning, "tracks": dict.fromkeys(ids)}
        for f, ids in enumerate(tracks_by_frame)
    ]


def test_one_id_held_throughout_is_one_long_life():
    figure = id_lifetimes(rows([[3]] * 70), rate_hz=7.0)
    assert figure["ids"] == 1
    assert figure["median_life_s"] == pytest.approx(10.0)
    assert figure["ids_per_min"] == pytest.approx(6.0)


def test_a_person_split_into_restarts_gives_more_ids_and_shorter_lives():
    held = id_lifetimes(rows([[0, 1]] * 70), rate_hz=7.0)
    restarted = id_lifetimes(rows([[0, 10 + f // 14] for f in range(70)]), rate_hz=7.0)
    assert restarted["ids"] == held["ids"] + 4
    assert restarted["median_life_s"] < held["median_life_s"]
    assert restarted["mean_life_s"] < held["mean_life_s"]


def test_ids_are_born_per_minute_of_the_frames_the_model_reports():
    """The learning frames, where no track can exist, are not minutes ids could be born in."""
    figure = id_lifetimes(rows([[]] * 10 + [[3]] * 70, learning=10), rate_hz=7.0)
    assert figure["ids_per_min"] == pytest.approx(6.0)


def test_no_tracks_no_ids():
    assert id_lifetimes(rows([[]] * 5), rate_hz=7.0)["ids"] == 0
    assert id_lifetimes([], rate_hz=7.0)["ids_per_min"] == 0.0


def test_a_track_is_on_the_person_whose_box_holds_the_view_aimed_at_it():
    from bench.pets_tracks import RIG, aimed_at

    from gazed.config import load_rig
    from gazed.eval.view_people import ViewPeople
    from gazed.geometry.camera import CameraModel
    from gazed.geometry.ground import GroundGeometry
    from gazed.geometry.kinematics import HeadKinematics
    from gazed.vision.digital_camera import wide_camera
    from gazed.vision.digital_view import DigitalView

    rig = load_rig(RIG)
    view = DigitalView(
        wide_camera(rig.wide),
        CameraModel.from_section(rig.camera),
        HeadKinematics.from_section(rig.head),
    )
    people, aim = ViewPeople(view), GroundGeometry.from_rig(rig)
    track = np.array([[-8.0, -6.0]])
    # the wide pixel the view's centre sees with the head aimed at the track
    camera = CameraModel.from_section(rig.camera)
    ideal = view.homography(*aim.gaze_from_ground(-8.0, -6.0)) @ [*camera.K[:2, 2], 1.0]
    u, v = view.wide.pixel(view.wide.K_inv @ (ideal / ideal[2]))
    # a person's box round it, and one beside it
    boxes = np.array([[u + 3.0, v - 4.0, 20.0, 50.0], [u + 30.0, v, 20.0, 50.0]])
    angles = aimed_at(people, aim, boxes, track)
    assert np.isfinite(angles[0, 0]) and angles[1, 0] == np.inf


def test_a_change_while_the_track_before_still_holds_the_person_is_a_twin():
    from bench.pets_tracks import change_kind

    on_person = np.array([0.01, np.inf, 0.02])
    assert change_kind(5, was_elsewhere=True, on_person=on_person, track_ids=[5, 6, 7]) == "twin"
    assert change_kind(6, was_elsewhere=True, on_person=on_person, track_ids=[5, 6, 7]) == "swap"
    assert change_kind(6, was_elsewhere=False, on_person=on_person, track_ids=[5, 6, 7]) == (
        "restart"
    )
    assert change_kind(9, was_elsewhere=False, on_person=on_person, track_ids=[5, 6, 7]) == (
        "restart"
    )


def test_one_id_share_is_the_most_held_tracks_share_of_the_persons_frames():
    from bench.pets_tracks import one_id_share

    # lost 2 of 10 frames (any track: 0.8 held), but no one track holds more than half
    share, ids = one_id_share([{4}, {4}, set(), {7}, {7}, {7}, {4}, set(), {9}, {7}])
    assert share == pytest.approx(0.4) and ids == 3
    assert one_id_share([{4}, {4, 7}, {7, 4}]) == (1.0, 2)  # twins both hold the person
    assert one_id_share([{5}] * 6) == (1.0, 1)
    assert one_id_share([set(), set()]) == (0.0, 0)
    assert one_id_share([]) == (0.0, 0)
