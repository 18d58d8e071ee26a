"""Several people at once: the estimator keeps one track per person, with a stable id, where two
or three people cross, pass and walk side by side at 0.5-1.5 m/s, and predicts the chosen one.

Detections are made through the sim rig's true geometry: each person's tracked point (at the
rig's `target_height_m`) seen by the still head, with pixel and image-velocity noise and a noisy
colour histogram of each person's own colours, in a shuffled order every frame (seeded). Where
two are close, the one farther from the camera is hidden and its track coasts."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gazed.config import Rig, load_rig
from gazed.estimation.measurement import Measurement
from gazed.estimation.target_tracker import TargetTracker
from gazed.estimation.tracks import Sighting, TrackSet
from gazed.geometry.camera import CameraModel
from gazed.geometry.ground import GroundGeometry
from gazed.geometry.pose import CameraPose
from gazed.messages import Detection, EstimatorState, HeadPose, Mover

SIM_RIG = Path(__file__).resolve().parents[1] / "configs" / "sim.toml"
GEOMETRY = GroundGeometry.from_rig(load_rig(SIM_RIG))
PIXEL_NOISE_PX = 1.5
RATE_NOISE_PX_S = 10.0
SECONDS = 4.0
T0_NS = 1_700_000_000_000_000_000
APART_M = 0.5
OCCLUDED_M = 0.4  # a person this near another who is nearer the camera is hidden  # a person's track is read off only where no one else is this near

# each person: start (x, y) m and velocity (vx, vy) m/s on the sim rig's court
SCENES = {
    "two crossing": [((-2.5, 0.0), (1.0, 0.5)), ((2.5, 0.0), (-1.0, 0.5))],
    "passing": [((-3.0, 1.0), (1.5, 0.0)), ((2.0, 1.6), (-0.5, 0.0))],
    "side by side": [((-2.5, 1.0), (1.0, 0.1)), ((-2.5, 1.7), (1.0, 0.1))],
    "three crossing": [
        ((-2.5, 0.0), (1.0, 0.5)),
        ((2.5, 0.0), (-1.0, 0.5)),
        ((0.0, -1.0), (0.0, 0.9)),
    ],
}


def walk(scene: str, t_s: float) -> np.ndarray:
    """(people, 2) ground positions at t_s."""
    return np.array([np.add(p0, np.multiply(v, t_s)) for p0, v in SCENES[scene]])


class Scene:
    """Detections of a scene's people through the rig's geometry."""

    def __init__(self, rig: Rig, scene: str, seed: int) -> None:
        self.rig, self.scene = rig, scene
        self.rng = np.random.default_rng(seed)
        self.pose = CameraPose.from_rig(rig)
        self.camera = CameraModel.from_section(rig.camera)
        self.height_m = rig.calibration.target_height_m
        self.period_s = rig.camera.frame_period_s
        people = len(SCENES[scene])
        self.colours = self.rng.dirichlet(np.ones(16) * 0.5, people)

    def pixels(self, xy: np.ndarray) -> np.ndarray:
        points = np.column_stack([xy, np.full(len(xy), self.height_m)])
        return self.pose.pixels(points, 0.0, 0.0, self.camera)

    def detection(self, k: int) -> Detection:
        t = k * self.period_s
        now, ahead = walk(self.scene, t), walk(self.scene, t + 1e-3)
        uv = self.pixels(now)
        duv = (self.pixels(ahead) - uv) / 1e-3
        uv = uv + self.rng.normal(0.0, PIXEL_NOISE_PX, uv.shape)
        duv = duv + self.rng.normal(0.0, RATE_NOISE_PX_S, duv.shape)
        movers = [
            Mover(
                u_px=float(u),
                v_px=float(v),
                du_px_s=float(du),
                dv_px_s=float(dv),
                box_height_px=60.0,
                appearance=tuple(self.rng.dirichlet(self.colours[i] * 200 + 0.1)),
            )
            for i, ((u, v), (du, dv)) in enumerate(zip(uv, duv, strict=True))
        ]
        camera_y = self.rig.sim.camera_xyz_m[1]
        hidden = {  # behind someone nearer to the camera
            i
            for i in range(len(now))
            for j in range(len(now))
            if np.linalg.norm(now[i] - now[j]) < OCCLUDED_M
            and now[j][1] - camera_y < now[i][1] - camera_y
        }
        order = [i for i in self.rng.permutation(len(movers)) if i not in hidden]
        movers = [movers[i] for i in order]
        assert all(0 <= m.u_px < 640 and 0 <= m.v_px < 480 for m in movers)
        first = movers[0]
        return Detection(
            t_capture_ns=T0_NS + round(t * 1e9),
            seq=k,
            detector="flow",
            found=True,
            u_px=first.u_px,
            v_px=first.v_px,
            du_px_s=first.du_px_s,
            dv_px_s=first.dv_px_s,
            width_px=640,
            height_px=480,
            head=HeadPose(pan_rad=0.0, tilt_rad=0.0),
            movers=tuple(movers),
        )


def run(
    scene: str, seed: int, choose_person: int | None = None, rig: Rig | None = None
) -> tuple[dict, list]:
    """Each person's track ids where no one else is near, and the states of the run."""
    rig = rig or load_rig(SIM_RIG)
    source = Scene(rig, scene, seed)
    tracker = TargetTracker(rig, "estimator", clock_ns=lambda: clock_ns)
    ids: dict[int, set[int]] = {i: set() for i in range(len(SCENES[scene]))}
    states: list[tuple[float, EstimatorState]] = []
    frames = round(SECONDS / source.period_s)
    for k in range(frames):
        detection = source.detection(k)
        clock_ns = detection.t_capture_ns + 100_000_000
        update = tracker.update(detection, clock_ns)
        assert update is not None
        state, _ = tracker.settle(update)
        assert state is not None
        t = k * source.period_s
        states.append((t, state))
        truth = walk(scene, t)
        if choose_person is not None and k == 10:
            tracker.choose(nearest_track(state, truth[choose_person]))
        if t < 0.5:
            continue
        for i, xy in enumerate(truth):
            others = np.delete(truth, i, axis=0)
            if np.min(np.linalg.norm(others - xy, axis=1)) > APART_M:
                ids[i].add(nearest_track(state, xy))
    return ids, states


def nearest_track(state: EstimatorState, xy: np.ndarray) -> int:
    confirmed = [t for t in state.tracks if t.confirmed]
    if state.filter == "image-cv":  # no ground: the head angles that centre each
        pan, tilt = GEOMETRY.gaze_from_ground(*xy)
        return min(confirmed, key=lambda t: math.hypot(t.pan_rad - pan, t.tilt_rad - tilt)).id
    return min(confirmed, key=lambda t: float(np.linalg.norm(np.subtract(t.ground_xy_m, xy)))).id


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("seed", [1, 2])
def test_every_person_keeps_one_id(scene: str, seed: int) -> None:
    ids, states = run(scene, seed)
    assert all(len(found) == 1 for found in ids.values()), ids
    assert len({next(iter(found)) for found in ids.values()}) == len(ids)  # one each
    _, last = states[-1]
    assert sum(t.confirmed for t in last.tracks) == len(SCENES[scene])  # no clutter confirmed


@pytest.mark.parametrize("scene", ["two crossing", "side by side"])
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
