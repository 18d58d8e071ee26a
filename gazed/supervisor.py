"""`gazed run RIG`: start the rig's processes, watch them, restart them, talk to systemd.

- Holds the bus: a router-mode zenoh session on the rig's `[bus] listen` endpoints (or a client
  of an external router when `[bus] router = false`).
- Starts every enabled process in `[services]` as `python -m <module> --rig RIG` in its own
  session (terminal signals reach only the supervisor; children die with it, see
  services/runtime.py). A process is up when its liveliness token `gazed/<rig>/alive/<name>`
  appears; a process whose module is not installed is reported as missing and skipped.
- Restarts a process that exits, or whose token vanishes while it still runs (frozen: killed
  first), after a backoff of 0.5 s doubling to 10 s (`[services] backoff_*`). More than
  `restart_max` restarts of one process within `restart_window_s` -> stop everything, exit 1,
  and let systemd take over.
- systemd: `READY=1` once every enabled process is up, `WATCHDOG=1` from this loop at half of
  `WATCHDOG_USEC` while healthy, `STATUS=` on changes, `STOPPING=1` on stop.
- SIGTERM/SIGINT: orderly stop (SIGTERM to children, SIGKILL after `stop_grace_s`).
  SIGHUP: re-read the rig; an invalid one is reported and the old one kept; a valid one
  restarts only the processes whose sections changed.
- Publishes `gazed/<rig>/supervisor/status` once a second and on every change.
- Shows the loop (`console.LiveStatus`): a live status line in a terminal; under systemd a log
  line per gaze state change.
"""

from __future__ import annotations

import argparse
import contextlib
import enum
import importlib.util
import logging
import os
import signal
import socket
import subprocess
import sys
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

from gazed.bus import Bus, BusError
from gazed.config import SERVICE_NAMES, Rig, RigError, ServiceSpec, load_rig, sections_read_by
from gazed.console import REFRESH_S, LiveStatus
from gazed.messages import ProcessStatus, SupervisorStatus
from gazed.sdnotify import Notifier
from gazed.topics import SUPERVISOR_STATUS

log = logging.getLogger("gazed.supervisor")

STATUS_PERIOD_S = 1.0
EXIT_GRACE_S = 0.5  # a token can vanish just before its process's exit is seen
IDLE_WAKE_S = 0.25
ENV_SUPERVISOR_PID = "GAZED_SUPERVISOR_PID"
ENV_PROCESS = "GAZED_PROCESS"


class GiveUp(Exception):
    """A process exceeded the restart intensity."""


class State(enum.StrEnum):
    STARTING = "starting"  # spawned, waiting for its liveliness token
    RUNNING = "running"
    BACKOFF = "backoff"  # exited, waiting to be restarted
    STOPPED = "stopped"
    MISSING = "missing"  # module not installed
    DISABLED = "disabled"


@dataclass
class Child:
    """One supervised process and its restart bookkeeping (monotonic seconds)."""

    name: str
    module: str
    state: State = State.STOPPED
    popen: subprocess.Popen[bytes] | None = None
    alive: bool = False
    lost_s: float = 0.0  # when its token vanished
    started_s: float = 0.0
    up_s: float = 0.0
    restart_at_s: float = 0.0
    backoff_s: float = 0.0
    restarts: int = 0
    restart_times_s: deque[float] = field(default_factory=deque)
    last_exit: int | None = None
    message: str = ""

    @property
    def pid(self) -> int | None:
        return self.popen.pid if self.popen is not None else None

    def status(self) -> ProcessStatus:
        return ProcessStatus(
            name=self.name,
            state=self.state.value,
            pid=self.pid if self.state in (State.STARTING, State.RUNNING) else None,
            alive=self.alive,
            restarts=self.restarts,
            last_exit=self.last_exit,
            message=self.message,
        )


def module_of(name: str, spec: ServiceSpec) -> str:
    return spec.module or f"services.{name}"


