"""Calibration files for `gazed calibrate`: TOML with [[point]] and [[line]] tables, or CSV
points. Angles are gazed joint angles in degrees (as odometry and `gazed servo` report them,
after [head] signs and zero offsets); ground coordinates in metres.

    kinematics = "pan-tilt"          # optional if --kinematics or the rig gives it
    [[point]]
    name = "A"                       # optional
    pan_deg = 1.24
    tilt_deg = 21.51
    x_m = 0.0
    y_m = 0.0

    [[line]]                          # ground line: normal angle phi, signed distance d (§3.2)
    phi_deg = 90.0
    d_m = 7.9
    samples_deg = [[3.1, 16.2], [2.0, 12.5], [0.4, 8.8]]   # [pan, tilt] traced along it

CSV: a header `pan_deg,tilt_deg,x_m,y_m` (and optionally `name`), one point per row; blank
lines and lines starting with `#` are skipped. Errors name the file, the line and the entry.
"""

from __future__ import annotations

import csv
import difflib
import math
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, get_args

import numpy as np

from gazed.geometry.kinematics import Kinematics
from gazed.geometry.line_calibration import CalibrationLine
from gazed.geometry.point_calibration import CalibrationPoint

POINT_KEYS = ("pan_deg", "tilt_deg", "x_m", "y_m")
LINE_KEYS = ("phi_deg", "d_m", "samples_deg")
TOP_KEYS = ("kinematics", "point", "line")


class CalibrationFileError(ValueError):
    """A calibration file that cannot be read; the message names the file, line and entry."""


@dataclass(frozen=True)
class CalibrationFile:
    path: Path
    kinematics: Kinematics | None
    points: tuple[CalibrationPoint, ...]
    lines: tuple[CalibrationLine, ...]


