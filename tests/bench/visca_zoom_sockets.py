"""Pan-tilt demands and a moving zoom sharing the VISCA camera's two command sockets: the head
link of `configs/sim-zoom.toml` against its emulated VISCA-over-IP camera (in this process, on a
loopback port), fed 25 demands a second that pan back and forth and zoom in and out. Prints the
time from each demand to its set-point's bytes (median, 90th percentile, max), how often a
set-point was held for a socket, how often the zoom's command was cancelled for a fresh demand,
the zoom commands written and the device errors.

    python tests/bench/visca_zoom_sockets.py [--seconds 8]
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from servo_link_support import Demands, demand
from test_servo_visca_ip_link import free_udp_port

from gazed.config import load_rig
from gazed.servo.head_link import HeadLink
from gazed.sim.head_emulator import HeadEmulator
from services.runtime import Now

REPO = Path(__file__).resolve().parents[2]
DEMAND_PERIOD_S = 0.04


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=8.0)
    args = parser.parse_args()
    text = (REPO / "configs" / "sim-zoom.toml").read_text()
    text = text.replace("127.0.0.1:52381", f"127.0.0.1:{free_udp_port()}")
    with tempfile.TemporaryDirectory(prefix="gazed-visca-zoom-") as tmp:
        (Path(tmp) / "rig.toml").write_text(text)
        rig = load_rig(Path(tmp) / "rig.toml")
    demands = Demands()
    sent_s: dict[int, float] = {}
    delays_ms: list[float] = []

    def written(command, _t_ns: int) -> None:
        if command.t_capture_ns in sent_s:
            delays_ms.append((time.monotonic() - sent_s.pop(command.t_capture_ns)) * 1000)

    def now(immediate: bool = False) -> Now:
        return Now(time.time_ns(), time.monotonic(), immediate)

    with HeadEmulator(rig):
        link = HeadLink(rig, demands.take, written)
        step = link.step(now())
        start_s = next_s = time.monotonic()
        i = 0
        while time.monotonic() - start_s < args.seconds:
            if time.monotonic() >= next_s:
                i += 1
                d = demand(10 * math.sin(i / 25), 0.0)
                d = d.model_copy(update={"zoom": 0.3 + 0.2 * math.sin(i / 30)})
                sent_s[d.t_capture_ns] = time.monotonic()
                demands.put(d)
                step = link.step(now(immediate=True))
                next_s += DEMAND_PERIOD_S
            else:
                step = link.step(now())
            time.sleep(max(0.0, min(step.wait_s, next_s - time.monotonic())))
        counters = link.counters()
        zoom = link.zoom
        link.close()
    assert zoom is not None
    delays_ms.sort()
    print(
        f"demand -> set-point written: {len(delays_ms)} of {i}, median "
        f"{statistics.median(delays_ms):.2f} ms, p90 {delays_ms[int(0.9 * len(delays_ms))]:.2f} "
        f"ms, max {delays_ms[-1]:.2f} ms"
    )
    print(
        f"set-points {counters['commands']}, held for a socket {counters['held_for_a_socket']}, "
        f"moves cancelled for a fresh demand {counters['superseded']}; "
        f"zoom commands {zoom.writes}, cancelled for a fresh demand {zoom.cancelled}; "
        f"errors {counters['errors']}, poll timeouts {counters['timeouts']}"
    )


if __name__ == "__main__":
    main()
