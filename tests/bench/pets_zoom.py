"""Zoom on real footage: the digital head of configs/pets.toml following PETS 2009 S2.L1 walkers,
with its fixed view and with its digital zoom holding the walker's height, side by side.

    python tests/bench/pets_zoom.py [--people 15,9] [--setpoint 0.3] [--rig configs/pets.toml]

For each person, two runs of the rig over the footage, from the person's first annotated frame
until they leave the wide view (the operator chooses them there, as `gazed eval loop --truth
--select-id` does): the rig as it is, then the rig with a zoom lens and `[gaze] zoom_control`
(`ZOOM` below, added to a private copy). Per run, over the rendered views from the first in
pursuit on: the share of views with the person's annotated box, seen through the view at its
own pose and zoom, within ±20 % of the setpoint's height, the height's 5th, 50th and 95th
percentiles (fractions of the view's height), and the share of views in pursuit.

The zoom lens: the view's focal length from its own (`[camera] hfov_deg`, about the wide
camera's pixel scale) to three times it; past the wide camera's scale a digital zoom only
enlarges pixels, so the range stays short. The box margin is the flow detector's smoothing
(about 2 sigma of 1.5 px each side, docs/zoom.md).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import tomlkit

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from gazed.config import load_rig  # noqa: E402
from gazed.eval.footage_loop import Selection  # noqa: E402
from gazed.eval.loop import record_run, running  # noqa: E402
from gazed.eval.private_rig import private_document, write_rig  # noqa: E402
from gazed.eval.truth import Person, read_truth  # noqa: E402
from gazed.eval.zoom_score import TOLERANCE  # noqa: E402
from gazed.geometry.camera import CameraModel  # noqa: E402
from gazed.geometry.kinematics import HeadKinematics  # noqa: E402
from gazed.geometry.zoom import ZoomLens  # noqa: E402
from gazed.messages import Detection, GazeState  # noqa: E402
from gazed.topics import GAZE_STATE, VISION_DETECTION  # noqa: E402
from gazed.vision.digital_camera import wide_camera  # noqa: E402
from gazed.vision.digital_view import DigitalView  # noqa: E402

TRUTH = ROOT.parent / "shared" / "data" / "footage" / "pets09-s2l1" / "truth_frames_0000-0399.csv"
ZOOM_RANGE = 3.0  # the longest focal length, of the view's own
ZOOM = {"zoom_box_margin_px": 6.0, "zoom_in_steady_ms": 300.0, "zoom_deadband": 0.05}


def zoomed(document: tomlkit.TOMLDocument, setpoint: float) -> None:
    """Give the rig's view a digital zoom and the gaze the control that holds `setpoint`."""
    camera = document["camera"]
    fx_px = float(camera["width_px"]) / 2.0 / np.tan(np.radians(float(camera["hfov_deg"]) / 2.0))
    camera["zoom_focal_px"] = [[0.0, fx_px], [1.0, ZOOM_RANGE * fx_px]]
    gaze = document["gaze"]
    gaze["zoom_control"] = True
    gaze["zoom_target_height"] = setpoint
    for key, value in ZOOM.items():
        gaze[key] = value


def run(rig_path: Path, person: Person, setpoint: float, zoom: bool) -> dict[str, Any]:
    """One run over the footage following `person`; with `zoom`, zooming to hold `setpoint`."""
    with tempfile.TemporaryDirectory(prefix="gazed-bench-") as directory:
        document = private_document(rig_path, Path(directory), None, None)
        document["wide"]["start_frame"] = int(person.frame[0])
        if zoom:
            zoomed(document, setpoint)
        private = write_rig(document, Path(directory))
        selection = Selection(person)
        rig = load_rig(private)
        seconds = (len(person.frame) + 20) / rig.wide.rate_hz
        with running(private) as (rig, supervisor, log_path):
            topics = (VISION_DETECTION, GAZE_STATE)
            recording = record_run(rig, supervisor, log_path, topics, seconds, selection.watch)
    messages = recording.messages
    detections, states = messages[VISION_DETECTION.suffix], messages[GAZE_STATE.suffix]
    return score(rig, person, detections, states, setpoint)


def score(
    rig: Any, person: Person, detections: list[Detection], states: list[GazeState], setpoint: float
) -> dict[str, Any]:
    """The person's height in each view from the first in pursuit on (module docstring)."""
    lens = ZoomLens.from_section(rig.camera)
    view = DigitalView(
        wide_camera(rig.wide),
        CameraModel.from_section(rig.camera),
        HeadKinematics.from_section(rig.head),
        lens,
    )
    transitions = sorted(states, key=lambda s: s.t_capture_ns)
    heights, pursuing, k, state = [], [], 0, None
    for detection in sorted(detections, key=lambda d: d.t_capture_ns):
        while k < len(transitions) and transitions[k].t_capture_ns <= detection.t_capture_ns:
            state, k = transitions[k].state, k + 1
        row = person.at_frame(detection.seq)
        if detection.head is None or row is None or (state != "pursuit" and not pursuing):
            continue
        pursuing.append(state == "pursuit")
        heights.append(height_in_view(view, person.box_px[row], detection.head))
    h = np.asarray(heights, float)
    if not len(h):
        return {"views": 0}
    p5, p50, p95 = np.nanpercentile(h, [5, 50, 95])
    return {
        "views": len(h),
        "held": round(float(np.mean(np.abs(h / setpoint - 1.0) <= TOLERANCE)), 3),
        "p5": round(float(p5), 3),
        "p50": round(float(p50), 3),
        "p95": round(float(p95), 3),
        "pursuit": round(float(np.mean(pursuing)), 3),
    }


def height_in_view(view: DigitalView, box_px: np.ndarray, head: Any) -> float:
    """The height of an annotated box (wide pixels: centre u, v, width, height) in the view at
    the head's pose and zoom, as a fraction of the view's height."""
    u, v, _, h = box_px
    ideal = np.stack([*view.wide.undistort(np.array([u, u]), np.array([v - h / 2, v + h / 2]))])
    H = view.homography(head.pan_rad, head.tilt_rad, head.zoom)
    pixels = np.linalg.solve(H, np.vstack([ideal, np.ones(2)]))
    rows = pixels[1] / pixels[2]
    return float(abs(rows[1] - rows[0])) / view.view.height_px


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--people", default="15,9", help="annotated ids, e.g. 15,9")
    parser.add_argument("--setpoint", type=float, default=0.3, help="zoom_target_height")
    parser.add_argument("--rig", type=Path, default=ROOT / "configs" / "pets.toml")
    parser.add_argument("--truth", type=Path, default=TRUTH)
    args = parser.parse_args()
    people = read_truth(args.truth)
    print(
        f"{'person':>6} {'zoom':>5} {'views':>5} {'held':>6} {'p5':>6} {'p50':>6} {'p95':>6} "
        f"{'pursuit':>7}"
    )
    for person_id in (int(p) for p in args.people.split(",")):
        for zoom in (False, True):
            r = run(args.rig, people[person_id], args.setpoint, zoom)
            print(
                f"{person_id:>6} {'on' if zoom else 'off':>5} {r['views']:>5}"
                f" {r.get('held')!s:>6} {r.get('p5')!s:>6} {r.get('p50')!s:>6}"
                f" {r.get('p95')!s:>6} {r.get('pursuit')!s:>7}",
                flush=True,
            )
    print(f"setpoint {args.setpoint} of the view's height, held within ±{TOLERANCE:.0%}")


if __name__ == "__main__":
    main()
