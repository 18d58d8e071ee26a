"""How the gaze takes up a person selected in PETS 2009 S2.L1, and where the fovea fraction goes.

    python tests/bench/pets_acquisition.py [--people 9,15] [--delays 0,150] [--filter imm]
                                           [--second-half]

For each person visible for at least `--min-seconds`, one `gazed eval loop --truth …
--start-frame FIRST --select-id ID` run (`footage_loop.run_footage`, its recording kept, with
vision's candidates added), and per run, in seconds after the person's first frame:

- select: when the operator's choice took a track, and the changes of choice with their reasons;
  chosen_born / chosen_confirmed: when that track first appeared, and was first confirmed;
- saccade: when the first saccade began, why, and the person's angle from the view's axis in
  the first pursued frame after it (landed_deg: where it landed);
- pursuit: when the gaze first pursued; acquired: the scored acquisition;
- track_on: runs of the chosen track's nearest annotated person, "track:person(median
  distance)xframes": whom the choice followed on the ground;
- fovea: the fovea fraction, and its shortfall split by what the gaze was doing in the frames
  from acquisition where the person was outside the fovea: pursuing them or nobody (pursuit
  error, with its median angle), pursuing another person (switch), in saccade, lost, or in
  search; the share of frames out of the head's reach, and the ground RMSE.

With `--second-half`: one run from frame 400 (no truth; the rule chooses), the share of frames
in each state from the first pursuit, every transition with its reason, and for each search
what vision showed meanwhile: candidate frames, those whose best candidate had a measured
velocity and their longest run (a run of `CANDIDATE_VELOCITY_FRAMES` draws a saccade),
detections found, and where the head looked.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from gazed.config import load_rig  # noqa: E402
from gazed.eval import footage_loop  # noqa: E402
from gazed.eval.person_score import FrameFacts  # noqa: E402
from gazed.eval.truth import read_truth  # noqa: E402
from gazed.eval.view_people import ViewPeople  # noqa: E402
from gazed.sim.reach import FieldOfRegard  # noqa: E402
from gazed.topics import ESTIMATOR_STATE, GAZE_STATE, VISION_CANDIDATES, VISION_DETECTION  # noqa: E402
from gazed.vision.digital_camera import rig_view  # noqa: E402

RIG = ROOT / "configs" / "pets.toml"
TRUTH = ROOT.parent / "shared" / "data" / "footage" / "pets09-s2l1" / "truth_frames_0000-0399.csv"
RATE_HZ = 7.0
SECOND_HALF = 400
FOOTAGE_FRAMES = 795


class Kept:
    """`record_run` with its recording kept for the analysis."""

    def __init__(self) -> None:
        self.original = footage_loop.record_run
        self.recording: Any = None

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        args = (*args[:3], (*args[3], VISION_CANDIDATES), *args[4:])
        self.recording = self.original(*args, **kwargs)
        return self.recording


def analyse(result: dict[str, Any], messages: dict[str, list[Any]], people: dict) -> dict:
    rig = load_rig(RIG)
    frames = footage_loop.view_frames(
        messages[VISION_DETECTION.suffix], messages[GAZE_STATE.suffix]
    )
    view = rig_view(rig, zoom=False)
    facts = FrameFacts.of(frames, people, ViewPeople(view, FieldOfRegard.for_scoring(rig)))
    person_id = result["select_id"]
    own = facts.person(person_id)
    fovea_rad = math.radians(rig.gaze.fovea_half_angle_deg)
    scored = own.scored(fovea_rad)
    out: dict[str, Any] = {"id": person_id}
    if scored is None:
        return out
    first, start, end = scored
    t0 = frames[first].t_capture_ns
    states = sorted(messages[GAZE_STATE.suffix], key=lambda s: s.t_capture_ns)

    def after_s(t_ns: int | None) -> float | None:
        return None if t_ns is None else round((t_ns - t0) / 1e9, 2)

    chose = next((s.t_capture_ns for s in states if "chose track" in s.reason), None)
    saccade = next((s for s in states if s.state == "saccade" and s.previous != "saccade"), None)
    pursued = next((s.t_capture_ns for s in states if s.state == "pursuit"), None)
    landed = None
    if saccade is not None:
        after = [
            k
            for k in range(first, end)
            if frames[k].t_capture_ns > saccade.t_capture_ns and frames[k].pursuing
        ]
        if after:
            landed = round(math.degrees(own.error_rad[after[0]]), 2)
    out.update(
        select=after_s(chose),
        saccade=after_s(saccade.t_capture_ns if saccade else None),
        saccade_why=saccade.reason if saccade else None,
        landed_deg=landed,
        pursuit=after_s(pursued),
        acquired=result["person"]["acquired_after_s"],
        fovea=result["person"]["fovea_fraction"],
        switches=result["person"]["switches"],
        choices=[f"{after_s(s.t_capture_ns)}: {s.reason}" for s in states if s.state == s.previous],
    )
    chosen_id = next(
        (
            int(s.reason.split("chose track ")[1].split()[0])
            for s in states
            if "chose track" in s.reason
        ),
        None,
    )
    seen = [e for e in messages[ESTIMATOR_STATE.suffix] for t in e.tracks if t.id == chosen_id]
    sure = [e for e in seen for t in e.tracks if t.id == chosen_id and t.confirmed]
    out["chosen_born"] = after_s(min(e.t_capture_ns for e in seen)) if seen else None
    out["chosen_confirmed"] = after_s(min(e.t_capture_ns for e in sure)) if sure else None
    out["track_on"] = _track_on(frames, messages[ESTIMATOR_STATE.suffix], people, person_id)
    if start is None:
        return out
    state_at = _states_at(frames, states)
    missed_deg = []
    split = dict.fromkeys(("pursuit_error", "switch", "saccade", "lost", "search", "other"), 0)
    for k in range(start, end):
        if own.error_rad[k] <= fovea_rad:
            continue
        state = state_at[k]
        if state == "pursuit":
            on = facts.gaze_on[k]
            other = on is not None and on != person_id
            split["switch" if other else "pursuit_error"] += 1
            if not other:
                missed_deg.append(math.degrees(own.error_rad[k]))
        else:
            split[state if state in split else "other"] += 1
    n = end - start
    out["shortfall"] = {key: round(v / n, 3) for key, v in split.items() if v}
    if missed_deg:
        out["pursuit_error_median_deg"] = round(float(np.median(missed_deg)), 1)
    out["out_of_reach"] = result["person_reach"]["out_of_reach_fraction"]
    out["ground_rmse_m"] = result["person"]["ground_rmse_m"]
    return out


def _track_on(frames: list, estimates: list, people: dict, person_id: int) -> list[str]:
    """Runs of the chosen track's nearest annotated person: "track:person(distance m)xframes"."""
    frame_at = {f.t_capture_ns: f.frame for f in frames}
    runs: list[list] = []
    for e in estimates:
        frame = frame_at.get(e.t_capture_ns)
        if frame is None or e.target_id is None:
            continue
        chosen = next((t for t in e.tracks if t.id == e.target_id), None)
        if chosen is None or chosen.ground_xy_m is None:
            continue
        best, best_m = None, math.inf
        for p in people.values():
            row = p.at_frame(frame)
            if row is not None:
                d = float(np.linalg.norm(np.subtract(chosen.ground_xy_m, p.ground_m[row])))
                if d < best_m:
                    best, best_m = p.id, d
        key = (e.target_id, best)
        if runs and runs[-1][0] == key:
            runs[-1][1] += 1
            runs[-1][2].append(best_m)
        else:
            runs.append([key, 1, [best_m]])
    return [f"{k[0]}:{k[1]}({np.median(d):.1f}m)x{n}" for k, n, d in runs if n >= 3]


