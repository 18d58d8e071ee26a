"""`gazed record` on the running sim rig keeps what the bus carried (counted by an independent
subscriber), and `gazed replay` of it on another rig, recorded again, carries the same
messages."""

from __future__ import annotations

import signal
import subprocess
import threading
import time
from collections import Counter
from pathlib import Path

import pytest
import zenoh
from conftest import PYTHON, REPO, RunningSupervisor, child_env, poll_until, write_rig
from test_record_replay import Router

from gazed.eval.private_rig import private_rig
from gazed.record.mcap_reader import read_recording

pytestmark = pytest.mark.e2e

RECORD_S = 8.0
FRAMES = "sim/frame"


def gazed(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [PYTHON, "-m", "gazed.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=child_env(),
    )


def suffix_counts(path: Path) -> tuple[Counter[str], int, int]:
    """Messages per key suffix, and the first and last log time (ns)."""
    counts: Counter[str] = Counter()
    times = []
    for recorded in read_recording(path):
        counts[recorded.key.split("/", 2)[2]] += 1
        times.append(recorded.log_time_ns)
    return counts, min(times), max(times)


def test_record_matches_the_bus_and_replay_records_the_same(tmp_path: Path) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 3, None)
    supervisor = RunningSupervisor(rig_path, tmp_path)
    seen: list[tuple[int, str]] = []  # (receive time ns, suffix) as an independent observer
    lock = threading.Lock()

    def observe(sample: zenoh.Sample) -> None:
        with lock:
            seen.append((time.time_ns(), str(sample.key_expr).split("/", 2)[2]))

    first = tmp_path / "run.mcap"
    try:
        supervisor.wait_ready(60.0)
        supervisor.bus.session.declare_subscriber(
            f"gazed/{supervisor.rig.name}/**", zenoh.handlers.Callback(observe, indirect=False)
        )
        record = gazed(
            "record", "--rig", str(rig_path), "-o", str(first), "--seconds", str(RECORD_S)
        )
        out, err = record.communicate(timeout=RECORD_S + 60)
        assert record.returncode == 0, err
    finally:
        supervisor.stop()
    recorded, start_ns, end_ns = suffix_counts(first)
    with lock:
        observed = Counter(s for t, s in seen if start_ns <= t <= end_ns)
    print(out, observed)
    assert recorded[FRAMES] > 0.5 * RECORD_S * 5
    assert abs(recorded[FRAMES] - observed[FRAMES]) <= 0.02 * observed[FRAMES] + 1
    total, bus_total = sum(recorded.values()), sum(observed.values())
    assert abs(total - bus_total) <= 0.02 * bus_total
    assert set(observed) <= set(recorded)

    # the recording replayed on another rig (its bus hosted here), recorded again
    other = Router(write_rig(tmp_path))
    again = tmp_path / "again.mcap"
    try:
        rerecord = gazed(
            "record", "--rig", str(tmp_path / f"{other.rig.name}.toml"), "-o", str(again)
        )
        assert rerecord.stderr is not None
        assert "gazed record:" in rerecord.stderr.readline()  # subscribed
        replay = subprocess.run(
            [
                PYTHON,
                "-m",
                "gazed.cli",
                "replay",
                str(first),
                "--rig",
                str(tmp_path / f"{other.rig.name}.toml"),
                "--rate",
                "2",
            ],
            capture_output=True,
            text=True,
            env=child_env(),
            timeout=RECORD_S + 60,
        )
        assert replay.returncode == 0, replay.stderr
        poll_until(lambda: other.total() >= total, 10.0)  # the bus delivered every message
        rerecord.send_signal(signal.SIGINT)
        rerecord.communicate(timeout=30)
        assert rerecord.returncode == 0
    finally:
        if rerecord.poll() is None:
            rerecord.kill()
        other.session.close()
    replayed, _, _ = suffix_counts(again)
    assert replayed == recorded
