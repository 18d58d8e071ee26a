"""Where the closed loop's gaze error comes from: the mean offset along the target's motion, across
it and in tilt, of the head, the detection, the prediction and the written command, each against
the truth (`sim/truth`) at its own instant.

    python tests/bench/gaze_error_parts.py [--rig configs/sim.toml] [--scenario rounded-square]
                                           [--seconds 25] [--seed S]

All in joint angles (pan scaled by cos tilt), degrees, over the instants the target's direction
turns faster than 2°/s. "along" is positive when ahead of the target, so a head that trails it
shows a negative mean; "head then - command" is where the head was when a command was written,
and 20 / 40 / 60 ms later, against that command: the head's response lag, seen in angle.

Then the gaze error's RMS split over the walker's motion, from the truth's ground velocity:
standing, turning (heading rate over 10°/s), changing speed (over 0.2 m/s²), the second after
any of those ends (the transient), and steady walking; with, for each, the RMS of the
prediction's error at its instant and of the command's when written, so that the share of the
error the estimator makes is told from what the head and the latency add.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from gazed.config import Rig  # noqa: E402
from gazed.eval.loop import START_TIMEOUT_S, observed  # noqa: E402
from gazed.eval.private_rig import private_rig  # noqa: E402
from gazed.geometry.camera import CameraModel  # noqa: E402
from gazed.geometry.kinematics import HeadKinematics  # noqa: E402
from gazed.geometry.pose import CameraPose  # noqa: E402
from gazed.geometry.target_angles import target_angles  # noqa: E402
from gazed.topics import (  # noqa: E402
    ESTIMATOR_PREDICTION,
    GAZE_STATE,
    SERVO_COMMAND,
    SIM_TRUTH,
    VISION_DETECTION,
)

SETTLE_S = 2.0  # after the first pursuit: the track settles
MIN_RATE_DEG_S = 2.0
STANDING_M_S = 0.1
TURNING_RAD_S = np.radians(10.0)
ACCELERATING_M_S2 = 0.2
TRANSIENT_S = 1.0
TOPICS = {
    "truth": SIM_TRUTH,
    "detections": VISION_DETECTION,
    "predictions": ESTIMATOR_PREDICTION,
    "commands": SERVO_COMMAND,
}


def record(
    rig_file: Path, scenario: str, seconds: float, seed: int | None
) -> tuple[Rig, dict[str, list[Any]]]:
    with tempfile.TemporaryDirectory(prefix="gazed-parts-") as directory:
        rig_path = private_rig(rig_file, Path(directory), scenario, None, None, seed, None)
        with observed(rig_path, "bench") as (rig, bus, wakeup):
            subscriptions = {k: bus.subscribe(t, capacity=100_000) for k, t in TOPICS.items()}
            states = bus.subscribe(GAZE_STATE, capacity=1000)
            deadline_s = time.monotonic() + START_TIMEOUT_S
            while not any(s.state == "pursuit" for s in states.take()):
                if time.monotonic() > deadline_s:
                    raise SystemExit(f"no pursuit within {START_TIMEOUT_S:g} s")
                wakeup.wait(0.1)
            time.sleep(SETTLE_S)  # a bench, not a test
            for subscription in subscriptions.values():
                subscription.take()
            recorded: dict[str, list] = {k: [] for k in TOPICS}
            end_s = time.monotonic() + seconds
            while time.monotonic() < end_s:
                wakeup.wait(0.5)
                for k, subscription in subscriptions.items():
                    recorded[k].extend(subscription.take())
    return rig, recorded


class Truth:
    """The target's joint angles, their rates and the head's, interpolated in time."""

    def __init__(self, rig: Rig, truth: list[Any]) -> None:
        pose, self.kinematics = CameraPose.from_rig(rig), HeadKinematics.from_section(rig.head)
        truth = sorted(truth, key=lambda t: t.t_capture_ns)
        self.t_s = np.array([t.t_capture_ns for t in truth]) / 1e9
        middles = np.array([[*t.target_xy_m, t.target_height_m / 2.0] for t in truth])
        directions = pose.base_directions(middles)
        self.target = np.array([self.kinematics.angles_from_direction(d) for d in directions])
        self.target_rate = np.gradient(self.target, self.t_s, axis=0)
        self.head = np.array([[t.head.pan_rad, t.head.tilt_rad] for t in truth])

    def at(self, t_s: np.ndarray, series: np.ndarray) -> np.ndarray:
        return np.stack([np.interp(t_s, self.t_s, series[:, i]) for i in (0, 1)], axis=-1)


def offsets(truth: Truth, t_s: np.ndarray, angles: np.ndarray, reference: np.ndarray) -> str:
    """Mean and sd of angles - reference along and across the target's motion, and mean tilt."""
    error = np.degrees(angles - reference)
    rate = np.degrees(truth.at(t_s, truth.target_rate))
    cos_tilt = np.cos(truth.at(t_s, truth.target)[:, 1])
    error[:, 0] *= cos_tilt
    rate[:, 0] *= cos_tilt
    speed = np.linalg.norm(rate, axis=1)
    moving = speed > MIN_RATE_DEG_S
    along_unit = rate[moving] / speed[moving, None]
    across_unit = np.stack([-along_unit[:, 1], along_unit[:, 0]], axis=1)
    along = (error[moving] * along_unit).sum(axis=1)
    across = (error[moving] * across_unit).sum(axis=1)
    return (
        f"n {moving.sum():4d}  along {along.mean():+.3f} (sd {along.std():.3f})"
        f"  across {across.mean():+.3f} (sd {across.std():.3f})"
        f"  tilt {error[moving, 1].mean():+.3f}"
    )


