"""How far a PETS 2009 S2.L1 mover's centroid lies from its person, against its own box's size:
what `[estimator] mover_extent_noise` measures.

    python tests/bench/mover_extent.py [--frames 0-794]

The wide camera's movers (`WideMovers`, the rig's segmentation, centroids) over the frames:

- against the annotation (frames 0-399): each mover whose centroid lies in exactly one
  annotated person's box, that box holding no other mover's centroid, gives the offset of its
  centroid from the box's centre as a fraction of the mover's own box width (u) and height (v).
  Its std per axis, over every such mover of every frame, is the fraction a mover's point is off
  the person it shows; it takes in the errors that last (a shadow, a part hidden for a while) as
  well as those that come and go;
- without the annotation (any frames): movers linked frame to frame (each the other's nearest
  centroid, within half the larger box), and along every chain of three frames the centroid's
  second difference c(t+1) - 2c(t) + c(t-1) over the middle mover's box. For a walker (whose
  acceleration moves the centroid by a fraction of a pixel between 7 Hz frames) independent
  errors of std s give a second difference of std sqrt(6) s: the part of the error that changes
  from frame to frame, a lower bound of the first.

Printed per axis: the std and the MAD-based std of each fraction, and how many movers or chains
it comes from. Against the annotation also: whether the offsets are white, as the filters take
them: the correlation of one person's offsets in consecutive frames (and two and five frames
apart), and the tail's persistence, the chance that a mover whose offset is the tail's (by the
fitted mixture's posterior) is followed by another in the person's next frame, beside the tail's
weight, which is that chance for independent offsets.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from gazed.config import load_rig  # noqa: E402
from gazed.vision.digital_camera import rig_view  # noqa: E402
from gazed.vision.frames import CapturedFrame  # noqa: E402
from gazed.vision.person_size import PersonSize  # noqa: E402
from gazed.vision.wide_movers import WideMovers  # noqa: E402

RIG = ROOT / "configs" / "pets.toml"
TRUTH = ROOT.parent / "shared" / "data" / "footage" / "pets09-s2l1" / "truth_frames_0000-0399.csv"


def links(a: np.ndarray, b: np.ndarray) -> dict[int, int]:
    """Row of b -> row of a: mutual nearest centroids within half the larger box. Rows:
    (u, v, w, h)."""
    if not len(a) or not len(b):
        return {}
    d = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])
    out = {}
    for j in range(len(b)):
        i = int(np.argmin(d[:, j]))
        reach = 0.5 * max(a[i, 2], a[i, 3], b[j, 2], b[j, 3])
        if int(np.argmin(d[i])) == j and d[i, j] <= reach:
            out[j] = i
    return out


def annotated() -> dict[int, np.ndarray]:
    """Frame -> the annotated people (N, 5): id, box centre u, v, width, height."""
    boxes: dict[int, list[list[float]]] = {}
    with TRUTH.open(newline="") as handle:
        for row in csv.DictReader(handle):
            box = [float(row[k]) for k in ("id", "box_u_px", "box_v_px", "box_w_px", "box_h_px")]
            boxes.setdefault(int(row["frame"]), []).append(box)
    return {frame: np.array(b) for frame, b in boxes.items()}


def offsets(movers: np.ndarray, people: np.ndarray) -> dict[int, np.ndarray]:
    """Person id -> the offset over its own box of the mover alone in that person's box, where
    the mover lies in no other person's box."""
    if not len(movers) or not len(people):
        return {}
    half = people[None, :, 3:] / 2.0
    inside = (np.abs(movers[:, None, :2] - people[None, :, 1:3]) <= half).all(axis=2)
    out = {}
    for i in range(len(movers)):
        (held,) = np.nonzero(inside[i])
        if len(held) == 1 and inside[:, held[0]].sum() == 1:
            out[int(people[held[0], 0])] = (movers[i, :2] - people[held[0], 1:3]) / movers[i, 2:]
    return out


def lag_correlation(seen: dict[tuple[int, int], np.ndarray], lag: int) -> tuple[np.ndarray, int]:
    """The correlation (2,) per axis of one person's offsets `lag` frames apart, over every
    person and frame (keys: person id, frame) where both are seen, and how many pairs."""
    pairs = [(x, seen[(p, f + lag)]) for (p, f), x in seen.items() if (p, f + lag) in seen]
    if len(pairs) < 3:
        return np.full(2, np.nan), len(pairs)
    a, b = (np.array(side) for side in zip(*pairs, strict=True))
    return np.array([np.corrcoef(a[:, k], b[:, k])[0, 1] for k in (0, 1)]), len(pairs)