def _states_at(frames: list, states: list) -> list[str]:
    """The gaze's state at each frame's capture."""
    result, k, current = [], 0, "park"
    for frame in frames:
        while k < len(states) and states[k].t_capture_ns <= frame.t_capture_ns:
            current, k = states[k].state, k + 1
        result.append(current)
    return result


def second_half(delay_ms: float, filter_mode: str, people: dict, kept: Kept) -> None:
    """Frames 400 onwards (no truth; the rule chooses): after the first pursuit, the share of
    frames in each state, and each transition out of pursuit with its reason."""
    seconds = (FOOTAGE_FRAMES - SECOND_HALF) / RATE_HZ
    result = footage_loop.run_footage(
        RIG, people, filter_mode, frame_delay_ms=delay_ms, start_frame=SECOND_HALF, seconds=seconds
    )
    messages = kept.recording.messages
    frames = footage_loop.view_frames(
        messages[VISION_DETECTION.suffix], messages[GAZE_STATE.suffix]
    )
    states = sorted(messages[GAZE_STATE.suffix], key=lambda s: s.t_capture_ns)
    at = _states_at(frames, states)
    first = next((k for k, s in enumerate(at) if s == "pursuit"), None)
    shares: dict[str, int] = {}
    for state in at[first:] if first is not None else []:
        shares[state] = shares.get(state, 0) + 1
    n = max(1, sum(shares.values()))
    t0 = frames[0].t_capture_ns
    changes = [
        f"{(s.t_capture_ns - t0) / 1e9:.1f} {s.previous}->{s.state}: {s.reason}"
        for s in states
        if s.state != s.previous and s.previous not in (None, "park")
    ]
    for a, b in zip(states, [*states[1:], None], strict=True):
        if a.state != "search" or b is None:
            continue
        changes.append(_search_facts(messages, a.t_capture_ns, b.t_capture_ns, t0))
    print(
        f"{delay_ms:g} ms frames {SECOND_HALF}-: {result['pursuit']} "
        f"{ {k: round(v / n, 3) for k, v in shares.items()} }\n    " + "\n    ".join(changes),
        flush=True,
    )


