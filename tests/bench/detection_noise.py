"""How well the sim rig's detector measures the target on the ground: each detection mapped to
the ground as the estimator maps it (`ground_measurement`), against `sim/truth` at the same
capture instant — the noise to put into the offline estimator scenarios.

    python tests/bench/detection_noise.py [--rig configs/sim.toml] [--scenario oval] [--seconds 40]

Runs the rig on a private bus (as `gazed eval loop` does), skips the first 4 s (acquisition),
and prints the bias and standard deviation of the position (m) and velocity (m/s) errors per
ground axis, and the standard deviations the estimator is told (the measurement covariance's
median diagonal).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from gazed.estimation.observation import ground_measurement
from gazed.eval.loop import observed
from gazed.eval.private_rig import private_rig
from gazed.geometry.ground import GroundGeometry, MeasurementNoise
from gazed.topics import SIM_TRUTH, VISION_DETECTION

REPO = Path(__file__).resolve().parents[2]
SETTLE_S = 4.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rig", type=Path, default=REPO / "configs" / "sim.toml")
    parser.add_argument("--scenario", default="oval")
    parser.add_argument("--seconds", type=float, default=40.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as directory:
        rig_path = private_rig(args.rig, Path(directory), args.scenario, None, None, None, None)
        with observed(rig_path, "observer") as (rig, bus, wakeup):
            detections = bus.subscribe(VISION_DETECTION, capacity=100000)
            truths = bus.subscribe(SIM_TRUTH, capacity=100000)
            end_s = time.monotonic() + SETTLE_S + args.seconds
            seen, truth = [], {}
            while time.monotonic() < end_s:
                wakeup.wait(0.5)
                seen += detections.take()
                truth.update((t.t_capture_ns, t) for t in truths.take())
    geometry = GroundGeometry.from_rig(rig)
    section = rig.estimator
    noise = MeasurementNoise.from_head(
        rig.head, section.pixel_noise_px, section.pixel_rate_noise_px_s
    )
    start_ns = min(truth) + round(SETTLE_S * 1e9)
    position, velocity, told = [], [], []
    for detection in seen:
        t = truth.get(detection.t_capture_ns)
        if t is None or t.t_capture_ns < start_ns or not detection.found or not detection.head:
            continue
        m = ground_measurement(detection, geometry, noise)
        position.append(m.position - np.array(t.target_xy_m))
        velocity.append(m.velocity - np.array(t.target_velocity_m_s))
        told.append(np.sqrt([*m.position_cov.diagonal(), *m.velocity_cov.diagonal()]))
    position, velocity = np.array(position), np.array(velocity)
    print(
        f"{args.scenario}: {len(position)} detections after {SETTLE_S:.0f} s, per ground axis X, Y"
    )
    print(f"  position error: bias {position.mean(0).round(4)} m, std {position.std(0).round(4)} m")
    print(
        f"  velocity error: bias {velocity.mean(0).round(3)} m/s, "
        f"std {velocity.std(0).round(3)} m/s"
    )
    told_std = np.median(told, axis=0)
    print(
        f"  the estimator is told: position std {told_std[:2].round(4)} m,"
        f" velocity std {told_std[2:].round(3)} m/s"
    )


if __name__ == "__main__":
    main()
