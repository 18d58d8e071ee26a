"""`gazed eval loop --truth FILE.csv`: run a digital head's rig over its footage on a private bus
and score it against the annotated people (`person_score`).

The rig file is copied as for the simulator (`private_rig.private_document`) with the footage's
first frame (`[wide] start_frame`) and the frames' delay (`[wide] frame_delay_ms`, from
`--latency-ms`). Each view the head renders carries its footage frame as its sequence number and
the pose it was rendered at, so every detection names both. With `--select-id`, the person's
ground point in the first frame of the run that shows them goes out on `gaze/select` (the
operator's choice), and the recording ends once they leave the wide view; without it, the
person scored is the first one the gaze pursues (whom the rig's rule chose). `--compare` runs
`imm`, `image-cv` and `none` one after the other.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path
from typing import Any

from gazed.bus import Bus
from gazed.config import Rig, RigError, load_rig
from gazed.eval.loop import (
    DEFAULT_SECONDS,
    print_results,
    record_run,
    running,
    servo_summary,
)
from gazed.eval.loop_metrics import latencies_ms
from gazed.eval.person_score import (
    FrameFacts,
    ViewFrame,
    first_pursued,
    pursuit_summary,
    reach_scores,
    score_person,
)
from gazed.eval.private_rig import private_document, write_rig
from gazed.eval.progress import EvalProgress
from gazed.eval.truth import Person, TruthFileError, read_truth
from gazed.eval.view_people import ViewPeople
from gazed.messages import Detection, GazeSelect, GazeState
from gazed.sim.reach import FieldOfRegard
from gazed.topics import (
    ESTIMATOR_STATE,
    GAZE_SELECT,
    GAZE_STATE,
    SERVO_COMMAND,
    SERVO_STATUS,
    VISION_DETECTION,
)
from gazed.vision.digital_camera import file_frame_count, rig_view

MODES = ("imm", "image-cv", "none")
TOPICS = (VISION_DETECTION, GAZE_STATE, ESTIMATOR_STATE, SERVO_COMMAND, SERVO_STATUS)
LEFT_FRAMES = 3  # frames without the selected person that end the recording


def footage_command(args: argparse.Namespace) -> int:
    """`gazed eval loop --truth …` (the rig has loaded)."""
    rig = load_rig(args.rig)
    problem = _refusal(args, rig)
    if problem is not None:
        print(f"gazed eval loop: {problem}", file=sys.stderr)
        return 2
    try:
        people = read_truth(args.truth)
    except TruthFileError as exc:
        print(f"gazed eval loop: {exc}", file=sys.stderr)
        return 2
    if args.select_id is not None and args.select_id not in people:
        print(
            f"gazed eval loop: --select-id {args.select_id}: no such person in {args.truth}",
            file=sys.stderr,
        )
        return 2
    modes = MODES if args.compare else (args.filter,)
    results = []
    progress = EvalProgress(len(modes), args.json)
    for mode in modes:
        try:
            results.append(
                run_footage(
                    args.rig,
                    people,
                    mode,
                    seconds=args.seconds,
                    frame_delay_ms=args.latency_ms,
                    start_frame=args.start_frame,
                    select_id=args.select_id,
                    control=args.control,
                    progress=progress,
                )
            )
        except (RuntimeError, RigError) as exc:
            progress.close()
            print(f"gazed eval loop: {exc}", file=sys.stderr)
            return 1
    progress.close()
    print_results(results, args.json, table)
    return 0


def _refusal(args: argparse.Namespace, rig: Rig) -> str | None:
    """Why the arguments cannot score footage, or None."""
    if args.scenario is not None or args.seed is not None:
        return "--scenario and --seed are the simulator's; --truth scores footage"
    if rig.servo.protocol != "digital" or rig.wide_source is None:
        return (
            f"{args.rig}: --truth needs a digital head over footage "
            '([servo] protocol = "digital" and a [wide] source)'
        )
    if args.start_frame is not None:
        frames = file_frame_count(rig.wide_source)
        if args.start_frame < 0 or (frames is not None and args.start_frame >= frames):
            last = (frames or 1) - 1
            return f"--start-frame {args.start_frame}: the footage has frames 0 to {last}"
    return None


def run_footage(
    rig_path: Path,
    people: dict[int, Person],
    filter_mode: str | None = None,
    *,
    seconds: float | None = None,
    frame_delay_ms: float | None = None,
    start_frame: int | None = None,
    select_id: int | None = None,
    control: str | None = None,
    progress: EvalProgress | None = None,
) -> dict[str, Any]:
    """Run the rig over its footage on a private bus and score it against `people`; with
    `progress`, show it there."""
    with tempfile.TemporaryDirectory(prefix="gazed-eval-") as directory:
        document = private_document(rig_path, Path(directory), filter_mode, control)
        wide = document["wide"]
        if start_frame is not None:
            wide["start_frame"] = start_frame
        if frame_delay_ms is not None:
            wide["frame_delay_ms"] = frame_delay_ms
        private = write_rig(document, Path(directory))
        selection = Selection(people[select_id] if select_id is not None else None)
        if seconds is None:
            chosen = select_id is not None
            seconds = selection.longest_s(load_rig(private)) if chosen else DEFAULT_SECONDS
        watch = selection.watch
        if progress is not None:
            watch = progress.recording(seconds, "footage", filter_mode, control, then=watch)
        with running(private) as (rig, supervisor, log_path):
            recording = record_run(rig, supervisor, log_path, TOPICS, seconds, watch)
    messages = recording.messages
    frames = view_frames(messages[VISION_DETECTION.suffix], messages[GAZE_STATE.suffix])
    result: dict[str, Any] = {
        "filter": filter_mode or rig.estimator.filter,
        "control": rig.gaze.control,
        "frame_delay_ms": rig.wide.frame_delay_ms,
        "start_frame": rig.wide.start_frame,
        "select_id": select_id,
        "selected_frame": selection.frame,
        "frames": len(frames),
        "footage_frames": [frames[0].frame, frames[-1].frame] if frames else None,
        "pursuit": pursuit_summary(frames),
    }
    view = rig_view(rig, zoom=False)
    facts = FrameFacts.of(frames, people, ViewPeople(view, FieldOfRegard.for_scoring(rig)))
    person_id = select_id if select_id is not None else first_pursued(facts)
    fovea_deg = rig.gaze.fovea_half_angle_deg
    if person_id is None:
        result.update(person=None, person_reach=None)
    else:
        estimates = messages[ESTIMATOR_STATE.suffix]
        result["person"] = score_person(frames, facts, people[person_id], fovea_deg, estimates)
        result["person_reach"] = reach_scores(facts, person_id, fovea_deg)
    result["latency_ms"] = latencies_ms(messages[SERVO_COMMAND.suffix])
    result["cpu_percent"] = recording.cpu_percent
    result["servo"] = servo_summary(messages[SERVO_STATUS.suffix])
    return result


class Selection:
    """The operator's choice of `person` (None: no choice) in the first frame of the run that
    shows them; the recording ends LEFT_FRAMES frames after they leave the wide view."""

    def __init__(self, person: Person | None) -> None:
        self.person = person
        self.frame: int | None = None  # the footage frame the choice was made at
        self._seen = 0  # detections looked at
        self._absent = 0  # frames in a row without the person since the choice

    def longest_s(self, rig: Rig) -> float:
        """Time enough for the footage to reach the person from anywhere and show them all."""
        frames = file_frame_count(rig.wide_source or "") or 0
        span = len(self.person.frame) if self.person is not None else 0
        return (frames + span) / rig.wide.rate_hz

    def watch(self, bus: Bus, messages: dict[str, list[Any]]) -> bool:
        """Choose the person when a frame shows them; True once they have left."""
        detections = messages[VISION_DETECTION.suffix]
        new, self._seen = detections[self._seen :], len(detections)
        if self.person is None:
            return False
        for detection in new:
            row = self.person.at_frame(detection.seq)
            if self.frame is None and row is not None:
                self.frame = detection.seq
                ground = self.person.ground_m[row]
                bus.publisher(GAZE_SELECT).put(
                    GazeSelect(
                        t_capture_ns=detection.t_capture_ns,
                        ground_xy_m=(float(ground[0]), float(ground[1])),
                    )
                )
            elif self.frame is not None:
                self._absent = 0 if row is not None else self._absent + 1
        return self._absent >= LEFT_FRAMES


def view_frames(detections: list[Detection], states: list[GazeState]) -> list[ViewFrame]:
    """The rendered views in capture order, each with the gaze's state and target then (the
    latest transition at or before its capture; not pursuing before the first)."""
    transitions = sorted(states, key=lambda s: s.t_capture_ns)
    frames, k = [], 0
    current: GazeState | None = None
    for detection in sorted(detections, key=lambda d: d.t_capture_ns):
        while k < len(transitions) and transitions[k].t_capture_ns <= detection.t_capture_ns:
            current, k = transitions[k], k + 1
        if detection.head is None:
            continue
        frames.append(
            ViewFrame(
                frame=detection.seq,
                t_capture_ns=detection.t_capture_ns,
                pan_rad=detection.head.pan_rad,
                tilt_rad=detection.head.tilt_rad,
                pursuing=current is not None and current.state == "pursuit",
                target_id=current.target_id if current is not None else None,
            )
        )
    return frames


def table(results: list[dict[str, Any]]) -> str:
    """The runs side by side, one row per figure."""

    def person(key: str) -> Any:
        return lambda r: (r["person"] or {}).get(key)

    rows = [
        ("filter", lambda r: r["filter"]),
        ("frame delay (ms)", lambda r: r["frame_delay_ms"]),
        ("person", person("id")),
        ("visible frames", person("visible_frames")),
        ("acquired after (s)", person("acquired_after_s")),
        ("fovea fraction", person("fovea_fraction")),
        ("switches", person("switches")),
        ("gaze error rms (deg)", lambda r: (person("gaze_error_deg")(r) or {}).get("rms")),
        ("ground rmse (m)", person("ground_rmse_m")),
        ("pursuit fraction", lambda r: r["pursuit"]["pursuit_fraction"]),
        ("track switches", lambda r: r["pursuit"]["track_switches"]),
    ]
    first = results[0]
    lines = [f"footage frames {first['footage_frames']}, person {first['select_id']}"]
    for label, get in rows:
        lines.append(f"  {label:<24}" + "".join(f"{get(r)!s:>14}" for r in results))
    return "\n".join(lines)
