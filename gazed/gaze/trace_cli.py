"""`gazed calibrate trace --rig RIG --lines FILE`: calibrate the ground homography by tracing
ground lines with the running rig (seed 000 §3.2.1).

For each line of FILE the command asks the rig's gaze process to trace it (`gaze/command`):
the head moves to the line's start gaze, and the gaze controller follows the line's image edge
(`vision/edge`: Canny in the fovea, the edge nearest the centre, a step along it) collecting
the joint angles of the edge points until a corner, a lost edge, enough samples or a joint
limit (`gaze/trace`). The samples of all lines then go to the line calibration of §3.2 (no
endpoint matching). On a simulated rig the traced homography is also scored against the true
one over the calibrated area (stderr, so that `--json` stays exactly the calibration's).

FILE (TOML): one `[[line]]` per ground line, as for `gazed calibrate lines` but with a start
gaze near the line instead of samples:

    [[line]]
    phi_deg = 0.0            # the line's normal angle on the ground
    d_m = -3.0               # its signed distance from the origin
    start_deg = [-31.5, -9.0]   # [pan, tilt] looking near the line
    max_samples = 20         # optional
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gazed.bus import Subscription
from gazed.bustools.gaze_answer import gaze_listens
from gazed.bustools.tool_session import NoRunningRig, tool_session
from gazed.config import Rig
from gazed.geometry.calibrate_cli import Solved, calibrate, calibrate_options
from gazed.geometry.calibration import CalibrationError
from gazed.geometry.calibration_file import CalibrationFileError
from gazed.geometry.homography import GroundHomography
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.line_calibration import CalibrationLine, calibrate_lines
from gazed.geometry.pose import CameraPose
from gazed.messages import GazeCommand, TraceResult
from gazed.topics import GAZE_COMMAND, GAZE_TRACE
from gazed.wakeup import Wakeup

GAZE_WAIT_S = 10.0
LINE_TIMEOUT_S = 120.0


@dataclass(frozen=True)
class TraceLine:
    label: str
    phi_rad: float
    d_m: float
    start_rad: tuple[float, float]
    max_samples: int


def read_trace_file(path: Path) -> list[TraceLine]:
    """The lines of a trace file; CalibrationFileError naming the entry at fault."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise CalibrationFileError(f"{path}: cannot read: {exc.strerror or exc}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise CalibrationFileError(f"{path}: TOML syntax error: {exc}") from exc
    entries = data.get("line", [])
    if not isinstance(entries, list) or len(entries) < 4:
        raise CalibrationFileError(f"{path}: a line calibration needs at least 4 [[line]] entries")
    lines = []
    for k, entry in enumerate(entries, start=1):
        label = f"line {k}"
        try:
            start = entry["start_deg"]
            if len(start) != 2:
                raise ValueError("start_deg must be [pan_deg, tilt_deg]")
            values = [
                float(entry["phi_deg"]),
                float(entry["d_m"]),
                float(start[0]),
                float(start[1]),
            ]
            if not all(math.isfinite(v) for v in values):
                raise ValueError("not finite")
            max_samples = int(entry.get("max_samples", 20))
            if not 2 <= max_samples <= 1000:
                raise ValueError("max_samples must be 2 to 1000")
        except (KeyError, TypeError, ValueError) as exc:
            raise CalibrationFileError(
                f"{path}: {label}: {exc} (expected phi_deg, d_m, start_deg = [pan, tilt])"
            ) from exc
        lines.append(
            TraceLine(
                label,
                math.radians(values[0]),
                values[1],
                (math.radians(values[2]), math.radians(values[3])),
                max_samples,
            )
        )
    return lines


