"""What the closed-loop benchmarks share: a list of seeds from the command line and one
`gazed eval loop --json` run (the real processes) with its result.

    from loop_runs import eval_loop, seeds
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
GAZED = str(Path(sys.executable).parent / "gazed")  # the entry point beside this interpreter


def seeds(text: str) -> list[int]:
    """'1-20' or '4,5,8' (or a mix) as a list of seeds."""
    chosen: list[int] = []
    for part in text.split(","):
        first, _, last = part.partition("-")
        chosen += range(int(first), int(last or first) + 1)
    return chosen


def eval_loop(rig: Path, scenario: str, seed: int, seconds: float) -> dict[str, Any]:
    """`gazed eval loop` on `rig` and `scenario` with `seed`: its JSON result (exits with the
    loop's error output when it fails)."""
    command = [GAZED, "eval", "loop", "--rig", str(rig), "--scenario", scenario]
    command += ["--seconds", f"{seconds:g}", "--seed", str(seed), "--json"]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"{scenario} seed {seed}: gazed eval loop failed:\n{done.stderr}")
    return json.loads(done.stdout)