def read_calibration_file(path: Path) -> CalibrationFile:
    """Read a TOML (any suffix but .csv) or CSV calibration file."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise CalibrationFileError(f"{path}: cannot read: {exc}") from exc
    if path.suffix.lower() == ".csv":
        return CalibrationFile(path, None, _csv_points(path, text), ())
    return _toml_file(path, text)


def _toml_file(path: Path, text: str) -> CalibrationFile:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CalibrationFileError(f"{path}: TOML syntax error: {exc}") from exc
    _check_keys(data, TOP_KEYS, f"{path}: (top level)")
    kinematics = data.get("kinematics")
    allowed = get_args(Kinematics)
    if kinematics is not None and kinematics not in allowed:
        raise CalibrationFileError(
            f"{path}: kinematics: expected one of {', '.join(map(repr, allowed))}, "
            f"got {kinematics!r}"
        )
    points = tuple(
        _point(entry, f"point {k}", _where(path, text, "point", k))
        for k, entry in _entries(data, "point", path)
    )
    lines = tuple(
        _line(entry, f"line {k}", _where(path, text, "line", k))
        for k, entry in _entries(data, "line", path)
    )
    return CalibrationFile(path, kinematics, points, lines)


def _entries(data: dict[str, Any], table: str, path: Path) -> list[tuple[int, dict[str, Any]]]:
    entries = data.get(table, [])
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise CalibrationFileError(f"{path}: {table}: expected [[{table}]] tables")
    return list(enumerate(entries, start=1))


def _where(path: Path, text: str, table: str, k: int) -> str:
    """'FILE:LINE: [[point]] #k' — the line of the k-th [[table]] header when it has one."""
    headers = [
        n
        for n, line in enumerate(text.splitlines(), start=1)
        if re.match(rf"^\s*\[\[\s*{table}\s*\]\]", line)
    ]
    line = f":{headers[k - 1]}" if k <= len(headers) else ""
    return f"{path}{line}: [[{table}]] #{k}"


def _point(entry: dict[str, Any], label: str, where: str) -> CalibrationPoint:
    _check_keys(entry, (*POINT_KEYS, "name"), where)
    pan, tilt, x, y = (_number(entry, key, where) for key in POINT_KEYS)
    return CalibrationPoint(
        math.radians(pan), math.radians(tilt), x, y, _label(label, entry.get("name"), where)
    )


def _line(entry: dict[str, Any], label: str, where: str) -> CalibrationLine:
    _check_keys(entry, (*LINE_KEYS, "name"), where)
    phi, d = _number(entry, "phi_deg", where), _number(entry, "d_m", where)
    samples = entry.get("samples_deg")
    if samples is None:
        raise CalibrationFileError(f"{where}: samples_deg: missing (expected [[pan, tilt], ...])")
    if not isinstance(samples, list):
        raise CalibrationFileError(f"{where}: samples_deg: expected [[pan, tilt], ...]")
    pairs = []
    for n, sample in enumerate(samples, start=1):
        if not (
            isinstance(sample, list)
            and len(sample) == 2
            and all(_is_finite_number(v) for v in sample)
        ):
            raise CalibrationFileError(
                f"{where}: samples_deg[{n}]: expected [pan, tilt] as two finite numbers, "
                f"got {sample!r}"
            )
        pairs.append(sample)
    samples_rad = np.radians(np.array(pairs, dtype=float).reshape(-1, 2))
    return CalibrationLine(
        math.radians(phi), d, samples_rad, _label(label, entry.get("name"), where)
    )


def _csv_points(path: Path, text: str) -> tuple[CalibrationPoint, ...]:
    header: list[str] | None = None
    points = []
    for number, raw in enumerate(text.splitlines(), start=1):
        if not raw.strip() or raw.lstrip().startswith("#"):
            continue
        cells = [c.strip() for c in next(csv.reader([raw]))]
        if header is None:
            if not set(POINT_KEYS) <= set(cells) or not set(cells) <= {*POINT_KEYS, "name"}:
                raise CalibrationFileError(
                    f"{path}:{number}: header: expected {','.join(POINT_KEYS)} (and optionally "
                    f"name), got {raw.strip()!r}"
                )
            header = cells
            continue
        where = f"{path}:{number}"
        if len(cells) != len(header):
            raise CalibrationFileError(
                f"{where}: expected {len(header)} values ({','.join(header)}), got {len(cells)}"
            )
        row = dict(zip(header, cells, strict=True))
        values = {key: _parse_number(row[key], key, where) for key in POINT_KEYS}
        label = _label(f"point {len(points) + 1}", row.get("name") or None, where)
        points.append(
            CalibrationPoint(
                math.radians(values["pan_deg"]),
                math.radians(values["tilt_deg"]),
                values["x_m"],
                values["y_m"],
                label,
            )
        )
    if header is None:
        raise CalibrationFileError(f"{path}: empty: expected a header {','.join(POINT_KEYS)}")
    return tuple(points)


def _check_keys(entry: dict[str, Any], known: tuple[str, ...], where: str) -> None:
    for key in entry:
        if key not in known:
            close = difflib.get_close_matches(key, known, n=1, cutoff=0.6)
            hint = (
                f"did you mean '{close[0]}'?" if close else f"expected one of: {', '.join(known)}"
            )
            raise CalibrationFileError(f"{where}: {key}: unknown key ({hint})")


def _number(entry: dict[str, Any], key: str, where: str) -> float:
    if key not in entry:
        raise CalibrationFileError(f"{where}: {key}: missing (expected a number)")
    value = entry[key]
    if not _is_finite_number(value):
        raise CalibrationFileError(f"{where}: {key}: expected a finite number, got {value!r}")
    return float(value)


def _parse_number(text: str, key: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise CalibrationFileError(f"{where}: {key}: expected a finite number, got {text!r}")
    return value


def _is_finite_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _label(label: str, name: Any, where: str) -> str:
    if name is None:
        return label
    if not isinstance(name, str):
        raise CalibrationFileError(f"{where}: name: expected a string, got {name!r}")
    return f"{label} ({name})"
