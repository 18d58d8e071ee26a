"""`gazed calibrate`: the frontal-plane -> ground homography from a calibration file.

    gazed calibrate points FILE [--kinematics pan-tilt|tilt-pan] [--rig RIG] [--json] [--write RIG]
    gazed calibrate lines FILE  [--kinematics pan-tilt|tilt-pan] [--rig RIG] [--json] [--write RIG]
    gazed calibrate trace --rig RIG --lines FILE [--json] [--write RIG]   (gazed/gaze/trace_cli.py)

FILE formats: calibration_file.py. The head's kinematics come from --kinematics, the file's
`kinematics` key or the rig's [head] (they must agree when several are given); the rig (--rig,
or the one --write updates) also gives the joint limits calibration angles must respect.

Output: a table of every entry with its ground residual and its leave-one-out error (the
distance at which the homography of all the *other* entries places it: the one entry that
disagrees with the rest stands out there, where a plain least-squares residual spreads its
error over its neighbours), the entry that stands out if any, the homography and the camera
position it implies. `--json` prints exactly
{"homography": [[...], [...], [...]], "n": N, "rms_m": r, "max_m": m, "residuals_m": [...]}.
`--write RIG` stores the homography in the rig's [calibration], keeping comments and layout.
Exit 0 on success, 2 on a bad file, degenerate input or a bad rig (the message names the
line or entry at fault).

A method is a command of the `calibrate` group in `gazed.cli.COMMANDS`: its
`NAME_arguments` adds its own arguments and `calibrate_options`, and its `NAME_command` is
`calibrate(args, NAME, solve)`, where `solve` turns the parsed arguments into a `Solved`;
output and --write are shared.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tomlkit

from gazed.config import HeadSection, Rig, RigError, load_rig_or_exit, parse_rig
from gazed.geometry.calibration import CalibrationError, CalibrationResult
from gazed.geometry.calibration_file import (
    CalibrationFile,
    CalibrationFileError,
    read_calibration_file,
)
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.line_calibration import calibrate_lines
from gazed.geometry.point_calibration import calibrate_points


@dataclass(frozen=True)
class Solved:
    """A fit and how to show it: the input columns of each entry, in the result's order."""

    result: CalibrationResult
    source: str
    columns: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]


Solve = Callable[[argparse.Namespace, Rig | None], Solved]


def calibrate_options(parser: argparse.ArgumentParser) -> None:
    """The options every method shares: the rig, JSON output, writing the result."""
    parser.add_argument(
        "--rig",
        type=Path,
        help="rig whose [head] gives the kinematics and joint limits (default: the --write rig)",
    )
    parser.add_argument("--json", action="store_true", help="print the result as one JSON object")
    parser.add_argument(
        "--write",
        type=Path,
        metavar="RIG",
        help="store the homography in this rig's [calibration], keeping its comments",
    )


def calibrate(args: argparse.Namespace, method: str, solve: Solve) -> int:
    """Solve with `method`, print the result, and store it with --write."""
    rig_path = args.rig or args.write
    rig = load_rig_or_exit(rig_path) if rig_path is not None else None
    try:
        solved = solve(args, rig)
    except CalibrationFileError as exc:
        print(f"gazed calibrate {method}: {exc}", file=sys.stderr)
        return 2
    result = solved.result
    print(_json(result) if args.json else _report(solved))
    if args.write is not None:
        note = (
            f"gazed calibrate {method} {solved.source}: n = {result.n}, "
            f"rms {result.rms_m:.3f} m, max {result.max_m:.3f} m"
        )
        try:
            write_homography(args.write, result.homography.matrix, note)
        except (OSError, RigError) as exc:
            print(f"gazed calibrate: cannot write {args.write}: {exc}", file=sys.stderr)
            return 2
        print(f"wrote [calibration] homography to {args.write}", file=sys.stderr)
    return 0


