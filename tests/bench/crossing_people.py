"""Several people walking through the sim rig's view, as vision would report them, and the
estimator's work per frame on them (`TargetTracker.update` and `settle`: every mover on the
ground, association, one filter per track, the chosen track's prediction and the state with
every track).

    python tests/bench/crossing_people.py [--seconds 4] [--repeats 3]

Each person walks a straight line at 0.5-1.5 m/s (`SCENES`); their tracked point (at the rig's
`target_height_m`) is seen by the still head through the rig's true geometry, with pixel and
image-velocity noise and a noisy colour histogram of the person's own colours, the movers in a
shuffled order every frame (seeded). Where two are close, the one farther from the camera is
hidden. `tests/test_estimation_tracks.py` checks the ids on these scenes; this prints the median
and p90 µs per frame of each scene.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np

from gazed.config import Rig, load_rig
from gazed.estimation.target_tracker import TargetTracker
from gazed.geometry.camera import CameraModel
from gazed.geometry.pose import CameraPose
from gazed.messages import Detection, HeadPose, Mover

REPO = Path(__file__).resolve().parents[2]
SIM_RIG = REPO / "configs" / "sim.toml"
PIXEL_NOISE_PX = 1.5
RATE_NOISE_PX_S = 10.0
T0_NS = 1_700_000_000_000_000_000
OCCLUDED_M = 0.4  # a person this near another who is nearer the camera is hidden

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
        for _ in range(args.repeats):
            times = frame_us(rig, scene, args.seconds)
            print(
                f"  {scene:15s} {len(people)} people: median {statistics.median(times):6.0f} µs,"
                f" p90 {np.percentile(times, 90):6.0f} µs per frame"
            )


if __name__ == "__main__":
    main()
