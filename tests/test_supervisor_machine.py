"""The supervisor's state machine without processes: restart delays that double from
`backoff_initial_s` to `backoff_max_s` and start over once a process runs stably, giving up past
the restart intensity, and the processes a reloaded rig restarts (from the sections
`gazed.topics.PROCESSES` declares each reads)."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from gazed.config import SERVICE_NAMES, Rig, parse_rig
from gazed.sdnotify import Notifier
from gazed.supervisor.child import Child, State
from gazed.supervisor.machine import EXIT_GRACE_S, GiveUp, Supervisor
from gazed.supervisor.reload import processes_to_restart


class FakePopen:
    """A child process that runs until the test sets its exit code."""

    pids = iter(range(1000, 100000))

    def __init__(self) -> None:
        self.pid = next(self.pids)
        self.returncode: int | None = None

    def poll(self) -> int | None:
        return self.returncode

    def wait(self, timeout: float | None = None) -> int | None:
        return self.returncode


class Sent:
    def __init__(self) -> None:
        self.sent: list[Any] = []

    def put(self, message: Any) -> None:
        self.sent.append(message)


class StandInBus:
    """What the supervisor uses of its bus: a status publisher and liveliness changes."""

    def __init__(self) -> None:
        self.status = Sent()
        self.on_alive: Callable[[str, int, bool], None] | None = None

    def publisher(self, topic: Any) -> Sent:
        return self.status

    def watch_alive(self, callback: Callable[[str, int, bool], None]) -> None:
        self.on_alive = callback


def token(supervisor: Supervisor, name: str, pid: int, alive: bool) -> None:
    """The liveliness token of `name`'s run `pid` appears (or vanishes)."""
    supervisor.bus.on_alive(name, pid, alive)  # type: ignore[attr-defined]


def pid_of(supervisor: Supervisor, name: str) -> int:
    popen = supervisor.children[name].popen
    assert popen is not None
    return popen.pid


def rig(services: str = "") -> Rig:
    return parse_rig(f'[rig]\nname = "t"\n[services]\n{services}\n', "rig.toml")


@pytest.fixture
def supervisor(monkeypatch: pytest.MonkeyPatch) -> Supervisor:
    monkeypatch.setattr(
        Child, "spawn", lambda child, rig_path: setattr(child, "popen", FakePopen())
    )
    monkeypatch.setattr(Child, "signal", lambda child, signum: None)  # no real process to signal
    policy = (
        "backoff_initial_s = 0.5\nbackoff_max_s = 3.0\nrestart_max = 6\n"
        "restart_window_s = 1000\nready_timeout_s = 600"
    )
    running = Supervisor(
        Path("rig.toml"),
        rig(policy),
        StandInBus(),  # type: ignore[arg-type]
        Notifier({}),
    )
    running.start(0.0)
    return running


def crash(supervisor: Supervisor, name: str, now_s: float) -> float:
    """Let `name` exit with 3 at `now_s`; the delay before its restart."""
    child = supervisor.children[name]
    assert child.popen is not None and child.state in (State.STARTING, State.RUNNING)
    child.popen.returncode = 3
    supervisor.step(now_s)
    assert child.state == State.BACKOFF and child.message.startswith("exited with code 3")
    delay_s = child.restart_at_s - now_s
    supervisor.step(child.restart_at_s)
    assert child.state == State.STARTING
    return delay_s


def test_restart_delays_double_up_to_the_maximum(supervisor: Supervisor) -> None:
    assert set(supervisor.children) == set(SERVICE_NAMES)
    now_s, delays = 1.0, []
    for _ in range(5):
        delays.append(crash(supervisor, "gaze", now_s))
        now_s += 10.0
    assert delays == pytest.approx([0.5, 1.0, 2.0, 3.0, 3.0])
    assert supervisor.children["gaze"].restarts == 5
    assert all(supervisor.children[n].restarts == 0 for n in SERVICE_NAMES if n != "gaze")


