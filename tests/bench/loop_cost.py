"""What the benches of an observer's cost share: the sim rig under `gazed run` on a private bus,
and the loop's processing latency and CPU over alternating phases with and without an observer.

The loop's processing latency is each command's time from the frame's arrival at vision to the
bytes written to the head (`gazed.latency.processing_s`, the `servo/command` stamps); CPU is
the user plus system time of the rig's processes (sim, servo, vision, estimator, gaze) over the
phase, as a share of one core. Phases alternate (without, with, without, with, ...) so that
a drift of the machine's load falls on both sides alike.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any

import numpy as np
import psutil

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from gazed.config import SERVICE_NAMES  # noqa: E402
from gazed.eval.loop import observed  # noqa: E402
from gazed.eval.loop_record import cpu_seconds  # noqa: E402
from gazed.eval.private_rig import private_rig  # noqa: E402
from gazed.latency import processing_s  # noqa: E402
from gazed.topics import SERVO_COMMAND, SUPERVISOR_STATUS  # noqa: E402

WARM_UP_S = 5.0

Observer = Callable[[], AbstractContextManager[Any]]


def sim_rig(directory: Path, extra: str = "") -> Path:
    """A private copy of configs/sim.toml (oval, seed 1) with `extra` appended."""
    path = private_rig(REPO / "configs" / "sim.toml", directory, "oval", None, None, 1, None)
    path.write_text(path.read_text() + extra)
    return path


def measure(
    rig_path: Path, observer: Observer, phase_s: float, rounds: int
) -> Iterator[dict[str, Any]]:
    """Per phase: its label, the processing latency p50/p99 (ms), n, and the CPU share of the
    rig's processes (and of the others the supervisor runs, such as the view)."""
    with observed(rig_path, "bench") as (_rig, bus, wakeup):
        commands = bus.subscribe(SERVO_COMMAND, capacity=100_000)
        status = bus.subscribe(SUPERVISOR_STATUS)
        pids = _wait_for_pids(status, wakeup)
        handles = {name: psutil.Process(pid) for name, pid in pids.items()}
        time.sleep(WARM_UP_S)
        for _ in range(rounds):
            for label in ("without", "with"):
                if label == "with":
                    with observer():
                        yield _phase(label, commands, handles, phase_s)
                else:
                    yield _phase(label, commands, handles, phase_s)


def _phase(
    label: str, commands: Any, handles: dict[str, psutil.Process], phase_s: float
) -> dict[str, Any]:
    commands.take()
    cpu0 = {name: cpu_seconds(h) for name, h in handles.items()}
    t0 = time.monotonic()
    time.sleep(phase_s)
    elapsed_s = time.monotonic() - t0
    cpu = {name: (cpu_seconds(h) - cpu0[name]) / elapsed_s for name, h in handles.items()}
    latencies_ms = [1e3 * s for m in commands.take() if (s := processing_s(m)) is not None]
    p50, p99 = np.percentile(latencies_ms, [50, 99]) if latencies_ms else (np.nan, np.nan)
    loop_cpu = sum(v for name, v in cpu.items() if name in SERVICE_NAMES)
    return {
        "phase": label,
        "n": len(latencies_ms),
        "processing_p50_ms": round(float(p50), 3),
        "processing_p99_ms": round(float(p99), 3),
        "loop_cpu_percent": round(100 * loop_cpu, 1),
        "other_cpu_percent": {
            name: round(100 * v, 1) for name, v in cpu.items() if name not in SERVICE_NAMES
        },
    }


def _wait_for_pids(status: Any, wakeup: Any, timeout_s: float = 90.0) -> dict[str, int]:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        wakeup.wait(0.5)
        latest = status.latest()
        if latest is not None and latest.state == "running":
            return {p.name: p.pid for p in latest.processes if p.pid}
    raise RuntimeError("the rig did not come up")


def summary(phases: list[dict[str, Any]]) -> str:
    """Each phase, then the medians of the phases without and with the observer side by side."""
    lines = [f"{'phase':<8} {'n':>5} {'p50 ms':>8} {'p99 ms':>8} {'loop CPU %':>10}  others"]
    for p in phases:
        lines.append(
            f"{p['phase']:<8} {p['n']:>5} {p['processing_p50_ms']:>8.2f} "
            f"{p['processing_p99_ms']:>8.2f} {p['loop_cpu_percent']:>10.1f}  "
            f"{p['other_cpu_percent']}"
        )
    lines.append("median over phases:")
    for label in ("without", "with"):
        chosen = [p for p in phases if p["phase"] == label]
        p50 = np.median([p["processing_p50_ms"] for p in chosen])
        p99 = np.median([p["processing_p99_ms"] for p in chosen])
        cpu = np.median([p["loop_cpu_percent"] for p in chosen])
        lines.append(f"  {label:<8} p50 {p50:6.2f} ms  p99 {p99:6.2f} ms  loop CPU {cpu:5.1f} %")
    return "\n".join(lines)
