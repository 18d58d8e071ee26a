"""Milliseconds to render the digital head's view from one wide frame.

    python tests/bench/digital_view.py [--frames N] [--wide 1920x1080] [--view 640x480]

A wide camera with a barrel lens (the PETS 2009 camera's fitted OpenCV coefficients) and a
30° view, panned and tilted a little every frame so that nothing is cached between renders.
Colour and grey frames; OpenCV with its default threads and with one. Prints the median and p99
of the wall time per render.
"""

from __future__ import annotations

import argparse
import math
import time

import cv2
import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.vision.digital_view import DigitalView

LENS = (-0.158, 0.0735, 0.0, 0.0, -0.0365)  # k1, k2, p1, p2, k3


def size(text: str) -> tuple[int, int]:
    width, height = text.lower().split("x")
    return int(width), int(height)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--wide", type=size, default=(1920, 1080))
    parser.add_argument("--view", type=size, default=(640, 480))
    args = parser.parse_args()
    (ww, wh), (vw, vh) = args.wide, args.view
    focal = 0.78 * ww  # the PETS camera's focal length for its width
    wide = CameraModel.from_intrinsics(ww, wh, focal, focal, ww / 2, wh / 2, LENS)
    view = DigitalView(wide, CameraModel.from_fov(vw, vh, math.radians(30.0)))
    rng = np.random.default_rng(1)
    colour = rng.integers(0, 256, (wh, ww, 3), dtype=np.uint8)
    frames = {"colour": colour, "grey": cv2.cvtColor(colour, cv2.COLOR_BGR2GRAY)}
    print(f"wide {ww}x{wh} -> view {vw}x{vh}, {args.frames} renders each")
    for threads in (cv2.getNumThreads(), 1):
        cv2.setNumThreads(threads)
        for name, frame in frames.items():
            times = []
            for i in range(args.frames):
                pan = math.radians(-20.0 + 40.0 * i / args.frames)
                started = time.perf_counter()
                view.render(frame, pan, math.radians(-5.0))
                times.append((time.perf_counter() - started) * 1e3)
            print(
                f"  {name:<6} opencv threads {threads}: "
                f"p50 {np.median(times):.2f} ms, p99 {np.percentile(times, 99):.2f} ms"
            )


if __name__ == "__main__":
    main()
