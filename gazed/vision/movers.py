"""Movers: the separate moving things a detector segments in one frame.

A detector's foreground mask is grouped into 8-connected blobs (`blobs`). Where two walkers are
close their silhouettes touch and form one blob; `split_blob` separates them by a person-sized
width model: a standing person is taller than wide (at most `PERSON_WIDTH_RATIO` of their height
across, arms and stride included), so a blob wider than that may hold several, side by side.
Its column profile (the foreground pixels in each column) then shows each body as a peak and the
place where they touch as a valley; the blob is cut at the deepest valley that is at most
`VALLEY_FRACTION` of the lower of the peaks on either side, each peak being a body (at least
`BODY_FRACTION` of the blob's height), and each side is split again the same way. A blob with no
such valley — one wide thing, or people one behind the other — stays whole. Where the camera is
calibrated, a person's width where the blob stands (`gazed.vision.person_size`) replaces that
model: a blob at least `SEVERAL_WIDTHS` people across holds n = round(width / person's width)
side by side, touching or not; the first ends at the emptiest column within half a person of
width / n, and the rest is split again.

Each mover is reported as a `MoverRegion`: its point (the centroid, or the ground contact point
at the bottom of its silhouette), its independent image velocity, its box, area and confidence;
its appearance (`gazed.vision.appearance`) is added by the pipeline from the colour frame.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

PERSON_WIDTH_RATIO = 0.5  # a standing person's width over height, at most
VALLEY_FRACTION = 0.5  # a column this low against the bodies either side separates them
SEVERAL_WIDTHS = 2.0  # a blob at least this many people's widths across holds more than one
BODY_FRACTION = 0.5  # a body's column holds at least this fraction of the blob's height
FOOT_FRACTION = 0.1  # the bottom tenth of a silhouette gives its ground contact point's u
MAX_MOVERS = 64  # a Detection carries at most this many, the target's own first
OPENING_KERNEL = np.ones((3, 3), np.uint8)  # an opening by it drops a mask's speckle
CLOSING_KERNEL = np.ones((5, 5), np.uint8)  # a closing by it joins a silhouette's parts


@dataclass(frozen=True)
class MoverRegion:
    """One mover in a frame (full-resolution pixels, px/s). `box`: left, top, width, height."""

    u_px: float
    v_px: float
    du_px_s: float
    dv_px_s: float
    box: tuple[float, float, float, float]
    area_px: float
    confidence: float
    appearance: tuple[float, ...] = ()
    velocity_known: bool = True  # False: no velocity yet (du, dv are 0 and say nothing)

    @classmethod
    def tracked(
        cls,
        u_px: float,
        v_px: float,
        velocity_px_s: tuple[float, float] | None,
        box: tuple[float, float, float, float],
        area_px: float,
        confidence: float,
    ) -> MoverRegion:
        """A mover with the velocity of its region's track (`region_tracks`; None: none yet)."""
        du, dv = velocity_px_s or (0.0, 0.0)
        known = velocity_px_s is not None
        return cls(u_px, v_px, du, dv, box, area_px, confidence, velocity_known=known)

    @property
    def radius_px(self) -> float:
        """Half the box's longer side: how far the mover reaches from its point."""
        return 0.5 * max(self.box[2], self.box[3])


@dataclass(frozen=True)
class Blob:
    """A mover's pixels in a mask: `mask` (bool) over its box at (x, y) in the mask's pixels,
    trimmed to the pixels it holds."""

    x: int
    y: int
    mask: np.ndarray

    @property
    def width(self) -> int:
        return self.mask.shape[1]

    @property
    def height(self) -> int:
        return self.mask.shape[0]

    @cached_property
    def area(self) -> int:
        return int(np.count_nonzero(self.mask))

    def centroid(self) -> tuple[float, float]:
        """Mean position of its pixels (mask pixels)."""
        ys, xs = np.nonzero(self.mask)
        return self.x + float(xs.mean()), self.y + float(ys.mean())

    def ground_contact(self) -> tuple[float, float]:
        """Where the silhouette meets the ground (mask pixels): the mean column of its bottom
        rows (`FOOT_FRACTION` of its height), on its bottom row."""
        foot_rows = max(1, round(self.height * FOOT_FRACTION))
        feet = self.mask[self.height - foot_rows :]
        return self.x + float(np.nonzero(feet)[1].mean()), float(self.y + self.height - 1)

    def box_at(self, scale: int) -> tuple[float, float, float, float]:
        """Its box in the pixels of a level `scale` times finer (level-0 pixels)."""
        return (
            float(self.x * scale),
            float(self.y * scale),
            float(self.width * scale),
            float(self.height * scale),
        )


