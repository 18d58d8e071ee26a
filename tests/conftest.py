"""Shared test helpers: waiting on conditions, private bus endpoints, rig files."""

from __future__ import annotations

import gc
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import pytest

# The project's modules and the tests rewritten for their asserts are compiled once and kept in
# the ignored __pycache__ folders, even where the environment asks Python to write no bytecode:
# compiling them and rewriting the tests' asserts again on every run is most of what collecting
# costs. Set before the project's first import.
sys.dont_write_bytecode = False

from gazed.bus import Bus  # noqa: E402
from gazed.config import load_rig  # noqa: E402
from gazed.messages import SupervisorStatus  # noqa: E402
from gazed.topics import SUPERVISOR_STATUS  # noqa: E402
from gazed.wakeup import Wakeup  # noqa: E402

T = TypeVar("T")

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"
SUPPORT = Path(__file__).resolve().parent / "support"


def pytest_collection_finish(session: pytest.Session) -> None:
    """What the collection imported lives until the session ends: frozen out of the garbage
    collector (after a pass that frees what is already garbage), whose full passes would
    otherwise walk all of it again during the tests."""
    gc.collect()
    gc.freeze()


def poll_until(predicate: Callable[[], T], timeout_s: float, interval_s: float = 0.01) -> T:
    """Return the first truthy value of `predicate()`; fail the test after `timeout_s`."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"condition not met within {timeout_s} s: {predicate}")
        time.sleep(interval_s)


def free_tcp_port() -> int:
    """A loopback port nobody listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def unique_rig_name(prefix: str = "t") -> str:
    return f"{prefix}{uuid.uuid4().hex[:10]}"


def write_rig(
    directory: Path, body: str = "", *, name: str | None = None, port: int | None = None
) -> Path:
    """A rig file with its own name and loopback port; `body` adds sections after [rig]/[bus]."""
    name = name or unique_rig_name()
    port = port or free_tcp_port()
    path = directory / f"{name}.toml"
    path.write_text(f'[rig]\nname = "{name}"\n\n[bus]\nlisten = ["tcp/127.0.0.1:{port}"]\n\n{body}')
    return path


def child_env(**extra: str) -> dict[str, str]:
    """Environment for subprocesses: the test support modules importable, zenoh quiet."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(SUPPORT), str(REPO), env.get("PYTHONPATH", "")]
    ).rstrip(os.pathsep)
    env.setdefault("RUST_LOG", "error")
    env.update(extra)
    return env


PYTHON = sys.executable


def start_service(name: str, rig_path: Path) -> subprocess.Popen[str]:
    """The real entry point `python -m services.NAME --rig RIG`, its stdout and stderr together
    on one text pipe."""
    return subprocess.Popen(
        [PYTHON, "-m", f"services.{name}", "--rig", str(rig_path)],
        cwd=REPO,
        env=child_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


@pytest.fixture
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.skip(
            f"{SHARED_DATA} is absent (the shared data sits beside the repository only in CI)"
        )
    return SHARED_DATA


class NotifySocket:
    """A fake systemd: collects the datagrams a process sends to $NOTIFY_SOCKET."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.messages: list[str] = []
        self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self._sock.bind(str(path))
        self._sock.settimeout(0.2)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        while not self._stop.is_set():
            try:
                data = self._sock.recv(4096)
            except OSError:
                continue
            self.messages.extend(data.decode().split("\n"))

    def count(self, line: str) -> int:
        return sum(1 for m in list(self.messages) if m == line)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self._sock.close()


def pid_alive(pid: int) -> bool:
    """True if the process exists and is not a zombie."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(") ", 1)[1][0] != "Z"
    except (FileNotFoundError, ProcessLookupError):
        return False


FAKE = "".join(
    f'[services.{name}]\nmodule = "fake_process"\n\n'
    for name in ("sim", "servo", "vision", "estimator", "gaze")
)


class RunningSupervisor:
    """`gazed run RIG` as a subprocess, with a fake NOTIFY_SOCKET and a bus observer."""

    def __init__(self, rig_path: Path, tmp_path: Path, **env: str) -> None:
        self.rig_path = rig_path
        self.rig = load_rig(rig_path)
        self.notify = NotifySocket(tmp_path / "notify.sock")
        self.process = subprocess.Popen(
            [PYTHON, "-m", "gazed.cli", "run", str(rig_path)],
            env=child_env(NOTIFY_SOCKET=str(self.notify.path), **env),
            stderr=subprocess.PIPE,
            text=True,
        )
        self.stderr: list[str] = []
        self._reader = threading.Thread(
            target=lambda: self.stderr.extend(self.process.stderr), daemon=True
        )
        self._reader.start()
        self.alive_events: list[tuple[float, str, int, bool]] = []
        self.statuses: list[SupervisorStatus] = []
        self.bus = Bus(self.rig, "observer")
        self.wakeup = Wakeup()  # every arrival on the observer's bus wakes it
        self.bus.on_arrival(self.wakeup.notify)
        try:
            poll_until(self._connect, 20.0, 0.05)
        except BaseException:  # no caller holds us to stop: leave no `gazed run` behind
            self.process.kill()
            self.stop()
            raise
        self.bus.watch_alive(
            lambda name, pid, alive: self.alive_events.append((time.monotonic(), name, pid, alive))
        )
        self._status = self.bus.subscribe(SUPERVISOR_STATUS)

    def _connect(self) -> bool:
        assert self.process.poll() is None, "".join(self.stderr)
        try:
            self.bus.open()
        except ConnectionError:
            return False
        return True

    def status(self) -> SupervisorStatus | None:
        """The newest supervisor/status seen (None before the first)."""
        self.statuses.extend(self._status.take())
        return self.statuses[-1] if self.statuses else None

    def pids(self) -> dict[str, int]:
        """Pids of the running processes, once every process reported running has one."""

        def complete() -> SupervisorStatus | None:
            status = self.status()
            if status and all(p.pid for p in status.processes if p.state == "running"):
                return status
            return None

        status = poll_until(complete, 10.0)
        return {p.name: p.pid for p in status.processes if p.pid is not None}

    def back_after(self, name: str, old_pid: int, since_s: float) -> float | None:
        """When the liveliness token of a run of `name` other than `old_pid` appeared after
        `since_s` (monotonic); None before then."""
        for t, n, pid, alive in list(self.alive_events):
            if n == name and pid != old_pid and alive and t > since_s:
                return t
        return None

    def wait_ready(self, timeout_s: float = 30.0) -> None:
        poll_until(lambda: self.notify.count("READY=1") >= 1, timeout_s)

    def stop(self) -> int:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
        try:
            return self.process.wait(timeout=30)
        finally:
            self.bus.close()
            self.wakeup.close()
            self.notify.close()
