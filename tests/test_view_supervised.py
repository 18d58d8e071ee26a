"""`gazed run` starts the live view as one more supervised process when the rig has a `[view]`,
restarts it like the others, and a reload that changes `[view]` restarts it alone."""

from __future__ import annotations

from pathlib import Path

import pytest
from test_supervisor_machine import FakePopen, StandInBus

from gazed.config import parse_rig
from gazed.sdnotify import Notifier
from gazed.supervisor.child import Child, State
from gazed.supervisor.machine import VIEW, VIEW_MODULE, Supervisor

BASE = '[rig]\nname = "t"\n[services]\nready_timeout_s = 600\n'


@pytest.fixture(autouse=True)
def no_processes(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(
        Child, "spawn", lambda child, rig_path: setattr(child, "popen", FakePopen())
    )
    monkeypatch.setattr(Child, "signal", lambda child, signum: None)


def supervisor(rig_path: Path, text: str) -> Supervisor:
    rig_path.write_text(text)
    running = Supervisor(rig_path, parse_rig(text, rig_path), StandInBus(), Notifier({}))  # type: ignore[arg-type]
    running.start(0.0)
    return running


def test_a_rig_with_a_view_starts_it_and_restarts_it(tmp_path: Path) -> None:
    running = supervisor(tmp_path / "rig.toml", BASE + "[view]\nport = 9000\n")
    view = running.children[VIEW]
    assert view.module == VIEW_MODULE and view.state == State.STARTING
    assert view.popen is not None
    running._on_alive(VIEW, view.popen.pid, True)
    running.step(0.1)
    assert view.state == State.RUNNING
    assert running.up() == (1, 6)
    assert view.popen is not None
    view.popen.returncode = 1
    running.step(0.2)
    assert view.state == State.BACKOFF


def test_a_rig_without_a_view_starts_none(tmp_path: Path) -> None:
    running = supervisor(tmp_path / "rig.toml", BASE)
    assert VIEW not in running.children


def test_a_reload_that_changes_the_view_restarts_only_the_view(tmp_path: Path) -> None:
    rig_path = tmp_path / "rig.toml"
    running = supervisor(rig_path, BASE + "[view]\nport = 9000\n")
    before = {name: child.popen for name, child in running.children.items()}
    rig_path.write_text(BASE + "[view]\nport = 9001\n")
    assert running.reload(1.0)
    after = {name: child.popen for name, child in running.children.items()}
    assert [n for n in before if before[n] is not after[n]] == [VIEW]
    rig_path.write_text(BASE)
    assert running.reload(2.0)
    assert VIEW not in running.children
