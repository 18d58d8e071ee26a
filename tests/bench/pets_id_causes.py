"""Why a person's track changes while the person is annotated: each change `pets_tracks.py`
reports, classified from what the estimator did to the track before it.

    python tests/bench/pets_id_causes.py [--frames 0-399] [pets_tracks options]

The replay of `pets_tracks.py` runs with the track set instrumented (every frame: each track's
nearest mover in Mahalanobis d², the mover it took, whether its filter gated it out, the blob it
was a member of; births, merges and ends with the time coasted). For each change of a person's
track from `before` to `after`:

- `coasted out`: `before` ended after coasting past `coast_max_ms`; `coasted` where it still
  coasts at the change. Each is split by why it coasted over its last run of coasted frames
  (the most frequent reason): `no mover` (none within the gate's reach at all: missed or merged
  into another's blob), `outside gate` (its nearest mover beyond the gate: d² given),
  `taken by another` (its nearest mover in its gate went to another track), `filter gated`
  (assigned, but the filter's own gate refused it);
- `merged`: `before` ended in a merge;
- `twin`: `before` is live and on the person: `split` where `after` was born while `before`
  took another mover in that frame (two movers on one person), `back to the older track`
  where `after` is the older of the two (the match alternates);
- `drifted`: `before` is live and took a mover, but its aim left the person: split by where
  the mover it took aims the view (the person's box, another's, both, no one's).
"""

from __future__ import annotations

import contextlib
import io
import re
import sys
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import pets_tracks

from gazed.estimation import tracks as tracks_module

LOG: dict = {"frame": -1, "rows": {}, "born": {}, "ended": {}, "merged": {}}
PER_FRAME: dict[int, dict] = defaultdict(dict)  # frame -> track id -> record
BORN: dict[int, tuple[int, str]] = {}  # id -> (frame, what `before`-like tracks did)
ENDED: dict[int, tuple[int, str, float]] = {}  # id -> (frame, reason, coasted s)
TS = tracks_module.TrackSet
_step, _assign, _take, _start, _merge, _end = (
    TS.step,
    TS._assign,
    TS._take,
    TS._start,
    TS._merge,
    TS._end,
)
RATE = [7.0]


def frame_of(t_s: float) -> int:
    return round((t_s - pets_tracks.T0_NS / 1e9) * RATE[0])


def step(self, t_s, sightings, to_pixel=None):
    f = frame_of(t_s)
    LOG["frame"] = f
    LOG["sightings"] = sightings
    for track in self.tracks:
        PER_FRAME[f][track.id] = {"reason": "no mover", "d2": np.inf, "took": None}
    _step(self, t_s, sightings, to_pixel)
    for track in self.tracks:
        rec = PER_FRAME[f].setdefault(track.id, {})
        rec["coasting"] = track.coasting
        rec["confirmed"] = track.confirmed


def assign(self, predicted, P, sightings, looks):
    pairs, lone, costs = _assign(self, predicted, P, sightings, looks)
    f = LOG["frame"]
    holder = {c: r for r, c in pairs.items()}
    for row, track in enumerate(self.tracks):
        rec = PER_FRAME[f][track.id]
        if not sightings:
            continue
        d2 = []
        for s in sightings:
            y = s.measurement.position - predicted[row]
            S = P[row] + s.tail_or_core
            d2.append(float(y @ np.linalg.solve(S, y)))
        k = int(np.argmin(d2))
        rec["d2"] = d2[k]
        if row in pairs:
            rec["reason"] = "assigned"
        elif d2[k] > self.gate_d2:
            rec["reason"] = "outside gate"
        elif k in holder:
            rec["reason"] = "taken by another"
            rec["by"] = self.tracks[holder[k]].id
        else:
            rec["reason"] = "in gate, unassigned"
    return pairs, lone, costs


def take(self, track, sighting, t_s):
    _take(self, track, sighting, t_s)
    rec = PER_FRAME[LOG["frame"]].setdefault(track.id, {})
    if track.coasting:
        rec["reason"] = "filter gated"
    else:
        rec["reason"] = rec.get("reason", "assigned")
        rec["took"] = True
        rec["z"] = np.asarray(sighting.measurement.position)
        state = track.estimator.predict(t_s)
        rec["x"] = None if state is None else np.asarray(state.position[:2])
        if rec["reason"] not in ("assigned",):
            rec["reason"] = "blob" if rec["reason"] != "assigned" else "assigned"


def start(self, sighting, t_s):
    n = self.next_id
    _start(self, sighting, t_s)
    if self.next_id > n:
        BORN[n] = (LOG["frame"], "")


def merge(self, lost, found):
    gone = _merge(self, lost, found)
    kept = found.id if gone == lost.id else lost.id
    ENDED[gone] = (LOG["frame"], f"merged into {kept}", 0.0)
    return gone


