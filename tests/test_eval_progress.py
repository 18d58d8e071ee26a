"""Progress of long `gazed eval` runs: shown on a terminal (what runs, how far, the time left),
silent when stderr is not a terminal or with --json."""

from __future__ import annotations

import fcntl
import io
import os
import pty
import struct
import subprocess
import sys
import termios
from pathlib import Path

import pytest
from conftest import PYTHON, REPO, child_env
from test_eval_estimator import write_tracks

from gazed.eval.progress import EvalProgress


class Terminal(io.StringIO):
    """stderr as a terminal that keeps what is written."""

    def isatty(self) -> bool:
        return True


def on_terminal(monkeypatch: pytest.MonkeyPatch) -> Terminal:
    """stderr a terminal, for the rest of the test (set in the test itself: pytest's capture
    sets sys.stderr again after the fixtures)."""
    screen = Terminal()
    monkeypatch.setattr(sys, "stderr", screen)
    return screen


def test_silent_when_stderr_is_not_a_terminal_or_with_json(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    piped = io.StringIO()  # isatty() is False
    monkeypatch.setattr(sys, "stderr", piped)
    with EvalProgress(2, quiet=False) as progress:
        assert progress.bar.disable
        list(progress.steps("imm", 5))
    assert piped.getvalue() == ""
    screen = on_terminal(monkeypatch)
    with EvalProgress(2, quiet=True) as progress:  # --json
        assert progress.bar.disable
        list(progress.steps("imm", 5))
    assert screen.getvalue() == ""


def test_steps_name_each_part_and_advance_by_its_share(monkeypatch: pytest.MonkeyPatch) -> None:
    terminal = on_terminal(monkeypatch)
    with EvalProgress(2, quiet=False) as progress:
        assert not progress.bar.disable
        for k in progress.steps("cv-ml", 4):
            assert progress.bar.n == pytest.approx(k / 4)
        assert progress.bar.n == pytest.approx(1.0)
        steps = progress.steps("imm", 2)
        next(steps)
        assert progress.bar.desc == "imm (2/2): 2 steps"
        assert progress.bar.n == pytest.approx(1.0)
        list(steps)
        assert progress.bar.n == pytest.approx(2.0)
    shown = terminal.getvalue()
    assert "cv-ml (1/2): 4 steps" in shown and "imm (2/2): 2 steps" in shown
    assert "/2 [" in shown and "<" in shown  # how far, and the time elapsed < left


def test_a_recording_shows_the_start_then_the_seconds_recorded(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    on_terminal(monkeypatch)
    now_s = [100.0]
    told: list[int] = []

    def own_watch(_bus: object, messages: dict[str, list[int]]) -> bool:
        told.append(len(messages["x"]))
        return len(messages["x"]) >= 3  # the run's own end: the recording stops early

    with EvalProgress(2, quiet=False, clock=lambda: now_s[0]) as progress:
        watch = progress.recording(10.0, "oval", None, "pid")
        assert progress.bar.desc == "oval pid (1/2): starting the rig"
        now_s[0] = 130.0  # the rig took 30 s to start: no progress in the run's seconds
        assert watch(None, {}) is False  # type: ignore[arg-type]
        assert progress.bar.desc == "oval pid (1/2): recording 10 s"
        assert progress.bar.n == pytest.approx(0.0)
        now_s[0] = 134.0
        watch(None, {})  # type: ignore[arg-type]
        assert progress.bar.n == pytest.approx(0.4)
        now_s[0] = 150.0  # past its length: the run is all done
        watch(None, {})  # type: ignore[arg-type]
        assert progress.bar.n == pytest.approx(1.0)

        watch = progress.recording(10.0, "footage", "imm", None, then=own_watch)
        assert progress.bar.desc == "footage imm (2/2): starting the rig"
        assert watch(None, {"x": [1]}) is False  # type: ignore[arg-type]
        now_s[0] = 152.0
        assert watch(None, {"x": [1, 2, 3]}) is True  # type: ignore[arg-type]
        assert told == [1, 3] and progress.bar.n == pytest.approx(1.2)
        progress.begin("after", "ending early")  # a part ended early: the next starts whole
        assert progress.bar.n == pytest.approx(2.0)


def on_a_pty(argv: list[str]) -> tuple[str, str]:
    """`argv` run with its stderr on a terminal: its stdout, and what the terminal showed."""
    main, child = pty.openpty()
    # a terminal's size, as a real one has (tqdm shows nothing on one 0 rows high)
    fcntl.ioctl(child, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 120, 0, 0))
    with subprocess.Popen(argv, env=child_env(), stdout=subprocess.PIPE, stderr=child) as process:
        os.close(child)
        shown = bytearray()
        while True:
            try:
                chunk = os.read(main, 4096)
            except OSError:  # the pty closed: the process ended
                break
            if not chunk:
                break
            shown += chunk
        out = process.stdout.read().decode() if process.stdout else ""
        assert process.wait(timeout=120) == 0, shown.decode(errors="replace")
    os.close(main)
    return out, shown.decode(errors="replace")


def run_estimator(tmp_path: Path, *extra: str, on_terminal: bool) -> tuple[str, str]:
    """`gazed eval estimator --data` over all filters: its stdout, and stderr (a pty or a pipe)."""
    data = write_tracks(tmp_path / "walkers.txt")
    argv = [PYTHON, "-m", "gazed.cli", "eval", "estimator", "--data", str(data), "--filter", "all"]
    if on_terminal:
        return on_a_pty([*argv, *extra])
    done = subprocess.run(
        [*argv, *extra], env=child_env(), capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    return done.stdout, done.stderr


@pytest.mark.e2e
def test_eval_estimator_shows_its_progress_on_a_terminal_only(tmp_path: Path) -> None:
    out, shown = run_estimator(tmp_path, on_terminal=True)
    for part in ("constant-position (1/8)", "cv-ml (3/8)", "imm (4/8)", "innovation (8/8)"):
        assert part in shown
    assert "%|" in shown and "/8 [" in shown
    assert "cv-ml: q =" in out and "%|" not in out  # the report itself is on stdout, unmixed
    _, piped = run_estimator(tmp_path, on_terminal=False)
    assert "(1/8)" not in piped and "%|" not in piped
    _, as_json = run_estimator(tmp_path, "--json", on_terminal=True)
    assert "(1/8)" not in as_json and "%|" not in as_json


@pytest.mark.e2e
def test_eval_loop_shows_the_rigs_start_then_its_recording_on_a_terminal() -> None:
    rig = str(REPO / "configs" / "sim.toml")
    argv = [PYTHON, "-m", "gazed.cli", "eval", "loop", "--rig", rig, "--scenario", "oval"]
    out, shown = on_a_pty([*argv, "--seconds", "3", "--control", "pid"])
    assert "oval pid (1/1): starting the rig" in shown
    assert "oval pid (1/1): recording 3 s" in shown and "/1 [" in shown
    assert "scenario oval, 3 s" in out and "%|" not in out
