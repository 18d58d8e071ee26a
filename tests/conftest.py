"""Shared test helpers: waiting on conditions, private bus endpoints, rig files."""

from __future__ import annotations

import os
import socket
import sys
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import pytest

T = TypeVar("T")

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"
SUPPORT = Path(__file__).resolve().parent / "support"


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


@pytest.fixture
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.skip(
            f"{SHARED_DATA} is absent (the shared data sits beside the repository only in CI)"
        )
    return SHARED_DATA
