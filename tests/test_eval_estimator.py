"""`gazed eval estimator`: scenarios, track files (JSON shape, errors), and the pedestrian data."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gazed.cli import main
from gazed.config import EstimatorSection
from gazed.eval.baselines import TwoPoint
from gazed.eval.pedestrians import TrackFileError, read_tracks
from gazed.eval.scenario_reports import (
    ideal_switch_delay_obs,
    switch_threshold_nats,
    turn_evidence_nats,
)
from gazed.eval.track_prediction import _align, _prediction_errors, track_errors

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "pedestrians"


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(["eval", "estimator", *argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def write_tracks(path: Path) -> Path:
    """Three walkers sampled every 10 frame units (0.4 s): straight, turning, standing."""
    lines = []
    for k in range(30):
        frame = 100 + 10 * k
        t = k * 0.4
        lines.append(f"{frame}\t1.0\t{1.2 * t:.2f}\t{0.3 * t:.2f}")
        lines.append(f"{frame}\t2.0\t{3 * np.cos(0.3 * t):.2f}\t{3 * np.sin(0.3 * t):.2f}")
        if k < 10:
            lines.append(f"{frame}\t3.0\t5.00\t5.00")
    path.write_text("\n".join(lines) + "\n")
    return path


def test_rounded_square_report(capsys) -> None:
    code, out, _ = run(capsys, "--scenario", "rounded-square", "--json", "--seed", "3")
    assert code == 0
    report = json.loads(out)
    assert report["observations"] == 400
    assert {"model", "estimated_obs", "actual_obs", "mean_probability"} <= set(
        report["segments"][0]
    )
    assert [s["model"] for s in report["true_segments"]] == ["CSD", "CS"] * 4
    assert report["switch_delay_obs"]["median"] <= 12
    assert report["switch_delay_obs"]["ratio_to_ideal"] <= 1.5
    assert report["turn_rate_rel_error"] < 0.2
    assert report["turn_rate_rel_error_combined"] > report["turn_rate_rel_error"]


def test_rounded_square_switches_sooner_on_better_velocity_measurements(capsys) -> None:
    """The switch delay is set by the measurements' information: the same seed with a quarter
    of the velocity noise switches sooner."""
    delays = []
    for noise in ("0.2", "0.05"):
        code, out, _ = run(
            capsys, "--scenario", "rounded-square", "--json", "--velocity-noise-m-s", noise
        )
        assert code == 0
        report = json.loads(out)
        assert report["velocity_noise_m_s"] == float(noise)
        delays.append(report["switch_delay_obs"]["median"])
    assert delays[1] < delays[0]


def test_the_ideal_detectors_evidence_is_the_derived_one() -> None:
    """docs/estimation.md: at 45°/s, T = 0.04 s, σ_p = 0.05 m, σ_v = 0.2 m/s the expected
    evidence is 0.18, 0.40, 0.75, 1.30 nats after 3-6 observations and 3.2 after 8; a straight
    path's own first observation differs by ωT in heading alone."""
    motion = {
        "speed_m_s": 1.0,
        "turn_rate_rad_s": np.radians(45.0),
        "period_s": 0.04,
        "position_noise_m": 0.05,
        "velocity_noise_m_s": 0.2,
    }
    evidence = turn_evidence_nats(8, **motion)
    np.testing.assert_allclose(evidence[[2, 3, 4, 5, 7]], [0.18, 0.40, 0.75, 1.30, 3.2], atol=0.01)
    u = np.radians(45.0) * 0.04
    first = (np.hypot(np.sin(u) - u, 1 - np.cos(u)) / np.radians(45.0)) ** 2 / (2 * 0.05**2)
    assert evidence[0] == pytest.approx(first + (2 * np.sin(u / 2)) ** 2 / (2 * 0.2**2))
    assert ideal_switch_delay_obs(3.0, **motion) == 7  # on the 8th observation
    assert ideal_switch_delay_obs(4.0, **motion) == 8  # on the 9th: 4.7 nats
    slower = ideal_switch_delay_obs(4.0, **{**motion, "velocity_noise_m_s": 0.4})
    assert slower > 8
    assert switch_threshold_nats(0.96, 3) == pytest.approx(np.log(48.0))


def test_kelly_report_text(capsys) -> None:
    code, out, _ = run(capsys, "--scenario", "kelly")
    assert code == 0
    rows = [line.split() for line in out.splitlines()[2:]]
    assert [(r[0], r[1]) for r in rows] == [
        ("rest", "CP"),
        ("accelerate", "CA"),
        ("constant", "CV"),
        ("decelerate", "CA"),
        ("rest", "CP"),
    ]


def test_track_file_all_filters(capsys, tmp_path: Path) -> None:
    path = write_tracks(tmp_path / "walkers.txt")
    code, out, _ = run(
        capsys, "--data", str(path), "--filter", "all", "--json", "--horizons", "0.4,1.0"
    )
    assert code == 0
    report = json.loads(out)
    assert report["tracks"] == 3 and set(report["filters"]) == {
        "imm",
        "cv",
        "ca",
        "alphabeta",
        "innovation",
    }
    for name, result in report["filters"].items():
        assert result["points"] == 70 and set(result["error_m"]) == {"0.4", "1"}
        errors = result["error_m"]["0.4"]
        # 0.4 s ahead: every step from the second on whose horizon the track still covers
        assert errors["n"] == 28 + 28 + 8
        assert 0 < errors["median"] < 0.3, name
    code, out, _ = run(capsys, "--data", str(path), "--filter", "cv")
    assert code == 0 and "cv" in out and "0.4" in out


