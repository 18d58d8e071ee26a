"""`gazed detect VIDEO`: run a detector over every frame of a video file.

    gazed detect clip.mp4 --detector flow|pyramid|background [--json] [--annotate OUT.mp4]
                 [--odometry ODO.csv] [--rig RIG] [--hfov-deg DEG]

Frame i is taken as captured at `t_s = i / fps` (the file's rate). The head is still unless an
odometry CSV (`t_s,pan_deg,tilt_deg`, times on the same clock, rates from its differences)
says otherwise. The camera is the rig's `[camera]` (its size must match the video), or a pinhole
of `--hfov-deg` over the video's size; the detector settings are the rig's `[vision]` (defaults
without `--rig`). `--json` prints one line per frame:

    {"frame": i, "t_s": ..., "found": bool, "u": ..., "v": ..., "du": ..., "dv": ...,
     "area": ..., "ms": ..., "movers": [{"u", "v", "du", "dv", "box": [x, y, w, h]}, ...]}

(position and velocity null when nothing is found; the movers in the detector's order, the
target's own first); otherwise a summary. `--annotate` writes a video with the detection, its
window, velocity, every mover's box and index, and the candidates drawn. Exit 2 on a video that
cannot be read or bad input files.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path

import cv2
import numpy as np

from gazed.config import Rig, VisionSection, load_rig_or_exit
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import Odometry
from gazed.vision.annotate import annotate
from gazed.vision.detector import DetectorOutput
from gazed.vision.frames import CapturedFrame, gray_frame
from gazed.vision.odometry_history import OdometryHistory
from gazed.vision.pipeline import VisionPipeline

DEFAULT_HFOV_DEG = 60.0


class InputError(ValueError):
    """A bad command-line input (exit code 2)."""


def detect_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("video", type=Path, help="video file to read")
    parser.add_argument(
        "--detector",
        choices=("flow", "pyramid", "background"),
        default=None,
        help="detector (default: the rig's [vision] detector, else flow)",
    )
    parser.add_argument("--json", action="store_true", help="one JSON line per frame")
    parser.add_argument("--annotate", type=Path, metavar="OUT.mp4", help="write an annotated video")
    parser.add_argument(
        "--odometry", type=Path, metavar="CSV", help="head angles: t_s,pan_deg,tilt_deg per line"
    )
    parser.add_argument("--rig", type=Path, help="rig file for [camera], [head] and [vision]")
    parser.add_argument(
        "--hfov-deg",
        type=float,
        default=DEFAULT_HFOV_DEG,
        help=f"horizontal field of view without --rig (default {DEFAULT_HFOV_DEG:g})",
    )


def detect_command(args: argparse.Namespace) -> int:
    rig = load_rig_or_exit(args.rig) if args.rig is not None else None
    capture = cv2.VideoCapture(str(args.video))
    if not capture.isOpened():
        print(f"gazed detect: cannot read video {args.video}", file=sys.stderr)
        return 2
    try:
        return _run(args, rig, capture)
    except InputError as exc:
        print(f"gazed detect: {exc}", file=sys.stderr)
        return 2
    finally:
        capture.release()


def _run(args: argparse.Namespace, rig: Rig | None, capture: cv2.VideoCapture) -> int:
    width = int(capture.get(cv2.CAP_PROP_FRAME_WIDTH))
    height = int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT))
    fps = capture.get(cv2.CAP_PROP_FPS)
    if not fps or not math.isfinite(fps) or fps <= 0:
        fps = rig.camera.rate_hz if rig is not None else 25.0
    camera, kinematics, vision = _setup(args, rig, width, height)
    history = _odometry(args.odometry) if args.odometry else None
    detector = args.detector or (vision.detector if rig is not None else "flow")
    pose_noise_rad = rig.pose_noise_rad if rig is not None else 0.0
    pipeline = VisionPipeline(camera, kinematics, vision, detector, pose_noise_rad=pose_noise_rad)
    writer = None
    if args.annotate:
        writer = cv2.VideoWriter(
            str(args.annotate), cv2.VideoWriter_fourcc(*"mp4v"), fps, (width, height)
        )
        if not writer.isOpened():
            raise InputError(f"cannot write {args.annotate}")
    times_ms: list[float] = []
    found = compensated = 0
    index = 0
    try:
        while True:
            ok, pixels = capture.read()
            if not ok:
                break
            t_s = index / fps
            t_ns = round(t_s * 1e9)
            frame = CapturedFrame(pixels, "bgr8" if pixels.ndim == 3 else "gray8", t_ns, index)
            gray = gray_frame(frame, width, height)
            head = history.pose_at(t_ns) if history is not None else None
            result = pipeline.process(gray, t_ns, head, colour=pixels, encoding=frame.encoding)
            out = result.output
            times_ms.append(out.processing_ms)
            found += int(out.found)
            compensated += int(result.compensated)
            if args.json:
                print(json.dumps(_frame_record(index, t_s, out)))
            if writer is not None:
                caption = f"{index}  t={t_s:.2f}s  {detector}  {out.processing_ms:.1f} ms"
                writer.write(annotate(pixels, out, result.candidates, caption))
            index += 1
    finally:
        if writer is not None:
            writer.release()
    if index == 0:
        raise InputError(f"no frame could be decoded from {args.video}")
    if not args.json:
        times = np.array(times_ms)
        print(
            f"{args.video}: {index} frames at {fps:g} fps ({width}x{height}), detector {detector}\n"
            f"found in {found} ({100.0 * found / index:.1f}%), head rotation compensated in "
            f"{compensated}\n"
            f"time per frame: median {np.median(times):.2f} ms, "
            f"p99 {np.percentile(times, 99):.2f} ms"
        )
        if args.annotate:
            print(f"annotated video: {args.annotate}")
    return 0


def _setup(
    args: argparse.Namespace, rig: Rig | None, width: int, height: int
) -> tuple[CameraModel, HeadKinematics, VisionSection]:
    if rig is None:
        camera = CameraModel.from_fov(width, height, math.radians(args.hfov_deg))
        return camera, HeadKinematics(), VisionSection()
    if (rig.camera.width_px, rig.camera.height_px) != (width, height):
        raise InputError(
            f"the video is {width}x{height}, the rig's camera is "
            f"{rig.camera.width_px}x{rig.camera.height_px}"
        )
    return (
        CameraModel.from_section(rig.camera),
        HeadKinematics.from_section(rig.head),
        rig.vision,
    )


def _frame_record(index: int, t_s: float, out: DetectorOutput) -> dict[str, object]:
    def number(value: float) -> float | None:
        return round(value, 3) if out.found else None

    return {
        "frame": index,
        "t_s": round(t_s, 6),
        "found": out.found,
        "u": number(out.u_px),
        "v": number(out.v_px),
        "du": number(out.du_px_s),
        "dv": number(out.dv_px_s),
        "area": number(out.area_px),
        "ms": round(out.processing_ms, 3),
        "movers": [
            {
                "u": round(m.u_px, 3),
                "v": round(m.v_px, 3),
                "du": round(m.du_px_s, 3),
                "dv": round(m.dv_px_s, 3),
                "velocity_known": m.velocity_known,
                "box": [round(x, 1) for x in m.box],
            }
            for m in out.movers
        ],
    }


def _odometry(path: Path) -> OdometryHistory:
    """Head angles from a CSV `t_s,pan_deg,tilt_deg` (a header line is allowed); rates from
    the differences of consecutive lines."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read odometry {path}: {exc}") from exc
    rows: list[tuple[float, float, float]] = []
    for number, row in enumerate(csv.reader(lines), start=1):
        if not row or (number == 1 and row[0].strip() == "t_s"):
            continue
        try:
            t_s, pan_deg, tilt_deg = (float(x) for x in row)
        except ValueError as exc:
            raise InputError(
                f"{path}:{number}: expected three numbers t_s,pan_deg,tilt_deg, got {row}"
            ) from exc
        if not all(math.isfinite(x) for x in (t_s, pan_deg, tilt_deg)) or t_s < 0:
            raise InputError(f"{path}:{number}: expected finite numbers and t_s >= 0, got {row}")
        if rows and t_s <= rows[-1][0]:
            raise InputError(f"{path}:{number}: t_s must increase ({t_s} after {rows[-1][0]})")
        rows.append((t_s, pan_deg, tilt_deg))
    if len(rows) < 2:
        raise InputError(f"{path}: needs at least two lines of t_s,pan_deg,tilt_deg")
    t, pan, tilt = (np.array(c) for c in zip(*rows, strict=True))
    pan, tilt = np.radians(pan), np.radians(tilt)
    pan_rate, tilt_rate = np.gradient(pan, t), np.gradient(tilt, t)
    span_s = float(t[-1] - t[0]) + 1.0
    history = OdometryHistory(span_s, max_gap_s=float(np.max(np.diff(t))) + 1e-6)
    for i in range(len(t)):
        history.add(
            Odometry(
                t_capture_ns=round(t[i] * 1e9),
                pan_rad=float(pan[i]),
                tilt_rad=float(tilt[i]),
                pan_rate_rad_s=float(pan_rate[i]),
                tilt_rate_rad_s=float(tilt_rate[i]),
            )
        )
    return history
