"""How well the sim rig's detector measures the target on the ground: each detection mapped to
the ground as the estimator maps it (`ground_measurement`), against `sim/truth` at the same
capture instant — the noise to put into the offline estimator scenarios.

    python tests/bench/detection_noise.py [--rig configs/sim.toml] [--scenario oval] [--seconds 40]

Runs the rig on a private bus (as `gazed eval loop` does), skips the first 4 s (acquisition),
and prints the bias and standard deviation of the position (m) and velocity (m/s) errors per
ground axis, and the standard deviations the estimator is told (the measurement covariance's
median diagonal).

Then the detection's point in the image against the truth's (the target's ground point at the
rig's target height, seen through the lens at the detection's own pose), over the target's own
box on each axis (u, v): what `[estimator] mover_extent_noise` measures on real walkers
(`mover_extent.py`), with the two-Gaussian scale mixture fitted to it; for every detection, and
apart for the fits that move less than the misregistration of two frames' head poses
(√2 σ f per frame, σ `[head] angle_noise_deg`), whose region can take in the background.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from mover_extent import scale_mixture

from gazed.config import Rig
from gazed.estimation.observation import ground_measurement
from gazed.eval.loop import observed
from gazed.eval.private_rig import private_rig
from gazed.gaze.zoom import target_mover
from gazed.geometry.ground import GroundGeometry, MeasurementNoise
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Detection, SimTruth
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
    scored = [(d, truth.get(d.t_capture_ns)) for d in seen]
    scored = [(d, t) for d, t in scored if t is not None and t.t_capture_ns >= start_ns]
    over_box(scored, geometry, ZoomLens.from_section(rig.camera), rig)


def over_box(
    scored: list[tuple[Detection, SimTruth]], geometry: GroundGeometry, lens: ZoomLens, rig: Rig
) -> None:
    """Print the point's image error over the target's box, all fits and the slow ones."""
    fractions, slow = [], []
    period_s = rig.camera.frame_period_s
    for detection, t in scored:
        head, mover = detection.head, target_mover(detection)
        if not detection.found or head is None or mover is None:
            continue
        box = mover.box_width_px, mover.box_height_px
        camera = lens.at_pose(head)
        try:
            seen = geometry.with_camera(camera).pixel_from_ground(
                *t.target_xy_m, head.pan_rad, head.tilt_rad
            )
        except ValueError:
            continue
        error = np.array([detection.u_px, detection.v_px]) - seen
        fractions.append(error / np.array(box))
        step_px = np.hypot(detection.du_px_s, detection.dv_px_s) * period_s
        slow.append(step_px <= np.sqrt(2.0) * rig.head.angle_noise_rad * camera.focal_px)
    if not fractions:
        return
    x, slow_fits = np.array(fractions), np.array(slow)
    print("  the point's image error over the target's box (u, v):")
    for name, part in (("every fit", x), ("slow fits", x[slow_fits]), ("the rest", x[~slow_fits])):
        if len(part) < 10:
            print(f"    {name:>9}: {len(part)} detections")
            continue
        weight, core, tail, _ = scale_mixture(part)
        print(
            f"    {name:>9}: {len(part)} detections, std u {part[:, 0].std():.3f} "
            f"v {part[:, 1].std():.3f}; mixture core u {core[0]:.3f} v {core[1]:.3f}, "
            f"tail u {tail[0]:.3f} v {tail[1]:.3f}, tail weight {weight:.3f}"
        )


if __name__ == "__main__":
    main()
