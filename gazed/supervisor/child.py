"""One supervised process: its state, its restart bookkeeping, and starting and signalling it."""

from __future__ import annotations

import contextlib
import enum
import importlib.util
import os
import signal
import subprocess
import sys
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

from gazed.backoff import Backoff
from gazed.config import ServiceSpec
from gazed.messages import ProcessStatus

ENV_SUPERVISOR_PID = "GAZED_SUPERVISOR_PID"
ENV_PROCESS = "GAZED_PROCESS"


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
    backoff: Backoff | None = None  # the restart delays since it last ran stably
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

    def spawn(self, rig_path: Path) -> None:
        """Start `python -m MODULE --rig RIG` in its own session, told who supervises it."""
        env = dict(os.environ, **{ENV_SUPERVISOR_PID: str(os.getpid()), ENV_PROCESS: self.name})
        # pydantic looks for plugins through every installed package's metadata at import:
        # none are used, and skipping the search shortens every (re)start
        env.setdefault("PYDANTIC_DISABLE_PLUGINS", "__all__")
        command = [sys.executable, "-m", self.module, "--rig", str(rig_path)]
        self.popen = subprocess.Popen(command, env=env, start_new_session=True)

    def signal(self, signum: int) -> None:
        """Signal its process group, if it still runs (the child leads its own group)."""
        if self.popen is not None and self.popen.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.popen.pid, signum)

    def terminate(self, grace_s: float) -> bool:
        """SIGTERM, then SIGKILL if it has not exited after `grace_s`; reaped either way.
        False if it had to be killed."""
        assert self.popen is not None
        self.signal(signal.SIGTERM)
        try:
            self.popen.wait(timeout=grace_s)
        except subprocess.TimeoutExpired:
            self.kill()
            return False
        return True

    def kill(self) -> None:
        """SIGKILL and reap."""
        assert self.popen is not None
        self.signal(signal.SIGKILL)
        self.popen.wait()


def module_of(name: str, spec: ServiceSpec) -> str:
    return spec.module or f"services.{name}"


def installed(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def describe_exit(code: int) -> str:
    if code < 0:
        return f"signal {signal.Signals(-code).name}"
    return f"code {code}"
