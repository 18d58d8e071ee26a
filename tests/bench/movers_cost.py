"""What reporting every mover adds to a frame: each detector with its movers and with them
left out, side by side in one process.

    python tests/bench/movers_cost.py [--frames N] [--detector NAME ...]

The sequences are `vision_speed`'s (the head pursuing a textured target at up to ~60°/s for
`flow` and `pyramid`; a still head and a walker crossing for `background`), frames grey as the
sim rig sends them. "without" replaces the detector's movers step by one that reports none (so
no appearance is computed either); everything else is the same code. The two run in alternate
passes, so a change in the machine's load affects both alike. Prints median and p99 of the
thread's CPU time per frame (one pipeline step), and the median number of movers.
"""

from __future__ import annotations

import argparse
import time

import cv2
import numpy as np
from vision_speed import DETECTORS, SEQUENCE, frames

from gazed.config import VisionSection
from gazed.geometry.kinematics import HeadKinematics
from gazed.vision.background import BackgroundDetector
from gazed.vision.normal_flow import NormalFlowDetector
from gazed.vision.pipeline import VisionPipeline
from gazed.vision.pyramid_search import PyramidDetector
from gazed.vision.silhouettes import SilhouetteModel

WARM_UP = 15  # frames per pass left out: caches, and the background model's learning


def no_movers(*_args: object, **_kwargs: object) -> tuple[()]:
    return ()


def without_movers(pipeline: VisionPipeline) -> None:
    """The pipeline's detector with its movers step replaced by one that reports none."""
    detector = pipeline.detector
    if isinstance(detector, (NormalFlowDetector, PyramidDetector)):
        detector._movers = no_movers
    elif isinstance(detector, BackgroundDetector):
        assert isinstance(detector.silhouettes, SilhouetteModel)
        detector.silhouettes.movers = no_movers


def one_pass(camera, sequence, detector: str, movers: bool, times: list, counts: list) -> None:
    pipeline = VisionPipeline(camera, HeadKinematics(), VisionSection(candidates=False), detector)
    if not movers:
        without_movers(pipeline)
    for i, (image, truth) in enumerate(sequence):
        cpu0 = time.thread_time()
        gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        out = pipeline.process(gray, round(truth.t_s * 1e9), truth.head).output
        cpu1 = time.thread_time()
        if i >= WARM_UP:
            times.append((cpu1 - cpu0) * 1e3)
            counts.append(len(out.movers))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=405, help="timed frames per configuration")
    parser.add_argument("--detector", action="append", choices=DETECTORS)
    args = parser.parse_args()
    cv2.setNumThreads(1)
    detectors = args.detector or list(DETECTORS)
    sizes = ((320, 240), (640, 480))
    sequences = {(d, w, h): frames(d, w, h) for d in detectors for w, h in sizes}
    times = {(key, m): [] for key in sequences for m in (False, True)}
    counts = {(key, m): [] for key in sequences for m in (False, True)}
    rounds = -(-args.frames // (SEQUENCE - WARM_UP))
    for _ in range(rounds):
        for key, (camera, sequence) in sequences.items():
            for movers in (False, True):
                one_pass(camera, sequence, key[0], movers, times[key, movers], counts[key, movers])
    print(f"movers' cost, one core, {rounds * (SEQUENCE - WARM_UP)} frames each; CPU ms per frame")
    print(f"{'detector':<11}{'size':>9}   {'without':>13}   {'with movers':>13}   movers")
    for detector, w, h in sequences:
        cells = [times[(detector, w, h), m] for m in (False, True)]
        text = [f"{np.median(c):5.2f} / {np.percentile(c, 99):5.2f}" for c in cells]
        count = np.median(counts[(detector, w, h), True])
        print(f"{detector:<11}{w:>4}x{h:<4}   {text[0]:>13}   {text[1]:>13}   {count:g}")


if __name__ == "__main__":
    main()
