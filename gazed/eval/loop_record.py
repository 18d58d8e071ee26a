"""What a running rig publishes, recorded for `gazed eval loop`: the topics asked for, on an open
bus session, from the moment the supervisor reports every process running, with each process's
CPU share over the same window.

A `watch` sees the recording as it grows, with the bus session it arrives on: it may publish
(the operator's choice of a scored person) and ends the recording early by returning True.
"""

from __future__ import annotations

import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import psutil

from gazed.bus import Bus
from gazed.topics import SUPERVISOR_STATUS, Topic
from gazed.wakeup import Wakeup

CAPACITY = 100000  # messages a subscription holds between takes
TAKE_PERIOD_S = 0.5  # the longest wait between takes when nothing arrives

Watch = Callable[[Bus, dict[str, list[Any]]], bool]


@dataclass(frozen=True)
class Recording:
    """The messages of each topic (by suffix) in arrival order, and CPU % by process."""

    messages: dict[str, list[Any]]
    cpu_percent: dict[str, float]


def record(
    bus: Bus,
    supervisor: subprocess.Popen[bytes],
    log_path: Path,
    topics: tuple[Topic, ...],
    seconds: float,
    start_timeout_s: float,
    watch: Watch | None = None,
) -> Recording:
    """`topics` for `seconds` once every process runs, which they do within `start_timeout_s`
    (or until `watch` says so)."""
    deadline = time.monotonic() + start_timeout_s
    wakeup = Wakeup()
    bus.on_arrival(wakeup.notify)
    try:
        subscriptions = {t.suffix: bus.subscribe(t, capacity=CAPACITY) for t in topics}
        status = bus.subscribe(SUPERVISOR_STATUS)
        pids = wait_running(wakeup, status, supervisor, deadline, log_path)
        for subscription in subscriptions.values():
            subscription.take()
        processes = {name: psutil.Process(pid) for name, pid in pids.items()}
        cpu_start = {name: cpu_seconds(p) for name, p in processes.items()}
        started = time.monotonic()
        messages: dict[str, list[Any]] = {suffix: [] for suffix in subscriptions}
        while time.monotonic() - started < seconds:
            wakeup.wait(TAKE_PERIOD_S)
            for suffix, subscription in subscriptions.items():
                messages[suffix].extend(subscription.take())
            if supervisor.poll() is not None:
                raise RuntimeError(
                    f"gazed run stopped during the run:\n{log_path.read_text()[-2000:]}"
                )
            if watch is not None and watch(bus, messages):
                break
        elapsed = time.monotonic() - started
        cpu = {
            name: round(100.0 * (cpu_seconds(p) - cpu_start[name]) / elapsed, 1)
            for name, p in processes.items()
        }
        return Recording(messages, cpu)
    finally:
        wakeup.close()


def wait_running(
    wakeup: Wakeup,
    status: Any,
    supervisor: subprocess.Popen[bytes],
    deadline: float,
    log_path: Path,
) -> dict[str, int]:
    """Pids of the processes once the supervisor reports every one running."""
    while time.monotonic() < deadline:
        wakeup.wait(0.5)
        latest = status.latest()
        if latest is not None and latest.state == "running":
            running = {p.name: p.pid for p in latest.processes if p.state == "running" and p.pid}
            if len(running) == len([p for p in latest.processes if p.state != "disabled"]):
                return running
        if supervisor.poll() is not None:
            break
    raise RuntimeError(f"the rig's processes did not all come up:\n{log_path.read_text()[-2000:]}")


def cpu_seconds(process: psutil.Process) -> float:
    """User plus system CPU time of a process so far (0 once it is gone)."""
    try:
        times = process.cpu_times()
    except psutil.NoSuchProcess:
        return 0.0
    return times.user + times.system