def test_added_noise_is_seeded_and_hurts(tmp_path: Path) -> None:
    tracks = read_tracks(write_tracks(tmp_path / "walkers.txt"))
    section = EstimatorSection()
    clean = track_errors(section, tracks, "cv", [0.4], 0.0, 0)["error_m"]["0.4"]["mean"]
    noisy = track_errors(section, tracks, "cv", [0.4], 0.2, 0)["error_m"]["0.4"]["mean"]
    again = track_errors(section, tracks, "cv", [0.4], 0.2, 0)["error_m"]["0.4"]["mean"]
    assert noisy == again and noisy > clean


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("100\t1.0\t2.0\n", "expected 4 fields"),
        ("100\t1.0\tx\t2.0\n", "not a number"),
        ("100\t1.0\tnan\t2.0\n", "not finite"),
        ("100\t1.0\t1\t2\n100\t1.0\t1\t2\n", "two observations in one frame"),
        ("", "no observations"),
    ],
)
def test_bad_track_files_are_refused_with_the_line(
    capsys, tmp_path: Path, text: str, message: str
) -> None:
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(TrackFileError, match=message):
        read_tracks(path)
    code, _, err = run(capsys, "--data", str(path))
    assert code == 2 and message in err


def test_bad_arguments(capsys, tmp_path: Path) -> None:
    path = write_tracks(tmp_path / "walkers.txt")
    assert run(capsys, "--data", str(path), "--horizons", "0.4,-1")[0] == 2
    assert run(capsys, "--data", str(path), "--noise-m", "-0.1")[0] == 2
    assert run(capsys, "--scenario", "rounded-square", "--velocity-noise-m-s", "nan")[0] == 2
    # a scenario without noise would give the filter a singular R
    assert run(capsys, "--scenario", "rounded-square", "--velocity-noise-m-s", "0")[0] == 2
    assert run(capsys, "--scenario", "kelly", "--noise-m", "0")[0] == 2
    code, _, err = run(capsys, "--scenario", "kelly", "--velocity-noise-m-s", "0.1")
    assert code == 2 and "goes with --scenario rounded-square" in err
    assert run(capsys, "--data", str(tmp_path / "missing.txt"))[0] == 2


@pytest.mark.skipif(
    not DATA.is_dir(),
    reason="../shared/data/pedestrians not present (CI clones it beside the repo)",
)
def test_pedestrian_file_is_read_as_its_readme_says() -> None:
    tracks = read_tracks(DATA / "biwi_eth.txt")
    assert len(tracks) == 360
    assert sum(len(t.t_s) for t in tracks) == 5492
    steps = np.concatenate([np.diff(t.t_s) for t in tracks])
    np.testing.assert_allclose(steps, 0.4)


@pytest.mark.skipif(
    not DATA.is_dir(),
    reason="../shared/data/pedestrians not present (CI clones it beside the repo)",
)
def test_imm_is_no_worse_than_cv_on_pedestrians() -> None:
    """The IMM predicts pedestrians at least as well as constant velocity (within 2 %), on the
    first 120 tracks of the eth scene at 0.4 s and 0.8 s."""
    tracks = read_tracks(DATA / "biwi_eth.txt")[:120]
    section = EstimatorSection()
    imm = track_errors(section, tracks, "imm", [0.4, 0.8], 0.0, 0)["error_m"]
    cv = track_errors(section, tracks, "cv", [0.4, 0.8], 0.0, 0)["error_m"]
    for h in ("0.4", "0.8"):
        assert imm[h]["mean"] <= cv[h]["mean"] * 1.02, (h, imm[h], cv[h])


def test_the_adapting_imm_follows_clean_walkers_where_the_fixed_one_lags(shared_data: Path) -> None:
    """On the PETS truth (hand-annotated, nearly noise-free) the IMM that learns its noise
    predicts 0.4 s ahead with less than half the fixed-noise IMM's error, and within 15 % of
    the two-point extrapolation."""
    tracks = read_tracks(shared_data / "footage" / "pets09-s2l1" / "truth_frames_0000-0399.csv")
    error = {
        name: track_errors(EstimatorSection(adapt_noise=adapt), tracks, "imm", [0.4], 0.0, 0)
        for name, adapt in (("adaptive", True), ("fixed", False))
    }
    two_point = _prediction_errors(TwoPoint(len(tracks)), _align(tracks, 0.0, 0), [0.4])
    adaptive = error["adaptive"]["error_m"]["0.4"]["mean"]
    assert adaptive < 0.5 * error["fixed"]["error_m"]["0.4"]["mean"]
    assert adaptive < 1.15 * two_point["error_m"]["0.4"]["mean"]
