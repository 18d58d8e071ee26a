"""Render time of one simulated 640x480 frame (ground, target body, sensor noise), the head
panning, as the `sim` process renders at each capture.

    python tests/bench/sim_speed.py [--frames 500] [--threads N]
"""

from __future__ import annotations

import argparse
import math
import time

import cv2
import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.geometry.pose import CameraPose
from gazed.sim.renderer import Body, Renderer


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=500)
    parser.add_argument(
        "--threads", type=int, default=None, help="OpenCV threads (default: OpenCV's)"
    )
    args = parser.parse_args()
    if args.threads is not None:
        cv2.setNumThreads(args.threads)
    camera = CameraModel.from_fov(640, 480, math.radians(60))
    pose = CameraPose(np.array([0.0, -6.0, 4.0]), math.radians(90))
    renderer = Renderer(camera, pose, seed=1, noise_std=2.0)
    times_ms = []
    for seq in range(args.frames):
        t = seq / 25.0
        target = (2.0 * math.cos(0.3 * t), 2.0 * math.sin(0.3 * t))
        pan, tilt = (float(a) for a in pose.gaze_angles(np.array([*target, 1.0])))
        start = time.perf_counter()
        renderer.render(seq, pan, tilt, [Body(target, 1.7, 0.5)], t_s=t)
        times_ms.append((time.perf_counter() - start) * 1e3)
    p50, p99 = np.percentile(times_ms[10:], [50, 99])
    print(
        f"render 640x480 (OpenCV threads: {cv2.getNumThreads()}): "
        f"median {p50:.2f} ms, p99 {p99:.2f} ms "
        f"over {args.frames - 10} frames; a 60 Hz rig needs < 16.7 ms"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