class Supervisor:
    """The supervisor's state machine; `step(now_s)` is its loop body."""

    def __init__(self, rig_path: Path, rig: Rig, bus: Bus, notifier: Notifier) -> None:
        self.rig_path = rig_path
        self.rig = rig
        self.bus = bus
        self.notifier = notifier
        self.children: dict[str, Child] = {}
        self.ready_sent = False
        self.stopping = False
        self._status_publisher = bus.publisher(SUPERVISOR_STATUS)
        self._next_status_s = 0.0
        self._next_watchdog_s = 0.0
        self._changed = True
        bus.watch_alive(self._on_alive)

    # -- lifecycle -------------------------------------------------------------------------

    def start(self, now_s: float) -> None:
        for name in SERVICE_NAMES:
            self._start_child(name, now_s)

    def _start_child(self, name: str, now_s: float) -> None:
        spec = self.rig.services.spec(name)
        child = self.children.get(name) or Child(name, module_of(name, spec))
        child.module = module_of(name, spec)
        self.children[name] = child
        if not spec.enabled:
            child.state, child.message = State.DISABLED, "disabled in the rig"
            return
        if _find_module(child.module) is None:
            child.state, child.message = State.MISSING, f"not installed ({child.module} not found)"
            log.warning("%s: %s", name, child.message)
            return
        self._spawn(child, now_s)

    def _spawn(self, child: Child, now_s: float) -> None:
        env = dict(os.environ, **{ENV_SUPERVISOR_PID: str(os.getpid()), ENV_PROCESS: child.name})
        # pydantic looks for plugins through every installed package's metadata at import:
        # none are used, and skipping the search takes ~0.1 s off every (re)start
        env.setdefault("PYDANTIC_DISABLE_PLUGINS", "__all__")
        command = [sys.executable, "-m", child.module, "--rig", str(self.rig_path)]
        child.popen = subprocess.Popen(command, env=env, start_new_session=True)
        child.state = State.STARTING
        child.started_s = now_s
        child.message = f"started (pid {child.popen.pid})"
        log.info("%s: %s", child.name, child.message)
        self._changed = True

    def stop(self) -> None:
        """Stop the children in the reverse of their start order (gaze first, so no new demand;
        servo before sim, so the head can park on its line), each SIGTERM then SIGKILL after
        the grace period; reap all."""
        self.stopping = True
        for child in reversed(list(self.children.values())):
            if child.popen is None or child.popen.poll() is not None:
                continue
            _signal(child, signal.SIGTERM)
            try:
                child.popen.wait(timeout=self.rig.services.stop_grace_s)
            except subprocess.TimeoutExpired:
                log.warning(
                    "%s: no exit %.1f s after SIGTERM, killing",
                    child.name,
                    self.rig.services.stop_grace_s,
                )
                _signal(child, signal.SIGKILL)
                child.popen.wait()
        for child in self.children.values():
            if child.state in (State.STARTING, State.RUNNING, State.BACKOFF):
                child.state, child.alive = State.STOPPED, False
                child.last_exit = child.popen.returncode if child.popen is not None else None
        self._changed = True

    # -- the loop body ---------------------------------------------------------------------

    def step(self, now_s: float) -> float:
        """Reap, restart, check readiness, notify systemd, publish status. Returns seconds until
        it wants to run again. Raises GiveUp when a process exceeds the restart intensity."""
        for child in self.children.values():
            self._check(child, now_s)
        if not self.ready_sent and self._all_up():
            self.ready_sent = True
            self.notifier.ready(self._summary())
            log.info("ready: %s", self._summary())
        if self.notifier.watchdog_interval_s is not None and now_s >= self._next_watchdog_s:
            self.notifier.watchdog()
            self._next_watchdog_s = now_s + self.notifier.watchdog_interval_s
        if self._changed or now_s >= self._next_status_s:
            if self._changed and self.ready_sent:
                self.notifier.status(self._summary())
            self._changed = False
            self._next_status_s = now_s + STATUS_PERIOD_S
            self.publish_status("running" if self.ready_sent else "starting")
        return self._next_wake_s(now_s)

    def _check(self, child: Child, now_s: float) -> None:
        services = self.rig.services
        if child.state in (State.STARTING, State.RUNNING) and child.popen is not None:
            code = child.popen.poll()
            if code is not None:
                self._exited(child, code, f"exited with {_describe_exit(code)}", now_s)
            elif child.state == State.STARTING and child.alive:
                child.state, child.up_s, child.message = State.RUNNING, now_s, "running"
                log.info("%s: up after %.2f s", child.name, now_s - child.started_s)
                self._changed = True
            elif (
                child.state == State.STARTING and now_s - child.started_s > services.ready_timeout_s
            ):
                _signal(child, signal.SIGKILL)
                child.popen.wait()
                self._exited(
                    child, child.popen.returncode, "no liveliness within ready_timeout_s", now_s
                )
            elif (
                child.state == State.RUNNING
                and not child.alive
                and now_s - child.lost_s > EXIT_GRACE_S
                and self._router_reachable()
            ):
                _signal(child, signal.SIGKILL)  # frozen: its lease expired
                child.popen.wait()
                self._exited(child, child.popen.returncode, "liveliness lost (frozen?)", now_s)
            elif (
                child.state == State.RUNNING
                and child.backoff_s
                and now_s - child.up_s > services.backoff_max_s
            ):
                child.backoff_s = 0.0  # stable again: the next failure restarts quickly
        if child.state == State.BACKOFF and now_s >= child.restart_at_s and not self.stopping:
            child.restarts += 1
            self._spawn(child, now_s)

    def _exited(self, child: Child, code: int, why: str, now_s: float) -> None:
        services = self.rig.services
        child.last_exit, child.alive = code, False
        window = child.restart_times_s
        window.append(now_s)
        while window and now_s - window[0] > services.restart_window_s:
            window.popleft()
        if len(window) > services.restart_max:
            child.state = State.STOPPED
            child.message = (
                f"{why}; {len(window)} failures in {services.restart_window_s:g} s: giving up"
            )
            self._changed = True
            raise GiveUp(f"{child.name}: {child.message}")
        child.backoff_s = (
            services.backoff_initial_s
            if not child.backoff_s
            else min(2 * child.backoff_s, services.backoff_max_s)
        )
        child.state = State.BACKOFF
        child.restart_at_s = now_s + child.backoff_s
        child.message = f"{why}; restarting in {child.backoff_s:g} s"
        log.warning("%s: %s", child.name, child.message)
        self._changed = True

    def _on_alive(self, name: str, alive: bool) -> None:
        child = self.children.get(name)
        if child is not None:
            child.alive = alive
            if not alive:
                child.lost_s = time.monotonic()
            self._changed = True

    def _router_reachable(self) -> bool:
        """Hosting the router, or connected to one: only then does a vanished token mean a
        frozen process (with the router gone, every token vanishes and nothing is frozen)."""
        return self.rig.bus.router or bool(self.bus.session.info.routers_zid())

    def up(self) -> tuple[int, int]:
        """(processes running, processes enabled and installed)."""
        expected = [
            c for c in self.children.values() if c.state not in (State.MISSING, State.DISABLED)
        ]
        return sum(1 for c in expected if c.state == State.RUNNING), len(expected)

    def _all_up(self) -> bool:
        return all(
            c.state in (State.RUNNING, State.MISSING, State.DISABLED)
            for c in self.children.values()
        )

    def _next_wake_s(self, now_s: float) -> float:
        deadlines = [self._next_status_s, now_s + IDLE_WAKE_S]
        if self.notifier.watchdog_interval_s is not None:
            deadlines.append(self._next_watchdog_s)
        deadlines += [c.restart_at_s for c in self.children.values() if c.state == State.BACKOFF]
        return max(0.0, min(deadlines) - now_s)

    # -- reload ------------------------------------------------------------------------------

    def reload(self, now_s: float) -> bool:
        """SIGHUP: re-read the rig. Invalid -> keep the old one (False). Valid -> restart the
        processes whose sections changed, start newly enabled ones, stop disabled ones."""
        try:
            new = load_rig(self.rig_path)
        except RigError as exc:
            message = f"reload failed, keeping the running rig: {exc.problems[0]}"
            log.error("%s", "\n".join(["reload failed, keeping the running rig:", *exc.problems]))
            self.notifier.status(message)
            self.publish_status("running", message)
            return False
        if new.rig != self.rig.rig or new.bus != self.rig.bus:
            log.error(
                "reload: [rig] and [bus] changes need a restart of gazed run; keeping the running rig"
            )
            self.notifier.status("reload refused: [rig]/[bus] changed (restart gazed run)")
            return False
        changed = [name for name in SERVICE_NAMES if _process_changed(name, self.rig, new)]
        self.rig = new
        for name in changed:
            child = self.children[name]
            if child.popen is not None and child.popen.poll() is None:
                _signal(child, signal.SIGTERM)
                try:
                    child.popen.wait(timeout=new.services.stop_grace_s)
                except subprocess.TimeoutExpired:
                    _signal(child, signal.SIGKILL)
                    child.popen.wait()
            child.alive, child.backoff_s = False, 0.0
            child.restart_times_s.clear()
            self._start_child(name, now_s)
        log.info("reloaded %s: restarted %s", self.rig_path, ", ".join(changed) or "nothing")
        self.notifier.status(f"reloaded; restarted {', '.join(changed) or 'nothing'}")
        self._changed = True
        return True

    # -- reporting ---------------------------------------------------------------------------

    def _summary(self) -> str:
        parts = [f"{c.name} {c.state.value}" for c in self.children.values()]
        return f"rig {self.rig.name}: " + ", ".join(parts)

    def publish_status(self, state: str, message: str = "") -> None:
        status = SupervisorStatus(
            t_capture_ns=time.time_ns(),
            state=state,
            host=socket.gethostname(),
            rig_path=str(self.rig_path),
            processes=tuple(c.status() for c in self.children.values()),
            message=message,
        )
        self._status_publisher.put(status)