def tail_persistence(seen: dict[tuple[int, int], float]) -> float:
    """P(tail in a person's next frame | tail in this one) from each offset's tail posterior
    (keys: person id, frame)."""
    now = np.array([w for (p, f), w in seen.items() if (p, f + 1) in seen])
    after = np.array([seen[(p, f + 1)] for (p, f) in seen if (p, f + 1) in seen])
    return float((now * after).sum() / now.sum())


def robust_std(x: np.ndarray) -> float:
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def scale_mixture(
    x: np.ndarray, steps: int = 200
) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """A two-component zero-mean Gaussian scale mixture of the centred fractions x (K, 2), by
    EM: the tail's weight, the core's and the tail's std on each axis (2,), and each sample's
    posterior of the tail (K,). One weight for both axes: a mask that splits or merges moves its
    point on both at once."""
    x = x - np.median(x, axis=0)
    core, tail, weight = np.array([robust_std(a) for a in x.T]), x.std(axis=0) * 2.0, 0.2
    for _ in range(steps):
        densities = []
        for std in (core, tail):
            d2 = np.square(x / std).sum(axis=1)
            densities.append(np.exp(-0.5 * d2) / (2 * np.pi * std.prod()))
        a, b = (1 - weight) * densities[0], weight * densities[1]
        w = b / np.maximum(a + b, 1e-300)  # each sample's posterior of the tail
        weight = float(w.mean())
        core = np.sqrt(((1 - w)[:, None] * x**2).sum(axis=0) / (1 - w).sum())
        tail = np.sqrt((w[:, None] * x**2).sum(axis=0) / w.sum())
    return weight, core, tail, w


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", default="0-794")
    args = parser.parse_args()
    first, last = (int(x) for x in args.frames.split("-"))
    rig = load_rig(RIG)
    view = rig_view(rig)
    movers = WideMovers(view, rig.vision, "centroid", PersonSize.from_rig(rig, view.wide))
    capture = cv2.VideoCapture(str(rig.wide_source))
    capture.set(cv2.CAP_PROP_POS_FRAMES, first)
    rows: list[np.ndarray] = []
    for frame in range(first, last + 1):
        ok, pixels = capture.read()
        if not ok:
            break
        t_ns = round(frame / rig.wide.rate_hz * 1e9)
        movers.observe(CapturedFrame(pixels, "bgr8", t_ns, frame))
        seen = [(m.u_px, m.v_px, m.box[2], m.box[3]) for m in movers._movers[frame]]
        rows.append(np.array(seen).reshape(-1, 4))
    truth = annotated() if TRUTH.exists() else {}
    seen = {
        (person, first + k): o
        for k, r in enumerate(rows)
        for person, o in offsets(r, truth.get(first + k, np.zeros((0, 5)))).items()
    }
    off = list(seen.values())
    second = []
    for k in range(2, len(rows)):
        back = links(rows[k - 1], rows[k])
        before = links(rows[k - 2], rows[k - 1])
        for j, i in back.items():
            if i in before:
                a, b, c = rows[k - 2][before[i]], rows[k - 1][i], rows[k][j]
                second.append((c[:2] - 2 * b[:2] + a[:2]) / b[2:] / np.sqrt(6))
    s = np.array(second).reshape(-1, 2)
    print(f"frames {first}-{last}: {len(off)} movers alone in an annotated box, {len(s)} chains")
    fractions = [("off the annotation", np.array(off).reshape(-1, 2))] if off else []
    fractions += [("frame to frame", s)]
    for name, x in fractions:
        print(
            f"  {name:>18}: u std {x[:, 0].std():.3f} robust {robust_std(x[:, 0]):.3f}   "
            f"v std {x[:, 1].std():.3f} robust {robust_std(x[:, 1]):.3f}"
        )
        weight, core, tail, posterior = scale_mixture(x)
        print(
            f"  {'':>18}  two-Gaussian scale mixture: core u {core[0]:.3f} v {core[1]:.3f}, "
            f"tail u {tail[0]:.3f} v {tail[1]:.3f}, tail weight {weight:.3f}"
        )
        if name == "off the annotation":
            whiteness(seen, dict(zip(seen, posterior, strict=True)), weight)


def whiteness(
    seen: dict[tuple[int, int], np.ndarray], posterior: dict[tuple[int, int], float], weight: float
) -> None:
    """Print how far a person's offsets in consecutive frames are from independent."""
    for lag in (1, 2, 5):
        r, n = lag_correlation(seen, lag)
        apart = f"{lag} frame{'s' if lag > 1 else ''} apart"
        print(f"  {'':>18}  {apart}: correlation u {r[0]:.2f} v {r[1]:.2f} ({n} pairs)")
    print(
        f"  {'':>18}  tail persistence P(tail | tail the frame before) "
        f"{tail_persistence(posterior):.2f}, against {weight:.3f} for independent offsets"
    )


if __name__ == "__main__":
    main()
