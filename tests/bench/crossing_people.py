"""Several people walking through the sim rig's view, as vision would report them, and the
estimator's work per frame on them (`TargetTracker.update` and `settle`: every mover on the
ground, association, one filter per track, the chosen track's prediction and the state with
every track).

    python tests/bench/crossing_people.py [--seconds 4] [--repeats 3]

Each person walks a straight line at 0.5-1.5 m/s (`SCENES`); their tracked point (at the rig's
`target_height_m`) is seen by the still head through the rig's true geometry, with pixel and
image-velocity noise and a noisy colour histogram of the person's own colours, the movers in a
shuffled order every frame (seeded). Where two are close, the one farther from the camera is
hidden; in the scenes of `BLOB_M`, people nearer each other than that are reported as one blob
(one mover at their centroid, with their mixed colours), as a wide background detector reports
people who walk together. Per scene it prints, with person 0 chosen after `CHOOSE_FRAME`:

- ids: the distinct tracks nearest each person where no one else is within `APART_M`
  (1 each: every person kept one track);
- kept: the fraction of frames after the choice whose chosen track is the one nearest person 0;
- the median and p90 µs per frame.

`tests/test_estimation_tracks.py` checks the ids and the chosen track on these scenes.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time
from pathlib import Path

import numpy as np

from gazed.config import Rig, load_rig
from gazed.estimation.target_tracker import TargetTracker
from gazed.geometry.camera import CameraModel
from gazed.geometry.ground import GroundGeometry
from gazed.geometry.pose import CameraPose
from gazed.messages import Detection, EstimatorState, HeadPose, Mover

REPO = Path(__file__).resolve().parents[2]
SIM_RIG = REPO / "configs" / "sim.toml"
PIXEL_NOISE_PX = 1.5
RATE_NOISE_PX_S = 10.0
T0_NS = 1_700_000_000_000_000_000
OCCLUDED_M = 0.4  # a person this near another who is nearer the camera is hidden
APART_M = 0.5  # a person's track is read off only where no one else is this near
CHOOSE_FRAME = 10  # person 0 is chosen at this frame

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
    "joining, one blob": [((-3.0, 0.5), (0.8, 0.1)), ((-3.0, 1.7), (0.8, -0.05))],
}
BLOB_M = {"joining, one blob": 1.0}  # people nearer each other than this are one mover


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
        movers = self.blobs(now, movers, hidden)
        movers = [movers[i] for i in self.rng.permutation(len(movers))]
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

    def blobs(self, xy: np.ndarray, movers: list[Mover], hidden: set[int]) -> list[Mover]:
        """The visible movers, those of people within the scene's `BLOB_M` of each other (in
        a chain) as one at their centroid with their mean colours."""
        visible = [i for i in range(len(movers)) if i not in hidden]
        reach = BLOB_M.get(self.scene, 0.0)
        groups: list[list[int]] = []
        for i in visible:
            joined = [g for g in groups if any(np.linalg.norm(xy[i] - xy[j]) < reach for j in g)]
            merged = [i] + [j for g in joined for j in g]
            groups = [g for g in groups if g not in joined] + [merged]
        out = []
        for group in groups:
            parts = [movers[i] for i in group]
            mean = {
                key: float(np.mean([getattr(m, key) for m in parts]))
                for key in ("u_px", "v_px", "du_px_s", "dv_px_s", "box_height_px")
            }
            looks = np.mean([m.appearance for m in parts], axis=0)
            out.append(Mover(**mean, appearance=tuple(looks / looks.sum())))
        return out


def nearest_track(state: EstimatorState, xy: np.ndarray, geometry: GroundGeometry) -> int:
    """The confirmed track nearest a ground point (image-cv: nearest the head angles that
    centre it)."""
    confirmed = [t for t in state.tracks if t.confirmed]
    if state.filter == "image-cv":
        pan, tilt = geometry.gaze_from_ground(*xy)
        return min(confirmed, key=lambda t: math.hypot(t.pan_rad - pan, t.tilt_rad - tilt)).id
    return min(confirmed, key=lambda t: float(np.linalg.norm(np.subtract(t.ground_xy_m, xy)))).id


def follow(
    rig: Rig, scene: str, seconds: float, seed: int, choose_person: int | None = None
) -> tuple[dict[int, set[int]], list[tuple[float, EstimatorState]]]:
    """One run of a scene: each person's track ids where no one else is within `APART_M`
    (from 0.5 s), and the estimator's states; `choose_person` is chosen at `CHOOSE_FRAME`."""
    source = Scene(rig, scene, seed)
    geometry = GroundGeometry.from_rig(rig)
    clock_ns = 0
    tracker = TargetTracker(rig, "estimator", clock_ns=lambda: clock_ns)
    ids: dict[int, set[int]] = {i: set() for i in range(len(SCENES[scene]))}
    states: list[tuple[float, EstimatorState]] = []
    for k in range(round(seconds / source.period_s)):
        detection = source.detection(k)
        clock_ns = detection.t_capture_ns + 100_000_000
        update = tracker.update(detection, clock_ns)
        assert update is not None
        state, _ = tracker.settle(update)
        assert state is not None
        t = k * source.period_s
        states.append((t, state))
        truth = walk(scene, t)
        if choose_person is not None and k == CHOOSE_FRAME:
            tracker.choose(nearest_track(state, truth[choose_person], geometry))
        if t < 0.5:
            continue
        for i, xy in enumerate(truth):
            others = np.delete(truth, i, axis=0)
            if np.min(np.linalg.norm(others - xy, axis=1)) > APART_M:
                ids[i].add(nearest_track(state, xy, geometry))
    return ids, states


def kept_fraction(rig: Rig, scene: str, states: list[tuple[float, EstimatorState]]) -> float:
    """Of the frames after the choice, those whose chosen track is nearest person 0."""
    geometry = GroundGeometry.from_rig(rig)
    after = states[CHOOSE_FRAME + 1 :]
    kept = sum(
        state.target_id == nearest_track(state, walk(scene, t)[0], geometry) for t, state in after
    )
    return kept / len(after)


def frame_us(rig: Rig, scene: str, seconds: float, seed: int = 1) -> list[float]:
    """Microseconds of update + settle per frame over one run of the scene."""
    source = Scene(rig, scene, seed)
    tracker = TargetTracker(rig, "estimator")
    times = []
    for k in range(round(seconds / source.period_s)):
        detection = source.detection(k)
        started = time.perf_counter()
        update = tracker.update(detection, detection.t_capture_ns + 100_000_000)
        if update is not None:
            tracker.settle(update)
        times.append((time.perf_counter() - started) * 1e6)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=4.0)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    rig = load_rig(SIM_RIG)
    print("load average " + " ".join(f"{a:.2f}" for a in os.getloadavg()))
    for scene, people in SCENES.items():
        ids, states = follow(rig, scene, args.seconds, 1, choose_person=0)
        counts = " ".join(str(len(found)) for found in ids.values())
        print(
            f"  {scene:17s} ids per person {counts}, kept {kept_fraction(rig, scene, states):.2f}"
        )
        for _ in range(args.repeats):
            times = frame_us(rig, scene, args.seconds)
            print(
                f"  {scene:17s} {len(people)} people: median {statistics.median(times):6.0f} µs,"
                f" p90 {np.percentile(times, 90):6.0f} µs per frame"
            )


if __name__ == "__main__":
    main()
