"""The random scenario over many seeds: each seed's closed-loop fovea fraction (all scored frames
and the reachable ones), the share of frames out of the head's reach and the gaze error RMS,
then how many seeds hold the fovea at or above 0.95 and the lowest.

    python tests/bench/random_sweep.py [--seeds 1-20] [--seconds 25] [--rig configs/sim.toml]

Each seed is one `gazed eval loop --scenario random --json` run (the real processes, one after
the other).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TARGET = 0.95
GAZED = str(Path(sys.executable).parent / "gazed")  # the entry point beside this interpreter


def seeds(text: str) -> list[int]:
    """'1-20' or '4,5,8' (or a mix) as a list of seeds."""
    chosen: list[int] = []
    for part in text.split(","):
        first, _, last = part.partition("-")
        chosen += range(int(first), int(last or first) + 1)
    return chosen


def run(rig: Path, seed: int, seconds: float) -> dict:
    command = [GAZED, "eval", "loop", "--rig", str(rig)]
    command += ["--scenario", "random", "--seconds", f"{seconds:g}", "--seed", str(seed), "--json"]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"seed {seed}: gazed eval loop failed:\n{done.stderr}")
    return json.loads(done.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=seeds, default=seeds("1-20"), help="e.g. 1-20 or 4,5,8")
    parser.add_argument("--seconds", type=float, default=25.0)
    parser.add_argument("--rig", type=Path, default=ROOT / "configs" / "sim.toml")
    args = parser.parse_args()
    print(f"{'seed':>4} {'fovea':>7} {'reachable':>9} {'out of reach':>12} {'rms (deg)':>9}")
    foveas = []
    for seed in args.seeds:
        result = run(args.rig, seed, args.seconds)
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