def _process_changed(name: str, old: Rig, new: Rig) -> bool:
    if old.services.spec(name) != new.services.spec(name):
        return True
    sections = sections_read_by(name)
    if sections is None:
        return old != new
    return any(getattr(old, s) != getattr(new, s) for s in sections)


def _find_module(module: str) -> object | None:
    try:
        return importlib.util.find_spec(module)
    except (ImportError, ValueError):
        return None


def _signal(child: Child, signum: int) -> None:
    if child.popen is not None and child.popen.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(child.popen.pid, signum)  # the child leads its own process group


def _describe_exit(code: int) -> str:
    if code < 0:
        return f"signal {signal.Signals(-code).name}"
    return f"code {code}"


# -- the command -----------------------------------------------------------------------------


def run_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("rig", type=Path, help="rig description (TOML), e.g. configs/sim.toml")
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")


def run_command(args: argparse.Namespace) -> int:
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    try:
        rig = load_rig(args.rig)
    except RigError as exc:
        print(exc, file=sys.stderr)
        return 2
    notifier = Notifier()
    try:
        with Bus(rig, "supervisor", router=rig.bus.router) as bus:
            flags = _install_signals(bus)
            supervisor = Supervisor(args.rig.resolve(), rig, bus, notifier)
            status = LiveStatus(bus)
            try:
                return _loop(supervisor, bus, notifier, flags, status)
            finally:
                status.close()
    except BusError as exc:
        print(f"gazed run: {exc}", file=sys.stderr)
        return 1
    finally:
        notifier.close()


