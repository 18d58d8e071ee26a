"""The closed loop on each shipped serial head: `configs/sim.toml` with the `[servo]` section of
`configs/pelco-d.toml`, `visca.toml`, `flir-ptu.toml` and `dynamixel.toml` (their protocol,
baud rate, timeouts and rates; the port swapped for the emulator's pty), scored by
`gazed eval loop`.

    python tests/bench/serial_rigs.py [--seconds 20] [--scenario oval] [--only pelco-d]

The emulator keeps each line's timing at its baud rate, so this shows whether a shipped rig's
rates fit its line: a 9600 baud Pelco-D or PTU line carries a set-point in 15-40 ms and a
position poll in 30 ms.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
HEADS = ("pelco-d", "visca", "flir-ptu", "dynamixel")
SECTION = re.compile(r"^\[servo\]\n.*?(?=^\[)", re.S | re.M)


def rig_text(head: str, port: Path) -> str:
    """The sim rig with `head`'s [servo] section, talking to the emulator on `port`."""
    servo = SECTION.search((REPO / "configs" / f"{head}.toml").read_text()).group(0)
    servo = re.sub(r"^port = .*$", f'port = "{port}"', servo, flags=re.M)
    sim = (REPO / "configs" / "sim.toml").read_text()
    return SECTION.sub(lambda _: servo, sim).replace('name = "sim"', f'name = "bench-{head}"')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--scenario", default="oval")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--only", choices=HEADS, action="append")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="gazed-serial-") as tmp:
        for head in args.only or HEADS:
            rig = Path(tmp) / f"{head}.toml"
            rig.write_text(rig_text(head, Path(tmp) / f"{head}-pty"))
            command = [sys.executable, "-m", "gazed.cli", "eval", "loop", "--rig", str(rig)]
            command += ["--scenario", args.scenario, "--seconds", str(args.seconds)]
            command += ["--seed", str(args.seed), "--json"]
            result = json.loads(subprocess.run(command, capture_output=True, text=True).stdout)
            error = result["gaze_error_deg"] or {}
            latency = result["latency_ms"]
            servo = result["servo"]
            print(
                f"{head:<10} acquired after {result['acquired_after_s']} s, gaze error RMS "
                f"{error.get('rms')} p95 {error.get('p95')} deg, fovea "
                f"{result['fovea_fraction']}, saccades {result['saccades_after_acquisition']}, "
                f"processing p50 {latency['processing_p50']} ms, "
                f"servo hop p50 {latency['hops_p50'].get('servo')} ms; line load mean "
                f"{servo['line_load_mean']} max {servo['line_load_max']}, polls timed out "
                f"{servo['timeouts']}, response lag {servo['response_lag_ms']} ms"
            )


if __name__ == "__main__":
    main()
