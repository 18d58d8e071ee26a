"""`gazed replay --reprocess`: a sim rig's recording fed to fresh vision, estimator and gaze with
the recorded settings reproduces the recorded detections within a pixel, frame by frame."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest
from conftest import PYTHON, REPO, RunningSupervisor, child_env

from gazed.eval.private_rig import private_rig

pytestmark = pytest.mark.e2e

RECORD_S = 8.0


def gazed(*args: str, timeout_s: float) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [PYTHON, "-m", "gazed.cli", *args],
        capture_output=True,
        text=True,
        env=child_env(),
        timeout=timeout_s,
    )


def test_reprocessing_with_the_recorded_settings_reproduces_the_detections(tmp_path: Path) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 1, None)
    supervisor = RunningSupervisor(rig_path, tmp_path)
    run = tmp_path / "run.mcap"
    try:
        supervisor.wait_ready(60.0)
        record = gazed(
            "record",
            "--rig",
            str(rig_path),
            "-o",
            str(run),
            "--seconds",
            str(RECORD_S),
            timeout_s=RECORD_S + 60,
        )
        assert record.returncode == 0, record.stderr
    finally:
        supervisor.stop()
    replay = gazed(
        "replay", str(run), "--rig", str(rig_path), "--reprocess", "--json", timeout_s=180
    )
    assert replay.returncode == 0, replay.stderr
    report = json.loads(replay.stdout)
    detections = report["detections"]
    assert detections["recorded"] > RECORD_S * 25 * 0.8
    assert detections["frames_in_both"] >= 0.95 * detections["recorded"]
    assert detections["found_agrees"] >= 0.95
    assert detections["pixel_error_px"]["p50"] < 1.0
    assert detections["pixel_error_px"]["within_1px"] >= 0.9
    # every recorded frame is fed; the recording may cut a frame from its detection at either end
    # (a detection of a frame sent before it began, a frame whose detection came after it ended)
    assert abs(report["fed"]["sim/frame"] - detections["recorded"]) <= 2
    assert report["most_likely_model"]["captures_in_both"] > 0
