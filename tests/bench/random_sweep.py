"""The random scenario over many seeds: each seed's closed-loop fovea fraction (all scored frames
and the reachable ones), the share of frames out of the head's reach and the gaze error RMS,
then how many seeds hold the fovea at or above 0.95 and the lowest.

    python tests/bench/random_sweep.py [--seeds 1-20] [--seconds 25] [--rig configs/sim.toml]

Each seed is one `gazed eval loop --scenario random --json` run (the real processes, one after
the other).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from loop_runs import ROOT, eval_loop, seeds

TARGET = 0.95


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=seeds, default=seeds("1-20"), help="e.g. 1-20 or 4,5,8")
    parser.add_argument("--seconds", type=float, default=25.0)
    parser.add_argument("--rig", type=Path, default=ROOT / "configs" / "sim.toml")
    args = parser.parse_args()
    print(f"{'seed':>4} {'fovea':>7} {'reachable':>9} {'out of reach':>12} {'rms (deg)':>9}")
    foveas = []
    for seed in args.seeds:
        result = eval_loop(args.rig, "random", seed, args.seconds)
        rms = (result["gaze_error_deg"] or {}).get("rms")
        foveas.append(result["fovea_fraction"])
        print(
            f"{seed:>4} {result['fovea_fraction']:>7} {result['fovea_fraction_reachable']!s:>9}"
            f" {result['out_of_reach_fraction']!s:>12} {rms!s:>9}",
            flush=True,
        )
    held = sum(f >= TARGET for f in foveas)
    print(f"fovea >= {TARGET}: {held} of {len(foveas)} seeds, lowest {min(foveas)}")


if __name__ == "__main__":
    main()
