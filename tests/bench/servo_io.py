"""Servo IO benchmark: the real `servo` process against the head emulator (a separate process on
a pty, emulating the serial line at the baud rate), per protocol at its usual baud rate, and
VISCA over IP (the emulator's camera on a loopback UDP port; baud 0 in the table).

Figures:
- odometry rate reached when polling flat out (`odometry_rate_hz = 1000`, no demands): the
  median of one-second windows;
- demand published -> command bytes written, p50 / p99, with demands at 10 Hz while odometry is
  polled at 50 Hz (the servo stamps `("servo", t)` when the bytes are written; the demand carries
  the bench's stamp from just before it was published, so the figure includes the bus hop and
  any wait behind a poll in progress — a poll holds the line until its reply is in), the share
  of demands whose stamps were seen, and the odometry rate reached meanwhile.

    python tests/bench/servo_io.py [--seconds 8] [--protocol visca ...]
"""

from __future__ import annotations

import argparse
import math
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from gazed.bus import Bus  # noqa: E402
from gazed.config import load_rig  # noqa: E402
from gazed.messages import GazeDemand  # noqa: E402
from gazed.topics import GAZE_DEMAND, SERVO_COMMAND, SERVO_ODOMETRY, SERVO_STATUS  # noqa: E402
from gazed.wakeup import Wakeup  # noqa: E402

# usual baud rates (PROTOCOLS.md): Pelco-D 2400/9600, VISCA 9600, PTU 9600, Dynamixel 57600
CASES = [
    ("pelco-d", 9600, ""),
    ("pelco-d", 2400, ""),
    ("visca", 9600, ""),
    ("flir-ptu", 9600, ""),
    ("dynamixel", 57600, ""),
    ("visca", 0, ""),  # VISCA over IP: visca-udp://127.0.0.1:PORT
]
BUS_PORT = 17590
# Each odometry message carries the stamps of the command last written; at 10 Hz nearly every
# demand is still the last one when the next odometry goes out (the share is printed).
DEMAND_RATE_HZ = 10.0


def write_rig(directory: Path, protocol: str, baud: int, odometry_hz: float, extra: str) -> Path:
    path = directory / f"bench-{protocol}-{baud}-{int(odometry_hz)}.toml"
    port = f"visca-udp://127.0.0.1:{free_udp_port()}" if baud == 0 else directory / "head"
    path.write_text(
        f"""
[rig]
name = "servobench"
[bus]
listen = ["tcp/127.0.0.1:{BUS_PORT}"]
[servo]
protocol = "{protocol}"
port = "{port}"
baud = {baud or 9600}
timeout_ms = 200
odometry_rate_hz = {odometry_hz}
command_timeout_ms = 500
{extra}
"""
    )
    return path


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def spawn(*args: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, *args], cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )


def stop(process: subprocess.Popen) -> None:
    process.terminate()
    try:
        process.wait(10)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


def wait_connected(wakeup: Wakeup, status, timeout_s: float = 20.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        wakeup.wait(0.1)
        if any(s.link == "connected" for s in status.take()):
            return
    raise RuntimeError("the servo process did not connect")


def run_case(protocol: str, baud: int, extra: str, seconds: float) -> dict[str, float]:
    results: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        for odometry_hz, demands in ((1000.0, False), (50.0, True)):
            rig_path = write_rig(directory, protocol, baud, odometry_hz, extra)
            rig = load_rig(rig_path)
            with Bus(rig, "bench", router=True) as bus, Wakeup() as wakeup:
                bus.on_arrival(wakeup.notify)
                odometry = bus.subscribe(SERVO_ODOMETRY, capacity=100000)
                status = bus.subscribe(SERVO_STATUS)
                commands = bus.subscribe(SERVO_COMMAND, capacity=100000)
                publisher = bus.publisher(GAZE_DEMAND)
                head = spawn("-m", "gazed.sim.head_emulator", "--rig", str(rig_path))
                while baud and not (directory / "head").exists():
                    time.sleep(0.05)  # a UDP camera: the servo retries until it answers
                servo = spawn("-m", "services.servo", "--rig", str(rig_path))
                try:
                    wait_connected(wakeup, status)
                    odometry.take()
                    if demands:
                        results.update(
                            measure_latency(wakeup, publisher, odometry, commands, seconds)
                        )
                    else:
                        results["odometry_max_hz"] = measure_rate(wakeup, odometry, seconds / 2)
                finally:
                    stop(servo)
                    stop(head)
    return results


def measure_rate(wakeup: Wakeup, odometry, seconds: float) -> float:
    counts = []
    for _ in range(max(3, int(seconds))):
        odometry.take()
        started = time.monotonic()
        n = 0
        while time.monotonic() - started < 1.0:
            wakeup.wait(0.05)
            n += len(odometry.take())
        counts.append(n / (time.monotonic() - started))
    return statistics.median(counts)


def measure_latency(
    wakeup: Wakeup, publisher, odometry, commands, seconds: float
) -> dict[str, float]:
    latencies_ms: dict[int, float] = {}
    received = 0
    period_s = 1.0 / DEMAND_RATE_HZ
    started = time.monotonic()
    next_s = started
    k = 0
    while time.monotonic() - started < seconds:
        now = time.monotonic()
        if now >= next_s:
            pan = math.radians(20.0 * math.sin(0.5 * k * period_s))
            publisher.put(
                GazeDemand(
                    t_capture_ns=time.time_ns(), kind="pursuit", pan_rad=pan, tilt_rad=0.0
                ).stamped("bench")
            )
            k += 1
            next_s += period_s
        wakeup.wait(max(0.0, next_s - time.monotonic()))
        received += len(odometry.take())
        for message in commands.take():
            stamps = dict(message.stamps)
            if "bench" in stamps and "servo" in stamps:
                latencies_ms[stamps["bench"]] = (stamps["servo"] - stamps["bench"]) / 1e6
    elapsed = time.monotonic() - started
    values = sorted(latencies_ms.values())
    return {
        "latency_p50_ms": statistics.median(values),
        "latency_p99_ms": values[min(len(values) - 1, int(0.99 * len(values)))],
        "demands_seen": len(values) / max(k, 1),
        "odometry_hz_with_demands": received / elapsed,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=8.0, help="per measurement")
    parser.add_argument("--protocol", action="append", help="only these protocols")
    args = parser.parse_args()
    print(
        f"{'protocol':<10} {'baud':>6} {'odometry max':>13} {'demand->bytes p50':>18} "
        f"{'p99':>8} {'odometry at 50 Hz':>18} {'demands sampled':>16}"
    )
    for protocol, baud, extra in CASES:
        if args.protocol and protocol not in args.protocol:
            continue
        r = run_case(protocol, baud, extra, args.seconds)
        print(
            f"{protocol:<10} {baud:>6} {r['odometry_max_hz']:>10.1f} Hz "
            f"{r['latency_p50_ms']:>15.2f} ms {r['latency_p99_ms']:>5.2f} ms "
            f"{r['odometry_hz_with_demands']:>15.1f} Hz {r['demands_seen']:>15.0%}",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
