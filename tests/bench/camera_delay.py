"""A hidden camera delay on the oval's closed loop: the online estimate off, on, and the delay
told to gazed, side by side.

    python tests/bench/camera_delay.py [--rig configs/sim.toml] [--scenario oval]
                                       [--delay-ms 150] [--seconds 30] [--seed 1] [--json]

Each run is `gazed run` on a private bus with `[sim] camera_delay_ms` hidden (frames stamped on
arrival). `off`: `[camera] delay_estimate = false` (stamps left at arrival); `online`: the
vision process estimates the delay; `told`: `[camera] delay_ms` is the true delay and the
estimate is off. For each: gaze error RMS and fovea fraction after acquisition (as `gazed eval
loop`), and the stamp correction's error against the truth (each detection's capture stamp
against its frame's true exposure, over the run's last half, and the time after which it
stays within a frame period), with the vision's own note.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import tomlkit

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from gazed.eval.loop import observed, private_rig  # noqa: E402
from gazed.eval.loop_metrics import LoopRecord, score  # noqa: E402
from gazed.geometry.pose import CameraPose  # noqa: E402
from gazed.messages import Detection, Health  # noqa: E402
from gazed.sim.reach import FieldOfRegard  # noqa: E402
from gazed.topics import (  # noqa: E402
    ESTIMATOR_STATE,
    GAZE_STATE,
    SERVO_COMMAND,
    SIM_TRUTH,
    VISION_DETECTION,
    health,
)

START_TIMEOUT_S = 90.0
MODES = {  # (delay_estimate, told)
    "off": (False, False),
    "online": (True, False),
    "told": (False, True),
}


def rig_with_delay(rig_file: Path, directory: Path, delay_ms: float, mode: str) -> Path:
    """A copy of the rig with the hidden camera delay and the mode's [camera] keys."""
    estimate, told = MODES[mode]
    document = tomlkit.parse(rig_file.read_text())
    document.setdefault("sim", tomlkit.table())["camera_delay_ms"] = delay_ms
    camera = document.setdefault("camera", tomlkit.table())
    camera["delay_estimate"] = estimate
    camera["delay_ms"] = delay_ms if told else 0.0
    path = directory / "delayed.toml"
    path.write_text(tomlkit.dumps(document))
    return path


def one_run(args: argparse.Namespace, mode: str) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="gazed-delay-") as directory:
        delayed = rig_with_delay(args.rig.resolve(), Path(directory), args.delay_ms, mode)
        rig_path = private_rig(delayed, Path(directory), args.scenario, None, None, args.seed, None)
        with observed(rig_path, "bench", START_TIMEOUT_S) as (rig, bus, wakeup):
            subs = {
                "truth": bus.subscribe(SIM_TRUTH, capacity=100_000),
                "states": bus.subscribe(GAZE_STATE, capacity=10_000),
                "commands": bus.subscribe(SERVO_COMMAND, capacity=100_000),
                "estimates": bus.subscribe(ESTIMATOR_STATE, capacity=100_000),
                "detections": bus.subscribe(VISION_DETECTION, capacity=100_000),
                "health": bus.subscribe(health("vision"), capacity=1000),
            }
            deadline = time.monotonic() + START_TIMEOUT_S
            while not subs["detections"].take():  # every process up: frames are detected
                if time.monotonic() > deadline:
                    raise RuntimeError("no detection: the loop did not start")
                wakeup.wait(0.2)
            for sub in subs.values():
                sub.take()
            got: dict[str, list[Any]] = {name: [] for name in subs}
            started = time.monotonic()
            while time.monotonic() - started < args.seconds:
                wakeup.wait(0.5)
                for name, sub in subs.items():
                    got[name].extend(sub.take())
    record = LoopRecord(got["truth"], got["states"], got["commands"], got["estimates"])
    result = score(
        record,
        CameraPose.from_rig(rig),
        rig.gaze.fovea_half_angle_deg,
        FieldOfRegard.for_scoring(rig),
    )
    period_ms = rig.camera.frame_period_s * 1e3
    result.update(stamp_errors_ms(got["detections"], got["truth"], period_ms))
    notes: list[Health] = got["health"]
    if notes:
        result["vision_note"] = notes[-1].notes.get("camera_delay")
        result["shift_ms"] = notes[-1].stage_ms.get("camera_delay_shift_median")
        result["fit_ms"] = notes[-1].stage_ms.get("camera_delay_fit_median")
    return {"mode": mode, **result}


def stamp_errors_ms(
    detections: list[Detection], truth: list[Any], period_ms: float
) -> dict[str, Any]:
    """Each detection's capture stamp minus its frame's true exposure, over the last half; and
    the time from the first frame after which it stays within a frame period."""
    exposure = {t.seq: t.t_capture_ns for t in truth}
    matched = [d for d in detections if d.seq in exposure]
    errors = np.array([(d.t_capture_ns - exposure[d.seq]) / 1e6 for d in matched])
    late = errors[len(errors) // 2 :]
    if not late.size:
        return {"stamp_error_ms": None, "converged_after_s": None}
    outside = np.flatnonzero(np.abs(errors) >= period_ms)
    first = 0 if not outside.size else int(outside[-1]) + 1
    converged = None
    if first < len(matched):
        converged = round((exposure[matched[first].seq] - exposure[matched[0].seq]) / 1e9, 2)
    return {
        "stamp_error_ms": {
            "median": round(float(np.median(late)), 1),
            "p95_abs": round(float(np.percentile(np.abs(late), 95)), 1),
        },
        "converged_after_s": converged,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rig", type=Path, default=REPO / "configs" / "sim.toml")
    parser.add_argument("--scenario", default="oval")
    parser.add_argument("--delay-ms", type=float, default=150.0)
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--modes", nargs="+", choices=tuple(MODES), default=list(MODES))
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    results = [one_run(args, mode) for mode in args.modes]
    if args.json:
        print(json.dumps(results, indent=2))
        return 0
    print(f"hidden camera delay {args.delay_ms:g} ms, {args.scenario}, {args.seconds:g} s")
    print(
        f"{'mode':<8} {'rms deg':>8} {'fovea':>7} {'stamp err ms':>13} {'p95 |err|':>10}"
        f" {'within a frame after s':>23}"
    )
    for r in results:
        rms = (r.get("gaze_error_deg") or {}).get("rms")
        stamp = r.get("stamp_error_ms") or {}
        print(
            f"{r['mode']:<8} {rms if rms is not None else '-':>8} {r['fovea_fraction']:>7} "
            f"{stamp.get('median', '-'):>13} {stamp.get('p95_abs', '-'):>10}"
            f" {r.get('converged_after_s')!s:>23}"
        )
        print(
            f"         vision: {r.get('vision_note')}; shift {r.get('shift_ms')} ms/frame, "
            f"fit {r.get('fit_ms')} ms twice a second"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
