"""Why a person of PETS 2009 S2.L1 is not held: the digital head's wide movers and the
estimator's tracks over the footage, offline (no loop, no clock), against the annotated people.

    python tests/bench/pets_tracks.py [--frames 0-399] [--filter imm]

Each footage frame is segmented as the vision process segments the wide frame (`WideMovers`,
the rig's `[vision]` settings), its movers are mapped into the view at rest and handed to the
estimator (`TargetTracker.update`) as one detection, in the frame's own time (`frame / rate`).
Per person visible for at least `--min-seconds`, over the frames from the first the background
model reports (after its `background_learning_frames`):

- out of reach: frames whose box centre the head cannot foveate within its limits
  (`ViewPeople`, `FieldOfRegard.for_scoring`);
- missed: frames in which no mover's point lies within the person's box (the detector);
- lost: frames in which no confirmed track is on the person, matched one to one, nearest
  first. `--match view` (the default) scores as the closed loop does: a track is on a person
  when the view aimed at its ground point (`GroundGeometry.gaze_from_ground`, at the rig's
  target height) has its centre in the person's box, nearest by the angle to the box's centre;
  `--match ground`: when it is within `MATCH_M` of the person's ground point (people walking
  side by side are closer than the detector's point is to their feet, so this one also counts
  the tracks of a walking pair as changing places where the view does not);
- changes of the person's track: `twin` (the track before is still live and still on the
  person: two tracks sit on one person, the detector split them, and the match alternates
  between them), else `restart` (a new id, or one back on the person, after a loss or a
  merge) or `swap` (an id that was on another person before), each with the nearest other
  person's distance then. Only restarts and swaps are the tracker losing or trading a person.

A replay's figures swing with small changes anywhere upstream (a mover a pixel off starts
another track, which changes every association after it), so a change is judged over many
replays: `--starts 0-280/20` replays from each of those frames to the last of `--frames` (the
background model learning a different scene each time) and prints the counts summed and the
one-id share averaged; with `--frames 400-794`, the truth-free figures averaged.

Frames without truth (400-794) are scored by a truth-free figure, printed for any range: the
ids of confirmed tracks born, per minute of footage, and how long each is held (from its first
to its last frame as a confirmed, non-coasting track). A tracker that loses people, or splits
one into several, starts more ids that live shorter lives.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from gazed.config import load_rig  # noqa: E402
from gazed.estimation.target_tracker import TargetTracker  # noqa: E402
from gazed.eval.person_score import people_at  # noqa: E402
from gazed.eval.truth import read_truth  # noqa: E402
from gazed.eval.view_people import ViewPeople  # noqa: E402
from gazed.geometry.ground import GroundGeometry  # noqa: E402
from gazed.messages import Detection, HeadPose  # noqa: E402
from gazed.sim.reach import FieldOfRegard  # noqa: E402
from gazed.vision.digital_camera import rig_view  # noqa: E402
from gazed.vision.frames import CapturedFrame  # noqa: E402
from gazed.vision.person_size import PersonSize  # noqa: E402
from gazed.vision.stage import mover_message  # noqa: E402
from gazed.vision.wide_movers import WideMovers  # noqa: E402

RIG = ROOT / "configs" / "pets.toml"
TRUTH = ROOT.parent / "shared" / "data" / "footage" / "pets09-s2l1" / "truth_frames_0000-0399.csv"
MATCH_M = 1.0  # a track this near a person's ground point is theirs (matched one to one)
REST = HeadPose(pan_rad=0.0, tilt_rad=0.0)
# the replay's clock at frame 0: fixed (not the wall clock), so every run computes alike
T0_NS = 1_000_000_000_000_000_000


def replay(rig_path: Path, frames: range, mode: str | None, point: str) -> list[dict]:
    """Per frame: the movers' wide points and the confirmed tracks' ids and ground points, and
    whether the background model was still learning the scene (it reports nothing then)."""
    rig = load_rig(rig_path)
    if mode is not None:
        rig = rig.model_copy(
            update={"estimator": rig.estimator.model_copy(update={"filter": mode})}
        )
    view = rig_view(rig)
    person = PersonSize.from_rig(rig, view.wide)
    movers = WideMovers(view, rig.vision, point, person)  # type: ignore[arg-type]
    now_ns = [0]  # the replay's clock: each frame arrives as it is captured
    tracker = TargetTracker(rig, "estimator", clock_ns=lambda: now_ns[0])
    capture = cv2.VideoCapture(str(rig.wide_source))
    capture.set(cv2.CAP_PROP_POS_FRAMES, frames.start)
    t0_ns = T0_NS
    out = []
    for frame in frames:
        ok, pixels = capture.read()
        if not ok:
            break
        t_ns = now_ns[0] = t0_ns + round(frame / rig.wide.rate_hz * 1e9)
        movers.observe(CapturedFrame(pixels, "bgr8", t_ns, frame))
        wide = movers._movers[frame]
        seen = movers.in_view(frame, REST) or ()
        detection = Detection(
            t_capture_ns=t_ns,
            seq=frame,
            detector="flow",
            found=False,
            point=point,
            width_px=rig.camera.width_px,
            height_px=rig.camera.height_px,
            head=REST,
            movers=tuple(mover_message(m) for m in seen),
        )
        update = tracker.update(detection, t_ns)
        if update is not None:
            tracker.settle(update)
        tracks = {}
        for track in tracker.tracks.tracks:
            state = track.estimator.predict(t_ns / 1e9)
            if track.confirmed and state is not None and not track.coasting:
                tracks[track.id] = np.asarray(state.position[:2])
        learning = frame - frames.start < rig.vision.background_learning_frames
        out.append(
            {
                "frame": frame,
                "learning": learning,
                "wide": [(m.u_px, m.v_px) for m in wide],
                "tracks": tracks,
            }
        )
    return out


def aimed_at(
    people: ViewPeople, aim: GroundGeometry, boxes: np.ndarray, track_xy: np.ndarray
) -> np.ndarray:
    """(people, tracks): the angle from each person's box centre to the view's centre with the
    head aimed at each track, inf where that centre is outside the person's box."""
    out = np.full((len(boxes), len(track_xy)), np.inf)
    for t, (x_m, y_m) in enumerate(track_xy):
        seen = people.at_pose(boxes, *aim.gaze_from_ground(float(x_m), float(y_m)))
        out[seen.held, t] = seen.error_rad[seen.held]
    return out


