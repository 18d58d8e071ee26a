"""Several people at once: the estimator keeps one track per person, with a stable id, where two
or three people cross, pass and walk side by side at 0.5-1.5 m/s, and predicts the chosen one.

Detections are made through the sim rig's true geometry (`bench/crossing_people.py`): each
person's tracked point seen by the still head, with pixel and image-velocity noise and a noisy
colour histogram of each person's own colours, in a shuffled order every frame (seeded). Where
two are close, the one farther from the camera is hidden and its track coasts."""

from __future__ import annotations

import numpy as np
import pytest
from bench.crossing_people import SCENES, SIM_RIG, follow, walk

from gazed.config import EstimatorSection, Rig, load_rig
from gazed.estimation import tracks as tracks_module
from gazed.estimation.measurement import Measurement
from gazed.estimation.target_tracker import TargetTracker
from gazed.estimation.tracks import Sighting, TrackSet

SECONDS = 4.0


def run(
    scene: str, seed: int, choose_person: int | None = None, rig: Rig | None = None
) -> tuple[dict, list]:
    """Each person's track ids where no one else is near, and the states of the run."""
    return follow(rig or load_rig(SIM_RIG), scene, SECONDS, seed, choose_person)


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("seed", [1, 2])
def test_every_person_keeps_one_id(scene: str, seed: int) -> None:
    ids, states = run(scene, seed)
    assert all(len(found) == 1 for found in ids.values()), ids
    assert len({next(iter(found)) for found in ids.values()}) == len(ids)  # one each
    _, last = states[-1]
    assert sum(t.confirmed for t in last.tracks) == len(SCENES[scene])  # no clutter confirmed


@pytest.mark.parametrize("scene", ["two crossing", "side by side", "joining, one blob"])
def test_the_chosen_track_is_predicted_and_kept(scene: str) -> None:
    ids, states = run(scene, 3, choose_person=0)
    (chosen,) = ids[0]
    for t, state in states[11:]:
        assert state.target_id == chosen
        truth = walk(scene, t)[0]
        assert np.linalg.norm(np.subtract(state.ground_xy_m, truth)) < 0.3


def test_image_cv_tracks_people_on_gaze_angles() -> None:
    rig = load_rig(SIM_RIG)
    rig = rig.model_copy(
        update={"estimator": rig.estimator.model_copy(update={"filter": "image-cv"})}
    )
    ids, states = run("passing", 1, rig=rig)
    assert all(len(found) == 1 for found in ids.values()), ids
    _, last = states[-1]
    assert all(t.ground_xy_m is None for t in last.tracks) and len(last.tracks) == 2


def measurement(t_s: float, xy: tuple[float, float]) -> Sighting:
    cov = np.eye(2) * 0.01
    return Sighting(Measurement.ground(t_s, xy, cov, (0.0, 0.0), np.eye(2) * 0.04))


def test_confirmation_is_m_of_n_and_ids_are_never_reused() -> None:
    rig = load_rig(SIM_RIG)
    section = rig.estimator.model_copy(
        update={"confirm_hits": 3, "confirm_frames": 4, "coast_max_ms": 300.0}
    )
    tracks = TrackSet(section)
    seen = [True, False, True, False]  # 2 of 4: never confirmed, dropped as clutter
    for k, hit in enumerate(seen):
        tracks.step(k * 0.04, [measurement(k * 0.04, (0.0, 1.0))] if hit else [])
    assert tracks.tracks == [] and tracks.counts["tracks_ended"] == 1
    for k in range(4, 8):  # a person now: 3 of the first 3 frames
        tracks.step(k * 0.04, [measurement(k * 0.04, (1.0, 1.0))])
    (person,) = tracks.tracks
    assert person.id == 1 and person.confirmed and person.hits == 4
    for k in range(8, 17):  # unseen: it coasts, keeps its id, and ends past coast_max_ms
        tracks.step(k * 0.04, [])
        coasted_s = k * 0.04 - person.last_hit_s
        assert (tracks.get(1) is person) == (coasted_s <= 0.3) and person.coasting
    assert tracks.get(1) is None
    tracks.step(0.7, [measurement(0.7, (1.0, 1.0))])
    assert [t.id for t in tracks.tracks] == [2]  # a new track, a new id


def test_a_frame_older_than_the_tracks_changes_nothing() -> None:
    tracks = TrackSet(load_rig(SIM_RIG).estimator)
    tracks.step(1.0, [measurement(1.0, (0.0, 1.0))])
    tracks.step(0.5, [measurement(0.5, (3.0, 1.0))])
    assert len(tracks.tracks) == 1 and tracks.counts["late_frames"] == 1


