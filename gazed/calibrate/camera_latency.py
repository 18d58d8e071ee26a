"""`gazed calibrate latency --rig RIG`: the camera's delay from exposure to arrival, measured by
stepping the head and timing when the image moves.

With the rig running and its gaze process off (`head_session`), the command steps the head's
pan back and forth and watches two things: the odometry and the camera's frames. The image's
global shift between consecutive frames (phase correlation) is matched against the odometry's
rotation, per step, by `camera_delay.fit_lag`: the lag between the two is the delay from the
exposure to the frame's arrival stamp. The delays of the steps give the median and the
spread. A digital head renders its views at a known pose: there is no delay to measure.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gazed.calibrate.head_session import (
    CalibrationError,
    HeadSession,
    head_session,
    position_demand,
)
from gazed.config import Rig, load_rig_or_exit
from gazed.vision.camera_delay import ImageShift, fit_lag
from gazed.vision.frames import CapturedFrame, FrameError, gray_frame

RETURN_S = 0.5  # back at the start pose, the last frames arriving
MIN_RESPONSE = 0.05  # phase correlation peak below which a shift is noise
LAG_STEP_S = 0.002
MIN_LAG_S = -0.1
MIN_RATE_STD_RAD_S = math.radians(2.0)
MIN_EXPLAINED = 0.6


class LatencyCalibrationError(CalibrationError):
    """The measurement cannot be made; the message says why."""


@dataclass(frozen=True)
class Recording:
    """What the steps produced: shifts (N, 4: a_s, b_s, du_px, dv_px, arrival stamps of each
    frame pair), odometry (M, 3: t_s, pan_rad, tilt_rad) and each step's start (wall s)."""

    shifts: np.ndarray
    odometry: np.ndarray
    step_starts_s: list[float]
    hold_s: float


def step_delays_s(recording: Recording, max_delay_s: float) -> list[float | None]:
    """The delay found in each step: the shifts of frames that arrived during the step matched
    against all the odometry; None for a step without a fit."""
    lags_s = np.arange(MIN_LAG_S, max_delay_s + LAG_STEP_S / 2, LAG_STEP_S)
    delays: list[float | None] = []
    a = recording.shifts[:, 0] if len(recording.shifts) else np.empty(0)
    for start_s in recording.step_starts_s:
        inside = (a >= start_s) & (a < start_s + recording.hold_s)
        fit = fit_lag(
            recording.shifts[inside],
            recording.odometry,
            lags_s,
            MIN_RATE_STD_RAD_S,
            MIN_EXPLAINED,
        )
        delays.append(None if fit is None else fit.lag_s)
    return delays


def summary(delays_s: list[float | None]) -> dict[str, object]:
    """The median delay and its spread over the steps that gave one (ms)."""
    found = np.array([d for d in delays_s if d is not None]) * 1e3
    if len(found) < 2:
        raise LatencyCalibrationError(
            f"only {len(found)} of {len(delays_s)} steps showed the image moving with the head "
            "(is the scene textured, the camera the head's, the gaze process off?)"
        )
    return {
        "delay_ms": round(float(np.median(found)), 1),
        "std_ms": round(float(np.std(found, ddof=1)), 1),
        "min_ms": round(float(found.min()), 1),
        "max_ms": round(float(found.max()), 1),
        "steps": len(delays_s),
        "steps_fitted": len(found),
        "step_delays_ms": [None if d is None else round(d * 1e3, 1) for d in delays_s],
    }


def record_steps(rig: Rig, steps: int, step_rad: float, hold_s: float) -> Recording:
    """Step the running rig's head and record the image's shifts and the odometry."""
    if rig.servo.protocol == "digital":
        raise LatencyCalibrationError(
            "a digital head renders its views at a known pose: no camera delay to measure "
            "(measure the wide camera's with a pan-tilt head, or state [camera] delay_ms)"
        )
    with head_session(rig) as session:
        return StepRecorder(rig, session).record(steps, step_rad, hold_s)


