"""The figures from plain data: each has the axes and lines its data asks for, is written as a
valid PNG, and is left out when its data is absent; a recording's messages become the same
series a run's record does; the estimator's scenarios give their truth, estimates, predictions
and model probabilities; `gazed plot` draws a recording, damaged or whole."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from gazed import cli
from gazed.config import EstimatorSection, parse_rig
from gazed.geometry.pose import CameraPose
from gazed.messages import EstimatorState, GazeDemand, GazeState, HeadPose, Prediction, SimTruth
from gazed.plots import figures
from gazed.plots.bus_series import bus_series
from gazed.plots.estimator_series import scenario_series, track_file_series
from gazed.plots.figures import (
    gaze_error_figure,
    latency_figure,
    model_probabilities_figure,
    trajectory_figure,
    write_figures,
)
from gazed.plots.series import RunSeries
from gazed.record.mcap_writer import McapRecording, Sample

PNG = b"\x89PNG\r\n\x1a\n"
T0 = 1_700_000_000_000_000_000
RIG = '[rig]\nname = "t"\n[sim]\ncamera_xyz_m = [0.0, -5.0, 3.0]\n'


def a_run() -> RunSeries:
    t = np.linspace(0, 10, 101)
    circle = np.column_stack([np.cos(t), np.sin(t)])
    return RunSeries(
        "test",
        truth_xy_m=circle,
        estimate_xy_m=circle + 0.01,
        prediction_xy_m=circle + 0.02,
        prediction_horizon_s=0.2,
        error_t_s=t,
        error_deg=np.abs(np.sin(t)),
        fovea_half_deg=3.0,
        saccade_t_s=[1.0, 6.0],
        state_changes=[(1.0, "saccade"), (1.5, "pursuit"), (6.0, "saccade")],
        model_t_s=t,
        model_probabilities={
            "CSD": np.full(101, 0.7),
            "CS": np.full(101, 0.2),
            "CD": np.full(101, 0.1),
        },
        hops_ms={"vision": [1.0, 2.0, 3.0], "servo": [0.5, 0.6]},
    )


def test_each_figure_draws_what_its_data_holds() -> None:
    run = a_run()
    trajectory = trajectory_figure(run).axes[0]
    assert [line.get_label() for line in trajectory.lines] == [
        "truth",
        "estimate",
        "prediction (0.20 s ahead)",
    ]
    assert trajectory.get_xlabel() == "X (m)" and trajectory.get_ylabel() == "Y (m)"
    error = gaze_error_figure(run).axes[0]
    assert error.get_ylabel() == "gaze error (deg)"
    saccades = [line for line in error.lines if line.get_color() == "tab:red"]
    assert [line.get_xdata()[0] for line in saccades] == [1.0, 6.0]
    assert {text.get_text() for text in error.texts} == {"saccade", "pursuit"}
    probabilities, likely = model_probabilities_figure(run).axes
    assert [line.get_label() for line in probabilities.lines] == ["CSD", "CS", "CD"]
    assert [line.get_linestyle() for line in probabilities.lines] == ["-", "--", ":"]
    assert set(likely.lines[0].get_ydata()) == {0}  # CSD is the most likely throughout
    latency = latency_figure(run).axes
    assert [axes.get_ylabel() for axes in latency] == ["vision", "servo"]
    # drawn up to the 99th percentile (2.98 ms): the slowest of the three falls beyond
    assert sum(patch.get_height() for patch in latency[0].patches) == 2
    assert "p50 2.00" in latency[0].texts[0].get_text()


def test_figures_without_data_are_left_out(tmp_path: Path) -> None:
    run = RunSeries("empty", estimate_xy_m=np.zeros((3, 2)))
    assert gaze_error_figure(run) is None and latency_figure(run) is None
    assert model_probabilities_figure(run) is None
    assert [p.name for p in write_figures(run, tmp_path)] == ["trajectory.png"]


def loop_messages() -> dict[str, list]:
    """A few seconds of a run: the target walking along x, the head on it, a saccade."""
    truth, states, commands, predictions = [], [], [], []
    for k in range(50):
        t = T0 + k * 40_000_000
        truth.append(
            SimTruth(
                t_capture_ns=t,
                seq=k,
                target_xy_m=(0.1 * k, 0.0),
                target_velocity_m_s=(2.5, 0.0),
                target_height_m=0.4,
                head=HeadPose(pan_rad=0.0, tilt_rad=-0.5),
            )
        )
        states.append(
            EstimatorState(
                t_capture_ns=t,
                filter="imm",
                x=(0.0,),
                P=((1.0,),),
                ground_xy_m=(0.1 * k, 0.01),
                model_probabilities={"CSD": 0.6, "CS": 0.3, "CD": 0.1},
            )
        )
        predictions.append(
            Prediction(
                t_capture_ns=t,
                filter="imm",
                t_effect_ns=t + 200_000_000,
                horizon_s=0.2,
                pan_rad=0,
                tilt_rad=0,
                pan_rate_rad_s=0,
                tilt_rate_rad_s=0,
                ground_xy_m=(0.1 * k + 0.5, 0.0),
                visual_latency_s=0.15,
                actuation_latency_s=0.05,
            )
        )
        commands.append(
            GazeDemand(
                t_capture_ns=t,
                kind="pursuit",
                pan_rad=0,
                tilt_rad=0,
                stamps=(("vision", t + 150_000_000), ("servo", t + 153_000_000)),
            )
        )
    gaze = [
        GazeState(t_capture_ns=T0 + 400_000_000, state="saccade", previous="search"),
        GazeState(t_capture_ns=T0 + 800_000_000, state="pursuit", previous="saccade"),
    ]
    return {
        "sim/truth": truth,
        "estimator/state": states,
        "estimator/prediction": predictions,
        "gaze/state": gaze,
        "servo/command": commands,
    }


def test_a_runs_messages_become_its_series() -> None:
    rig = parse_rig(RIG)
    run = bus_series("oval", loop_messages(), CameraPose.from_rig(rig), 3.0)
    assert run.truth_xy_m.shape == run.estimate_xy_m.shape == run.prediction_xy_m.shape == (50, 2)
    assert run.prediction_horizon_s == 0.2
    assert run.saccade_t_s == pytest.approx([0.4])
    assert [s for _, s in run.state_changes] == ["saccade", "pursuit"]
    assert run.error_t_s[-1] == pytest.approx(49 * 0.04)
    assert np.all(run.error_deg >= 0) and np.all(np.isfinite(run.error_deg))
    assert run.model_probabilities["CS"] == pytest.approx(np.full(50, 0.3))
    assert run.hops_ms["vision"] == pytest.approx([150.0] * 50)
    assert run.hops_ms["servo"] == pytest.approx([3.0] * 50)
    without_rig = bus_series("oval", loop_messages())
    assert without_rig.error_deg is None and gaze_error_figure(without_rig) is None


def test_the_estimators_scenario_gives_truth_estimates_predictions_and_models() -> None:
    run = scenario_series(EstimatorSection(), "rounded-square", 0, None, None, 0.4)
    assert list(run.model_probabilities) == ["CSD", "CS", "CD"]
    assert len(run.estimate_xy_m) == len(run.model_t_s) >= 390
    error_m = np.linalg.norm(run.estimate_xy_m - run.truth_xy_m[-len(run.estimate_xy_m) :], axis=1)
    assert np.median(error_m) < 0.05  # the estimate follows the truth
    total = sum(run.model_probabilities.values())
    assert total == pytest.approx(np.ones_like(total))
    kelly = scenario_series(EstimatorSection(), "kelly", 0, None, None, 0.4)
    assert list(kelly.model_probabilities) == ["CP", "CV", "CA"]


def test_a_pedestrian_files_walker_is_plotted() -> None:
    path = SHARED_DATA / "pedestrians" / "biwi_hotel.txt"
    if not path.is_file():
        pytest.skip(f"{path} is absent (the shared data sits beside the repository only in CI)")
    run = track_file_series(EstimatorSection(), path, "imm", 0.0, 0, 0.4)
    walked_m = np.linalg.norm(np.diff(run.truth_xy_m, axis=0), axis=1).sum()
    assert walked_m > 5.0
    assert len(run.prediction_xy_m) == len(run.estimate_xy_m) > 10
    assert list(run.model_probabilities) == ["CSD", "CS", "CD"]


def recording(path: Path, cut_at: float | None = None) -> None:
    with path.open("wb") as stream:
        mcap = McapRecording(stream)
        for suffix, messages in loop_messages().items():
            for m in messages:
                mcap.write(Sample(f"gazed/t/{suffix}", m.to_json(), None, m.t_capture_ns))
        mcap.close()
    if cut_at is not None:
        data = path.read_bytes()
        path.write_bytes(data[: int(len(data) * cut_at)])


def test_gazed_plot_draws_a_recording(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(figures, "DPI", 30)  # small images: the same drawing, rendered faster
    rig_path = tmp_path / "rig.toml"
    rig_path.write_text(RIG)
    recording(tmp_path / "run.mcap")
    out = tmp_path / "figures"
    assert (
        cli.main(["plot", str(tmp_path / "run.mcap"), "--plot", str(out), "--rig", str(rig_path)])
        == 0
    )
    assert sorted(p.name for p in out.iterdir()) == [
        "gaze_error.png",
        "latency.png",
        "model_probabilities.png",
        "trajectory.png",
    ]
    for path in out.iterdir():
        assert path.read_bytes()[:8] == PNG and path.stat().st_size > 1000
    capsys.readouterr()
    recording(tmp_path / "cut.mcap", cut_at=0.5)
    assert cli.main(["plot", str(tmp_path / "cut.mcap"), "--plot", str(tmp_path / "cut")]) == 0
    assert "damaged from byte" in capsys.readouterr().err
    assert (tmp_path / "cut" / "trajectory.png").read_bytes()[:8] == PNG
    assert cli.main(["plot", str(tmp_path / "none.mcap"), "--plot", str(out)]) == 2


def test_eval_estimator_writes_its_figures(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(figures, "DPI", 30)
    out = tmp_path / "figures"
    assert cli.main(["eval", "estimator", "--scenario", "kelly", "--plot", str(out)]) == 0
    assert "kelly" in capsys.readouterr().out  # the report as before
    assert sorted(p.name for p in out.iterdir()) == ["model_probabilities.png", "trajectory.png"]
