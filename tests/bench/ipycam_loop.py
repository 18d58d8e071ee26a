"""The whole loop through ipycam, a virtual ONVIF camera nobody here wrote: `gazed run` on
configs/pets.toml's world seen through ipycam's digital PTZ and MJPEG stream (the rig of
tests/test_onvif_e2e.py), in position and in speed mode. Prints how long the gaze held
someone in pursuit after it first took them up, how far the head went, and how closely the
servo's odometry follows the position ipycam itself reports (sampled every half second).

    python tests/bench/ipycam_loop.py [--seconds 25] [--mode speed]

Needs ipycam (`pip install --no-deps ipycam==1.3.0`) and /work/shared/data's PETS footage.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

import tomlkit

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from conftest import SHARED_DATA, RunningSupervisor
from onveef import OnvifClient
from onvif_support import LOOP_RANGE_DEG, ipycam_position_deg, loop_rig, running_ipycam

from gazed.topics import GAZE_STATE, SERVO_ODOMETRY


def run(folder: Path, mode: str, seconds: float) -> str:
    video = SHARED_DATA / "video" / "vtest_480x360.avi"
    with running_ipycam(video, folder) as (port, client, token):
        rig_path = loop_rig(folder, port)
        document = tomlkit.parse(rig_path.read_text())
        document["servo"]["mode"] = mode
        rig_path.write_text(tomlkit.dumps(document))
        return measure(RunningSupervisor(rig_path, folder), client, token, mode, seconds)


def measure(
    supervisor: RunningSupervisor, client: OnvifClient, token: str, mode: str, seconds: float
) -> str:
    states = supervisor.bus.subscribe(GAZE_STATE, capacity=10000)
    odometry = supervisor.bus.subscribe(SERVO_ODOMETRY, capacity=100000)
    seen_states, readings, gaps_deg = [], [], []
    try:
        supervisor.wait_ready(60.0)
        started = time.monotonic()
        while time.monotonic() - started < seconds:
            supervisor.wakeup.wait(0.5)
            seen_states.extend(states.take())
            readings.extend(odometry.take())
            if readings:
                reported = ipycam_position_deg(client, token, LOOP_RANGE_DEG)
                last = readings[-1]
                odometry_deg = (math.degrees(last.pan_rad), math.degrees(last.tilt_rad))
                gaps_deg.append(math.dist(reported, odometry_deg))
        ended_ns = time.time_ns()
    finally:
        supervisor.stop()
    changes = [(s.t_capture_ns, s.state) for s in seen_states]
    first = next((t for t, state in changes if state == "pursuit"), None)
    if first is None:
        return f"{mode:<8} never took anyone up"
    spans = zip(changes, [*changes[1:], (ended_ns, "")], strict=True)
    pursuing_s = sum((b - a) / 1e9 for (a, state), (b, _) in spans if state == "pursuit")
    pans = [math.degrees(r.pan_rad) for r in readings]
    return (
        f"{mode:<8} in pursuit {pursuing_s / ((ended_ns - first) / 1e9):.0%} of the time after "
        f"the first take-up ({(first - changes[0][0]) / 1e9:.1f} s in), pan range "
        f"{max(pans) - min(pans):.1f} deg, odometry vs ipycam's report median "
        f"{statistics.median(gaps_deg):.2f} deg, max {max(gaps_deg):.2f} deg"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=25.0)
    parser.add_argument("--mode", choices=("position", "speed"), action="append")
    args = parser.parse_args()
    for mode in args.mode or ("position", "speed"):
        with tempfile.TemporaryDirectory(prefix="gazed-ipycam-") as tmp:
            print(run(Path(tmp), mode, args.seconds), flush=True)


if __name__ == "__main__":
    main()