def _search_facts(messages: dict, from_ns: int, to_ns: int, t0: int) -> str:
    """What vision showed during one search: candidate frames, those whose best candidate had a
    velocity, the longest run of those, detections found, and the head's pose."""
    cands = [c for c in messages[VISION_CANDIDATES.suffix] if from_ns <= c.t_capture_ns < to_ns]
    dets = [d for d in messages[VISION_DETECTION.suffix] if from_ns <= d.t_capture_ns < to_ns]
    measured, run, longest = 0, 0, 0
    for c in sorted(cands, key=lambda c: c.t_capture_ns):
        best = max(c.candidates, key=lambda k: k.score, default=None)
        ok = best is not None and (best.du_px_s, best.dv_px_s) != (0.0, 0.0)
        measured += ok
        run = run + 1 if ok else 0
        longest = max(longest, run)
    pose = dets[0].head if dets and dets[0].head is not None else None
    where = f"{math.degrees(pose.pan_rad):.0f},{math.degrees(pose.tilt_rad):.0f}" if pose else "-"
    counts = [len(c.candidates) for c in cands]
    return (
        f"  search {(from_ns - t0) / 1e9:.1f}-{(to_ns - t0) / 1e9:.1f}: candidate frames "
        f"{len(cands)} (with any {sum(1 for k in counts if k)}), best measured {measured}, "
        f"longest run {longest}; detections found {sum(d.found for d in dets)}/{len(dets)}; "
        f"head {where} deg"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--people", help="ids, e.g. 9,15 (default: all visible long enough)")
    parser.add_argument("--delays", default="0,150")
    parser.add_argument("--filter", default="imm")
    parser.add_argument("--min-seconds", type=float, default=10.0)
    parser.add_argument("--second-half", action="store_true", help="frames 400- instead")
    args = parser.parse_args()
    people = read_truth(TRUTH)
    ids = (
        [int(i) for i in args.people.split(",")]
        if args.people
        else [i for i, p in people.items() if len(p.frame) / RATE_HZ >= args.min_seconds]
    )
    kept = Kept()
    footage_loop.record_run = kept
    for delay in [float(d) for d in args.delays.split(",")]:
        if args.second_half:
            second_half(delay, args.filter, people, kept)
            continue
        for person_id in ids:
            result = footage_loop.run_footage(
                RIG,
                people,
                args.filter,
                frame_delay_ms=delay,
                start_frame=int(people[person_id].frame[0]),
                select_id=person_id,
            )
            row = analyse(result, kept.recording.messages, people)
            print(f"{delay:g} ms {row}", flush=True)


if __name__ == "__main__":
    main()
