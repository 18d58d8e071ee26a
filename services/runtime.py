"""What every process shares: `--rig` parsing, the bus session, liveliness, health, signals,
and the loop that calls the service's `step(now)`.

A service is a small object built from the rig and the open bus:

    class Service(Protocol):
        def step(self, now: Now) -> float: ...   # work; returns seconds until it wants to run again
        def health(self) -> HealthReport: ...    # its own counters, notes and stage timings
        def close(self) -> None: ...             # orderly stop (the servo parks here)

The loop (`ServiceLoop`) wakes when a subscribed message arrives or when the service asked to
run again, and publishes `<process>/health` about once a second, with the keys the process
subscribes and publishes. A sample of the process's main input (a subscription made with
`immediate=True`) runs the step at once in the bus's receive thread instead, when no step is
running: one thread switch less per hop of the loop. SIGTERM and SIGINT stop it; the
liveliness token `gazed/<rig>/alive/<process>/<pid>` is declared once the service is built (so
"alive" means "ready") and vanishes when the session closes. An exception in `step` is logged
and counted; a process whose step fails persistently exits non-zero so the supervisor restarts
it.
"""

from __future__ import annotations

import argparse
import ctypes
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

from gazed.bus import Bus, BusError
from gazed.config import Rig, load_rig_or_exit
from gazed.messages import Health
from gazed.supervisor.child import ENV_SUPERVISOR_PID
from gazed.topics import health as health_topic
from gazed.wakeup import Wakeup

HEALTH_PERIOD_S = 1.0
PR_SET_PDEATHSIG = 1  # linux/prctl.h
MAX_CONSECUTIVE_STEP_FAILURES = 50
STEP_RETRY_S = 0.05  # after a failed step

log = logging.getLogger("gazed.service")


@dataclass(frozen=True)
class Now:
    """The instant a step runs: wall clock for stamps, monotonic for deadlines and intervals.

    `immediate`: the step runs in the bus's receive thread, for a sample of an `immediate`
    subscription (`ServiceLoop`); it should answer that sample and leave slow work (the servo's
    serial polls) to the loop's own steps, which come at the deadline it returns."""

    wall_ns: int
    mono_s: float
    immediate: bool = False

    @classmethod
    def read(cls, immediate: bool = False) -> Now:
        return cls(time.time_ns(), time.monotonic(), immediate)


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
    rig = load_rig_or_exit(parse_args(name, argv).rig)
    stop = StopFlag()
    try:
        with Bus(rig, name) as bus, Wakeup() as wakeup:
            bus.on_arrival(wakeup.notify)
            _install_signals(stop, wakeup)
            return ServiceLoop(name, bus, build(rig, bus), stop, wakeup).run()
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


def _install_signals(stop: StopFlag, wakeup: Wakeup) -> None:
    def on_signal(_signum: int, _frame: object) -> None:
        stop.set()
        wakeup.notify()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)  # the supervisor reloads, not its children


class ServiceLoop:
    """Runs one service's steps, one at a time: in the main thread when `wakeup` wakes it (an
    arrival, a signal, the time the service asked for, health), and — for a sample of a
    subscription made with `immediate=True`, the input the process exists to answer — at once
    in the bus's receive thread, unless a step is running already (then the sample wakes the
    main thread as any other). Only a peer on the rig's private bus steps immediately
    (`Bus.peer`): the wake-up it saves is a thread switch per hop of the loop."""

    def __init__(
        self, name: str, bus: Bus, service: Service, stop: StopFlag, wakeup: Wakeup
    ) -> None:
        self.service = service
        self.stop = stop
        self.wakeup = wakeup
        self.reporter = HealthReporter(name, bus)
        self._bus = bus
        self._lock = threading.Lock()  # held by the one step (or health, or close) running
        self._due_s = 0.0  # monotonic: when the service wants its next step
        self._failures = 0
        self._failed = False
        self._closed = False

    def run(self) -> int:
        """Step until stopped (0), or until the step failed MAX_CONSECUTIVE_STEP_FAILURES times
        in a row (1); close the service either way."""
        # a peer steps immediately: with its own link to each process, a step holds up only
        # its sender's link; a client's one link to the router carries everything, and
        # blocking it in a step (a slow frame, a put that waits) would hold up the router for
        # everyone
        self._bus.on_arrival(self.wakeup.notify, self._step_now if self._bus.peer else None)
        self._bus.declare_alive()
        next_health_s = time.monotonic()
        try:
            stepped_after = -1  # the wake-up count when the loop last stepped
            while not self.stop.is_set():
                wake_s = min(self._due_s, next_health_s)
                self.wakeup.wait(max(0.0, wake_s - time.monotonic()))
                if self.stop.is_set():
                    break
                with self._lock:
                    now = Now.read()
                    # step on news (a sample, a frame, a signal) or when due; a wake-up that
                    # only moved the deadline earlier (`_step_now`) waits for it
                    if self.wakeup.wakeups != stepped_after or now.mono_s >= self._due_s:
                        stepped_after = self.wakeup.wakeups
                        self._step(now)
                    if now.mono_s >= next_health_s:
                        next_health_s = now.mono_s + HEALTH_PERIOD_S
                        self.reporter.publish(self.service.health(), now)
        finally:
            with self._lock:
                self._closed = True
                self.service.close()
        return 1 if self._failed else 0

    def _step_now(self) -> bool:
        """In the receive thread: run the step now if none is running; True if it ran."""
        if not self._lock.acquire(blocking=False):
            return False
        try:
            if self._closed or self.stop.is_set():
                return False
            planned_s = self._due_s  # the main thread may sleep until then
            self._step(Now.read(immediate=True))
            if self._due_s < planned_s or self._failed:
                self.wakeup.reschedule()
            return True
        finally:
            self._lock.release()

    def _step(self, now: Now) -> None:
        try:
            self._due_s = now.mono_s + max(0.0, self.service.step(now))
            self._failures = 0
        except Exception:
            self._failures += 1
            self.reporter.step_errors += 1
            self._due_s = now.mono_s + STEP_RETRY_S
            log.exception("step failed (%d in a row)", self._failures)
            if self._failures >= MAX_CONSECUTIVE_STEP_FAILURES:
                self._failed = True
                self.stop.set()


class HealthReporter:
    """Publishes `<process>/health`: bus counters, the service's report, receive rates per key
    over the last period, and the keys the process subscribes and publishes."""

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
                subscribes=tuple(sorted(self._bus.subscribes)),
                publishes=tuple(sorted(self._bus.publishes)),
            )
        )
