"""What every process shares: `--rig` parsing, the bus session, liveliness, health, signals,
and the loop that calls the service's `step(now)`.

A service is a small object built from the rig and the open bus:

    class Service(Protocol):
        def step(self, now: Now) -> float: ...   # work; returns seconds until it wants to run again
        def health(self) -> HealthReport: ...    # its own counters, notes and stage timings
        def close(self) -> None: ...             # orderly stop (the servo parks here)

The loop wakes when a subscribed message arrives or when the service asked to run again, and
publishes `<process>/health` about once a second. SIGTERM and SIGINT stop it; the liveliness
token `gazed/<rig>/alive/<process>` is declared once the service is built (so "alive" means
"ready") and vanishes when the session closes. An exception in `step` is logged and counted;
a process whose step fails persistently exits non-zero so the supervisor restarts it.
"""

from __future__ import annotations

import argparse
import ctypes
import logging
import os
import signal
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

from gazed.bus import Bus, BusError
from gazed.config import Rig, RigError, load_rig
from gazed.messages import Health
from gazed.supervisor import ENV_SUPERVISOR_PID
from gazed.topics import health as health_topic

HEALTH_PERIOD_S = 1.0
PR_SET_PDEATHSIG = 1  # linux/prctl.h
MAX_CONSECUTIVE_STEP_FAILURES = 50

log = logging.getLogger("gazed.service")


@dataclass(frozen=True)
class Now:
    """The instant a step runs: wall clock for stamps, monotonic for deadlines and intervals."""

    wall_ns: int
    mono_s: float

    @classmethod
    def read(cls) -> Now:
        return cls(time.time_ns(), time.monotonic())


@dataclass
class HealthReport:
    counters: dict[str, int] = field(default_factory=dict)
    stage_ms: dict[str, float] = field(default_factory=dict)
    notes: dict[str, str] = field(default_factory=dict)


class Service(Protocol):
    def step(self, now: Now) -> float: ...

    def health(self) -> HealthReport: ...

    def close(self) -> None: ...


def parse_args(name: str, argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog=f"python -m services.{name}", description=f"gazed {name} process"
    )
    parser.add_argument("--rig", required=True, type=Path, help="rig description (TOML)")
    return parser.parse_args(argv)


def main(name: str, build: Callable[[Rig, Bus], Service], argv: list[str] | None = None) -> int:
    """Entry point of a process: exit 2 on a bad rig, 1 on a bus or persistent step failure."""
    logging.basicConfig(level=logging.INFO, format=f"%(levelname)s {name}: %(message)s")
    die_with_supervisor()
    args = parse_args(name, argv)
    try:
        rig = load_rig(args.rig)
    except RigError as exc:
        print(exc, file=sys.stderr)
        return 2
    stop = StopFlag()
    try:
        with Bus(rig, name) as bus:
            _install_signals(stop, bus)
            return run(name, rig, bus, build(rig, bus), stop)
    except BusError as exc:
        print(f"{name}: {exc}", file=sys.stderr)
        return 1


def die_with_supervisor() -> None:
    """Under `gazed run`, ask the kernel for SIGTERM when the supervisor dies, so no process
    outlives it even if it is SIGKILLed; exit at once if it is already gone."""
    supervisor_pid = os.environ.get(ENV_SUPERVISOR_PID, "")
    if not supervisor_pid.isdigit():
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):
        log.warning("cannot ask to die with the supervisor (no prctl)")
    if os.getppid() != int(supervisor_pid):
        raise SystemExit("the supervisor is gone")


class StopFlag:
    """Set by a signal handler, read by the loop: a plain attribute, no lock (a lock taken in a
    handler can deadlock the thread it interrupted)."""

    def __init__(self) -> None:
        self.raised = False

    def set(self) -> None:
        self.raised = True

    def is_set(self) -> bool:
        return self.raised


def _install_signals(stop: StopFlag, bus: Bus) -> None:
    def on_signal(_signum: int, _frame: object) -> None:
        stop.set()
        bus.notify()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)  # the supervisor reloads, not its children


def run(name: str, rig: Rig, bus: Bus, service: Service, stop: StopFlag) -> int:
    """The process loop: step on arrivals and when asked, health once a second, orderly close."""
    reporter = HealthReporter(name, bus)
    bus.declare_alive()
    next_health_s = time.monotonic()
    wait_s = 0.0
    failures = 0
    try:
        while not stop.is_set():
            bus.wait(min(wait_s, max(0.0, next_health_s - time.monotonic())))
            if stop.is_set():
                break
            now = Now.read()
            try:
                wait_s = max(0.0, service.step(now))
                failures = 0
            except Exception:
                failures += 1
                reporter.step_errors += 1
                wait_s = 0.05
                log.exception("step failed (%d in a row)", failures)
                if failures >= MAX_CONSECUTIVE_STEP_FAILURES:
                    return 1
            if now.mono_s >= next_health_s:
                next_health_s = now.mono_s + HEALTH_PERIOD_S
                reporter.publish(service.health(), now)
    finally:
        service.close()
    return 0


class HealthReporter:
    """Publishes `<process>/health`: bus counters, the service's report, receive rates per key
    over the last period."""

    def __init__(self, name: str, bus: Bus) -> None:
        self.name = name
        self.step_errors = 0
        self._bus = bus
        self._publisher = bus.publisher(health_topic(name))
        self._started_s = time.monotonic()
        self._last: tuple[float, dict[str, int]] = (self._started_s, {})

    def publish(self, report: HealthReport, now: Now) -> None:
        counters, received = self._bus.stats.snapshot()
        counters.update(report.counters)
        counters["step_errors"] = self.step_errors
        last_s, last_received = self._last
        period_s = max(now.mono_s - last_s, 1e-3)
        rates = {k: (n - last_received.get(k, 0)) / period_s for k, n in received.items()}
        self._last = (now.mono_s, received)
        notes = dict(report.notes)
        if self._bus.stats.last_malformed:
            notes["last_malformed"] = self._bus.stats.last_malformed
        self._publisher.put(
            Health(
                t_capture_ns=now.wall_ns,
                process=self.name,
                pid=os.getpid(),
                uptime_s=now.mono_s - self._started_s,
                counters=counters,
                rates_hz=rates,
                stage_ms=report.stage_ms,
                notes=notes,
            )
        )