def test_a_lone_target_that_jumps_keeps_its_id() -> None:
    section = load_rig(SIM_RIG).estimator
    tracks = TrackSet(section)
    for k in range(10):
        tracks.step(k * 0.04, [measurement(k * 0.04, (0.0, 1.0))])
    (lone,) = tracks.tracks
    for k in range(10, 10 + section.reinit_after_misses):  # the one mover is 1 m off: outliers
        tracks.step(k * 0.04, [measurement(k * 0.04, (1.0, 1.0))])
    assert tracks.tracks == [lone] and lone.id == 0 and not lone.coasting  # restarted there
    state = lone.estimator.predict(0.6)
    assert state is not None and state.position[0] == pytest.approx(1.0, abs=0.05)
    # with a second person in view, a mover outside both gates is someone new
    tracks.step(0.64, [measurement(0.64, (1.0, 1.0)), measurement(0.64, (-2.0, 1.0))])
    tracks.step(0.68, [measurement(0.68, (1.0, 1.0)), measurement(0.68, (-2.0, 1.0))])
    tracks.step(0.72, [measurement(0.72, (1.0, 1.0)), measurement(0.72, (3.0, 1.0))])
    assert [t.id for t in tracks.tracks] == [0, 1, 2]


def walking(t_s: float, xy: tuple[float, float]) -> Sighting:
    """A mover walking at 1 m/s along x, as a sighting."""
    cov = np.eye(2) * 0.0004
    return Sighting(Measurement.ground(t_s, xy, cov, (1.0, 0.0), np.eye(2) * 0.01))


def test_a_person_split_into_two_tracks_is_merged_under_the_older_id() -> None:
    tracks = TrackSet(load_rig(SIM_RIG).estimator)
    for k in range(10):
        tracks.step(k * 0.04, [walking(k * 0.04, (k * 0.04, 1.0))])
    for k in range(10, 14):  # the detector splits the walker: its other part 0.25 m off
        t = k * 0.04
        tracks.step(t, [walking(t, (t, 1.0)), walking(t, (t, 1.25))])
    assert [(t.id, t.confirmed) for t in tracks.tracks] == [(0, True), (1, True)]
    person = tracks.get(0)
    assert person is not None
    t = 14 * 0.04  # only the other part now: track 1 takes it where track 0 coasts
    tracks.step(t, [walking(t, (t, 1.25))])
    assert tracks.tracks == [person] and not person.coasting  # one track, the older id
    assert tracks.counts["tracks_merged"] == 1
    state = person.estimator.predict(t)
    assert state is not None and state.position[1] == pytest.approx(1.25, abs=0.05)


def test_people_crossing_where_one_hides_the_other_are_not_merged() -> None:
    tracks = TrackSet(load_rig(SIM_RIG).estimator)
    for k in range(25):  # one walks +x, the other -x; they meet at x = 0 at t = 1 s
        t = k * 0.04
        a = Sighting(
            Measurement.ground(t, (t - 1.0, 1.0), np.eye(2) * 4e-4, (1.0, 0.0), np.eye(2) * 0.01)
        )
        b = Sighting(
            Measurement.ground(t, (1.0 - t, 1.0), np.eye(2) * 4e-4, (-1.0, 0.0), np.eye(2) * 0.01)
        )
        tracks.step(t, [a] if 0.8 < t < 1.2 else [a, b])  # b hidden behind a near the meeting
    assert [t.id for t in tracks.tracks] == [0, 1] and tracks.counts["tracks_merged"] == 0


def test_tentative_tracks_leave_a_lone_person_alone() -> None:
    section = load_rig(SIM_RIG).estimator
    tracks = TrackSet(section)
    for k in range(10):
        tracks.step(k * 0.04, [measurement(k * 0.04, (0.0, 1.0))])
    (person,) = tracks.tracks
    clutter = [measurement(0.4, (x, 3.0)) for x in (-2.0, 0.0, 2.0)]  # the head's leftovers
    tracks.step(0.4, [measurement(0.4, (0.0, 1.0)), *clutter])
    assert len(tracks.tracks) == 4
    for k in range(11, 11 + section.reinit_after_misses):  # one mover, 1 m off: still the person's
        tracks.step(k * 0.04, [measurement(k * 0.04, (1.0, 1.0))])
    assert tracks.tracks == [person] and person.id == 0 and not person.coasting  # restarted
    state = person.estimator.predict(0.7)
    assert state is not None and state.position[0] == pytest.approx(1.0, abs=0.05)