def points_arguments(parser: argparse.ArgumentParser) -> None:
    _file_arguments(parser, "TOML with [[point]] tables, or CSV with pan_deg,tilt_deg,x_m,y_m")
    calibrate_options(parser)


def points_command(args: argparse.Namespace) -> int:
    return calibrate(args, "points", _solve_points)


def lines_arguments(parser: argparse.ArgumentParser) -> None:
    _file_arguments(parser, "TOML with [[line]] tables (phi_deg, d_m, samples_deg)")
    calibrate_options(parser)


def lines_command(args: argparse.Namespace) -> int:
    return calibrate(args, "lines", _solve_lines)


def write_homography(rig_path: Path, matrix: np.ndarray, note: str) -> None:
    """Set [calibration] homography in a rig file, keeping its comments and layout; the new
    text is validated as a rig before it atomically replaces the file."""
    document = tomlkit.parse(rig_path.read_text(encoding="utf-8"))
    rows = tomlkit.array()
    rows.multiline(True)
    for row in np.asarray(matrix, dtype=float):
        rows.append([float(v) for v in row])
    rows.comment(note)
    if "calibration" not in document:
        document["calibration"] = tomlkit.table()
    document["calibration"]["homography"] = rows
    replace_rig(rig_path, document)


def replace_rig(rig_path: Path, document: tomlkit.TOMLDocument) -> None:
    """Write an edited rig document over its file: validated as a rig first, then atomically."""
    text = tomlkit.dumps(document)
    parse_rig(text, rig_path)
    with tempfile.NamedTemporaryFile(
        "w", encoding="utf-8", dir=rig_path.parent, prefix=f".{rig_path.name}.", delete=False
    ) as handle:
        handle.write(text)
    shutil.copymode(rig_path, handle.name)
    os.replace(handle.name, rig_path)


