"""The zoom control in the closed loop: on the oval and on the `random` scenario, the share of
frames after acquisition with the target's true height within ±20 % of the setpoint, its
height's percentiles, the losses after acquisition and those while the zoom moved, the gaze
error RMS and fovea fraction, and where the frames not held go.

    python tests/bench/zoom_loop.py [--seeds 1-10] [--seconds 25] [--rig configs/sim-zoom.toml]

Each run is one `gazed eval loop` on the zoom rig (the real processes, one after the other): the
oval with seed 1, then `random` with each seed. The target: the height held in 90 % of the
frames, and no loss while zooming. A run in which the target is never acquired (never held in
the fovea: the gaze pursued something else) holds it in no frame, its losses unscored (None).

The frames after acquisition whose height is not held are sorted by what the loop was doing:
`reacq` the gaze not in pursuit (saccade, lost, search: the zoom goes to the widest); in
pursuit, with the target too small, `in` the true zoom rising (ramping in), `out` falling,
`still` unchanged (capped by the room, or waiting to be steady); `big` too tall. Each is a
fraction of the frames after acquisition.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

import gazed.eval.loop as loop
from gazed.config import load_rig
from gazed.eval.loop_metrics import LoopRecord
from gazed.eval.zoom_score import TOLERANCE, zoom_scoring

sys.path.insert(0, str(Path(__file__).resolve().parent))
from loop_runs import ROOT, seeds

HELD_TARGET = 0.9
CLASSES = ("reacq", "in", "out", "still", "big")
STILL_ZOOM = 1e-4  # a truth frame's zoom moved by less than this since the last: still


def run(rig: Path, scenario: str, seed: int, seconds: float) -> tuple[dict[str, Any], LoopRecord]:
    """One `gazed eval loop` run: its result and its record (taken as it is scored)."""
    records: list[LoopRecord] = []
    score = loop.score

    def keep(record: LoopRecord, *args: Any) -> dict[str, object]:
        records.append(record)
        return score(record, *args)

    loop.score = keep
    try:
        result = loop.run_loop(rig, scenario, seconds, seed=seed)
    finally:
        loop.score = score
    return result, records[0]


def classes(rig_path: Path, record: LoopRecord) -> dict[str, float]:
    """Of the frames after acquisition, the fraction not held in each class (docstring)."""
    rig = load_rig(rig_path)
    scoring = zoom_scoring(rig)
    assert scoring is not None
    truth = sorted(record.truth, key=lambda t: t.t_capture_ns)
    states = sorted(record.states, key=lambda s: s.t_capture_ns)
    state_ns = np.array([s.t_capture_ns for s in states])
    pursuing = np.array(
        [
            bool(states)
            and (i := int(np.searchsorted(state_ns, t.t_capture_ns, "right")) - 1) >= 0
            and states[i].state == "pursuit"
            for t in truth
        ]
    )
    if not pursuing.any():
        return {}
    start = int(np.argmax(pursuing))
    ratio = scoring.heights(truth[start:]) / scoring.setpoint
    zooms = np.array([t.head.zoom or 0.0 for t in truth[start:]])
    dz = np.diff(zooms, prepend=zooms[0])
    pursue = pursuing[start:]
    small = (ratio < 1.0 - TOLERANCE) & pursue
    counts = {
        "reacq": ~pursue & (np.abs(ratio - 1.0) > TOLERANCE),
        "in": small & (dz > STILL_ZOOM),
        "out": small & (dz < -STILL_ZOOM),
        "still": small & (np.abs(dz) <= STILL_ZOOM),
        "big": pursue & (ratio > 1.0 + TOLERANCE),
    }
    return {name: round(float(np.mean(mask)), 3) for name, mask in counts.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=seeds, default=seeds("1-10"), help="random's seeds")
    parser.add_argument("--seconds", type=float, default=25.0)
    parser.add_argument("--rig", type=Path, default=ROOT / "configs" / "sim-zoom.toml")
    args = parser.parse_args()
    print(
        f"{'scenario':>9} {'seed':>4} {'held':>6} {'p5':>6} {'p50':>6} {'p95':>6}"
        f" {'losses':>6} {'zooming':>7} {'fovea':>6} {'rms (deg)':>9} "
        + " ".join(f"{name:>6}" for name in CLASSES)
    )
    runs = [("oval", 1)] + [("random", seed) for seed in args.seeds]
    held_all, zooming_losses, unacquired = [], 0, 0
    for scenario, seed in runs:
        result, record = run(args.rig, scenario, seed, args.seconds)
        zoom = result["zoom"]
        heights = zoom.get("height_fraction", {})
        rms = (result["gaze_error_deg"] or {}).get("rms")
        held_all.append(zoom["height_within_fraction"])
        zooming_losses += zoom["losses_while_zooming"] or 0
        unacquired += zoom["losses"] is None  # the target never held in the fovea
        where = classes(args.rig, record)
        print(
            f"{scenario:>9} {seed:>4} {zoom['height_within_fraction']:>6}"
            f" {heights.get('p5')!s:>6} {heights.get('p50')!s:>6} {heights.get('p95')!s:>6}"
            f" {zoom['losses']!s:>6} {zoom['losses_while_zooming']!s:>7}"
            f" {result['fovea_fraction']:>6} {rms!s:>9} "
            + " ".join(f"{where.get(name)!s:>6}" for name in CLASSES),
            flush=True,
        )
    met = sum(h >= HELD_TARGET for h in held_all)
    print(
        f"setpoint {zoom.get('setpoint')}: height held in >= {HELD_TARGET:.0%} of the frames in "
        f"{met} of {len(runs)} runs, lowest {min(held_all)}; losses while zooming {zooming_losses};"
        f" never acquired in {unacquired}"
    )


if __name__ == "__main__":
    main()
