"""`gazed calibrate points|lines`: the table names the point that is off, --json prints exactly
the documented object, --write keeps the rig's comments, bad files exit 2 naming the line or
entry, and the example calibrations under configs/calibration/ solve."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from gazed import cli
from gazed.config import load_rig
from gazed.geometry import calibrate_cli
from gazed.geometry.ground import GroundGeometry
from gazed.geometry.pose import CameraPose

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "configs" / "calibration"
LAWN_POINTS = EXAMPLES / "lawn_points.toml"


def run(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = cli.main(["calibrate", *args])
    out, err = capsys.readouterr()
    return code, out, err


def test_eight_noisy_points_print_residuals_that_name_the_wrong_point(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, _ = run(["points", str(LAWN_POINTS)], capsys)
    assert code == 0
    assert "8 points" in out and "stands out" not in out
    rows = [line for line in out.splitlines() if re.match(r"point \d", line)]
    assert len(rows) == 8 and rows[5].startswith("point 6 (F)")
    # the same survey with mark F's y mistyped (3.95 -> 4.95)
    wrong = tmp_path / "wrong.toml"
    text = LAWN_POINTS.read_text()
    assert text.count("y_m = 3.95\n") == 2
    wrong.write_text(text.replace("y_m = 3.95\n", "y_m = 4.95\n", 1))
    code, out, _ = run(["points", str(wrong)], capsys)
    assert code == 0
    verdict = [line for line in out.splitlines() if "stands out" in line]
    assert len(verdict) == 1 and verdict[0].startswith("point 6 (F) stands out")
    assert "check its angles and ground coordinates" in verdict[0]
    row = next(line for line in out.splitlines() if line.startswith("point 6 (F)"))
    loo_m = float(row.split()[-1])
    assert 0.5 < loo_m < 1.5  # the others place F about the mistyped metre away


def test_json_is_exactly_the_documented_object(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(["points", str(LAWN_POINTS), "--json"], capsys)
    assert code == 0
    result = json.loads(out)
    assert list(result) == ["homography", "n", "rms_m", "max_m", "residuals_m"]
    assert np.array(result["homography"]).shape == (3, 3) and result["homography"][2][2] == 1.0
    residuals = np.array(result["residuals_m"])
    assert result["n"] == len(residuals) == 8
    assert result["rms_m"] == pytest.approx(math.sqrt(np.mean(residuals**2)))
    assert result["max_m"] == pytest.approx(residuals.max())
    # the lawn marks carry 0.05° noise, seen from 40-60 m at 19.2 m height: decimetres
    assert 0.02 < result["rms_m"] < 0.3


def test_csv_gives_the_same_result_as_toml(capsys: pytest.CaptureFixture[str]) -> None:
    _, toml_out, _ = run(["points", str(LAWN_POINTS), "--json"], capsys)
    code, csv_out, _ = run(
        ["points", str(EXAMPLES / "lawn_points.csv"), "--kinematics", "tilt-pan", "--json"], capsys
    )
    assert code == 0
    assert np.array(json.loads(csv_out)["homography"]) == pytest.approx(
        np.array(json.loads(toml_out)["homography"]), rel=1e-12
    )


def test_lines_solve_the_lawn(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(["lines", str(EXAMPLES / "lawn_lines.toml")], capsys)
    assert code == 0 and "4 lines" in out and "line 1 (edge AB)" in out
    _, json_out, _ = run(["lines", str(EXAMPLES / "lawn_lines.toml"), "--json"], capsys)
    lines_result = json.loads(json_out)
    _, points_out, _ = run(["points", str(LAWN_POINTS), "--json"], capsys)
    points_result = json.loads(points_out)
    assert lines_result["n"] == 4 and lines_result["rms_m"] < 0.3
    # lines and points of the same lawn agree: centre of the lawn within half a metre
    centre = []
    for result in (lines_result, points_result):
        homography = np.array(result["homography"])
        truth = CameraPose(np.array([44.7, -32.7, 19.2]), math.radians(120.8), math.radians(-21.9))
        ray = truth.frontal_to_ground().direction_from_ground(np.array([10.55, 3.95]))
        mapped = homography @ ray
        centre.append(mapped[:2] / mapped[2])
    assert np.linalg.norm(centre[0] - centre[1]) < 0.5


RIG = """\
# The lawn rig, as a person wrote it.
[rig]
name = "lawn"  # sixth floor

[head]
kinematics = "tilt-pan"   # the elevation axis is outer

[calibration]
# measured with a tape
camera_xyz_m = [44.7, -32.7, 19.2]