def test_a_process_running_stably_restarts_quickly_again(supervisor: Supervisor) -> None:
    assert [crash(supervisor, "vision", t) for t in (1.0, 2.0)] == pytest.approx([0.5, 1.0])
    token(supervisor, "vision", pid_of(supervisor, "vision"), True)
    supervisor.step(5.0)
    assert supervisor.children["vision"].state == State.RUNNING
    supervisor.step(5.0 + 3.0 + 0.1)  # up for longer than backoff_max_s
    assert crash(supervisor, "vision", 9.0) == pytest.approx(0.5)


def sigkill(supervisor: Supervisor, name: str, now_s: float) -> int:
    """`name` killed, seen at `now_s` and waiting to restart; the dead run's pid."""
    dead_pid = pid_of(supervisor, name)
    supervisor.children[name].popen.returncode = -9  # type: ignore[union-attr]
    supervisor.step(now_s)
    assert supervisor.children[name].state == State.BACKOFF
    return dead_pid


def test_a_dead_processs_token_seen_late_does_not_make_its_restart_running(
    supervisor: Supervisor,
) -> None:
    vision = supervisor.children["vision"]
    dead_pid = sigkill(supervisor, "vision", 1.0)
    token(supervisor, "vision", dead_pid, True)  # late, during the back-off
    supervisor.step(vision.restart_at_s)
    token(supervisor, "vision", dead_pid, True)  # late, after the restart
    supervisor.step(vision.restart_at_s + 0.01)
    assert vision.state == State.STARTING
    token(supervisor, "vision", pid_of(supervisor, "vision"), True)  # the new process's
    supervisor.step(vision.restart_at_s + 0.02)
    assert vision.state == State.RUNNING


def test_a_dead_processs_token_vanishing_late_does_not_kill_its_restart(
    supervisor: Supervisor,
) -> None:
    vision = supervisor.children["vision"]
    dead_pid = sigkill(supervisor, "vision", time.monotonic())
    supervisor.step(vision.restart_at_s)
    restarted_pid = pid_of(supervisor, "vision")
    token(supervisor, "vision", restarted_pid, True)
    supervisor.step(vision.restart_at_s + 0.01)
    assert vision.state == State.RUNNING
    token(supervisor, "vision", dead_pid, False)  # the dead run's token, gone late
    supervisor.step(time.monotonic() + 2 * EXIT_GRACE_S)
    assert vision.state == State.RUNNING and pid_of(supervisor, "vision") == restarted_pid
    token(supervisor, "vision", restarted_pid, False)  # its own: frozen, killed, restarted
    supervisor.step(time.monotonic() + 2 * EXIT_GRACE_S)
    assert vision.state == State.BACKOFF and vision.message.startswith("liveliness lost")


def test_it_gives_up_past_the_restart_intensity(supervisor: Supervisor) -> None:
    for k in range(6):
        crash(supervisor, "servo", 1.0 + 10.0 * k)
    supervisor.children["servo"].popen.returncode = 3  # type: ignore[union-attr]
    with pytest.raises(GiveUp, match="servo: exited with code 3; 7 failures in 1000 s"):
        supervisor.step(100.0)


@pytest.mark.parametrize(
    ("change", "restarted"),
    [
        ("[vision]\nfovea_deg = 8.0\n", ["vision"]),
        ("[estimator]\nfilter = 'alphabeta'\n", ["estimator"]),
        ("[gaze]\nrate_hz = 30.0\n", ["gaze"]),
        ("[servo]\nprotocol = 'visca'\n", ["sim", "servo", "vision"]),
        (
            "[calibration]\ntarget_height_m = 0.0\ncamera_xyz_m = [0, 0, 3]\n",
            ["sim", "estimator", "gaze"],
        ),
        ("[head]\npan_max_deg = 100.0\n", list(SERVICE_NAMES)),
        ("[sim]\nseed = 7\n", ["sim"]),
        ("[services.gaze]\nenabled = false\n", ["gaze"]),
        ("[services]\nrestart_max = 9\n", []),
        ("", []),
    ],
)
def test_a_reload_restarts_the_processes_that_read_what_changed(
    change: str, restarted: list[str]
) -> None:
    old = parse_rig('[rig]\nname = "t"\n', "rig.toml")
    new = parse_rig(f'[rig]\nname = "t"\n{change}', "rig.toml")
    assert processes_to_restart(old, new) == restarted