def cleaned(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A foreground mask (uint8) opened, its speckle dropped, and that closed, a silhouette's
    parts joined: (opened, closed)."""
    opened = cv2.morphologyEx(mask, cv2.MORPH_OPEN, OPENING_KERNEL)
    return opened, cv2.morphologyEx(opened, cv2.MORPH_CLOSE, CLOSING_KERNEL)


def trimmed(x: int, y: int, mask: np.ndarray) -> Blob | None:
    """The blob of `mask` at (x, y), its box trimmed to the pixels it holds (None: none)."""
    rows = np.flatnonzero(mask.any(axis=1))
    columns = np.flatnonzero(mask.any(axis=0))
    if len(rows) == 0:
        return None
    top, left = int(rows[0]), int(columns[0])
    return Blob(x + left, y + top, mask[top : rows[-1] + 1, left : columns[-1] + 1])


def split_blob(
    blob: Blob, evidence: np.ndarray | None = None, person_width: float | None = None
) -> list[Blob]:
    """The blob cut into the bodies it holds side by side (see the module docstring).
    `evidence`: the whole mask before it was closed, where the gaps between bodies show (the
    blob's own pixels without it). `person_width`: a person's width where the blob stands (mask
    pixels, `gazed.vision.person_size`), where the camera is calibrated."""
    h, w = blob.height, blob.width
    if person_width is None:
        several = w > PERSON_WIDTH_RATIO * h
    else:
        several = w >= SEVERAL_WIDTHS * person_width
    if not several or w < 3:
        return [blob]
    pixels = blob.mask
    if evidence is not None:
        pixels = pixels & evidence[blob.y : blob.y + h, blob.x : blob.x + w].astype(bool)
    profile = pixels.sum(axis=0).astype(float)
    cuts = np.arange(1, w - 1)
    if person_width is None:
        left_peak = np.maximum.accumulate(profile)
        right_peak = np.maximum.accumulate(profile[::-1])[::-1]
        bodies = np.minimum(left_peak[cuts - 1], right_peak[cuts + 1])
        depth = profile[cuts] / np.maximum(bodies, 1e-9)
        valid = (bodies >= BODY_FRACTION * h) & (depth <= VALLEY_FRACTION)
    else:
        # as wide as n people: the first of them ends at the emptiest column within half a
        # person of w / n, the nearest to it of those equally empty
        people = round(w / person_width)
        off = np.abs(cuts - w / people)
        depth = profile[cuts] + off / (w + 1.0)
        valid = off <= 0.5 * person_width
    if not valid.any():
        return [blob]
    cut = int(cuts[valid][np.argmin(depth[valid])])
    parts = []
    for x0, part in ((0, blob.mask[:, :cut]), (cut, blob.mask[:, cut:])):
        piece = trimmed(blob.x + x0, blob.y, part)
        if piece is not None:
            parts.extend(split_blob(piece, evidence, person_width))
    return parts


def blobs(
    mask: np.ndarray,
    min_area: float,
    *,
    split: bool,
    evidence: np.ndarray | None = None,
    person_width: Callable[[Blob], float | None] | None = None,
) -> list[tuple[Blob, list[Blob]]]:
    """The 8-connected blobs of `mask` (uint8 or bool) of at least `min_area` mask pixels, each
    with the bodies it holds (`split_blob` with `evidence` and the width of a person where it
    stands, by `person_width`; itself alone unless `split`), largest blob first."""
    _, labels, stats, _ = cv2.connectedComponentsWithStats(mask.view(np.uint8), connectivity=8)
    found = []
    for i in np.argsort(-stats[1:, cv2.CC_STAT_AREA], kind="stable") + 1:
        if stats[i, cv2.CC_STAT_AREA] < min_area:
            break
        x, y, w, h = (int(stats[i, k]) for k in range(4))
        blob = Blob(x, y, labels[y : y + h, x : x + w] == i)
        width = None if person_width is None else person_width(blob)
        found.append((blob, split_blob(blob, evidence, width) if split else [blob]))
    return found