class StepRecorder:
    """Steps the head and keeps the frames' shifts meanwhile."""

    def __init__(self, rig: Rig, session: HeadSession) -> None:
        self.rig = rig
        self.session = session
        self.shift = ImageShift(rig.camera.width_px, rig.camera.height_px)
        self.shifts: list[tuple[float, float, float, float]] = []
        self.last_arrival_s: float | None = None

    def record(self, steps: int, step_rad: float, hold_s: float) -> Recording:
        start = self.session.start(self._frame)
        away = start.pan_rad + step_rad
        if away > math.radians(self.rig.head.pan_max_deg):
            away = start.pan_rad - step_rad
        step_starts_s = []
        for k in range(steps):
            step_starts_s.append(time.time())
            pan = away if k % 2 == 0 else start.pan_rad
            print(f"step {k + 1}/{steps}: pan {math.degrees(pan):.1f} deg", file=sys.stderr)
            self.session.pump(hold_s, position_demand(pan, start.tilt_rad), self._frame)
        self.session.pump(RETURN_S, position_demand(start.pan_rad, start.tilt_rad), self._frame)
        odometry = self.session.odometry
        return Recording(
            np.array(self.shifts).reshape(-1, 4),
            np.array([(o.t_capture_ns * 1e-9, o.pan_rad, o.tilt_rad) for o in odometry]),
            step_starts_s,
            hold_s,
        )

    def _frame(self, frame: CapturedFrame) -> None:
        camera = self.rig.camera
        try:
            gray = gray_frame(frame, camera.width_px, camera.height_px)
        except FrameError as exc:  # not the rig's camera size or type: left out, the chain restarts
            print(f"frame left out: {exc}", file=sys.stderr)
            self.shift.reset()
            self.last_arrival_s = None
            return
        measured = self.shift.update(gray)
        arrival_s = frame.t_capture_ns * 1e-9
        if measured is not None and self.last_arrival_s is not None:
            du_px, dv_px, response = measured
            if response >= MIN_RESPONSE:
                self.shifts.append((self.last_arrival_s, arrival_s, du_px, dv_px))
        self.last_arrival_s = arrival_s


def latency_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rig", required=True, type=Path, help="the running rig (TOML)")
    parser.add_argument("--steps", type=int, default=6, help="pan steps, there and back (6)")
    parser.add_argument("--step-deg", type=float, default=8.0, help="pan step size (8)")
    parser.add_argument(
        "--hold-s", type=float, default=1.5, help="time per step, more than the delay (1.5)"
    )
    parser.add_argument(
        "--max-delay-ms", type=float, default=1000.0, help="longest delay looked for (1000)"
    )
    parser.add_argument("--json", action="store_true", help="print JSON")


def latency_command(args: argparse.Namespace) -> int:
    rig = load_rig_or_exit(args.rig)
    if not (2 <= args.steps <= 100 and 0 < args.step_deg <= 90 and 0 < args.hold_s <= 30):
        print(
            "gazed calibrate latency: --steps 2-100, --step-deg 0-90, --hold-s 0-30",
            file=sys.stderr,
        )
        return 2
    if args.hold_s * 1e3 <= args.max_delay_ms:
        print("gazed calibrate latency: --hold-s must exceed --max-delay-ms", file=sys.stderr)
        return 2
    try:
        recording = record_steps(rig, args.steps, math.radians(args.step_deg), args.hold_s)
        result = summary(step_delays_s(recording, args.max_delay_ms * 1e-3))
    except CalibrationError as exc:
        print(f"gazed calibrate latency: {exc}", file=sys.stderr)
        return 1
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(
            f"camera delay (exposure -> arrival): {result['delay_ms']} ms, spread "
            f"{result['std_ms']} ms (min {result['min_ms']}, max {result['max_ms']}) over "
            f"{result['steps_fitted']} of {result['steps']} steps\n"
            f"state it in the rig as [camera] delay_ms = {result['delay_ms']}"
        )
    return 0
