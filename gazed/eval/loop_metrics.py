"""Scores of a closed-loop run from what it published (seed 000 §6, Fig. 15: pursuit held without
corrective saccades).

- gaze error: the angle between the camera's optical axis (the true head pose at a frame's
  capture) and the true direction to the target's middle (half its height above its ground
  point), from `sim/truth`;
- acquisition: the first frame from which the target stays within the fovea for
  `ACQUIRED_FRAMES` frames in a row; fovea fraction, error RMS / p95 and saccades count from there;
- reach: with the rig's field of regard (`FieldOfRegard.for_scoring`), each truth frame is
  reachable when the head can put the target's middle in its fovea within its joint limits; the
  share of scored frames out of reach, and the fovea fraction over the reachable ones, tell a
  loop that could not follow from a scenario that went where no head can look;
- ground RMSE: the estimator's ground position at a capture time against the truth then, from
  acquisition on (before it, the estimator may still hold a track of something else);
- latency: processing from the frame's arrival at `vision` (its `vision.arrival` stamp) to the
  command bytes written, and end to end from capture; the first write of each capture counts.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from gazed.eval.zoom_score import ZoomScoring
from gazed.geometry.pose import CameraPose
from gazed.latency import processing_s
from gazed.messages import ARRIVAL_STAGE, EstimatorState, GazeDemand, GazeState, SimTruth
from gazed.sim.reach import FieldOfRegard

ACQUIRED_FRAMES = 10


@dataclass(frozen=True)
class LoopRecord:
    """What a run published, in arrival order."""

    truth: list[SimTruth]
    states: list[GazeState]
    commands: list[GazeDemand]
    estimates: list[EstimatorState]


def gaze_errors_rad(truth: list[SimTruth], pose: CameraPose) -> np.ndarray:
    """Per truth frame: angle between the optical axis and the target's middle."""
    errors = []
    for t in truth:
        axis = pose.base_to_world @ pose.head.gaze(t.head.pan_rad, t.head.tilt_rad)
        target = (
            np.array([t.target_xy_m[0], t.target_xy_m[1], t.target_height_m / 2.0]) - pose.centre_m
        )
        # atan2 of the cross and dot products: exact near zero, where acos of a cosine loses
        # half the digits (1 - 1e-16 is already 0.85e-6°)
        sine = float(np.linalg.norm(np.cross(axis, target)))
        errors.append(math.atan2(sine, float(axis @ target)))
    return np.asarray(errors)


def acquisition_index(errors_rad: np.ndarray, fovea_rad: float) -> int | None:
    """The first frame from which the target stays in the fovea for ACQUIRED_FRAMES frames."""
    inside = errors_rad <= fovea_rad
    run = 0
    for k, ok in enumerate(inside):
        run = run + 1 if ok else 0
        if run >= ACQUIRED_FRAMES:
            return k - ACQUIRED_FRAMES + 1
    return None


def reachable(truth: list[SimTruth], reach: FieldOfRegard) -> np.ndarray:
    """Per truth frame: whether the joint angles that centre the target's middle are within
    the field of regard."""
    middles = np.array([(*t.target_xy_m, t.target_height_m / 2.0) for t in truth])
    return reach.contains_angles(*reach.pose.gaze_angles(middles))


def score(
    record: LoopRecord,
    pose: CameraPose,
    fovea_half_angle_deg: float,
    reach: FieldOfRegard | None = None,
    zoom: ZoomScoring | None = None,
) -> dict[str, object]:
    """The run's scores (module docstring); the reach figures only with a `reach`, the zoom's
    (`zoom_score`) only with a `zoom`."""
    truth = sorted(record.truth, key=lambda t: t.t_capture_ns)
    if not truth:
        raise ValueError("no sim/truth was received: the simulator did not run")
    errors = gaze_errors_rad(truth, pose)
    fovea = math.radians(fovea_half_angle_deg)
    start = acquisition_index(errors, fovea)
    result: dict[str, object] = {"frames": len(truth)}
    scored_from_ns = truth[start].t_capture_ns if start is not None else truth[0].t_capture_ns
    if start is None:
        result.update(
            acquired_after_s=None,
            gaze_error_deg=None,
            fovea_fraction=0.0,
            saccades_after_acquisition=None,
        )
    else:
        acquired_ns = truth[start].t_capture_ns
        after = np.degrees(errors[start:])
        saccades = sum(  # entries into saccade: a change of target within one is not another
            1
            for s in record.states
            if s.state == "saccade" and s.previous != "saccade" and s.t_capture_ns >= acquired_ns
        )
        result.update(
            acquired_after_s=round((acquired_ns - truth[0].t_capture_ns) / 1e9, 3),
            gaze_error_deg={
                "rms": round(float(np.sqrt(np.mean(after**2))), 4),
                "p95": round(float(np.percentile(after, 95)), 4),
            },
            fovea_fraction=round(float(np.mean(after <= fovea_half_angle_deg)), 4),
            saccades_after_acquisition=saccades,
        )
    if reach is not None:
        scored = slice(start or 0, None)
        result.update(_reach_scores(reachable(truth, reach)[scored], errors[scored], fovea))
        if start is None:
            result["fovea_fraction_reachable"] = 0.0
    result["ground_rmse_m"] = ground_rmse_m(
        truth, [e for e in record.estimates if e.t_capture_ns >= scored_from_ns]
    )
    result["latency_ms"] = latencies_ms(record.commands)
    if zoom is not None:
        in_fovea = errors <= fovea
        result["zoom"] = zoom.score(truth, record.states, start, in_fovea)
    return result


