"""The recorder's cost to the loop: processing latency p50/p99 and CPU with `gazed record`
attached (every key, frames as JPEG) against none, side by side (tests/bench/loop_cost.py says
how each is measured).

    python tests/bench/record_cost.py [--seconds 20] [--rounds 2] [--json]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import psutil
from loop_cost import cpu_seconds, measure, sim_rig, summary


@contextlib.contextmanager
def recorder(rig_path: Path, output: Path) -> Iterator[None]:
    process = subprocess.Popen(
        [sys.executable, "-m", "gazed.cli", "record", "--rig", str(rig_path), "-o", str(output)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stderr is not None
    process.stderr.readline()  # "gazed record: ... -> FILE": subscribed
    handle = psutil.Process(process.pid)
    cpu0_s, t0_s = cpu_seconds(handle), time.monotonic()
    try:
        yield
    finally:
        share = (cpu_seconds(handle) - cpu0_s) / (time.monotonic() - t0_s)
        print(f"  the recorder took {100 * share:.1f} % of a core")
        process.send_signal(signal.SIGINT)
        out, _ = process.communicate(timeout=60)
        size_mib = output.stat().st_size / 2**20
        frames = next((line for line in out.splitlines() if "sim/frame" in line), "")
        print(f"  recorded {size_mib:.1f} MiB; {' '.join(frames.split())}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=20.0, help="length of each phase")
    parser.add_argument("--rounds", type=int, default=2, help="pairs of phases")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="record-cost-") as directory:
        rig_path = sim_rig(Path(directory))
        output = Path(directory) / "run.mcap"
        phases = []
        for phase in measure(
            rig_path, lambda: recorder(rig_path, output), args.seconds, args.rounds
        ):
            phases.append(phase)
            print(json.dumps(phase), flush=True)
    print(json.dumps(phases) if args.json else summary(phases))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
