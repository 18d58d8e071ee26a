"""`gazed run`: readiness, watchdog, restarts, restart intensity, reload, orderly stop.

Every process of the test rigs is tests/support/fake_process.py, a minimal real gazed process."""

from __future__ import annotations

import re
import signal
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import FAKE, PYTHON, RunningSupervisor, child_env, pid_alive, poll_until, write_rig

from gazed.config import SERVICE_NAMES

pytestmark = pytest.mark.e2e


@pytest.fixture
def running(tmp_path: Path) -> Iterator[RunningSupervisor]:
    supervisor = RunningSupervisor(write_rig(tmp_path, FAKE), tmp_path, WATCHDOG_USEC="400000")
    supervisor.wait_ready()
    yield supervisor
    supervisor.stop()


def test_ready_watchdog_status_and_orderly_stop(running: RunningSupervisor) -> None:
    pids = running.pids()
    assert set(pids) == set(SERVICE_NAMES)
    poll_until(lambda: running.notify.count("WATCHDOG=1") >= 3, 5.0)
    assert any(m.startswith("STATUS=rig ") for m in running.notify.messages)
    status = poll_until(
        lambda: (s := running.status()) is not None and s.state == "running" and s, 10.0
    )
    assert {p.name: p.state for p in status.processes} == dict.fromkeys(SERVICE_NAMES, "running")
    assert running.stop() == 0
    assert "STOPPING=1" in running.notify.messages
    assert [name for name, pid in pids.items() if pid_alive(pid)] == []


def test_restarts_a_sigkilled_child_within_2_s(running: RunningSupervisor) -> None:
    pids = running.pids()
    killed_at = time.monotonic()
    import os

    os.kill(pids["vision"], signal.SIGKILL)
    back_s = poll_until(lambda: running.back_after("vision", pids["vision"], killed_at), 10.0)
    recovery_s = back_s - killed_at
    print(f"kill -> liveliness back: {recovery_s * 1000:.0f} ms")
    assert recovery_s < 2.0
    new_pids = poll_until(
        lambda: (p := running.pids()).get("vision") not in (None, pids["vision"]) and p, 5.0
    )
    assert {k: v for k, v in new_pids.items() if k != "vision"} == {
        k: v for k, v in pids.items() if k != "vision"
    }
    status = poll_until(
        lambda: (
            (s := running.status())
            and [p for p in s.processes if p.name == "vision" and p.restarts == 1]
        ),
        5,
    )
    assert status[0].last_exit == -signal.SIGKILL


def test_gives_up_after_the_restart_intensity(tmp_path: Path) -> None:
    body = FAKE + "[services]\nrestart_max = 2\nbackoff_initial_s = 0.05\n"
    supervisor = RunningSupervisor(write_rig(tmp_path, body), tmp_path, FAKE_CRASH="gaze")
    code = supervisor.process.wait(timeout=60)
    supervisor.stop()
    assert code == 1
    log = "".join(supervisor.stderr)
    assert "gaze: exited with code 3; 3 failures in 60 s: giving up" in log
    assert "STOPPING=1" in supervisor.notify.messages
    started = [int(pid) for pid in re.findall(r"started \(pid (\d+)\)", log)]
    assert len(started) == len(SERVICE_NAMES) + 2  # gaze was restarted twice
    assert [pid for pid in started if pid_alive(pid)] == []


def test_sighup_restarts_only_what_changed_and_keeps_a_broken_rig_out(
    running: RunningSupervisor,
) -> None:
    pids = running.pids()
    text = running.rig_path.read_text()
    running.rig_path.write_text(text + "[vision]\nfovea_deg = 8.0\n")
    running.process.send_signal(signal.SIGHUP)
    new = poll_until(
        lambda: (p := running.pids()) and p.get("vision") != pids["vision"] and p, 15.0
    )
    assert {k: v for k, v in new.items() if k != "vision"} == {
        k: v for k, v in pids.items() if k != "vision"
    }

    running.rig_path.write_text(text + "[vision]\nfovea_dg = 8.0\n")
    running.process.send_signal(signal.SIGHUP)
    poll_until(lambda: any("reload failed" in m for m in running.notify.messages), 10.0)
    assert running.process.poll() is None
    assert running.pids() == new
    assert "vision.fovea_dg: unknown key (did you mean 'fovea_deg'?)" in "".join(running.stderr)


def test_missing_process_is_reported_and_the_rest_runs(tmp_path: Path) -> None:
    body = FAKE.replace(
        '[services.sim]\nmodule = "fake_process"',
        '[services.sim]\nmodule = "services.not_built_yet"',
    )
    supervisor = RunningSupervisor(write_rig(tmp_path, body), tmp_path)
    try:
        supervisor.wait_ready()
        status = poll_until(
            lambda: (s := supervisor.status()) is not None and s.state == "running" and s, 10.0
        )
        states = {p.name: p.state for p in status.processes}
        assert states["sim"] == "missing"
        assert all(states[n] == "running" for n in SERVICE_NAMES if n != "sim")
        assert "sim: not installed (services.not_built_yet not found)" in "".join(supervisor.stderr)
    finally:
        assert supervisor.stop() == 0


def test_children_die_with_a_killed_supervisor(running: RunningSupervisor) -> None:
    pids = running.pids()
    running.process.kill()
    running.process.wait(10)
    poll_until(lambda: not any(pid_alive(pid) for pid in pids.values()), 30.0)


def test_bad_rig_exits_2(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text('[rig]\nname = "x"\n[head]\npan_max = 3\n')
    result = subprocess.run(
        [PYTHON, "-m", "gazed.cli", "run", str(path)],
        capture_output=True,
        text=True,
        env=child_env(),
    )
    assert result.returncode == 2
    assert "head.pan_max: unknown key (did you mean 'pan_max_deg'?)" in result.stderr