def _reach_scores(
    reachable: np.ndarray, errors_rad: np.ndarray, fovea_rad: float
) -> dict[str, float | None]:
    """The out-of-reach share of the scored frames and the fovea fraction over the reachable."""
    inside = errors_rad[reachable] <= fovea_rad
    return {
        "out_of_reach_fraction": round(float(np.mean(~reachable)), 4),
        "fovea_fraction_reachable": round(float(np.mean(inside)), 4) if inside.size else None,
    }


def ground_rmse_m(truth: list[SimTruth], estimates: list[EstimatorState]) -> float | None:
    """The estimator's ground position against the truth of the frame it was made from: the
    capture nearest its stamp, within half a frame interval (vision may have moved the stamp by
    its estimate of the camera's delay, so it need not equal the capture's exactly)."""
    if len(truth) < 2:
        return None
    times_ns = np.array([t.t_capture_ns for t in truth])
    order = np.argsort(times_ns)
    times_ns = times_ns[order]
    half_interval_ns = float(np.median(np.diff(times_ns))) / 2.0
    squared = []
    for e in estimates:
        if e.ground_xy_m is None or e.coasting:
            continue
        k = int(np.searchsorted(times_ns, e.t_capture_ns))
        nearest = min(
            (j for j in (k - 1, k) if 0 <= j < len(times_ns)),
            key=lambda j: abs(times_ns[j] - e.t_capture_ns),
        )
        if abs(times_ns[nearest] - e.t_capture_ns) > half_interval_ns:
            continue
        x_m, y_m = truth[order[nearest]].target_xy_m
        squared.append((e.ground_xy_m[0] - x_m) ** 2 + (e.ground_xy_m[1] - y_m) ** 2)
    return round(math.sqrt(float(np.mean(squared))), 4) if squared else None


def latencies_ms(commands: list[GazeDemand]) -> dict[str, Any]:
    """Processing p50/p99 and end-to-end p50 (ms), and the p50 of each hop of the processing:
    the time from one stamp to the next, named by the later stamp's stage."""
    processing, end_to_end = [], []
    hops: dict[str, list[float]] = {}
    seen: set[int] = set()
    for command in commands:
        stamps = dict(command.stamps)
        gap_s = processing_s(command)
        if gap_s is None or command.t_capture_ns in seen:
            continue
        seen.add(command.t_capture_ns)
        processing.append(gap_s * 1e3)
        end_to_end.append((stamps["servo"] - command.t_capture_ns) / 1e6)
        stages = [stage for stage, _ in command.stamps]
        processed = stages[stages.index(ARRIVAL_STAGE) :]
        for earlier, later in itertools.pairwise(processed):
            hops.setdefault(later, []).append((stamps[later] - stamps[earlier]) / 1e6)
    if not processing:
        return {
            "processing_p50": None,
            "processing_p99": None,
            "end_to_end_p50": None,
            "hops_p50": {},
        }
    p50, p99 = np.percentile(processing, [50, 99])
    return {
        "processing_p50": round(float(p50), 2),
        "processing_p99": round(float(p99), 2),
        "end_to_end_p50": round(float(np.median(end_to_end)), 2),
        "hops_p50": {stage: round(float(np.median(v)), 2) for stage, v in hops.items()},
    }
