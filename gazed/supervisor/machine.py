"""The supervisor's state machine: start the rig's processes, notice exits and frozen ones,
restart them after a backoff, give up past the restart intensity, report to systemd and the
bus, and apply a reloaded rig."""

from __future__ import annotations

import logging
import socket
import time
from pathlib import Path

from gazed.backoff import Backoff
from gazed.bus import Bus
from gazed.config import SERVICE_NAMES, Rig, RigError, load_rig
from gazed.messages import SupervisorStatus
from gazed.sdnotify import Notifier
from gazed.supervisor.child import Child, State, describe_exit, installed, module_of
from gazed.supervisor.reload import processes_to_restart
from gazed.topics import SUPERVISOR_STATUS

log = logging.getLogger("gazed.supervisor")

VIEW = "view"  # the live view's process: `gazed.view.view_cli` under the supervisor
VIEW_MODULE = "gazed.view.view_cli"
STATUS_PERIOD_S = 1.0
EXIT_GRACE_S = 0.5  # a token can vanish just before its process's exit is seen
IDLE_WAKE_S = 0.25


class GiveUp(Exception):
    """A process exceeded the restart intensity."""


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
        self._start_view(now_s)

    def _start_view(self, now_s: float) -> None:
        """The live view (`[view]`), supervised like the rig's processes: a bus client in a
        process of its own, so that serving browsers never takes the loop's CPU time."""
        if not self.rig.serves_view:
            self.children.pop(VIEW, None)
            return
        child = self.children.get(VIEW) or Child(VIEW, VIEW_MODULE)
        self.children[VIEW] = child
        self._spawn(child, now_s)

    def _start_child(self, name: str, now_s: float) -> None:
        spec = self.rig.services.spec(name)
        child = self.children.get(name) or Child(name, module_of(name, spec))
        child.module = module_of(name, spec)
        self.children[name] = child
        if not spec.enabled:
            child.state, child.message = State.DISABLED, "disabled in the rig"
            return
        if not installed(child.module):
            child.state, child.message = State.MISSING, f"not installed ({child.module} not found)"
            log.warning("%s: %s", name, child.message)
            return
        self._spawn(child, now_s)

    def _spawn(self, child: Child, now_s: float) -> None:
        child.alive = False  # only the token of the run about to start says it is up
        child.spawn(self.rig_path)
        assert child.popen is not None
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
            if not child.terminate(self.rig.services.stop_grace_s):
                log.warning(
                    "%s: no exit %.1f s after SIGTERM, killed",
                    child.name,
                    self.rig.services.stop_grace_s,
                )
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
                self._exited(child, code, f"exited with {describe_exit(code)}", now_s)
            elif child.state == State.STARTING and child.alive:
                child.state, child.up_s, child.message = State.RUNNING, now_s, "running"
                log.info("%s: up after %.2f s", child.name, now_s - child.started_s)
                self._changed = True
            elif (
                child.state == State.STARTING and now_s - child.started_s > services.ready_timeout_s
            ):
                child.kill()
                self._exited(
                    child, child.popen.returncode, "no liveliness within ready_timeout_s", now_s
                )
            elif (
                child.state == State.RUNNING
                and not child.alive
                and now_s - child.lost_s > EXIT_GRACE_S
                and self._router_reachable()
            ):
                child.kill()  # frozen: its lease expired
                self._exited(child, child.popen.returncode, "liveliness lost (frozen?)", now_s)
            elif (
                child.state == State.RUNNING
                and child.backoff is not None
                and now_s - child.up_s > services.backoff_max_s
            ):
                child.backoff = None  # stable again: the next failure restarts quickly
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
        if child.backoff is None:
            child.backoff = Backoff(services.backoff_initial_s, services.backoff_max_s)
        delay_s = child.backoff.next_delay_s()
        child.state = State.BACKOFF
        child.restart_at_s = now_s + delay_s
        child.message = f"{why}; restarting in {delay_s:g} s"
        log.warning("%s: %s", child.name, child.message)
        self._changed = True

    def _on_alive(self, name: str, pid: int, alive: bool) -> None:
        """A token of `name`'s run `pid` appeared or vanished. Only the running child's own
        token counts: one of a run that has died, arriving late, says nothing of its restart."""
        child = self.children.get(name)
        if child is not None and child.popen is not None and child.popen.pid == pid:
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
                "reload: [rig] and [bus] changes need a restart of gazed run; "
                "keeping the running rig"
            )
            self.notifier.status("reload refused: [rig]/[bus] changed (restart gazed run)")
            return False
        changed = processes_to_restart(self.rig, new)
        view_changed = (new.serves_view, new.view) != (self.rig.serves_view, self.rig.view)
        self.rig = new
        for name in changed:
            child = self.children[name]
            if child.popen is not None and child.popen.poll() is None:
                child.terminate(new.services.stop_grace_s)
            child.alive, child.backoff = False, None
            child.restart_times_s.clear()
            self._start_child(name, now_s)
        if view_changed:
            self._restart_view(now_s)
            changed.append(VIEW)
        log.info("reloaded %s: restarted %s", self.rig_path, ", ".join(changed) or "nothing")
        self.notifier.status(f"reloaded; restarted {', '.join(changed) or 'nothing'}")
        self._changed = True
        return True

    def _restart_view(self, now_s: float) -> None:
        child = self.children.get(VIEW)
        if child is not None and child.popen is not None and child.popen.poll() is None:
            child.terminate(self.rig.services.stop_grace_s)
        if child is not None:
            child.alive, child.backoff, child.state = False, None, State.STOPPED
            child.restart_times_s.clear()
        self._start_view(now_s)

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