def end(self, t_s):
    before = {t.id: t for t in self.tracks}
    _end(self, t_s)
    after = {t.id for t in self.tracks}
    for i, t in before.items():
        if i not in after:
            kind = "coasted out" if t.confirmed else "tentative dropped"
            ENDED[i] = (LOG["frame"], kind, t_s - t.last_hit_s)


TS.step, TS._assign, TS._take, TS._start, TS._merge, TS._end = step, assign, take, start, merge, end


def coast_reason(track_id: int, frame: int) -> tuple[str, int, list[float]]:
    """The most frequent reason over the track's last run of coasted frames up to `frame`."""
    reasons, d2s, f = [], [], frame
    while f >= 0 and track_id in PER_FRAME[f] and PER_FRAME[f][track_id].get("coasting"):
        reasons.append(PER_FRAME[f][track_id]["reason"])
        d2s.append(PER_FRAME[f][track_id]["d2"])
        f -= 1
    if not reasons:
        return "?", 0, []
    return Counter(reasons).most_common(1)[0][0], len(reasons), d2s


PEOPLE = pets_tracks.read_truth(pets_tracks.TRUTH)


def whose(rec: dict, frame: int, person: int) -> str:
    """Where the mover the track took, and its estimate after it, aim the view: into the
    person's box, another's, both (overlapping boxes) or none (`pets_tracks.aimed_at`)."""
    ids, boxes = pets_tracks.people_at(PEOPLE, frame)
    z, x = rec.get("z"), rec.get("x")
    if z is None or x is None:
        return "?"
    held = np.isfinite(pets_tracks.aimed_at(VIEW[0], VIEW[1], boxes, np.array([z, x])))
    p = ids.index(person)
    others = np.delete(held, p, axis=0).any(axis=0)
    mover = (
        ("own+other" if others[0] else "own")
        if held[p, 0]
        else ("other's" if others[0] else "no one's")
    )
    estimate = "on" if held[p, 1] else "off"
    return f"mover aims at {mover} box, estimate {estimate} the person"


DETAIL: list[str] = []
VIEW: list = []


def main() -> None:
    rig = pets_tracks.load_rig(pets_tracks.RIG)
    VIEW[:] = [
        pets_tracks.ViewPeople(
            pets_tracks.rig_view(rig, zoom=False), pets_tracks.FieldOfRegard.for_scoring(rig)
        ),
        pets_tracks.GroundGeometry.from_rig(rig),
    ]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        pets_tracks.main()
    text = out.getvalue()
    print(text.split("changes of a person")[0])
    pattern = re.compile(r"frame (\d+): person (\d+) (\d+) -> (\d+) \((\w+);")
    causes: Counter[str] = Counter()
    detail = []
    for m in pattern.finditer(text):
        frame, person, before, after, kind = (m.group(1), *m.groups()[1:4], m.group(5))
        frame, before, after = int(frame), int(before), int(after)
        if kind == "twin":
            b_frame = BORN.get(after, (-1, ""))[0]
            rec = PER_FRAME.get(b_frame, {}).get(before, {})
            if before not in PER_FRAME.get(b_frame, {}):
                how = "back to the older track"
            elif rec.get("took"):
                how = "split (born while the other took a mover)"
            else:
                how = f"born while the other coasted ({rec.get('reason')})"
            cause = f"twin: {how}"
        elif before in ENDED and ENDED[before][0] <= frame:
            e_frame, reason, _ = ENDED[before]
            if reason.startswith("merged"):
                cause = f"merged ({reason})"
            else:
                why, n, d2 = coast_reason(before, e_frame - 1)
                cause = f"{reason}: {why}"
                finite = [x for x in d2 if np.isfinite(x)]
                if finite:
                    cause_d2 = f" d2 median {np.median(finite):.0f}"
                    detail.append(f"frame {frame} p{person} {before}->{after}: {cause}{cause_d2}")
        else:
            rec = PER_FRAME.get(frame, {}).get(before, {})
            if rec.get("coasting"):
                why, n, d2 = coast_reason(before, frame)
                cause = f"coasting: {why}"
            else:
                cause = "drifted: " + whose(rec, frame, int(person))
        b_rec = BORN.get(after, (-1, ""))
        causes[(kind, cause)] += 1
        detail.append(
            f"frame {frame} p{person} {before}->{after} [{kind}] {cause}; after born {b_rec[0]}"
        )
    print("causes (pets_tracks kind, cause):")
    for (kind, cause), n in sorted(causes.items(), key=lambda kv: -kv[1]):
        print(f"  {n:3d}  {kind:8s} {cause}")
    print(
        "ends:",
        Counter(r for _, r, _ in ENDED.values() if not r.startswith("merged")),
        "merged",
        sum(r.startswith("merged") for _, r, _ in ENDED.values()),
    )
    print("\n".join(detail))
    print("\n".join(DETAIL))


if __name__ == "__main__":
    main()
