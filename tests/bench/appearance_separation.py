"""How well the movers' appearance tells the PETS 2009 S2.L1 people apart where it matters: a
person's running template against their own next mover and against the movers of the people
within `NEAR_M` of them on the ground in the same frame.

    python tests/bench/appearance_separation.py [--frames 0-399]

Each footage frame is segmented as the vision process segments the wide frame (`WideMovers`,
the rig's `[vision]` settings); a mover is a person's when at least half of its box lies in
that person's annotated box (the person holding most of it, as `pets_movers.py` counts it).
Each person's template learns their movers as a track's does (`TrackAppearance`), and before
it learns a frame's mover it is compared with that mover (h², own) and with the movers of the
people near them in the frame (h², near). Printed for the descriptor (`colour_histogram`) and,
for comparison, a single hue-saturation histogram of the whole box without brightness bins
(`box_hue_saturation`):

- pairs: (own, near) pairs compared, and the share in which the own mover is the nearer;
- AUC: the share of all (own, near) pairs of distances, frames mixed, in which own is nearer;
- the medians of h², own and near, and the own distances' gamma shape fitted by the templates
  (quantiles over the frames, `appearance_model`).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from pets_movers import overlap  # noqa: E402

from gazed.config import load_rig  # noqa: E402
from gazed.estimation.appearance_model import TrackAppearance  # noqa: E402
from gazed.estimation.association import hellinger_squared  # noqa: E402
from gazed.eval.person_score import people_at  # noqa: E402
from gazed.eval.truth import read_truth  # noqa: E402
from gazed.vision.appearance import colour_histogram  # noqa: E402
from gazed.vision.digital_camera import rig_view  # noqa: E402
from gazed.vision.frames import CapturedFrame  # noqa: E402
from gazed.vision.person_size import PersonSize  # noqa: E402
from gazed.vision.wide_movers import WideMovers  # noqa: E402

RIG = ROOT / "configs" / "pets.toml"
TRUTH = ROOT.parent / "shared" / "data" / "footage" / "pets09-s2l1" / "truth_frames_0000-0399.csv"
NEAR_M = 2.0

Describe = Callable[[np.ndarray, tuple[float, float, float, float]], np.ndarray | None]


def box_hue_saturation(
    frame: np.ndarray, box: tuple[float, float, float, float]
) -> np.ndarray | None:
    """The comparison: one 8x4 hue-saturation histogram of the box's pixels with a reliable hue."""
    u, v, w, h = box
    patch = frame[
        max(0, round(v - h / 2)) : round(v + h / 2), max(0, round(u - w / 2)) : round(u + w / 2)
    ]
    if patch.size == 0:
        return None
    hsv = cv2.cvtColor(np.ascontiguousarray(patch), cv2.COLOR_BGR2HSV)
    usable = ((hsv[..., 2] >= 32) & (hsv[..., 1] >= 24)).astype(np.uint8)
    counts = cv2.calcHist([hsv], [0, 1], usable, [8, 4], [0, 180, 0, 256]).ravel()
    return None if counts.sum() < 16 else counts / counts.sum()


def owned_movers(
    frames: range,
) -> list[tuple[int, int, np.ndarray, tuple[float, float, float, float]]]:
    """(frame, person, frame pixels, mover box as centre u, v, width, height) per owned mover."""
    rig = load_rig(RIG)
    view = rig_view(rig, zoom=False)
    wide = WideMovers(view, rig.vision, "centroid", PersonSize.from_rig(rig, view.wide))
    people = read_truth(TRUTH)
    capture = cv2.VideoCapture(str(rig.wide_source))
    capture.set(cv2.CAP_PROP_POS_FRAMES, frames.start)
    owned = []
    for frame in frames:
        ok, pixels = capture.read()
        if not ok:
            break
        foreground = wide.silhouettes.segment(wide.image(CapturedFrame(pixels, "bgr8", 0, frame)))
        ids, boxes = people_at(people, frame)
        if foreground is None or not ids:
            continue
        corners = np.column_stack([boxes[:, :2] - boxes[:, 2:] / 2, boxes[:, 2:]])
        for _, parts in foreground.found:
            for body in parts:
                x, y, w, h = box = body.box_at(wide.silhouettes.scale)
                share = np.array([overlap(np.array(box), c) for c in corners]) / max(w * h, 1e-9)
                if share.max() >= 0.5:
                    owned.append(
                        (frame, ids[int(share.argmax())], pixels, (x + w / 2, y + h / 2, w, h))
                    )
    return owned


def separation(owned: list, describe: Describe, ground: dict[tuple[int, int], np.ndarray]) -> str:
    by_frame: dict[int, list[tuple[int, np.ndarray]]] = {}
    for frame, person, pixels, box in owned:
        histogram = describe(pixels, box)
        if histogram is not None:
            by_frame.setdefault(frame, []).append((person, histogram))
    templates: dict[int, TrackAppearance] = {}
    own, near, shapes, nearer, pairs = [], [], [], 0, 0
    for frame in sorted(by_frame):
        seen = by_frame[frame]
        for person, _ in seen:
            look = templates.get(person)
            if look is None:
                continue
            h2 = hellinger_squared(look.template[None], np.array([h for _, h in seen]))[0]
            mine = float(h2[[p for p, _ in seen].index(person)])
            own.append(mine)
            shapes.append(look.shape)
            for k, (other, _) in enumerate(seen):
                a, b = ground.get((frame, person)), ground.get((frame, other))
                if (
                    other != person
                    and a is not None
                    and b is not None
                    and np.hypot(*(a - b)) <= NEAR_M
                ):
                    near.append(float(h2[k]))
                    pairs += 1
                    nearer += int(mine < h2[k])
        for person, histogram in seen:
            if person in templates:
                templates[person].take(histogram)
            else:
                templates[person] = TrackAppearance(histogram)
    own_a, near_a = np.array(own), np.array(near)
    auc = float((near_a[None, :] > own_a[:, None]).mean()) if len(near) else float("nan")
    return (
        f"pairs {pairs}, own nearer {nearer / max(pairs, 1):.3f}; AUC {auc:.3f}; "
        f"median h² own {np.median(own_a):.3f}, near {np.median(near_a):.3f}; "
        f"shape quantiles 0.25/0.5/0.75 {np.quantile(shapes, [0.25, 0.5, 0.75]).round(1).tolist()}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", default="0-399")
    args = parser.parse_args()
    first, last = (int(x) for x in args.frames.split("-"))
    owned = owned_movers(range(first, last + 1))
    ground = {
        (int(f), person.id): person.ground_m[k]
        for person in read_truth(TRUTH).values()
        for k, f in enumerate(person.frame)
    }
    print(f"frames {first}-{last}: {len(owned)} movers on a person")
    print(
        "  colour_histogram (halves, hue-saturation and brightness):",
        separation(owned, colour_histogram, ground),
    )
    print(
        "  box_hue_saturation (one histogram, hue only):           ",
        separation(owned, box_hue_saturation, ground),
    )


if __name__ == "__main__":
    main()