def one_id_share(held: list[set[int]]) -> tuple[float, int]:
    """Of a person's frames (`held`: the tracks whose aim holds them in each), the share held
    by the one track that holds them most often, and how many tracks ever held them."""
    counts = Counter(t for tracks in held for t in tracks)
    if not held:
        return 0.0, 0
    return max(counts.values(), default=0) / len(held), len(counts)


def change_kind(before: int, was_elsewhere: bool, on_person: np.ndarray, track_ids: list) -> str:
    """`twin` where the track `before` is live and still on the person (`on_person`: finite for
    each of `track_ids` whose aim holds them), else `swap` where the new track was on another
    person, else `restart`."""
    if before in track_ids and np.isfinite(on_person[track_ids.index(before)]):
        return "twin"
    return "swap" if was_elsewhere else "restart"


def id_lifetimes(replayed: list[dict], rate_hz: float) -> dict[str, float]:
    """The truth-free figure of a replay (module docstring): ids born, ids per minute of the
    frames the background model reports, and their lifetimes' median and mean in seconds."""
    first: dict[int, int] = {}
    last: dict[int, int] = {}
    for row in replayed:
        for track_id in row["tracks"]:
            first.setdefault(track_id, row["frame"])
            last[track_id] = row["frame"]
    lives = np.array([(last[i] - first[i] + 1) / rate_hz for i in first])
    minutes = sum(not row["learning"] for row in replayed) / rate_hz / 60.0
    return {
        "ids": len(lives),
        "ids_per_min": len(lives) / minutes if minutes else 0.0,
        "median_life_s": float(np.median(lives)) if len(lives) else 0.0,
        "mean_life_s": float(lives.mean()) if len(lives) else 0.0,
    }