def _install_signals(bus: Bus) -> set[str]:
    """SIGTERM/SIGINT -> "stop", SIGHUP -> "hup"; every signal (SIGCHLD too) wakes the loop."""
    flags: set[str] = set()

    def on_signal(signum: int, _frame: object) -> None:
        if signum != signal.SIGCHLD:
            flags.add("hup" if signum == signal.SIGHUP else "stop")
        bus.notify()

    for signum in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGCHLD):
        signal.signal(signum, on_signal)
    return flags


def _loop(
    supervisor: Supervisor, bus: Bus, notifier: Notifier, flags: set[str], status: LiveStatus
) -> int:
    code = 0
    try:
        supervisor.start(time.monotonic())
        while "stop" not in flags:
            if "hup" in flags:
                flags.discard("hup")
                supervisor.reload(time.monotonic())
            wait_s = supervisor.step(time.monotonic())
            status.refresh(time.monotonic(), *supervisor.up())
            bus.wait(min(wait_s, REFRESH_S))
    except GiveUp as exc:
        log.error("%s", exc)
        notifier.status(f"failed: {exc}")
        code = 1
    finally:
        notifier.stopping("stopping")
        supervisor.stop()
        supervisor.publish_status("failed" if code else "stopping")
        log.info("stopped")
    return code