[gaze]
rate_hz = 40.0
"""


def test_write_stores_the_homography_keeping_comments_and_layout(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rig_path = tmp_path / "lawn.toml"
    rig_path.write_text(RIG)
    rig_path.chmod(0o644)
    code, out, err = run(["points", str(LAWN_POINTS), "--write", str(rig_path), "--json"], capsys)
    assert rig_path.stat().st_mode & 0o777 == 0o644
    assert code == 0 and f"wrote [calibration] homography to {rig_path}" in err
    written = rig_path.read_text()
    for original in RIG.splitlines():
        assert original in written
    assert "# gazed calibrate points" in written and "n = 8" in written
    rig = load_rig(rig_path)
    assert np.array(rig.calibration.homography) == pytest.approx(
        np.array(json.loads(out)["homography"]), rel=1e-15
    )
    assert rig.calibration.camera_xyz_m == (44.7, -32.7, 19.2) and rig.gaze.rate_hz == 40.0
    # a second calibration replaces the first
    code, out, _ = run(
        ["lines", str(EXAMPLES / "lawn_lines.toml"), "--write", str(rig_path), "--json"], capsys
    )
    assert code == 0 and rig_path.read_text().count("homography") == 1
    stored = np.array(load_rig(rig_path).calibration.homography)
    assert stored == pytest.approx(np.array(json.loads(out)["homography"]), rel=1e-15)


def test_calibrating_the_simulated_rig_recovers_its_true_geometry(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rig_path = tmp_path / "sim.toml"
    rig_path.write_text((REPO / "configs" / "sim.toml").read_text())
    code, out, _ = run(
        ["points", str(EXAMPLES / "sim_points.toml"), "--write", str(rig_path)], capsys
    )
    assert code == 0 and "M33 = 1" in out
    rig = load_rig(rig_path)
    geometry = GroundGeometry.from_rig(rig)
    truth = CameraPose.from_rig(rig).frontal_to_ground()
    grid = np.stack(np.meshgrid(np.linspace(-8, 8, 5), np.linspace(-3, 12, 5)), -1).reshape(-1, 2)
    mapped = geometry.homography.ground_from_direction(truth.direction_from_ground(grid))
    assert np.abs(mapped - grid).max() < 1e-5  # angles are written to 1e-6°


def test_kinematics_must_be_known_and_agree(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    csv_path = EXAMPLES / "lawn_points.csv"
    code, _, err = run(["points", str(csv_path)], capsys)
    assert code == 2 and "kinematics unknown" in err
    rig_path = tmp_path / "pan-tilt.toml"
    rig_path.write_text('[rig]\nname = "pt"\n[head]\nkinematics = "pan-tilt"\n')
    code, _, err = run(["points", str(LAWN_POINTS), "--write", str(rig_path)], capsys)
    assert (
        code == 2 and "kinematics disagree" in err and f"rig {rig_path} [head] says pan-tilt" in err
    )
    assert "homography" not in rig_path.read_text()  # nothing written


def test_angles_outside_the_rigs_limits_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rig_path = tmp_path / "narrow.toml"
    rig_path.write_text(
        '[rig]\nname = "narrow"\n[head]\nkinematics = "tilt-pan"\npan_min_deg = -20.0\n'
    )
    code, _, err = run(["points", str(LAWN_POINTS), "--rig", str(rig_path)], capsys)
    assert code == 2
    assert "point 1 (A): pan -21.575 deg is outside the head's pan limits [-20, 170] deg" in err


POINT = "[[point]]\npan_deg = {pan}\ntilt_deg = {tilt}\nx_m = {x}\ny_m = {y}\n"
GOOD = [
    ("-26.565", "-30.807", "-3", "0"),
    ("26.565", "-30.807", "3", "0"),
    ("14.036", "-17.920", "3", "6"),
    ("-14.036", "-17.920", "-3", "6"),
]


def points_text(entries=GOOD) -> str:
    return 'kinematics = "pan-tilt"\n\n' + "\n".join(
        POINT.format(pan=p, tilt=t, x=x, y=y) for p, t, x, y in entries
    )


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            points_text().replace("tilt_deg = -30.807\nx_m = 3", "x_m = 3"),
            "{f}:9: [[point]] #2: tilt_deg: missing",
        ),
        (
            points_text().replace("tilt_deg = -17.920\nx_m = 3", 'tilt_deg = "abc"\nx_m = 3'),
            "{f}:15: [[point]] #3: tilt_deg: expected a finite number, got 'abc'",
        ),
        (
            points_text().replace("pan_deg = -14.036", "pan_deg = nan"),
            "[[point]] #4: pan_deg: expected a finite number, got nan",
        ),
        (
            points_text().replace("tilt_deg = -30.807\nx_m = -3", "tilt_dg = -30.807\nx_m = -3"),
            "[[point]] #1: tilt_dg: unknown key (did you mean 'tilt_deg'?)",
        ),
        (points_text().replace("x_m = 3\ny_m = 6", "x_m = 3\ny_m = = 6"), "TOML syntax error"),
        ('kinematics = "pan-tilt"\n', "no calibration points"),
        (
            points_text().replace('"pan-tilt"', '"pan-pan"'),
            "kinematics: expected one of 'pan-tilt', 'tilt-pan', got 'pan-pan'",
        ),
        (points_text(GOOD[:3]), "need at least 4 points to fix the homography, got 3"),
        (
            points_text([*GOOD[:2], ("0.0", "-33.69", "0", "0"), GOOD[3]]),
            "point 1, point 2 and point 3 are collinear on the ground",
        ),
        (
            points_text([*GOOD[:3], ("95.0", "-17.92", "-3", "6")]),
            "point 4: gaze (pan 95.000, tilt -17.920 deg) does not meet the frontal plane",
        ),
    ],
)
def test_bad_point_files_exit_2_naming_the_line_or_entry(
    text: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "points.toml"
    path.write_text(text)
    code, out, err = run(["points", str(path)], capsys)
    assert code == 2 and out == ""
    assert message.format(f=path) in err


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("pan,tilt,x_m,y_m\n1,2,3,4\n", "{f}:1: header: expected pan_deg,tilt_deg,x_m,y_m"),
        (
            "# survey\npan_deg,tilt_deg,x_m,y_m\n1,2,3,4\n1,x,3,4\n",
            "{f}:4: tilt_deg: expected a finite number, got 'x'",
        ),
        (
            "pan_deg,tilt_deg,x_m,y_m\n1,2,3\n",
            "{f}:2: expected 4 values (pan_deg,tilt_deg,x_m,y_m), got 3",
        ),
        ("", "{f}: empty"),
    ],
)
def test_bad_csv_files_exit_2_naming_the_line(
    text: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "points.csv"
    path.write_text(text)
    code, _, err = run(["points", str(path), "--kinematics", "pan-tilt"], capsys)
    assert code == 2 and message.format(f=path) in err


LINE = "[[line]]\nphi_deg = {phi}\nd_m = {d}\nsamples_deg = {samples}\n"


@pytest.mark.parametrize(
    ("samples", "message"),
    [
        (
            "[[1.0], [2.0, 3.0]]",
            "{f}:2: [[line]] #1: samples_deg[1]: "
            "expected [pan, tilt] as two finite numbers, got [1.0]",
        ),
        ('"along the kerb"', "[[line]] #1: samples_deg: expected [[pan, tilt], ...]"),
        ("[[-10.0, -30.0]]", "line 1: needs at least 2 distinct gaze samples"),
    ],
)
def test_bad_line_files_exit_2_naming_the_entry(
    samples: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "lines.toml"
    other = "[[-5.0, -30.0], [5.0, -30.0]]"
    path.write_text(
        'kinematics = "pan-tilt"\n'
        + LINE.format(phi=90, d=0, samples=samples)
        + "".join(LINE.format(phi=phi, d=d, samples=other) for phi, d in ((0, 3), (90, 6), (0, -3)))
    )
    code, _, err = run(["lines", str(path)], capsys)
    assert code == 2 and message.format(f=path) in err


def test_an_unreadable_file_and_a_bad_rig_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = run(
        ["points", str(tmp_path / "missing.toml"), "--kinematics", "pan-tilt"], capsys
    )
    assert code == 2 and "cannot read" in err
    bad_rig = tmp_path / "bad.toml"
    bad_rig.write_text('[rig]\nname = "x"\n[head]\npan_max_dg = 3\n')
    code = cli.main(["calibrate", "points", str(LAWN_POINTS), "--write", str(bad_rig)])
    assert code == 2
    assert "head.pan_max_dg: unknown key" in capsys.readouterr().err


def replay_arguments(parser) -> None:
    """The arguments of the `replay` method below."""
    parser.add_argument("--marks", type=Path, required=True)
    calibrate_cli.calibrate_options(parser)


def replay_command(args) -> int:
    """A method made of a solve step; output and --write are calibrate_cli's."""
    from gazed.geometry.calibration_file import read_calibration_file
    from gazed.geometry.kinematics import HeadKinematics
    from gazed.geometry.point_calibration import calibrate_points

    def solve(args, rig) -> calibrate_cli.Solved:
        points = read_calibration_file(args.marks).points
        result = calibrate_points(points, HeadKinematics("tilt-pan"), None, math.radians(0.05))
        rows = tuple((p.label,) for p in points)
        return calibrate_cli.Solved(result, "live", ("mark",), rows)

    return calibrate_cli.calibrate(args, "replay", solve)


def test_a_new_method_is_one_entry_in_the_calibrate_group(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """How a method plugs in: its own arguments, a solve step, shared output and --write."""
    group = cli.COMMANDS["calibrate"]
    assert isinstance(group, cli.Group)
    extended = cli.Group(
        group.help, {**group.commands, "replay": cli.Command(__name__, "replay marks")}
    )
    monkeypatch.setitem(cli.COMMANDS, "calibrate", extended)
    code, out, _ = run(["replay", "--marks", str(LAWN_POINTS)], capsys)
    assert code == 0 and out.startswith("live: 8 marks") and "point 8 (H)" in out


@pytest.mark.parametrize(
    "path", sorted(p for p in EXAMPLES.glob("*") if "trace" not in p.name), ids=lambda p: p.name
)  # a trace file (gazed calibrate trace) holds start gazes, not samples
def test_every_example_calibration_solves(path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    method = "lines" if "lines" in path.name else "points"
    extra = ["--kinematics", "tilt-pan"] if path.suffix == ".csv" else []
    code, out, err = run([method, str(path), "--json", *extra], capsys)
    assert code == 0, err
    assert json.loads(out)["rms_m"] < 0.3
