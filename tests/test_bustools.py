"""`gazed tail`, `gazed status`, `gazed latency` against a running rig (and against nothing)."""

from __future__ import annotations

import json
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import FAKE, PYTHON, SUPPORT, RunningSupervisor, child_env, write_rig

from gazed.bustools.latency import latency_report, latency_text
from gazed.bustools.listen import Seen
from gazed.bustools.tail import LONG_LIST, _rounded, _tail_json, _tail_line
from gazed.config import SERVICE_NAMES
from gazed.messages import Detection, Health, Mover


@pytest.fixture(scope="module")
def running(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RunningSupervisor]:
    tmp_path = tmp_path_factory.mktemp("bustools")
    supervisor = RunningSupervisor(write_rig(tmp_path, FAKE), tmp_path)
    supervisor.wait_ready()
    yield supervisor
    supervisor.stop()


def gazed(*args: str, timeout_s: float = 60) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [PYTHON, "-m", "gazed.cli", *args],
        capture_output=True,
        text=True,
        env=child_env(),
        timeout=timeout_s,
    )


def start_gazed(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [PYTHON, "-m", "gazed.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=child_env(),
    )


def publish(rig_path: Path, count: int) -> None:
    subprocess.run(
        [
            PYTHON,
            str(SUPPORT / "publisher_process.py"),
            "--rig",
            str(rig_path),
            "--count",
            str(count),
        ],
        env=child_env(),
        check=True,
        timeout=60,
    )


@pytest.mark.e2e
def test_status_reports_processes_and_rates(running: RunningSupervisor) -> None:
    result = gazed("status", "--rig", str(running.rig_path), "--json", "--seconds", "2.5")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    rig = report["rigs"][running.rig.name]
    assert rig["supervisor"] == "running"
    assert {
        name: (p["alive"], p["state"], p["restarts"]) for name, p in rig["processes"].items()
    } == {name: (True, "running", 0) for name in SERVICE_NAMES}
    assert 0.3 <= rig["rates_hz"]["supervisor/status"] <= 3.0
    assert 0.3 <= rig["rates_hz"]["vision/health"] <= 3.0


@pytest.mark.e2e
def test_status_text_is_readable(running: RunningSupervisor) -> None:
    result = gazed("status", "--rig", str(running.rig_path), "--seconds", "1.5")
    assert result.returncode == 0, result.stderr
    assert f"rig {running.rig.name}: supervisor running" in result.stdout
    assert "vision     running   alive     restarts=0" in result.stdout


def test_a_tail_line_shows_a_histogram_as_its_length_and_json_shows_it_whole() -> None:
    histogram = tuple(float(k) / 2016 for k in range(64))  # sums to 1
    mover = Mover(u_px=10.0, v_px=20.0, box_width_px=5.0, box_height_px=9.0, appearance=histogram)
    detection = Detection(
        t_capture_ns=1_000_000,
        seq=4,
        detector="background",
        found=True,
        width_px=640,
        height_px=480,
        movers=[mover, mover.model_copy(update={"appearance": histogram[:3]})],
    )
    seen = Seen("gazed/r/vision/detection", detection.schema_id(), 3_000_000, detection,
                detection.to_json(), None)  # fmt: skip
    line = _tail_line(seen)
    assert line.startswith("gazed/r/vision/detection gazed.Detection/5      2.0ms ")
    assert '"appearance":"<64 numbers>"' in line
    assert '"appearance":[0.0,0.0005,0.001]' in line  # a short list is shown
    assert '"u_px":10.0' in line and len(line) < 800
    whole = json.loads(_tail_json(seen))["payload"]
    assert whole["movers"][0]["appearance"] == list(histogram)


def test_a_tail_line_shows_lists_up_to_the_long_ones_and_no_flags_as_numbers() -> None:
    assert _rounded([0.5] * LONG_LIST) == [0.5] * LONG_LIST
    assert _rounded([0.5] * (LONG_LIST + 1)) == f"<{LONG_LIST + 1} numbers>"
    assert _rounded([True] * (LONG_LIST + 1)) == [True] * (LONG_LIST + 1)
    assert _rounded([[1.0, 2.0]] * (LONG_LIST + 1)) == [[1.0, 2.0]] * (LONG_LIST + 1)


@pytest.mark.e2e
def test_tail_prints_one_line_per_message(running: RunningSupervisor) -> None:
    tail = start_gazed("tail", "vision/detection", "--rig", str(running.rig_path), "--count", "3")
    publish(running.rig_path, 3)
    out, err = tail.communicate(timeout=30)
    assert tail.returncode == 0, err
    lines = out.splitlines()
    assert len(lines) == 3
    key = f"gazed/{running.rig.name}/vision/detection"
    for seq, line in enumerate(lines):
        assert line.startswith(f"{key} gazed.Detection/5 ")
        assert f'"seq":{seq},' in line and '"detector":"test"' in line


@pytest.mark.e2e
def test_tail_json(running: RunningSupervisor) -> None:
    tail = start_gazed(
        "tail", "vision/detection", "--rig", str(running.rig_path), "--count", "2", "--json"
    )
    publish(running.rig_path, 2)
    out, err = tail.communicate(timeout=30)
    assert tail.returncode == 0, err
    records = [json.loads(line) for line in out.splitlines()]
    assert [r["payload"]["seq"] for r in records] == [0, 1]
    assert all(r["schema"] == "gazed.Detection/5" and r["age_ms"] >= 0 for r in records)


@pytest.mark.e2e
def test_latency_from_stamps(running: RunningSupervisor) -> None:
    latency = start_gazed("latency", "--rig", str(running.rig_path), "--seconds", "4", "--json")
    publish(running.rig_path, 100)
    out, err = latency.communicate(timeout=30)
    assert latency.returncode == 0, err
    report = json.loads(out)
    entry = report["keys"]["vision/detection"]
    assert entry["n"] == 100
    assert 0 <= entry["stages_ms"]["vision"]["p50"] <= entry["stages_ms"]["vision"]["p99"]


def test_latency_report_arithmetic() -> None:
    def d(t0: int, *stamps: tuple[str, int]) -> Detection:
        return Detection(
            t_capture_ns=t0,
            seq=0,
            detector="t",
            found=False,
            width_px=1,
            height_px=1,
            stamps=stamps,
        )

    stamped = [("gazed/r/x/y", d(0, ("a", 1_000_000), ("b", 3_000_000))) for _ in range(10)]
    report = latency_report(stamped)
    entry = report["keys"]["x/y"]
    assert entry["stages_ms"]["a"]["p50"] == 1.0
    assert entry["stages_ms"]["b"]["p99"] == 2.0
    assert entry["end_to_end_ms"]["p50"] == 3.0
    assert "camera_delay" not in report
    vision = Health(
        t_capture_ns=0,
        process="vision",
        pid=1,
        uptime_s=1.0,
        stage_ms={"camera_delay": 150.2},
        notes={"camera_delay": "150.2 ms (online)"},
    )
    report = latency_report(stamped, vision)
    assert report["camera_delay"] == {"ms": 150.2, "note": "150.2 ms (online)"}
    assert "camera delay" in latency_text(report)


@pytest.mark.e2e
@pytest.mark.parametrize("command", ["status", "latency", "tail"])
def test_nothing_answers(tmp_path: Path, command: str) -> None:
    result = gazed(command, "--rig", str(write_rig(tmp_path)), "--seconds", "0.5")
    assert result.returncode == 1
    assert "no bus answers" in result.stderr and "is `gazed run RIG` running?" in result.stderr


@pytest.mark.e2e
def test_silent_rig_is_reported(running: RunningSupervisor) -> None:
    result = gazed("tail", "nothing/here", "--rig", str(running.rig_path), "--seconds", "1")
    assert result.returncode == 1
    assert "nothing was published on" in result.stderr
