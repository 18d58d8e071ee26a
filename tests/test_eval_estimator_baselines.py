"""`gazed eval estimator --data`: the baselines beside the filters (closed forms on synthetic
tracks, through the command), and the annotated-people CSV format."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gazed.cli import main
from gazed.eval.pedestrians import TrackFileError, read_tracks

SPEEDS_M_S = (1.5, 0.5)
HEADER = "frame,t_s,id,box_u_px,box_v_px,box_w_px,box_h_px,foot_u_px,foot_v_px,x_m,y_m"


def run_json(capsys, path: Path, *argv: str) -> dict:
    code = main(["eval", "estimator", "--data", str(path), "--json", *argv])
    out = capsys.readouterr().out
    assert code == 0
    return json.loads(out)


def straight_walkers(path: Path) -> Path:
    """Two walkers on straight lines at constant speeds, sampled every 0.4 s."""
    lines = []
    for k in range(25):
        t = 0.4 * k
        lines.append(f"{10 * k}\t1\t{0.6 * SPEEDS_M_S[0] * t:.6f}\t{0.8 * SPEEDS_M_S[0] * t:.6f}")
        lines.append(f"{10 * k}\t2\t{3 - SPEEDS_M_S[1] * t:.6f}\t2.000000")
    path.write_text("\n".join(lines) + "\n")
    return path


def test_baselines_have_their_closed_forms_on_straight_tracks(capsys, tmp_path: Path) -> None:
    report = run_json(
        capsys,
        straight_walkers(tmp_path / "straight.txt"),
        "--filter",
        "all",
        "--horizons",
        "0.4,0.8",
    )
    baselines = report["baselines"]
    assert set(baselines) == {"constant-position", "two-point", "cv-ml"}
    for h in (0.4, 0.8):
        key = f"{h:g}"
        # the same samples as the filters
        assert all(
            b["error_m"][key]["n"] == report["filters"]["imm"]["error_m"][key]["n"]
            for b in baselines.values()
        )
        assert baselines["two-point"]["error_m"][key]["mean"] == pytest.approx(0.0, abs=1e-5)
        assert baselines["cv-ml"]["error_m"][key]["mean"] == pytest.approx(0.0, abs=1e-3)
        # constant position: each walker is off by its speed times the horizon, at every step
        held = baselines["constant-position"]["error_m"][key]
        assert held["mean"] == pytest.approx(np.mean(SPEEDS_M_S) * h, rel=1e-5)
        assert held["p90"] == pytest.approx(max(SPEEDS_M_S) * h, rel=1e-5)
    assert baselines["cv-ml"]["q"] > 0 and baselines["cv-ml"]["r"] > 0


def test_one_filter_is_shown_beside_the_baselines(capsys, tmp_path: Path) -> None:
    path = straight_walkers(tmp_path / "straight.txt")
    assert main(["eval", "estimator", "--data", str(path), "--filter", "cv"]) == 0
    out = capsys.readouterr().out
    for name in ("cv ", "constant-position", "two-point", "cv-ml", "q = ", "r = "):
        assert name in out


def test_two_point_carries_the_last_velocity_on_a_turn(capsys, tmp_path: Path) -> None:
    """On a circle the two-point forecast misses by the chord's velocity error: compare with the
    exact value computed here."""
    radius_m, rate_rad_s, dt_s, h_s = 3.0, 0.3, 0.4, 0.4
    t = dt_s * np.arange(30)
    xy = radius_m * np.stack([np.cos(rate_rad_s * t), np.sin(rate_rad_s * t)], axis=1)
    path = tmp_path / "circle.txt"
    path.write_text("".join(f"{10 * k} 1 {x:.9f} {y:.9f}\n" for k, (x, y) in enumerate(xy)))
    report = run_json(capsys, path, "--horizons", f"{h_s}")
    v = (xy[1:-1] - xy[:-2]) / dt_s
    expected = np.linalg.norm(xy[1:-1] + v * h_s - xy[2:], axis=1)
    got = report["baselines"]["two-point"]["error_m"]["0.4"]
    assert got["n"] == len(expected)
    assert got["mean"] == pytest.approx(expected.mean(), rel=1e-6)


def annotated(path: Path, rows: list[str]) -> Path:
    path.write_text("\n".join([HEADER, *rows]) + "\n")
    return path


def test_annotated_people_csv_is_read_by_its_header(capsys, tmp_path: Path) -> None:
    rows = []
    for frame in range(0, 21):
        t = frame / 7
        rows.append(f"{frame},{t:.6f},4,1,1,2,3,1,2,{1.0 * t:.6f},{-0.5:.6f}")
        if frame % 2 == 0:
            rows.append(f"{frame},{t:.6f},9,1,1,2,3,1,2,2.0,{0.7 * t:.6f}")
    path = annotated(tmp_path / "truth.csv", rows)
    tracks = read_tracks(path)
    assert [tr.ped_id for tr in tracks] == [4.0, 9.0]
    assert len(tracks[0].t_s) == 21 and len(tracks[1].t_s) == 11
    np.testing.assert_allclose(tracks[1].xy_m[-1], [2.0, 0.7 * 20 / 7], atol=1e-6)
    report = run_json(capsys, path, "--horizons", "0.4")
    assert report["tracks"] == 2
    assert report["baselines"]["two-point"]["error_m"]["0.4"]["mean"] == pytest.approx(0, abs=1e-5)


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        (["0,0.0,4,1,1,2,3,1,2,1.0,x"], ":2: not a number"),
        (["0,0.0,4,1,1,2,3,1,2,1.0,0.0", "1,0.1,4,1,1,2,3,1,2,1.0"], ":3: not a number"),
        (["0,0.0,4,1,1,2,3,1,2,1.0,0.0", "1,0.0,4,1,1,2,3,1,2,1.0,0.0"], "times do not increase"),
    ],
)
def test_bad_annotated_files_are_refused_naming_the_line(
    capsys, tmp_path: Path, rows: list[str], message: str
) -> None:
    path = annotated(tmp_path / "bad.csv", rows)
    with pytest.raises(TrackFileError, match=message):
        read_tracks(path)
    assert main(["eval", "estimator", "--data", str(path)]) == 2
    assert message in capsys.readouterr().err


def test_a_header_missing_columns_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "short.csv"
    path.write_text("frame,t_s,id,x_m,y_m\n0,0.0,1,0.0,0.0\n")
    with pytest.raises(TrackFileError, match=r"short.csv:1: missing column"):
        read_tracks(path)


def test_pets_truth_is_read_as_tracks(shared_data: Path) -> None:
    path = shared_data / "footage" / "pets09-s2l1" / "truth_frames_0000-0399.csv"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    tracks = read_tracks(path)
    assert len(tracks) >= 5
    for tr in tracks:
        # 7 frames a second: consecutive annotations are whole numbers of frames apart
        frames = tr.t_s * 7
        np.testing.assert_allclose(frames, np.round(frames), atol=1e-3)
        assert np.all(np.isfinite(tr.xy_m))


def test_a_half_is_scored_with_cv_ml_fitted_to_the_other(capsys, tmp_path: Path) -> None:
    """Walker 1 walks cleanly, walker 2 with a ±5 cm zig-zag: half 1 (walker 1) is scored
    with cv-ml fitted to walker 2, so its r is the zig-zag's, and half 2 the other way round."""
    lines = []
    for k in range(25):
        t = 0.4 * k
        lines.append(f"{10 * k}\t1\t{1.5 * t:.6f}\t0.000000")
        lines.append(f"{10 * k}\t2\t{3 - 0.5 * t:.6f}\t{2 + 0.05 * (-1) ** k:.6f}")
    path = tmp_path / "halves.txt"
    path.write_text("\n".join(lines) + "\n")
    first = run_json(capsys, path, "--filter", "cv", "--horizons", "0.4", "--half", "1")
    second = run_json(capsys, path, "--filter", "cv", "--horizons", "0.4", "--half", "2")
    # constant position is off by the walker's own step (and zig-zag): only that walker is scored
    for report, step_m in ((first, 0.6), (second, np.hypot(0.2, 0.1))):
        assert report["tracks"] == 1
        held = report["baselines"]["constant-position"]["error_m"]["0.4"]
        assert held["mean"] == pytest.approx(step_m, rel=1e-5)
        assert report["baselines"]["cv-ml"]["fitted_on"] == "the other half"
    assert first["baselines"]["cv-ml"]["r"] > 100 * second["baselines"]["cv-ml"]["r"]
    assert main(["eval", "estimator", "--scenario", "kelly", "--half", "1"]) == 2
    assert "--half goes with --data" in capsys.readouterr().err
    plot = ["eval", "estimator", "--data", str(path), "--half", "1", "--plot", str(tmp_path)]
    assert main(plot) == 2
    assert "without --plot" in capsys.readouterr().err
