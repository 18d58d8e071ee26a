"""What `gazed replay --reprocess` compares, without processes: detections frame by frame, the
most likely model at each capture (the fresh ones retimed), the gaze's transitions; and how a
retimed replay moves every time in a message; the progress bar of replays."""

from __future__ import annotations

import sys
import threading
from pathlib import Path
from typing import Any

import pytest
from test_record_mcap import odometry_sample, write_file

from gazed.messages import Detection, EstimatorState, GazeState
from gazed.record.replay_cli import Replayer, progress
from gazed.record.reprocess import compare

T0 = 1_700_000_000_000_000_000
SHIFT = 5_000_000_000


def detection(seq: int, u: float, found: bool = True, shift: int = 0) -> Detection:
    return Detection(
        t_capture_ns=T0 + seq + shift,
        seq=seq,
        detector="flow",
        found=found,
        u_px=u,
        v_px=10,
        width_px=64,
        height_px=48,
    )


def state(seq: int, model: str, shift: int = 0) -> EstimatorState:
    return EstimatorState(
        t_capture_ns=T0 + seq + shift, filter="imm", x=(0.0,), P=((1.0,),), most_likely=model
    )


def test_the_fresh_decisions_are_compared_with_the_recorded_ones() -> None:
    recorded: dict[str, list[Any]] = {
        "vision/detection": [detection(k, 10.0) for k in range(10)],
        "estimator/state": [state(k, "CSD") for k in range(10)],
        "gaze/state": [GazeState(t_capture_ns=T0, state="pursuit")],
    }
    fresh: dict[str, list[Any]] = {
        # frame 0 not reprocessed, frame 9 not found, frame 5 half a pixel off, frame 6 three
        "vision/detection": [
            detection(k, 10.0 + {5: 0.5, 6: 3.0}.get(k, 0.0), found=k != 9, shift=SHIFT)
            for k in range(1, 10)
        ],
        "estimator/state": [state(k, "CS" if k < 3 else "CSD", SHIFT) for k in range(10)],
        "gaze/state": [
            GazeState(t_capture_ns=T0, state="saccade"),
            GazeState(t_capture_ns=T0, state="pursuit"),
        ],
    }
    report = compare(recorded, fresh, SHIFT)
    detections = report["detections"]
    assert (detections["recorded"], detections["reprocessed"]) == (10, 9)
    assert detections["frames_in_both"] == 9 and detections["found_in_both"] == 8
    assert detections["found_agrees"] == pytest.approx(8 / 9, abs=1e-4)
    assert detections["pixel_error_px"]["max"] == 3.0
    assert detections["pixel_error_px"]["within_1px"] == pytest.approx(7 / 8)
    assert report["most_likely_model"] == {"captures_in_both": 10, "agrees": 0.7}
    assert report["gaze_states"]["reprocessed"] == {"saccade": 1, "pursuit": 1}


def test_a_retimed_replay_moves_every_time_in_a_message() -> None:
    replayer = Replayer(None, "r", 1.0, threading.Event(), retime=True)  # type: ignore[arg-type]
    replayer.shift_ns = 7
    body = {"t_capture_ns": 10, "t_effect_ns": 20, "seq": 3, "stamps": [["sim", 11]]}
    assert replayer._shifted(body) == {
        "t_capture_ns": 17,
        "t_effect_ns": 27,
        "seq": 3,
        "stamps": [["sim", 18]],
    }
    replayer.shift_ns = 0
    assert replayer._shifted(body) == body


def test_progress_shows_on_a_terminal_only_and_knows_the_recordings_length(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "run.mcap"
    write_file(path, [odometry_sample(i) for i in range(101)])  # 100 intervals of 10.0005 ms
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    with progress(path, "replay", quiet=False) as bar:
        assert not bar.disable and bar.total == pytest.approx(1.00005)
    with progress(path, "replay", quiet=True) as bar:  # --json
        assert bar.disable
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[:-200])  # no summary: no length, no time left
    with progress(cut, "replay", quiet=False) as bar:
        assert not bar.disable and bar.total is None
        bar.update(0.5)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False)
    with progress(path, "replay", quiet=False) as bar:
        assert bar.disable
