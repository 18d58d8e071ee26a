"""The closed loop on the emulated IP cameras, in position and in speed mode, against the serial
VISCA rig on the same seed: `configs/sim-onvif.toml` and `configs/sim-visca-ip.toml` with
`[servo] mode` set to each mode, and `configs/sim.toml` with the `[servo]` section of
`configs/visca.toml` (as `serial_rigs.py` runs it), scored by `gazed eval loop`.

    python tests/bench/ip_rigs.py [--seconds 20] [--scenario oval] [--seed 1] [--rounds 3]
                                  [--only onvif-speed]

The runs alternate (one of each rig per round, the serial VISCA rig first), so a busy spell on
a shared machine falls on all of them alike. Each line gives a run's gaze error RMS and fovea,
and for an IP rig its RMS over the serial VISCA rig's in the same round; the last lines give
each rig's median RMS, its lowest fovea and the median of its ratios over the rounds.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from serial_rigs import REPO, rig_text

REFERENCE = "serial-visca"
IP_RIGS = {
    "onvif-position": ("sim-onvif.toml", "position"),
    "onvif-speed": ("sim-onvif.toml", "speed"),
    "visca-ip-position": ("sim-visca-ip.toml", "position"),
    "visca-ip-speed": ("sim-visca-ip.toml", "speed"),
}


def ip_rig_text(file_name: str, mode: str) -> str:
    """The shipped IP sim rig in `mode`, its password file named by its full path."""
    text = (REPO / "configs" / file_name).read_text()
    text = re.sub(r"^mode = .*$", "", text, flags=re.M)
    text = text.replace("[servo]\n", f'[servo]\nmode = "{mode}"\n', 1)
    return re.sub(
        r'^password_file = "(.*?)"',
        lambda m: f'password_file = "{REPO / "configs" / m.group(1)}"',
        text,
        flags=re.M,
    )


def run(rig: Path, args: argparse.Namespace) -> dict:
    command = [sys.executable, "-m", "gazed.cli", "eval", "loop", "--rig", str(rig)]
    command += ["--scenario", args.scenario, "--seconds", str(args.seconds)]
    command += ["--seed", str(args.seed), "--json"]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{rig.name}: {done.stderr.strip()}")
    return json.loads(done.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--scenario", default="oval")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--only", choices=list(IP_RIGS), action="append")
    args = parser.parse_args()
    names = [REFERENCE, *(args.only or IP_RIGS)]
    rms: dict[str, list[float]] = {name: [] for name in names}
    fovea: dict[str, list[float]] = {name: [] for name in names}
    ratios: dict[str, list[float]] = {name: [] for name in names}
    with tempfile.TemporaryDirectory(prefix="gazed-ip-rigs-") as tmp:
        rigs = {REFERENCE: Path(tmp) / f"{REFERENCE}.toml"}
        rigs[REFERENCE].write_text(rig_text("visca", Path(tmp) / "visca-pty", {}))
        for name in names[1:]:
            rigs[name] = Path(tmp) / f"{name}.toml"
            rigs[name].write_text(ip_rig_text(*IP_RIGS[name]))
        for round_ in range(args.rounds):
            reference = None
            for name in names:
                result = run(rigs[name], args)
                error = (result["gaze_error_deg"] or {}).get("rms")
                fovea[name].append(result["fovea_fraction"] or 0.0)
                ratio = ""
                if error is not None:
                    rms[name].append(error)
                    if name == REFERENCE:
                        reference = error
                    elif reference:
                        ratios[name].append(error / reference)
                        ratio = f" ({error / reference:.2f} of {REFERENCE}'s this round)"
                servo = result["servo"]
                print(
                    f"round {round_ + 1} {name:<18} RMS {error} deg{ratio}, fovea "
                    f"{result['fovea_fraction']}, acquired after {result['acquired_after_s']} s, "
                    f"polls timed out {servo['timeouts']}, line load {servo['line_load_mean']}, "
                    f"response lag {servo['response_lag_ms']} ms, CPU {result['cpu_percent']}",
                    flush=True,
                )
    for name in names:
        if not rms[name]:
            print(f"{name:<18} never acquired")
            continue
        ratio = (
            f", ratio to {REFERENCE} median {statistics.median(ratios[name]):.2f} "
            f"(rounds {min(ratios[name]):.2f}-{max(ratios[name]):.2f})"
            if ratios[name]
            else ""
        )
        print(
            f"{name:<18} RMS median {statistics.median(rms[name]):.3f} deg "
            f"(rounds {min(rms[name]):.3f}-{max(rms[name]):.3f}), fovea min "
            f"{min(fovea[name]):.3f}{ratio}"
        )


if __name__ == "__main__":
    main()
