"""VISCA on the emulated camera over each of its transports: Sony's VISCA over IP (UDP), raw
VISCA over TCP (PTZOptics' `socket://`, through the tests' TCP-to-pty bridge) and a serial line
(a pty at `--baud`; the TCP camera's pty is paced as a network, not a line): the command rate
each sustains (absolute moves, Pan-tiltDrives and position inquiries back to back, each answered
before the next is sent) and the time from a command to the first position inquiry that shows
the head moving (with how many commands no inquiry showed within 2 s, counted rather than
waited for: a move to where the head already rests shows no change).

    python tests/bench/visca_io.py [--count 300] [--latency-ms 0] [--baud 9600]

`--latency-ms` is the emulated camera's own delay before it acts (`[sim] head_latency_ms`);
at 0 the figures are the transport's and the host's alone.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import statistics
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from command_timing_support import command_to_reading_ms, rate_hz
from servo_link_support import link_rig
from tcp_bridge_support import TcpBridge
from test_servo_visca_ip_link import udp_rig

from gazed.config import Rig
from gazed.servo import make_codec
from gazed.servo.driver import ServoDriver
from gazed.servo.visca_ip_transport import open_transport
from gazed.sim.head_emulator import HeadEmulator

TIMEOUT_S = 0.5
NETWORK_BAUD = (
    10_000_000  # the emulator paces a pty at the rig's baud: a network's bytes take ~no time
)


@contextlib.contextmanager
def camera(transport: str, folder: Path, baud: int, latency_ms: float) -> Iterator[Rig]:
    """The emulated camera behind `transport` (udp, tcp or serial), and the rig that reaches it."""
    pty = folder / f"{transport}-pty"
    with contextlib.ExitStack() as stack:
        if transport == "udp":
            rig = udp_rig(folder)
        elif transport == "tcp":
            bridge = stack.enter_context(TcpBridge(pty))
            rig = link_rig(bridge.url, protocol="visca", baud=NETWORK_BAUD)
        else:
            rig = link_rig(str(pty), protocol="visca", baud=baud)
        rig = rig.model_copy(
            update={"sim": rig.sim.model_copy(update={"head_latency_ms": latency_ms})}
        )
        stack.enter_context(HeadEmulator(rig, link=None if transport == "udp" else pty))
        yield rig


def measure(rig: Rig, count: int) -> dict[str, float]:
    servo = rig.servo
    driver = ServoDriver(
        make_codec("visca", **rig.servo_params()),
        open_transport(servo.port, servo.baud, TIMEOUT_S),
        TIMEOUT_S,
    )
    with driver:
        pan = [math.radians(10.0 * (i % 2)) for i in range(2)]
        rate = math.radians(20.0)
        figures = {
            "absolute moves/s": rate_hz(lambda i: driver.set_position(pan[i % 2], 0.0), count),
            "Pan-tiltDrives/s": rate_hz(
                lambda i: driver.set_velocity(rate * (-1) ** i, 0.0), count
            ),
            "position inquiries/s": rate_hz(lambda i: driver.query_position(), count),
        }
        driver.stop()
        absolute = command_to_reading_ms(
            driver, lambda i: driver.set_position(math.radians(10.0 * (i % 2)), 0.0), 50
        )
        drive = command_to_reading_ms(
            driver, lambda i: driver.set_velocity(rate * (-1) ** i, 0.0), 50
        )
    for name, (times, unseen) in (("absolute move", absolute), ("Pan-tiltDrive", drive)):
        figures[f"{name} -> reading median ms"] = statistics.median(times)
        figures[f"{name}s no reading showed in 2 s"] = unseen
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=300)
    parser.add_argument("--latency-ms", type=float, default=0.0)
    parser.add_argument("--baud", type=int, default=9600)
    args = parser.parse_args()
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for transport in ("udp", "tcp", "serial"):
            with camera(transport, Path(tmp), args.baud, args.latency_ms) as rig:
                results[transport] = measure(rig, args.count)
    print(f"{'':38s} {'UDP':>8s} {'TCP':>8s} {f'serial {args.baud}':>12s}")
    for name in results["udp"]:
        row = " ".join(f"{results[t][name]:8.1f}" for t in ("udp", "tcp"))
        print(f"{name:38s} {row} {results['serial'][name]:12.1f}")


if __name__ == "__main__":
    main()