@dataclass
class Scores:
    """One replay scored: per person their counts and the tracks holding them each frame, the
    changes of their tracks (lines), and the replay itself."""

    stats: dict[int, Counter]
    held_by: dict[int, list[set[int]]]
    changes: list[str]
    replayed: list[dict]

    def totals(self) -> tuple[Counter, float]:
        """The counts over every person, and the share of their frames held by one id."""
        total = sum(self.stats.values(), Counter())
        held = sum(one_id_share(self.held_by[p])[0] * s["frames"] for p, s in self.stats.items())
        return total, held / total["frames"] if total["frames"] else 0.0


def score(
    rig_path: Path, frames: range, mode: str | None, point: str, min_seconds: float, match: str
) -> Scores:
    """Replay `frames` and score the tracks against the people visible `min_seconds` or more."""
    rig = load_rig(rig_path)
    people = read_truth(TRUTH)
    replayed = replay(rig_path, frames, mode, point)
    geometry = ViewPeople(
        rig_view(rig, zoom=False),
        FieldOfRegard.for_scoring(rig),
    )
    aim = GroundGeometry.from_rig(rig)
    scored = sorted(p.id for p in people.values() if p.seconds_visible >= min_seconds)
    stats = {pid: Counter() for pid in scored}
    owner: dict[int, int] = {}  # track id -> the person it was last on
    held: dict[int, int | None] = {}
    held_by: dict[int, list[set[int]]] = {pid: [] for pid in scored}
    changes: list[str] = []
    for row in replayed:
        frame = row["frame"]
        ids, boxes = people_at(people, frame)
        if not ids or row["learning"]:
            continue
        here = geometry.at_pose(boxes, 0.0, 0.0)
        ground = np.array([people[i].ground_m[people[i].at_frame(frame)] for i in ids])
        wide = np.array(row["wide"]).reshape(-1, 2)
        track_ids = list(row["tracks"])
        track_xy = np.array([row["tracks"][t] for t in track_ids]).reshape(-1, 2)
        if match == "view":
            distance = aimed_at(geometry, aim, boxes, track_xy)
        else:
            distance = np.linalg.norm(ground[:, None] - track_xy[None], axis=-1)
            distance[distance > MATCH_M] = np.inf
        matched: dict[int, int] = {}
        for k in np.argsort(distance, axis=None):
            p, t = divmod(int(k), len(track_ids))
            if not np.isfinite(distance[p, t]):
                break
            if p not in matched and track_ids[t] not in matched.values():
                matched[p] = track_ids[t]
        for p, pid in enumerate(ids):
            u, v, w, h = boxes[p]
            others = np.delete(np.linalg.norm(ground - ground[p], axis=1), p)
            nearest = float(others.min()) if len(others) else np.inf
            if pid in stats:
                s = stats[pid]
                s["frames"] += 1
                s["out_of_reach"] += int(not here.reachable[p])
                inside = (np.abs(wide[:, 0] - u) <= w / 2) & (np.abs(wide[:, 1] - v) <= h / 2)
                s["missed"] += int(not inside.any())
                s["lost"] += int(p not in matched)
                aims = zip(track_ids, distance[p], strict=True)
                held_by[pid].append({t for t, d in aims if d < np.inf})
            track = matched.get(p)
            if track is None:
                continue
            before = held.get(pid)
            if before is not None and before != track and pid in stats:
                kind = change_kind(before, owner.get(track, pid) != pid, distance[p], track_ids)
                stats[pid][kind] += 1
                changes.append(
                    f"  frame {frame}: person {pid} {before} -> {track} ({kind}; "
                    f"was on {owner.get(track)}), nearest other {nearest:.2f} m"
                )
            held[pid] = track
            owner[track] = pid
    return Scores(stats, held_by, changes, replayed)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", default="0-399")
    parser.add_argument("--filter", default=None, help="estimation mode (default: the rig's)")
    parser.add_argument("--min-seconds", type=float, default=10.0)
    parser.add_argument("--rig", type=Path, default=RIG)
    parser.add_argument("--match", choices=("view", "ground"), default="view")
    parser.add_argument(
        "--point", default="centroid", help="the movers' point: centroid or ground-contact"
    )
    parser.add_argument(
        "--starts",
        default=None,
        help="FIRST-LAST/STEP: replay from each of these frames to --frames' last, and print "
        "the sums (module docstring)",
    )
    args = parser.parse_args()
    first, last = (int(x) for x in args.frames.split("-"))
    rig = load_rig(args.rig)
    if args.starts is not None:
        span, step = args.starts.split("/")
        low, high = (int(x) for x in span.split("-"))
        print_starts(args, range(low, high + 1, int(step)), last, rig.wide.rate_hz)
        return
    scores = score(
        args.rig, range(first, last + 1), args.filter, args.point, args.min_seconds, args.match
    )
    print(
        f"frames {first}-{last}, filter {args.filter or rig.estimator.filter}, {args.point}, "
        f"matched by {args.match}"
    )
    print(
        f"  {'person':>6} {'frames':>6} {'out of reach':>12} {'missed':>6} {'lost':>5} "
        f"{'restarts':>8} {'swaps':>5} {'twins':>5} {'one id':>6} {'ids':>4}"
    )
    for pid, s in scores.stats.items():
        share, n_ids = one_id_share(scores.held_by[pid])
        print(
            f"  {pid:>6} {s['frames']:>6} {s['out_of_reach']:>12} {s['missed']:>6} "
            f"{s['lost']:>5} {s['restart']:>8} {s['swap']:>5} {s['twin']:>5} {share:>6.2f} "
            f"{n_ids:>4}"
        )
    total, one_id = scores.totals()
    print(
        f"  {'all':>6} {total['frames']:>6} {total['out_of_reach']:>12} {total['missed']:>6} "
        f"{total['lost']:>5} {total['restart']:>8} {total['swap']:>5} {total['twin']:>5} "
        f"{one_id:>6.2f}"
    )
    ids = id_lifetimes(scores.replayed, rig.wide.rate_hz)
    print(
        f"  ids born {ids['ids']} ({ids['ids_per_min']:.1f} per minute), lifetime median "
        f"{ids['median_life_s']:.1f} s, mean {ids['mean_life_s']:.1f} s"
    )
    print("changes of a person's track:")
    print("\n".join(scores.changes))


