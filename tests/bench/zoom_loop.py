"""The zoom control in the closed loop: on the oval and on the `random` scenario, the share of
frames after acquisition with the target's true height within ±20 % of the setpoint, its
height's percentiles, the losses after acquisition and those while the zoom moved, and the gaze
error RMS and fovea fraction.

    python tests/bench/zoom_loop.py [--seeds 1-10] [--seconds 25] [--rig configs/sim-zoom.toml]

Each run is one `gazed eval loop --json` on the zoom rig (the real processes, one after the
other): the oval with seed 1, then `random` with each seed. The target: the height held in 90 %
of the frames, and no loss while zooming.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from loop_runs import ROOT, eval_loop, seeds

HELD_TARGET = 0.9


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=seeds, default=seeds("1-10"), help="random's seeds")
    parser.add_argument("--seconds", type=float, default=25.0)
    parser.add_argument("--rig", type=Path, default=ROOT / "configs" / "sim-zoom.toml")
    args = parser.parse_args()
    print(
        f"{'scenario':>9} {'seed':>4} {'held':>6} {'p5':>6} {'p50':>6} {'p95':>6}"
        f" {'losses':>6} {'zooming':>7} {'fovea':>6} {'rms (deg)':>9}"
    )
    runs = [("oval", 1)] + [("random", seed) for seed in args.seeds]
    held_all, zooming_losses = [], 0
    for scenario, seed in runs:
        result = eval_loop(args.rig, scenario, seed, args.seconds)
        zoom = result["zoom"]
        heights = zoom.get("height_fraction", {})
        rms = (result["gaze_error_deg"] or {}).get("rms")
        held_all.append(zoom["height_within_fraction"])
        zooming_losses += zoom["losses_while_zooming"] or 0
        print(
            f"{scenario:>9} {seed:>4} {zoom['height_within_fraction']:>6}"
            f" {heights.get('p5')!s:>6} {heights.get('p50')!s:>6} {heights.get('p95')!s:>6}"
            f" {zoom['losses']!s:>6} {zoom['losses_while_zooming']!s:>7}"
            f" {result['fovea_fraction']:>6} {rms!s:>9}",
            flush=True,
        )
    met = sum(h >= HELD_TARGET for h in held_all)
    print(
        f"setpoint {zoom.get('setpoint')}: height held in >= {HELD_TARGET:.0%} of the frames in "
        f"{met} of {len(runs)} runs, lowest {min(held_all)}; losses while zooming {zooming_losses}"
    )


if __name__ == "__main__":
    main()
