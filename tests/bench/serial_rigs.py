"""The closed loop on each shipped serial head: `configs/sim.toml` with the `[servo]` section of
`configs/pelco-d.toml`, `visca.toml`, `flir-ptu.toml` and `dynamixel.toml` (their protocol,
baud rate, timeouts and rates; the port swapped for the emulator's pty), scored by
`gazed eval loop`.

    python tests/bench/serial_rigs.py [--seconds 20] [--scenario oval] [--only pelco-d]
                                      [--odometry-rate-hz 15] [--command-rate-hz 15]

The emulator keeps each line's timing at its baud rate, so this shows whether a shipped rig's
rates fit its line: every set-point and position poll takes its bytes' time at the baud rate,
and the servo's `line_load` says how full the line was. The rate options replace the shipped
rates, to find the ones a line carries.
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


def rig_text(head: str, port: Path, rates: dict[str, float | None]) -> str:
    """The sim rig with `head`'s [servo] section, talking to the emulator on `port`, with the
    rates given (None: the shipped one)."""
    servo = SECTION.search((REPO / "configs" / f"{head}.toml").read_text()).group(0)
    servo = re.sub(r"^port = .*$", f'port = "{port}"', servo, flags=re.M)
    for key, value in rates.items():
        if value is not None:
            servo = re.sub(rf"^{key} = .*$", f"{key} = {value}", servo, flags=re.M)
    sim = (REPO / "configs" / "sim.toml").read_text()
    return SECTION.sub(lambda _: servo, sim).replace('name = "sim"', f'name = "bench-{head}"')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--scenario", default="oval")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--only", choices=HEADS, action="append")
    parser.add_argument("--odometry-rate-hz", type=float)
    parser.add_argument("--command-rate-hz", type=float)
    args = parser.parse_args()
    rates = {"odometry_rate_hz": args.odometry_rate_hz, "command_rate_hz": args.command_rate_hz}
    with tempfile.TemporaryDirectory(prefix="gazed-serial-") as tmp:
        for head in args.only or HEADS:
            rig = Path(tmp) / f"{head}.toml"
            rig.write_text(rig_text(head, Path(tmp) / f"{head}-pty", rates))
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
