"""`gazed eval loop --truth`, without processes: a malformed truth file is refused naming its
line, arguments that cannot score footage are refused, the operator's choice goes out at the
person's first frame in the run and the recording ends when they have left, and each rendered
view gets the gaze's state at its capture."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gazed import cli
from gazed.eval.footage_loop import LEFT_FRAMES, Selection, table, view_frames
from gazed.eval.private_rig import private_document
from gazed.eval.truth import COLUMNS, Person
from gazed.messages import Detection, GazeSelect, GazeState, HeadPose
from gazed.topics import GAZE_SELECT, VISION_DETECTION

RIG = """
[rig]
name = "footage"
[camera]
width_px = 160
height_px = 120
hfov_deg = 30
[servo]
protocol = "digital"
[wide]
source = "0"
width_px = 320
height_px = 240
fx_px = 300
"""


def rig_file(tmp_path: Path, text: str = RIG) -> Path:
    path = tmp_path / "rig.toml"
    path.write_text(text)
    return path


def test_a_malformed_truth_file_is_refused_naming_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    truth = tmp_path / "truth.csv"
    truth.write_text(
        ",".join(COLUMNS) + "\n0,0.0,7,10,20,5,12,10,26,1.5,-2.0\n1,0.14,7,10,20,5,12,10,26,x,-2\n"
    )
    argv = ["eval", "loop", "--rig", str(rig_file(tmp_path)), "--truth", str(truth), "--json"]
    assert cli.main(argv) == 2
    assert "truth.csv:3: not a number" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("extra", "rig_text", "message"),
    [
        (["--scenario", "oval"], RIG, "--scenario and --seed are the simulator's"),
        ([], RIG.replace('"digital"', '"visca"'), "needs a digital head over footage"),
        (["--select-id", "99"], RIG, "--select-id 99: no such person"),
    ],
)
def test_arguments_that_cannot_score_footage_are_refused(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    extra: list[str],
    rig_text: str,
    message: str,
) -> None:
    truth = tmp_path / "truth.csv"
    truth.write_text(",".join(COLUMNS) + "\n0,0.0,7,10,20,5,12,10,26,1.5,-2.0\n")
    rig = rig_file(tmp_path, rig_text)
    assert cli.main(["eval", "loop", "--rig", str(rig), "--truth", str(truth), *extra]) == 2
    assert message in capsys.readouterr().err


def test_without_truth_or_scenario_the_command_says_what_it_needs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli.main(["eval", "loop", "--rig", str(rig_file(tmp_path))]) == 2
    assert "give --scenario" in capsys.readouterr().err


def detection(seq: int, t_ns: int) -> Detection:
    return Detection(
        t_capture_ns=t_ns,
        seq=seq,
        detector="flow",
        found=False,
        width_px=160,
        height_px=120,
        head=HeadPose(pan_rad=0.01 * seq, tilt_rad=0.0),
    )


class FakeBus:
    def __init__(self) -> None:
        self.sent: list[GazeSelect] = []

    def publisher(self, topic):
        assert topic is GAZE_SELECT
        return self

    def put(self, message: GazeSelect) -> None:
        self.sent.append(message)


def test_the_choice_is_made_at_the_first_frame_showing_the_person_and_the_run_ends_after() -> None:
    frames = np.arange(20, 30)
    person = Person(
        id=5,
        frame=frames,
        t_s=frames / 7.0,
        box_px=np.tile([100.0, 100.0, 20.0, 60.0], (10, 1)),
        foot_px=np.tile([100.0, 130.0], (10, 1)),
        ground_m=np.column_stack([frames * 0.1, np.full(10, 2.0)]),
    )
    selection = Selection(person)
    bus = FakeBus()
    detections: list[Detection] = []
    messages = {VISION_DETECTION.suffix: detections}
    for seq in range(15, 22):  # the footage reaches the person's first frame, 20
        detections.append(detection(seq, seq))
    assert not selection.watch(bus, messages)  # type: ignore[arg-type]
    assert selection.frame == 20 and len(bus.sent) == 1
    assert bus.sent[0].ground_xy_m == pytest.approx((2.0, 2.0))
    for seq in range(22, 30 + LEFT_FRAMES - 1):
        detections.append(detection(seq, seq))
        assert not selection.watch(bus, messages)  # type: ignore[arg-type]
    detections.append(detection(30 + LEFT_FRAMES, 100))
    assert selection.watch(bus, messages)  # type: ignore[arg-type]
    assert len(bus.sent) == 1


def test_each_view_has_the_gazes_state_at_its_capture() -> None:
    states = [
        GazeState(t_capture_ns=15, state="pursuit", previous="saccade", target_id=4),
        GazeState(t_capture_ns=5, state="saccade", previous="search"),
        GazeState(t_capture_ns=35, state="lost", previous="pursuit"),
    ]
    frames = view_frames([detection(k, k * 10) for k in (3, 0, 1, 2, 4)], states)
    assert [f.frame for f in frames] == [0, 1, 2, 3, 4]
    assert [f.pursuing for f in frames] == [False, False, True, True, False]
    assert [f.target_id for f in frames] == [None, None, 4, 4, None]
    assert frames[2].pan_rad == pytest.approx(0.02)


def test_the_table_puts_the_runs_side_by_side() -> None:
    person = {"id": 5, "visible_frames": 40, "acquired_after_s": 1.2, "fovea_fraction": 0.9}
    person |= {"switches": 1, "gaze_error_deg": {"rms": 1.5, "p95": 2.5}, "ground_rmse_m": 0.4}
    pursuit = {"frames": 50, "acquired_after_s": 0.5, "pursuit_fraction": 0.9, "track_switches": 0}
    common = {"frame_delay_ms": 150.0, "footage_frames": [10, 59], "select_id": 5}
    runs = [
        {**common, "filter": "imm", "person": person, "pursuit": pursuit},
        {**common, "filter": "none", "person": None, "pursuit": pursuit},
    ]
    lines = table(runs).splitlines()
    assert lines[0] == "footage frames [10, 59], person 5"
    assert lines[1].split()[-2:] == ["imm", "none"]
    rms = next(line for line in lines if "gaze error rms" in line)
    assert rms.split()[-2:] == ["1.5", "None"]


def test_the_private_rig_has_its_own_bus_and_stream_ports(tmp_path: Path) -> None:
    document = private_document(rig_file(tmp_path), tmp_path, "none", None)
    bus_port = int(str(document["bus"]["listen"][0]).rsplit(":", 1)[1])
    assert document["wide"]["stream_port"] not in (bus_port, 8090)
    assert document["estimator"]["predict_over_latency"] is False