def phases(truth: Truth, velocity: np.ndarray) -> dict[str, np.ndarray]:
    """Per truth frame, which part of the walker's motion it is in (module docstring)."""
    speed = np.linalg.norm(velocity, axis=1)
    heading = np.unwrap(np.arctan2(velocity[:, 1], velocity[:, 0]))
    turn_rate = np.abs(np.gradient(heading, truth.t_s))
    accel = np.abs(np.gradient(speed, truth.t_s))
    standing = speed < STANDING_M_S
    turning = ~standing & (turn_rate > TURNING_RAD_S)
    speeding = ~standing & ~turning & (accel > ACCELERATING_M_S2)
    maneuver = standing | turning | speeding
    last_ns = np.maximum.accumulate(np.where(maneuver, truth.t_s, -np.inf))
    transient = ~maneuver & (truth.t_s - last_ns < TRANSIENT_S)
    return {
        "standing": standing,
        "turning": turning,
        "speed change": speeding,
        "transient": transient,
        "steady": ~maneuver & ~transient,
    }


def error_deg(truth: Truth, t_s: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """The angle (about) between joint angles and the target's at each instant, degrees."""
    target = truth.at(t_s, truth.target)
    error = np.degrees(angles - target)
    error[:, 0] *= np.cos(target[:, 1])
    return np.linalg.norm(error, axis=1)


def split(truth: Truth, parts: dict[str, np.ndarray], t_s: np.ndarray, errors: np.ndarray) -> dict:
    """The RMS of `errors` (at `t_s`) in each part of the motion (the truth frame nearest)."""
    k = np.clip(np.searchsorted(truth.t_s, t_s), 0, len(truth.t_s) - 1)
    return {
        name: float(np.sqrt(np.mean(errors[mask[k]] ** 2))) if mask[k].any() else float("nan")
        for name, mask in parts.items()
    }


def print_phases(truth: Truth, velocity: np.ndarray, predictions: list, commands: list) -> None:
    parts = phases(truth, velocity)
    gaze = error_deg(truth, truth.t_s, truth.head)
    t_p = np.array([p.t_effect_ns for p in predictions]) / 1e9
    predicted = error_deg(truth, t_p, np.array([[p.pan_rad, p.tilt_rad] for p in predictions]))
    t_c = np.array([dict(c.stamps)["servo"] for c in commands]) / 1e9
    commanded = error_deg(truth, t_c, np.array([[c.pan_rad, c.tilt_rad] for c in commands]))
    rows = {
        "gaze (head)": split(truth, parts, truth.t_s, gaze),
        "prediction": split(truth, parts, t_p, predicted),
        "command": split(truth, parts, t_c, commanded),
    }
    print(f"gaze error RMS {np.sqrt(np.mean(gaze**2)):.3f} deg; by the walker's motion:")
    print(f"  {'':14s}" + "".join(f"{name:>13s}" for name in parts))
    share = {name: f"{mask.mean():.2f}" for name, mask in parts.items()}
    print(f"  {'share':14s}" + "".join(f"{share[name]:>13s}" for name in parts))
    energy = {
        name: float(np.sum(gaze[mask] ** 2) / np.sum(gaze**2)) for name, mask in parts.items()
    }
    print(f"  {'share of MS':14s}" + "".join(f"{energy[name]:>13.2f}" for name in parts))
    for label, row in rows.items():
        print(f"  {label:14s}" + "".join(f"{row[name]:>13.3f}" for name in parts))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rig", type=Path, default=REPO / "configs" / "sim.toml")
    parser.add_argument("--scenario", default="rounded-square")
    parser.add_argument("--seconds", type=float, default=25.0)
    parser.add_argument("--seed", type=int)
    args = parser.parse_args()
    rig, recorded = record(args.rig, args.scenario, args.seconds, args.seed)
    truth = Truth(rig, recorded["truth"])
    camera = CameraModel.from_section(rig.camera)
    print(f"{args.scenario}, {args.seconds:g} s; offsets in degrees against the truth")
    print(f"  head             {offsets(truth, truth.t_s, truth.head, truth.target)}")

    seen = [d for d in recorded["detections"] if d.found and d.head is not None]
    t_s = np.array([d.t_capture_ns for d in seen]) / 1e9
    aims = [
        target_angles(camera, truth.kinematics, d.head.pan_rad, d.head.tilt_rad, d.u_px, d.v_px)
        for d in seen
    ]
    angles = np.array([[a.pan_rad, a.tilt_rad] for a in aims])
    print(f"  detection        {offsets(truth, t_s, angles, truth.at(t_s, truth.target))}")

    predictions = recorded["predictions"]
    t_s = np.array([p.t_effect_ns for p in predictions]) / 1e9
    angles = np.array([[p.pan_rad, p.tilt_rad] for p in predictions])
    print(f"  prediction       {offsets(truth, t_s, angles, truth.at(t_s, truth.target))}")
    actuation_ms = 1e3 * np.median([p.actuation_latency_s for p in predictions])
    print(f"  (predicted over an actuation latency of {actuation_ms:.1f} ms, median)")

    commands = recorded["commands"]
    t_s = np.array([dict(c.stamps)["servo"] for c in commands]) / 1e9
    angles = np.array([[c.pan_rad, c.tilt_rad] for c in commands])
    print(f"  command written  {offsets(truth, t_s, angles, truth.at(t_s, truth.target))}")
    for later_s in (0.0, 0.02, 0.04, 0.06):
        head = truth.at(t_s + later_s, truth.head)
        label = f"head +{later_s * 1e3:.0f} ms - cmd"
        print(f"  {label:16s} {offsets(truth, t_s, head, angles)}")
    ordered = sorted(recorded["truth"], key=lambda t: t.t_capture_ns)
    velocity = np.array([t.target_velocity_m_s for t in ordered])
    print_phases(truth, velocity, predictions, commands)


if __name__ == "__main__":
    main()