def trace_lines(rig: Rig, lines: list[TraceLine]) -> list[tuple[TraceLine, TraceResult]]:
    """Have the rig's gaze process trace each line; its samples and why each trace ended."""
    try:
        with tool_session(rig, "calibrate") as (bus, wakeup):
            commands = bus.publisher(GAZE_COMMAND)
            results = bus.subscribe(GAZE_TRACE)
            if not gaze_listens(commands, wakeup, time.monotonic() + GAZE_WAIT_S):
                raise CalibrationFileError(
                    f"rig '{rig.name}': no gaze process reads {GAZE_COMMAND.suffix}"
                )
            traced = []
            for k, line in enumerate(lines):
                request_id = f"trace-{k + 1}-{time.time_ns()}"
                pan, tilt = line.start_rad
                commands.put(
                    GazeCommand(
                        t_capture_ns=time.time_ns(),
                        command="trace",
                        request_id=request_id,
                        pan_rad=pan,
                        tilt_rad=tilt,
                        max_samples=line.max_samples,
                    )
                )
                print(f"tracing {line.label} ...", file=sys.stderr, flush=True)
                traced.append((line, _wait_result(wakeup, results, request_id, line)))
            return traced
    except NoRunningRig as exc:
        raise CalibrationFileError(str(exc)) from exc


def _wait_result(
    wakeup: Wakeup, results: Subscription[TraceResult], request_id: str, line: TraceLine
) -> TraceResult:
    deadline = time.monotonic() + LINE_TIMEOUT_S
    while time.monotonic() < deadline:
        wakeup.wait(0.5)
        for result in results.take():
            if result.request_id == request_id:
                print(
                    f"  {len(result.samples_rad)} samples, ended by {result.reason}",
                    file=sys.stderr,
                )
                return result
    raise CalibrationFileError(f"{line.label}: no trace result within {LINE_TIMEOUT_S:g} s")


def calibration_lines(traced: list[tuple[TraceLine, TraceResult]]) -> list[CalibrationLine]:
    return [
        CalibrationLine(
            line.phi_rad, line.d_m, np.array(result.samples_rad).reshape(-1, 2), line.label
        )
        for line, result in traced
    ]


def truth_error_m(
    rig: Rig, homography: GroundHomography, lines: list[CalibrationLine]
) -> tuple[float, float]:
    """On a simulated rig: (max, rms) ground distance between where the traced and the true
    homographies put the points of the calibrated area (the hull of the traced samples' ground
    points, sampled on a grid)."""
    truth = CameraPose.from_rig(rig).frontal_to_ground()
    head = HeadKinematics.from_section(rig.head)
    samples = np.vstack([line.samples_rad for line in lines])
    directions = np.stack([head.gaze(float(p), float(t)) for p, t in samples])
    ground = truth.ground_from_direction(directions)
    low, high = ground.min(axis=0), ground.max(axis=0)
    xs, ys = np.meshgrid(np.linspace(low[0], high[0], 15), np.linspace(low[1], high[1], 15))
    grid = np.stack([xs.ravel(), ys.ravel()], axis=-1)
    mapped = homography.ground_from_direction(truth.direction_from_ground(grid))
    errors = np.hypot(*(mapped - grid).T)
    return float(errors.max()), float(np.sqrt(np.mean(errors**2)))


def trace_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--lines", type=Path, required=True, help="ground lines and a start gaze near each (TOML)"
    )
    calibrate_options(parser)


def trace_command(args: argparse.Namespace) -> int:
    return calibrate(args, "trace", solve_trace)


def solve_trace(args: argparse.Namespace, rig: Rig | None) -> Solved:
    """The `trace` method of `gazed calibrate`: trace, then the line calibration."""
    if rig is None:
        raise CalibrationFileError("trace needs the running rig: --rig RIG")
    traced = trace_lines(rig, read_trace_file(args.lines))
    lines = calibration_lines(traced)
    short = [line.label for line in lines if len(line.samples_rad) < 2]
    if short:
        raise CalibrationFileError(f"{args.lines}: too few samples traced on {', '.join(short)}")
    try:
        result = calibrate_lines(lines, HeadKinematics.from_section(rig.head), rig.head)
    except CalibrationError as exc:
        raise CalibrationFileError(f"{args.lines}: {exc}") from exc
    if rig.services.sim.enabled:
        worst, rms = truth_error_m(rig, result.homography, lines)
        print(
            f"simulator: the traced homography against the true one over the calibrated area: "
            f"max {worst:.3f} m, rms {rms:.3f} m",
            file=sys.stderr,
        )
    rows = tuple(
        (
            line.label,
            f"{math.degrees(line.phi_rad):.3f}",
            f"{line.d_m:.3f}",
            str(len(result_.samples_rad)),
            result_.reason,
        )
        for line, result_ in traced
    )
    return Solved(result, str(args.lines), ("line", "phi_deg", "d_m", "samples", "ended by"), rows)
