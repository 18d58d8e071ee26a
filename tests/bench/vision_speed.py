"""Milliseconds per frame of each detector at 320x240 and 640x480, on one core.

    python tests/bench/vision_speed.py [--frames N] [--gap-ms MS] [--detector NAME ...]
                                       [--pose-noise-deg DEG]

Synthetic sequences (gazed.vision.synthetic): for `flow` and `pyramid` the head pursues a
textured target while turning at up to ~60°/s (ego-motion compensation on); for `background`
the head is still and a walker crosses the view. Frames are rendered beforehand. A frame's time
is one pipeline step — grey conversion, ego-motion, the detector (for `pyramid` including the
motion-energy pyramid) — with the candidates off, then with them on (they add the whole-frame
motion energy and its regions). OpenCV is limited to one thread. Prints median and p99 of the
thread's CPU time and of the wall time. `--gap-ms 40` sleeps that long before each frame, as
the live loop runs vision once per frame period at 25 Hz: the caches are then cold, and a frame
costs more than back to back. The pipeline is told the head's pose noise `--pose-noise-deg`
(`[head] angle_noise_deg`'s default): the flow detector then registers its fovea on the
background around it; 0 times it without (the digital head's).
"""

from __future__ import annotations

import argparse
import math
import time

import cv2
import numpy as np

from gazed.config import HeadSection, VisionSection
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.vision.pipeline import VisionPipeline
from gazed.vision.synthetic import SyntheticScene, pursuing_head, still_head

RATE_HZ = 25.0
SEQUENCE = 60  # frames rendered per configuration, replayed until enough are timed
DETECTORS = ("flow", "pyramid", "background")


pursuit = pursuing_head(-0.8, 0.4, math.radians(37.0), math.radians(-20.0))


def frames(detector: str, width: int, height: int) -> tuple[CameraModel, list]:
    camera = CameraModel.from_fov(width, height, math.radians(60))
    if detector == "background":
        scene = SyntheticScene(
            camera,
            HeadKinematics(),
            still_head(),
            lambda t: (-0.5 + 0.35 * t, 0.0),
            seed=2,
            target_brightness=-60.0,
            field_rad=0.8,
        )
    else:
        scene = SyntheticScene(
            camera,
            HeadKinematics(),
            pursuit,
            lambda t: (-0.8 + math.radians(37.0) * t + 0.01, 0.4 + math.radians(-20.0) * t),
            seed=2,
            field_rad=1.4,
        )
    return camera, scene.frames(RATE_HZ, SEQUENCE)


def one_pass(
    camera: CameraModel,
    sequence: list,
    detector: str,
    candidates: bool,
    times: dict,
    gap_s: float = 0.0,
    pose_noise_rad: float = 0.0,
) -> None:
    """One pass over a sequence with a fresh pipeline: per-frame CPU time of this thread and
    wall time (ms) of a step — grey conversion + detector (+ motion energy for `pyramid`)
    (+ candidates if on)."""
    pipeline = VisionPipeline(
        camera,
        HeadKinematics(),
        VisionSection(candidates=candidates),
        detector,
        pose_noise_rad=pose_noise_rad,
    )
    for i, (image, truth) in enumerate(sequence):
        if gap_s:
            time.sleep(gap_s)
        cpu0, wall0 = time.thread_time(), time.perf_counter()
        gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        pipeline.process(gray, round(truth.t_s * 1e9), truth.head)
        cpu1, wall1 = time.thread_time(), time.perf_counter()
        if i < 15:  # warm-up, and the background model's learning
            continue
        times["cpu"].append((cpu1 - cpu0) * 1e3)
        times["wall"].append((wall1 - wall0) * 1e3)


def cell(values: list[float]) -> str:
    return f"{np.median(values):5.2f} / {np.percentile(values, 99):5.2f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=405, help="timed frames per configuration")
    parser.add_argument(
        "--gap-ms", type=float, default=0.0, help="sleep before each frame (cold caches)"
    )
    parser.add_argument(
        "--detector",
        action="append",
        choices=DETECTORS,
        help="time only this detector (repeat for several; default all)",
    )
    parser.add_argument(
        "--pose-noise-deg",
        type=float,
        default=HeadSection().angle_noise_deg,
        help="the head pose's std the pipeline is told (0: no registration)",
    )
    args = parser.parse_args()
    detectors = args.detector or list(DETECTORS)
    cv2.setNumThreads(1)
    configs = [
        (detector, width, height, candidates)
        for detector in detectors
        for width, height in ((320, 240), (640, 480))
        for candidates in (False, True)
    ]
    sequences = {(d, w, h): frames(d, w, h) for d, w, h, _ in configs}
    times = {config: {"cpu": [], "wall": []} for config in configs}
    # round robin, one pass of each configuration per round, so a change in the machine's
    # load during the run affects them all alike
    rounds = -(-args.frames // (SEQUENCE - 15))
    for _ in range(rounds):
        for config in configs:
            detector, width, height, candidates = config
            camera, sequence = sequences[(detector, width, height)]
            one_pass(
                camera,
                sequence,
                detector,
                candidates,
                times[config],
                args.gap_ms / 1e3,
                math.radians(args.pose_noise_deg),
            )
    gap = f", {args.gap_ms:g} ms asleep before each" if args.gap_ms else ""
    print(
        f"vision speed, one core, {rounds * (SEQUENCE - 15)} timed frames each{gap}, pose noise"
        f" {args.pose_noise_deg:g}°; ms per frame,"
    )
    print("median / p99. cpu: this thread's CPU time (what one core spends); wall: elapsed,")
    print("including any wait for the CPU on a shared machine")
    header = f"{'detector':<11}{'size':>9}   {'detector cpu':>13} {'detector wall':>13}"
    print(header + f"   {'+candidates cpu':>15} {'+candidates wall':>16}")
    for detector in detectors:
        for width, height in ((320, 240), (640, 480)):
            alone = times[(detector, width, height, False)]
            both = times[(detector, width, height, True)]
            print(
                f"{detector:<11}{width:>4}x{height:<4}   {cell(alone['cpu']):>13} "
                f"{cell(alone['wall']):>13}   {cell(both['cpu']):>15} {cell(both['wall']):>16}"
            )


if __name__ == "__main__":
    main()
