"""The digital head's wide movers of PETS 2009 S2.L1 against the annotated people, frame by frame:
how often one person is reported as several movers, several people as one, or nobody at all.

    python tests/bench/pets_movers.py [--frames 0-399] [--list]

Each footage frame is segmented as the vision process segments the wide frame (`WideMovers`'
`SilhouetteModel`, the rig's `[vision]` settings and its person size). A mover is on a person
when at least half of its box lies in the person's box (the person holding most of it). Per
person and frame:

- split: two or more movers on the person;
- twins: two or more movers' points (centroids) in the person's box and in no other person's,
  each a detection the estimator may start a second track on;
- merged: a mover covering at least half of the person's box covers half of another's too;
- missed: no mover's box centre in the person's box, and no mover covering half of it;
- two near: two or more movers on the person or on nobody whose points lie within twice the
  person's box (2w x 2h about its centre): two movers that two tracks of the one person may
  each take, a part, a shadow or a ghost beside them included. Their share of the
  person-frames is the rig's `[estimator] split_probability`, and the share of them followed by
  two near again in the person's next frame its `split_continues_probability`
  (`gazed.estimation.duplicates`).

A mover spanning two people is counted by how the two stand in the image: one in front of the
other (their boxes share at least half the narrower one's columns, so no cut between columns
separates them) or side by side (a splitter's case).

Over all movers: those on nobody (a shadow, a leg cut from its body, the strip joining two
people, or a column of two people), the movers' box width and height against a person's where
each stands (`PersonSize`, quantiles), and where the splits come from: cut from one blob or
separate blobs, side by side or one above the other. `--list` prints every split with its boxes.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from gazed.config import load_rig  # noqa: E402
from gazed.eval.person_score import people_at  # noqa: E402
from gazed.eval.truth import read_truth  # noqa: E402
from gazed.vision.digital_camera import rig_view  # noqa: E402
from gazed.vision.frames import CapturedFrame  # noqa: E402
from gazed.vision.person_size import PersonSize  # noqa: E402
from gazed.vision.wide_movers import WideMovers  # noqa: E402

RIG = ROOT / "configs" / "pets.toml"
TRUTH = ROOT.parent / "shared" / "data" / "footage" / "pets09-s2l1" / "truth_frames_0000-0399.csv"
QUANTILES = (0.1, 0.25, 0.5, 0.75, 0.9)


def overlap(a: np.ndarray, b: np.ndarray) -> float:
    """The area two boxes (left, top, width, height) share."""
    w = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    h = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    return max(w, 0.0) * max(h, 0.0)


def split_kind(boxes: list[np.ndarray], blobs: list[int]) -> str:
    """Where a person's several movers come from."""
    source = "cut from one blob" if len(set(blobs)) < len(blobs) else "separate blobs"
    for i, a in enumerate(boxes):
        for b in boxes[i + 1 :]:
            across = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
            down = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
            if across > 0.5 * min(a[2], b[2]) and down < 0.5 * min(a[3], b[3]):
                return f"{source}, one above the other"
    return f"{source}, side by side"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", default="0-399")
    parser.add_argument("--list", action="store_true", help="print every split")
    args = parser.parse_args()
    first, last = (int(x) for x in args.frames.split("-"))
    rig = load_rig(RIG)
    view = rig_view(rig, zoom=False)
    person = PersonSize.from_rig(rig, view.wide)
    wide_movers = WideMovers(view, rig.vision, "centroid", person)
    silhouettes = wide_movers.silhouettes
    people = read_truth(TRUTH)
    capture = cv2.VideoCapture(str(rig.wide_source))
    capture.set(cv2.CAP_PROP_POS_FRAMES, first)
    total, kinds = Counter(), Counter()
    per_person: dict[int, Counter] = {}
    two_near_before: dict[int, tuple[int, bool]] = {}  # person -> (their last frame, two near)
    relative: dict[str, list[tuple[float, float]]] = {"on a person": [], "on nobody": []}
    for frame in range(first, last + 1):
        ok, pixels = capture.read()
        if not ok:
            break
        foreground = silhouettes.segment(wide_movers.image(CapturedFrame(pixels, "bgr8", 0, frame)))
        if foreground is None:
            continue
        found = [(b, body) for b, (_, parts) in enumerate(foreground.found) for body in parts]
        boxes = [np.array(body.box_at(silhouettes.scale)) for _, body in found]
        points = np.array([silhouettes.point(body, "centroid") for _, body in found])
        points = points.reshape(-1, 2)
        total["movers"] += len(found)
        ids, centred = people_at(people, frame)
        if not ids:
            continue
        areas = centred[:, 2] * centred[:, 3]
        corner = np.column_stack([centred[:, :2] - centred[:, 2:] / 2, centred[:, 2:]])
        shared = np.array([[overlap(m, p) for p in corner] for m in boxes]).reshape(-1, len(ids))
        on = shared / np.maximum([[m[2] * m[3]] for m in boxes], 1e-9).reshape(-1, 1)
        covers = shared >= 0.5 * areas  # (movers, people)
        owner = np.where(on.max(axis=1, initial=0) >= 0.5, on.argmax(axis=1), -1)
        inside = (np.abs(points[:, None] - centred[None, :, :2]) <= centred[None, :, 2:] / 2).all(
            axis=2
        )
        for m, box in enumerate(boxes):
            size = person.at(box[0] + box[2] / 2, box[1] + box[3])
            if size is not None:
                key = "on nobody" if owner[m] < 0 else "on a person"
                relative[key].append((box[2] / size[0], box[3] / size[1]))
        total["on nobody"] += int((owner < 0).sum())
        for m in np.flatnonzero(covers.sum(axis=1) >= 2):
            a, b = corner[np.flatnonzero(covers[m])[:2]]
            columns = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
            behind = columns >= 0.5 * min(a[2], b[2])
            total["one in front of the other" if behind else "side by side"] += 1
        for p, pid in enumerate(ids):
            counts = per_person.setdefault(pid, Counter())
            counts["frames"] += 1
            mine = np.flatnonzero(owner == p)
            centres = [(b[0] + b[2] / 2, b[1] + b[3] / 2) for b in boxes]
            centre_in = any(
                abs(u - centred[p, 0]) <= centred[p, 2] / 2
                and abs(v - centred[p, 1]) <= centred[p, 3] / 2
                for u, v in centres
            )
            counts["missed"] += int(not centre_in and not covers[:, p].any())
            counts["merged"] += int((covers[covers[:, p]].sum(axis=1) >= 2).any())
            counts["twins"] += int((inside[:, p] & (inside.sum(axis=1) == 1)).sum() >= 2)
            near = (np.abs(points - centred[p, :2]) <= centred[p, 2:]).all(axis=1)
            two_near = bool(((owner == p) | (owner < 0))[near].sum() >= 2)
            counts["two near"] += int(two_near)
            if two_near_before.get(pid) == (frame - 1, True):  # two near in the frame before
                counts["after two near"] += 1
                counts["two near again"] += int(two_near)
            two_near_before[pid] = (frame, two_near)
            if len(mine) >= 2:
                counts["split"] += 1
                kind = split_kind([boxes[m] for m in mine], [found[m][0] for m in mine])
                kinds[kind] += 1
                if args.list:
                    listed = [tuple(round(float(x)) for x in boxes[m]) for m in mine]
                    print(f"  frame {frame} person {pid}: {listed} ({kind})")
    all_people = sum(per_person.values(), Counter())
    print(f"frames {first}-{last}: movers {total['movers']}")
    if not per_person:
        return
    behind, beside = total["one in front of the other"], total["side by side"]
    print(
        f"  movers on nobody {total['on nobody']}, spanning two people {behind + beside}"
        f" (one in front of the other {behind}, side by side {beside})"
    )
    for key, rows in relative.items():
        if rows:
            ratio = np.array(rows)
            print(
                f"  {key} ({len(rows)}): "
                f"width / a person's {np.quantile(ratio[:, 0], QUANTILES).round(2)}"
                f", height / a person's {np.quantile(ratio[:, 1], QUANTILES).round(2)}"
                f" (quantiles {', '.join(str(q) for q in QUANTILES)})"
            )
    print("  splits:", ", ".join(f"{kind} {n}" for kind, n in kinds.most_common()) or "none")
    columns = ("frames", "split", "twins", "merged", "missed", "two near")
    print("  " + " ".join(f"{c:>6}" for c in ("person", *columns)))
    for pid in sorted(per_person):
        print("  " + " ".join(f"{v:>6}" for v in (pid, *(per_person[pid][c] for c in columns))))
    print("  " + " ".join(f"{v:>6}" for v in ("all", *(all_people[c] for c in columns))))
    print(
        "  two near per person-frame (the rig's [estimator] split_probability): "
        f"{all_people['two near'] / all_people['frames']:.4f}; two near again in the next frame "
        f"(split_continues_probability): {all_people['two near again']}"
        f" of {all_people['after two near']}, "
        f"{all_people['two near again'] / max(all_people['after two near'], 1):.4f}"
    )


if __name__ == "__main__":
    main()
