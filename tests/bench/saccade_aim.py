"""How well the first saccade is aimed: the motion candidate it aims with against the truth.

    python tests/bench/saccade_aim.py [--runs 6] [--rig configs/sim.toml] [--scenario oval]
                                      [--seed S]

Each run starts the rig's loop in the simulator (`gazed eval loop`'s private copy), records
`vision/candidates`, `gaze/state` and `sim/truth` until the first saccade, and prints, for the
best candidate of the newest frame published before the gaze decided, its position and angular
rate against the target's at that frame's capture (degrees, in joint angles). The saccade aims
at where the candidate says the target will be after the visual latency and the move, so a
rate error counts over both.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from gaze_error_parts import Truth  # noqa: E402

from gazed.eval.loop import START_TIMEOUT_S, observed  # noqa: E402
from gazed.eval.private_rig import private_rig  # noqa: E402
from gazed.geometry.camera import CameraModel  # noqa: E402
from gazed.geometry.target_angles import target_angles  # noqa: E402
from gazed.topics import GAZE_STATE, SIM_TRUTH, VISION_CANDIDATES  # noqa: E402

TOPICS = {"truth": SIM_TRUTH, "candidates": VISION_CANDIDATES, "states": GAZE_STATE}


def first_saccade(rig_file: Path, scenario: str, seed: int | None) -> str:
    with tempfile.TemporaryDirectory(prefix="gazed-aim-") as directory:
        rig_path = private_rig(rig_file, Path(directory), scenario, None, None, seed, None)
        with observed(rig_path, "bench") as (rig, bus, wakeup):
            subscriptions = {k: bus.subscribe(t, capacity=100_000) for k, t in TOPICS.items()}
            recorded: dict[str, list] = {k: [] for k in TOPICS}
            deadline_s = time.monotonic() + START_TIMEOUT_S
            while not any(s.state == "saccade" for s in recorded["states"]):
                if time.monotonic() > deadline_s:
                    return f"no saccade within {START_TIMEOUT_S:g} s"
                wakeup.wait(0.1)
                for k, subscription in subscriptions.items():
                    recorded[k].extend(subscription.take())
            wakeup.wait(0.2)  # the truth of the last frames before it
            recorded["truth"].extend(subscriptions["truth"].take())
    saccade = next(s for s in recorded["states"] if s.state == "saccade")
    if saccade.reason != "motion candidate":
        return f"the first saccade was drawn by a {saccade.reason}"
    # the gaze aimed with the newest candidates it had: published before it decided (its
    # state's time), a visual latency after their capture
    sent = [
        c
        for c in recorded["candidates"]
        if c.candidates and c.head is not None and dict(c.stamps)["vision"] <= saccade.t_capture_ns
    ]
    if not sent:
        return "no candidates were published before the saccade"
    last = max(sent, key=lambda c: c.t_capture_ns)
    best = max(last.candidates, key=lambda k: k.score)
    truth = Truth(rig, recorded["truth"])
    camera = CameraModel.from_section(rig.camera)
    aim = target_angles(
        camera, truth.kinematics, last.head.pan_rad, last.head.tilt_rad, best.u_px, best.v_px
    )
    rate = np.degrees(aim.rates(best.du_px_s, best.dv_px_s))
    t_s = np.array([last.t_capture_ns / 1e9])
    where = np.degrees(truth.at(t_s, truth.target)[0])
    true_rate = np.degrees(truth.at(t_s, truth.target_rate)[0])
    miss = np.degrees([aim.pan_rad, aim.tilt_rad]) - where
    return (
        f"position off by {miss[0]:+.2f} {miss[1]:+.2f}°, rate {rate[0]:+.1f} {rate[1]:+.1f}°/s "
        f"against {true_rate[0]:+.1f} {true_rate[1]:+.1f}°/s"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=6)
    parser.add_argument("--rig", type=Path, default=REPO / "configs" / "sim.toml")
    parser.add_argument("--scenario", default="oval")
    parser.add_argument("--seed", type=int)
    args = parser.parse_args()
    for run in range(args.runs):
        print(f"run {run + 1}: {first_saccade(args.rig, args.scenario, args.seed)}", flush=True)


if __name__ == "__main__":
    main()