def _file_arguments(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument("file", type=Path, metavar="FILE", help=what)
    parser.add_argument(
        "--kinematics",
        choices=("pan-tilt", "tilt-pan"),
        help="the head's axis order (else the file's `kinematics` or the rig's [head])",
    )


def _solve_points(args: argparse.Namespace, rig: Rig | None) -> Solved:
    file = read_calibration_file(args.file)
    if not file.points:
        raise CalibrationFileError(f"{file.path}: no calibration points ([[point]] tables)")
    head, limits = _head(file, args.kinematics, rig)
    angle_noise_rad = (rig.head if rig is not None else HeadSection()).angle_noise_rad
    try:
        result = calibrate_points(file.points, head, limits, angle_noise_rad)
    except CalibrationError as exc:
        raise CalibrationFileError(f"{file.path}: {exc}") from exc
    rows = tuple(
        (
            p.label,
            f"{np.degrees(p.pan_rad):.3f}",
            f"{np.degrees(p.tilt_rad):.3f}",
            f"{p.x_m:.3f}",
            f"{p.y_m:.3f}",
        )
        for p in file.points
    )
    return Solved(result, str(file.path), ("point", "pan_deg", "tilt_deg", "x_m", "y_m"), rows)


def _solve_lines(args: argparse.Namespace, rig: Rig | None) -> Solved:
    file = read_calibration_file(args.file)
    if not file.lines:
        raise CalibrationFileError(f"{file.path}: no calibration lines ([[line]] tables)")
    head, limits = _head(file, args.kinematics, rig)
    try:
        result = calibrate_lines(file.lines, head, limits)
    except CalibrationError as exc:
        raise CalibrationFileError(f"{file.path}: {exc}") from exc
    rows = tuple(
        (
            line.label,
            f"{np.degrees(line.phi_rad):.3f}",
            f"{line.d_m:.3f}",
            str(len(line.samples_rad)),
        )
        for line in file.lines
    )
    return Solved(result, str(file.path), ("line", "phi_deg", "d_m", "samples"), rows)


def _head(
    file: CalibrationFile, flag: str | None, rig: Rig | None
) -> tuple[HeadKinematics, HeadSection | None]:
    """Kinematics from the flag, the file and the rig (which must agree); limits from the rig."""
    sources = {"--kinematics": flag, f"{file.path}": file.kinematics}
    if rig is not None:
        sources[f"rig {rig.source_path} [head]"] = rig.head.kinematics
    given = {name: value for name, value in sources.items() if value is not None}
    if not given:
        raise CalibrationFileError(
            f"{file.path}: kinematics unknown: give --kinematics, `kinematics = ...` in the file, "
            "or --rig/--write RIG"
        )
    if len(set(given.values())) > 1:
        said = ", ".join(f"{name} says {value}" for name, value in given.items())
        raise CalibrationFileError(f"{file.path}: kinematics disagree: {said}")
    return HeadKinematics(next(iter(given.values()))), rig.head if rig is not None else None


def _json(result: CalibrationResult) -> str:
    return json.dumps(
        {
            "homography": result.homography.matrix.tolist(),
            "n": result.n,
            "rms_m": result.rms_m,
            "max_m": result.max_m,
            "residuals_m": result.residuals_m.tolist(),
        }
    )


def _report(solved: Solved) -> str:
    result = solved.result
    kind = solved.columns[0]
    header = (*solved.columns, "residual_m", "loo_m")
    body = [
        (*row, f"{residual:.3f}", "-" if loo is None else f"{loo:.3f}")
        for row, residual, loo in zip(
            solved.rows, result.residuals_m, result.leave_one_out_m, strict=True
        )
    ]
    widths = [max(len(str(cell)) for cell in column) for column in zip(header, *body, strict=True)]
    lines = [f"{solved.source}: {result.n} {kind}s"]
    lines += [
        "  ".join(
            cell.ljust(width) if i == 0 else cell.rjust(width)
            for i, (cell, width) in enumerate(zip(row, widths, strict=True))
        )
        for row in (header, *body)
    ]
    worst = result.labels[int(np.argmax(result.residuals_m))]
    at = f" ({worst})" if round(result.max_m, 3) > 0 else ""
    lines.append(f"rms {result.rms_m:.3f} m, max {result.max_m:.3f} m{at}")
    lines.append(
        "loo_m: how far the homography of all the other entries places this one "
        "(large: this entry disagrees with the rest)"
        if result.n >= 5
        else f"{result.n} {kind}s fix the homography exactly, so they cannot check each other: "
        f"add {kind}s to find a wrong one"
    )
    if result.angle_rms_rad is not None:
        lines.append(f"angle residual rms {np.degrees(result.angle_rms_rad):.4f} deg")
    if result.outlier is not None:
        outlier = result.outlier
        lines.append(
            f"{result.labels[outlier.index]} stands out: the other {result.n - 1} {kind}s agree "
            f"with each other (P = {outlier.probability_without:.2g}) and miss its gaze by "
            f"{np.degrees(outlier.miss_rad):.3f} deg; with it the {kind}s disagree beyond the "
            f"head's angle noise (P = {outlier.probability_with:.1e}): check its angles and "
            "ground coordinates"
        )
    elif result.consistent is False:
        lines.append(
            f"the {kind}s disagree beyond the head's angle noise ([head] angle_noise_deg) and no "
            f"single {kind} explains it: check the kinematics, the noise setting or several {kind}s"
        )
    homography = result.homography
    scale = "M33 = 1" if homography.rest_gaze_meets_ground else "unit third row: level rest gaze"
    lines.append(f"homography M (frontal plane -> ground, {scale}):")
    lines += ["  [" + "  ".join(f"{v:14.9g}" for v in row) + " ]" for row in homography.matrix]
    x, y, z = homography.implied_camera_xyz_m()
    lines.append(
        f"implied camera rotation centre: X {x:.2f} m, Y {y:.2f} m, height {z:.2f} m "
        "(a plausibility check; [calibration] camera_xyz_m)"
    )
    return "\n".join(lines)