def test_the_tracks_import_the_assignment_solver_as_they_start(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    started = []
    monkeypatch.setattr(tracks_module, "load_solver", lambda: started.append(True))
    TargetTracker(load_rig(SIM_RIG), "estimator")
    assert started == [True]


@pytest.mark.parametrize("apart_m", [0.6, 1.2])
def test_two_people_seen_as_one_blob_keep_their_tracks(apart_m: float) -> None:
    tracks = TrackSet(load_rig(SIM_RIG).estimator)
    for k in range(50):  # side by side, apart_m apart, at 1 m/s along x
        t = k * 0.04
        people = [walking(t, (t, 1.0)), walking(t, (t, 1.0 + apart_m))]
        blob = walking(t, (t, 1.0 + apart_m / 2))  # the detector's one box round both
        tracks.step(t, people if k < 15 or k >= 45 else [blob])
    assert [t.id for t in tracks.tracks] == [0, 1]  # neither ended, nobody new
    assert tracks.counts["group_updates"] == 30 and tracks.counts["tracks_started"] == 2
    for track, y in zip(tracks.tracks, (1.0, 1.0 + apart_m), strict=True):
        state = track.estimator.predict(49 * 0.04)
        assert state is not None and not track.coasting
        assert state.position == pytest.approx((49 * 0.04, y), abs=0.1)


def test_a_person_hidden_behind_another_is_not_pulled_onto_them() -> None:
    tracks = TrackSet(load_rig(SIM_RIG).estimator)
    for k in range(40):  # b 1.5 m beside a, hidden from 0.6 s: a's box is a's alone
        t = k * 0.04
        a, b = walking(t, (t, 1.0)), walking(t, (t, 2.5))
        tracks.step(t, [a, b] if k < 15 else [a])
    assert tracks.counts["group_updates"] == 0
    hidden = tracks.get(1)
    assert hidden is not None and hidden.coasting


def walk_side_by_side(wild_frame: int | None) -> TrackSet:
    """Two people 0.8 m apart walking abreast at 1 m/s for 40 frames, each seen every frame; in
    `wild_frame` the first one's mover has a velocity of 5.8 m/s (its mask changed shape)."""
    section = load_rig(SIM_RIG).estimator
    rng = np.random.default_rng(1)
    tracks = TrackSet(section)
    walking = np.array([1.0, 0.0])
    cov = np.diag([0.01, 0.04])
    for k in range(40):
        t = k / 7.0
        sightings = []
        for lane_m in (10.0, 10.8):
            velocity = walking + rng.normal(0.0, 0.1, 2)
            if k == wild_frame and lane_m == 10.0:
                velocity = np.array([-5.0, -3.0])
            xy = np.array([t, lane_m]) + rng.normal(0.0, 0.05, 2)
            sightings.append(Sighting(Measurement.ground(t, xy, cov, velocity, np.eye(2) * 0.09)))
        tracks.step(t, sightings)
    return tracks


def test_a_mover_whose_velocity_is_off_still_gives_its_position() -> None:
    """A mover's velocity outside its gate is left out and its position is taken: the person's
    track neither coasts nor counts an outlier, and keeps its id where another person walks
    alongside (a coasting track beside them would be merged into theirs: the id would follow
    the other person, and the first would start a new one)."""
    tracks = walk_side_by_side(wild_frame=20)
    assert [t.id for t in tracks.tracks] == [0, 1]
    lanes = {t.id: t.estimator.predict(39 / 7.0).position[1] for t in tracks.tracks}
    assert lanes[0] == pytest.approx(10.0, abs=0.2) and lanes[1] == pytest.approx(10.8, abs=0.2)
    assert tracks.health().get("gated", 0) == 0
    assert tracks.counts["tracks_merged"] == 0


def split_rarely(q: float = 0.032, r: float = 0.37) -> EstimatorSection:
    """The sim rig's estimator for a detector that reports two movers near one person in a
    frame with probability q, and again in the next with r (the PETS rig's measured values)."""
    update = {"split_probability": q, "split_continues_probability": r}
    return load_rig(SIM_RIG).estimator.model_copy(update=update)


def walk_abreast(
    apart_m: float, hidden_frame: int, section: EstimatorSection | None = None
) -> TrackSet:
    """Two people `apart_m` apart walking abreast at 1 m/s for 40 frames at 7 Hz, each seen
    every frame but the first one in `hidden_frame` (the other hides them)."""
    rng = np.random.default_rng(2)
    tracks = TrackSet(section or load_rig(SIM_RIG).estimator)
    cov = np.eye(2) * 0.01
    for k in range(40):
        t = k / 7.0
        sightings = []
        for lane_m in (10.0, 10.0 + apart_m):
            if k == hidden_frame and lane_m == 10.0:
                continue
            xy = np.array([t, lane_m]) + rng.normal(0.0, 0.05, 2)
            velocity = np.array([1.0, 0.0]) + rng.normal(0.0, 0.1, 2)
            sightings.append(Sighting(Measurement.ground(t, xy, cov, velocity, np.eye(2) * 0.09)))
        tracks.step(t, sightings)
    return tracks


def test_people_walking_abreast_are_not_merged_when_one_is_hidden_a_frame() -> None:
    """Their tracks' states agree within their covariances, but the movers they took frame
    after frame are two people's: the one hidden for a frame coasts and keeps its id, and
    the other's id does not take over (it would follow the other person)."""
    tracks = walk_abreast(0.8, hidden_frame=20)
    assert [t.id for t in tracks.tracks] == [0, 1] and tracks.counts["tracks_merged"] == 0
    lanes = {t.id: t.estimator.predict(39 / 7.0).position[1] for t in tracks.tracks}
    assert lanes[0] == pytest.approx(10.0, abs=0.2) and lanes[1] == pytest.approx(10.8, abs=0.2)


@pytest.mark.parametrize("apart_m", [0.3, 0.5])
def test_people_shoulder_to_shoulder_are_two_where_a_detector_rarely_splits_one(
    apart_m: float,
) -> None:
    """Closer than their movers' noise and a person's width tell apart, two people's tracks
    merge when one is hidden a frame, where the detector may report any person as two movers
    (the defaults); where it seldom does, the latest frames in which both tracks took a mover
    (7 of the at most 8 each keeps) say they are two, and both keep their ids."""
    merged = walk_abreast(apart_m, hidden_frame=20)
    assert merged.counts["tracks_merged"] == 1
    tracks = walk_abreast(apart_m, hidden_frame=20, section=split_rarely())
    assert [t.id for t in tracks.tracks] == [0, 1] and tracks.counts["tracks_merged"] == 0
    lanes = {t.id: t.estimator.predict(39 / 7.0).position[1] for t in tracks.tracks}
    assert lanes[0] == pytest.approx(10.0, abs=0.2)
    assert lanes[1] == pytest.approx(10.0 + apart_m, abs=0.2)


@pytest.mark.parametrize(("split_frames", "merged"), [(3, True), (8, False)])
def test_a_split_that_lasts_is_two_people_where_a_detector_rarely_splits_one(
    split_frames: int, merged: bool
) -> None:
    """The price of the count's evidence: a person split into two movers 0.25 m apart for three
    frames (the second track just confirmed) is one person, merged when a part is missing;
    split for eight frames in a row, longer than the detector's splits run, they are taken
    for two people, and the second track stays (a twin)."""
    tracks = TrackSet(split_rarely())
    for k in range(10):
        tracks.step(k / 7.0, [walking(k / 7.0, (k / 7.0, 1.0))])
    for k in range(10, 10 + split_frames):
        t = k / 7.0
        tracks.step(t, [walking(t, (t, 1.0)), walking(t, (t, 1.25))])
    t = (10 + split_frames) / 7.0
    tracks.step(t, [walking(t, (t, 1.25))])
    assert tracks.counts["tracks_merged"] == int(merged)
    assert [t.id for t in tracks.tracks] == ([0] if merged else [0, 1])


def test_a_person_seen_as_two_movers_is_still_merged() -> None:
    """Two movers of one person (parts 0.25 m apart, within the noise and a person's width)
    start two tracks; the one left without its part for a frame is merged into the other."""
    tracks = TrackSet(load_rig(SIM_RIG).estimator)
    for k in range(10):
        tracks.step(k / 7.0, [walking(k / 7.0, (k / 7.0, 1.0))])
    for k in range(10, 18):
        t = k / 7.0
        tracks.step(t, [walking(t, (t, 1.0)), walking(t, (t, 1.25))])
    tracks.step(18 / 7.0, [walking(18 / 7.0, (18 / 7.0, 1.25))])
    assert [t.id for t in tracks.tracks] == [0] and tracks.counts["tracks_merged"] == 1


def test_a_blob_share_is_no_detection_to_merge_a_coasting_track_into() -> None:
    """Two people seen as one blob take its shares; a third walks 0.8 m beside them, seen only
    since the blob formed, and is hidden for a frame: the share is a position the blob member's
    own prediction made, so the hidden one coasts under its own id instead of ending in it."""
    tracks = TrackSet(load_rig(SIM_RIG).estimator)
    for k in range(50):  # a and b side by side 1.2 m apart, one blob from frame 15 on
        t = k * 0.04
        people = [walking(t, (t, 1.0)), walking(t, (t, 2.2))]
        seen = people if k < 15 else [walking(t, (t, 1.6))]
        if k >= 15 and k != 30:
            seen.append(walking(t, (t, 0.2)))
        tracks.step(t, seen)
    assert [t.id for t in tracks.tracks] == [0, 1, 2] and tracks.counts["tracks_merged"] == 0
    third = tracks.get(2)
    assert third is not None and not third.coasting
    state = third.estimator.predict(49 * 0.04)
    assert state is not None and state.position[1] == pytest.approx(0.2, abs=0.1)
