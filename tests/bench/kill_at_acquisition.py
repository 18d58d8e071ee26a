"""Vision killed the moment pursuit begins: how long until the target is in the fovea for good.

    python tests/bench/kill_at_acquisition.py [--rig configs/sim.toml] [--scenario oval]
                                              [--seeds 1 2 3 4 5 6] [--seconds 8] [--json]

The hardest moment for a process fault: the track is a frame old, so the estimator has no
velocity to coast on and the head drifts off the target while vision restarts. For each seed it
runs `gazed run` on a private bus, waits for the first `search/saccade -> pursuit`, SIGKILLs
vision, watches `--seconds`, and prints the gaze states after the kill and the time from the
kill after which the target never left the fovea again (None: it was outside at the end).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from gazed.eval.loop import observed  # noqa: E402
from gazed.eval.loop_metrics import gaze_errors_rad  # noqa: E402
from gazed.eval.private_rig import private_rig  # noqa: E402
from gazed.geometry.pose import CameraPose  # noqa: E402
from gazed.messages import GazeState, SimTruth, SupervisorStatus  # noqa: E402
from gazed.topics import GAZE_STATE, SIM_TRUTH, SUPERVISOR_STATUS  # noqa: E402

START_TIMEOUT_S = 90.0


def vision_pid(statuses: list[SupervisorStatus]) -> int | None:
    for status in reversed(statuses):
        for process in status.processes:
            if process.name == "vision" and process.state == "running" and process.pid:
                return process.pid
    return None


def one_seed(rig_file: Path, scenario: str, seed: int, seconds: float) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="gazed-kill-") as directory:
        rig_path = private_rig(rig_file, Path(directory), scenario, None, None, seed, None)
        with observed(rig_path, "bench", START_TIMEOUT_S) as (rig, bus, wakeup):
            truth_sub = bus.subscribe(SIM_TRUTH, capacity=100_000)
            state_sub = bus.subscribe(GAZE_STATE, capacity=1000)
            status_sub = bus.subscribe(SUPERVISOR_STATUS, capacity=100)
            truth: list[SimTruth] = []
            states: list[GazeState] = []
            statuses: list[SupervisorStatus] = []

            def pump() -> None:
                wakeup.wait(0.05)
                truth.extend(truth_sub.take())
                states.extend(state_sub.take())
                statuses.extend(status_sub.take())

            deadline_s = time.monotonic() + START_TIMEOUT_S
            while not any(s.state == "pursuit" for s in states) or vision_pid(statuses) is None:
                if time.monotonic() > deadline_s:
                    raise SystemExit(f"seed {seed}: no pursuit within {START_TIMEOUT_S:g} s")
                pump()
            killed_ns = time.time_ns()
            os.kill(vision_pid(statuses), signal.SIGKILL)  # type: ignore[arg-type]
            end_s = time.monotonic() + seconds
            while time.monotonic() < end_s:
                pump()
    after = [t for t in truth if t.t_capture_ns > killed_ns]
    if not after:
        raise SystemExit(f"seed {seed}: no truth frames after the kill")
    fovea_rad = math.radians(rig.gaze.fovea_half_angle_deg)
    errors = gaze_errors_rad(after, CameraPose.from_rig(rig))
    outside = [t.t_capture_ns for t, e in zip(after, errors, strict=True) if e > fovea_rad]
    for_good_s = None
    if not outside or outside[-1] < after[-1].t_capture_ns:
        for_good_s = round(((outside[-1] if outside else killed_ns) - killed_ns) / 1e9, 2)
    return {
        "seed": seed,
        "in_fovea_for_good_after_s": for_good_s,
        "max_error_deg": round(math.degrees(float(errors.max())), 1),
        "states": [
            (round((s.t_capture_ns - killed_ns) / 1e9, 2), s.state, s.reason)
            for s in states
            if s.t_capture_ns > killed_ns
        ],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rig", type=Path, default=REPO / "configs" / "sim.toml")
    parser.add_argument("--scenario", default="oval")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5, 6])
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    results = [one_seed(args.rig, args.scenario, seed, args.seconds) for seed in args.seeds]
    if args.json:
        print(json.dumps(results, indent=2))
        return
    for r in results:
        print(f"seed {r['seed']}: in the fovea for good after {r['in_fovea_for_good_after_s']} s")
        for t, state, reason in r["states"]:
            print(f"    {t:6.2f} s  -> {state}: {reason}")
    found = [r["in_fovea_for_good_after_s"] for r in results]
    settled = sorted(x for x in found if x is not None)
    print(f"recovered in {len(settled)} of {len(found)} seeds; times (s): {settled}")


if __name__ == "__main__":
    main()