def print_starts(args: argparse.Namespace, starts: range, last: int, rate_hz: float) -> None:
    """One replay from each start to `last`: the person-frames' counts summed, the share held
    by one id averaged, and the ids born per minute and their mean lifetime averaged."""
    total: Counter = Counter()
    one_ids, per_minute, lives = [], [], []
    for start in starts:
        scores = score(
            args.rig, range(start, last + 1), args.filter, args.point, args.min_seconds, args.match
        )
        counts, one_id = scores.totals()
        total += counts
        if counts["frames"]:
            one_ids.append(one_id)
        ids = id_lifetimes(scores.replayed, rate_hz)
        per_minute.append(ids["ids_per_min"])
        lives.append(ids["mean_life_s"])
    print(
        f"{len(starts)} replays, from frames {starts.start}-{starts[-1]} every {starts.step} "
        f"to {last}:"
    )
    print(
        f"  person-frames {total['frames']}: missed {total['missed']}, lost {total['lost']}, "
        f"restarts {total['restart']}, swaps {total['swap']}, twins {total['twin']}"
        + (f"; one id (mean) {np.mean(one_ids):.3f}" if one_ids else "")
    )
    print(
        f"  ids born per minute (mean) {np.mean(per_minute):.1f}, "
        f"lifetime (mean) {np.mean(lives):.1f} s"
    )


if __name__ == "__main__":
    main()
