"""Scoring a run on footage against an annotated person, on synthetic streams: where people are
in the digital head's view, acquisition, the fovea fraction, switches (3 frames count, 2 do
not), the run ending when the person leaves the wide view, the ground error, and what a run
shows without truth."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from gazed.eval.person_score import (
    FrameFacts,
    ViewFrame,
    first_pursued,
    pursuit_summary,
    reach_scores,
    score_person,
)
from gazed.eval.truth import Person
from gazed.eval.view_people import ViewPeople
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import FLIP_Y, HeadKinematics
from gazed.geometry.pose import CameraPose
from gazed.messages import EstimatorState
from gazed.sim.reach import FieldOfRegard
from gazed.vision.digital_view import DigitalView

WIDE = CameraModel.from_intrinsics(480, 360, 400.0, 400.0, 239.5, 179.5)
LENS = CameraModel.from_intrinsics(160, 120, 133.0, 134.0, 77.0, 57.0, (-0.15, 0.07, 0, 0, -0.03))
VIEW = CameraModel.from_intrinsics(240, 180, 400.0, 400.0, 119.5, 89.5)
FOVEA_DEG = 3.0
DT_NS = 142_857_143  # 7 Hz
OFF_PX = 400.0 * math.tan(math.radians(5.0))  # 5° off the axis: outside the fovea
CENTRE = (239.5, 179.5)


@pytest.fixture(scope="module")
def geometry() -> ViewPeople:
    return ViewPeople(DigitalView(WIDE, VIEW, HeadKinematics()))


@pytest.fixture(scope="module")
def lens_geometry() -> ViewPeople:
    """A wide camera with a distorting lens, as a calibrated one has."""
    return ViewPeople(DigitalView(LENS, VIEW, HeadKinematics()))


def person(person_id: int, frames: list[int], centres: list[tuple[float, float]]) -> Person:
    """A person annotated in `frames`, their box (20 x 60 px) centred at `centres`."""
    n = len(frames)
    boxes = np.array([[u, v, 20.0, 60.0] for u, v in centres])
    return Person(
        id=person_id,
        frame=np.array(frames),
        t_s=np.array(frames) / 7.0,
        box_px=boxes,
        foot_px=boxes[:, :2] + [0.0, 30.0],
        ground_m=np.column_stack([np.arange(n) * 0.2, np.full(n, 3.0)]),
    )


def frames_at_rest(count: int, pursuing: bool = True) -> list[ViewFrame]:
    """The head at rest, so the view's centre is the wide frame's centre."""
    return [ViewFrame(k, k * DT_NS, 0.0, 0.0, pursuing) for k in range(count)]


def score(frames, people, person_id, geometry, estimates=()):
    facts = FrameFacts.of(frames, people, geometry)
    return score_person(frames, facts, people[person_id], FOVEA_DEG, list(estimates))


def test_a_box_centre_is_placed_by_the_head_pose(
    geometry: ViewPeople, lens_geometry: ViewPeople
) -> None:
    """The gaze error against the angle between the wide camera's ray through the box centre
    (OpenCV's undistortion) and the view's optical axis turned by the head."""
    boxes = np.array([[100.0, 40.0, 7, 20], [33.0, 83.0, 7, 20], [157.0, 3.0, 7, 20]])
    pan, tilt = math.radians(8.0), math.radians(-4.0)
    seen = lens_geometry.at_pose(boxes, pan, tilt)
    axis = FLIP_Y @ HeadKinematics().rotation(pan, tilt) @ FLIP_Y @ np.array([0.0, 0.0, 1.0])
    ideal = cv2.undistortPoints(boxes[:, None, :2], LENS.K, LENS.distortion).reshape(-1, 2)
    rays = np.column_stack([ideal, np.ones(len(ideal))])
    expected = np.arccos(rays @ axis / np.linalg.norm(rays, axis=1))
    assert np.allclose(seen.error_rad, expected, atol=1e-6)
    assert lens_geometry.at_pose(np.zeros((0, 4)), 0.1, 0.0).gaze_on() is None  # nobody
    at_rest = geometry.at_pose(np.array([[*CENTRE, 20, 60], [5.0, 5.0, 20, 60]]), 0.0, 0.0)
    assert at_rest.error_rad[0] == pytest.approx(0.0, abs=1e-12)
    assert at_rest.held.tolist() == [True, False] and at_rest.gaze_on() == 0
    outside = geometry.at_pose(np.array([[-5.0, 100.0, 20, 60]]), 0.0, 0.0)
    assert not outside.in_wide[0]


def test_a_person_out_of_the_heads_reach_is_told_apart(geometry: ViewPeople) -> None:
    """Pan limits ±0.1 rad: a person 0.05 rad off the axis can be foveated, one 0.2 rad off
    cannot; their frames are left out of the fovea fraction over the reachable."""
    reach = FieldOfRegard(
        CameraPose(np.array([0.0, 0.0, 1.0]), 0.0), (-0.1, 0.1), (-0.1, 0.1), (0.0, 0.0), 0.0
    )
    limited = ViewPeople(geometry.view, reach)
    near, far = CENTRE[0] + 400.0 * math.tan(0.05), CENTRE[0] + 400.0 * math.tan(0.2)
    seen = limited.at_pose(
        np.array([[near, CENTRE[1], 20, 60], [far, CENTRE[1], 20, 60]]), 0.0, 0.0
    )
    assert seen.reachable.tolist() == [True, False]
    assert geometry.at_pose(np.array([[far, CENTRE[1], 20, 60]]), 0.0, 0.0).reachable.all()
    frames = list(range(30))
    people = {6: person(6, frames, [CENTRE] * 20 + [(far, CENTRE[1])] * 10)}
    facts = FrameFacts.of(frames_at_rest(30), people, limited)
    assert reach_scores(facts, 6, FOVEA_DEG) == {
        "out_of_reach_fraction": pytest.approx(1 / 3, abs=1e-4),
        "fovea_fraction_reachable": 1.0,
    }
    assert score_person(frames_at_rest(30), facts, people[6], FOVEA_DEG, [])["fovea_fraction"] == (
        pytest.approx(2 / 3, abs=1e-4)
    )


def test_a_person_walking_through_the_view(geometry: ViewPeople) -> None:
    """Off the axis for 5 frames, then held at the centre until they leave at frame 30; their
    return later is not part of the run."""
    frames = list(range(30)) + list(range(40, 46))
    centres = [(CENTRE[0] + OFF_PX, CENTRE[1])] * 5 + [CENTRE] * 25 + [CENTRE] * 6
    people = {4: person(4, frames, centres)}
    estimates = [
        EstimatorState(
            t_capture_ns=k * DT_NS,
            filter="imm",
            x=(0.0,),
            P=((1.0,),),
            ground_xy_m=(k * 0.2 + 0.3, 3.0) if k < 30 else (99.0, 99.0),
        )
        for k in range(46)
    ]
    result = score(frames_at_rest(46), people, 4, geometry, estimates)
    assert result["id"] == 4 and result["visible_frames"] == 30
    assert result["acquired_after_s"] == pytest.approx(5 * DT_NS / 1e9, abs=1e-3)
    assert result["fovea_fraction"] == 1.0 and result["switches"] == 0
    assert result["gaze_error_deg"] == {"rms": 0.0, "p95": 0.0}
    assert result["ground_rmse_m"] == pytest.approx(0.3)
    assert set(result) == {
        "id",
        "visible_frames",
        "acquired_after_s",
        "fovea_fraction",
        "switches",
        "gaze_error_deg",
        "ground_rmse_m",
    }


@pytest.mark.parametrize(("away", "switches"), [(3, 1), (2, 0)])
def test_a_switch_is_three_frames_on_another_person(
    geometry: ViewPeople, away: int, switches: int
) -> None:
    """From frame 15 the gaze is on B for `away` frames (A 5° off), then back on A."""
    frames = list(range(30))
    a = [CENTRE] * 30
    b = [(CENTRE[0] + 60.0, CENTRE[1])] * 30
    for k in range(15, 15 + away):
        a[k], b[k] = (CENTRE[0] + OFF_PX, CENTRE[1]), CENTRE
    people = {1: person(1, frames, a), 2: person(2, frames, b)}
    result = score(frames_at_rest(30), people, 1, geometry)
    assert result["switches"] == switches
    assert result["fovea_fraction"] == pytest.approx((30 - away) / 30, abs=1e-4)
    assert result["gaze_error_deg"]["rms"] == pytest.approx(5.0 * math.sqrt(away / 30), abs=1e-3)


def test_overlapping_boxes_are_no_switch(geometry: ViewPeople) -> None:
    """In frames 10-19 B walks 3 px beside A, nearer the view's centre; A's box still holds
    it, so the view shows A: no switch. B alone at the centre in frames 25-29 is one."""
    frames = list(range(30))
    far, off = (CENTRE[0] + 60.0, CENTRE[1]), (CENTRE[0] + OFF_PX, CENTRE[1])
    a = [CENTRE] * 10 + [(CENTRE[0] + 5.0, CENTRE[1])] * 10 + [CENTRE] * 5 + [off] * 5
    b = [far] * 10 + [(CENTRE[0] + 2.0, CENTRE[1])] * 10 + [far] * 5 + [CENTRE] * 5
    people = {1: person(1, frames, a), 2: person(2, frames, b)}
    assert score(frames_at_rest(30), people, 1, geometry)["switches"] == 1


def test_frames_not_in_pursuit_are_no_switch(geometry: ViewPeople) -> None:
    frames = list(range(30))
    a = [CENTRE] * 12 + [(CENTRE[0] + OFF_PX, CENTRE[1])] * 5 + [CENTRE] * 13
    b = [(CENTRE[0] + 60.0, CENTRE[1])] * 12 + [CENTRE] * 5 + [(CENTRE[0] + 60, CENTRE[1])] * 13
    people = {1: person(1, frames, a), 2: person(2, frames, b)}
    stream = frames_at_rest(30)
    stream[12:17] = [ViewFrame(f.frame, f.t_capture_ns, 0.0, 0.0, False) for f in stream[12:17]]
    assert score(stream, people, 1, geometry)["switches"] == 0
    assert first_pursued(FrameFacts.of(stream, people, geometry)) == 1


def test_a_person_never_in_the_fovea_is_not_acquired(geometry: ViewPeople) -> None:
    frames = list(range(20))
    people = {3: person(3, frames, [(CENTRE[0] + OFF_PX, CENTRE[1])] * 20)}
    result = score(frames_at_rest(20), people, 3, geometry)
    assert result["visible_frames"] == 20 and result["acquired_after_s"] is None
    assert result["fovea_fraction"] == 0.0 and result["gaze_error_deg"] is None
    assert (
        score(frames_at_rest(20), {**people, 5: person(5, [99], [CENTRE])}, 5, geometry)[
            "visible_frames"
        ]
        == 0
    )


def test_without_truth_pursuit_and_track_switches_by_id() -> None:
    """Acquired at the first of ten frames in pursuit; a change of track counts once it has
    lasted three frames."""
    ids = [None] * 4 + [7] * 20 + [8, 8] + [7] * 10 + [9] * 3 + [9] * 5
    pursuing = [False] * 4 + [True] * (len(ids) - 4)
    frames = [
        ViewFrame(k, k * DT_NS, 0.0, 0.0, p, t)
        for k, (p, t) in enumerate(zip(pursuing, ids, strict=True))
    ]
    summary = pursuit_summary(frames)
    assert summary["acquired_after_s"] == pytest.approx(4 * DT_NS / 1e9, abs=1e-3)
    assert summary["pursuit_fraction"] == 1.0
    assert summary["track_switches"] == 1
    assert pursuit_summary(frames_at_rest(5, pursuing=False))["acquired_after_s"] is None
