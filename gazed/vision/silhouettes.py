"""A still camera's walkers: background subtraction, its foreground split into silhouettes.

OpenCV's Gaussian-mixture background model (MOG2, seed 003 §IV) learns the still scene,
`level` pyramid levels down (level 1: half resolution) to keep within the frame budget. Its
foreground is cleaned (a 3x3 opening drops speckle, a 5x5 closing joins a silhouette's parts),
grouped into blobs of at least `min_area_px` full-resolution pixels, and each blob is split into
the walkers it holds side by side (`gazed.vision.movers.split_blob`), judged against a
person's size where they stand when the camera is calibrated (`person`, `PersonSize`).

A colour frame is modelled in colour. MOG2 thresholds the squared Mahalanobis distance summed
over the channels, so the rig's `threshold` (one grey channel's) becomes the χ² quantile of
the channels' count at the same false-alarm rate (`channel_threshold`): three channels of
noise sum higher than one. With `shadows`, MOG2 also labels a pixel that is a darker copy of
its background, at most twice darker and of the same colour, a shadow (Prati, Mikic, Trivedi &
Cucchiara, "Detecting moving shadows", IEEE PAMI 25(7), 2003). A walker's cast shadow joins
them to the ground around them and to the walkers beside them, and widens their box; so the
foreground is the foreground pixels and only those shadow pixels that join them within the
columns of a foreground blob (`without_cast_shadows`): grey trousers under a coat, which the
test takes for a shadow on a grey road, stay with the coat, and a shadow cast sideways, or
along the ground between two walkers, is left out. A grey frame has no colour to tell a shadow
from dark clothes, and its shadows are kept.

The model learns its first `learning_frames` frames together, in runs of at most
`SCENE_BATCH_FRAMES` (their memory bounded), the people passing through them left out
(`gazed.vision.scene_learning`), and reports nothing until then.

A walker who stops would be learnt into the background within a few seconds. So the foreground
is taken against the model as it stands, and the model then learns the frame with the pixels
under the silhouettes shown as its own background image: the walker stays foreground. A pixel
is held out for at most `history_frames` frames in a row, the model's own memory, and then
learnt as it is, as the model would learn anything that stays that long. A ghost (the ground
where someone stood while the model learnt the scene, `gazed.vision.ghosts`) is not a walker:
with `ghosts` it is left out of the silhouettes and not held out, so the model learns the
ground it shows at its usual rate; a blob split into several bodies has each judged on its own
(a walker beside the ghost they left is kept).

Each walker is a mover: its point (the ground contact point at the bottom of its silhouette, or
its centroid), box and area in full-resolution pixels, its confidence the share of the frame's
foreground it covers, and its velocity the slope of its own recent points (`RegionTracks`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from gazed.estimation.chi_square import chi2_quantile, log_upper_tail
from gazed.vision.ego_motion import HeadStep
from gazed.vision.ghosts import ghost_mask, is_ghost
from gazed.vision.movers import CLOSING_KERNEL, OPENING_KERNEL, Blob, MoverRegion, blobs, cleaned
from gazed.vision.person_size import PersonSize
from gazed.vision.region_tracks import RegionTracks
from gazed.vision.scene_learning import without_passers_by

VELOCITY_POINTS = 6  # a mover's recent points its velocity is fitted to
FOREGROUND = 255  # MOG2's label of a foreground pixel
SHADOW = 127  # and of a shadow's
SCENE_BATCH_FRAMES = 15  # learning frames learnt together at most: their memory is bounded

PointKind = Literal["centroid", "ground-contact"]


@dataclass(frozen=True)
class Foreground:
    """One frame's silhouettes: each blob with the walkers it holds, largest blob first (model
    pixels), and the foreground's whole area in full-resolution pixels."""

    found: list[tuple[Blob, list[Blob]]]
    total_px: float


def channel_threshold(threshold: float, channels: int) -> float:
    """MOG2's threshold on the squared Mahalanobis distance summed over `channels`, at the false
    alarm rate `threshold` gives one channel: the χ²(channels) quantile of χ²(1)'s at it."""
    if channels == 1:
        return threshold
    return chi2_quantile(-math.expm1(log_upper_tail(threshold, 1)), channels)


def without_cast_shadows(labels: np.ndarray) -> np.ndarray:
    """MOG2's labels (foreground, shadow, background) as a foreground mask: the foreground (its
    speckle opened away), and the shadow pixels joined to it within the columns of one of its
    blobs (see the module docstring)."""
    core = cv2.morphologyEx(
        np.where(labels == FOREGROUND, FOREGROUND, 0).astype(np.uint8),
        cv2.MORPH_OPEN,
        OPENING_KERNEL,
    )
    _, _, stats, _ = cv2.connectedComponentsWithStats(core, connectivity=8)
    columns = np.zeros(labels.shape[1], bool)
    for x, w in stats[1:, [cv2.CC_STAT_LEFT, cv2.CC_STAT_WIDTH]]:
        columns[x : x + w] = True
    union = (core > 0) | ((labels == SHADOW) & columns[None, :])
    _, parts = cv2.connectedComponents(union.astype(np.uint8), connectivity=8)
    held = np.zeros(parts.max() + 1, bool)
    held[parts[core > 0]] = True
    held[0] = False
    return np.where(held[parts], FOREGROUND, 0).astype(np.uint8)


class SilhouetteModel:
    def __init__(
        self,
        *,
        level: int,
        history_frames: int,
        threshold: float,
        min_area_px: float,
        learning_frames: int,
        person: PersonSize | None = None,
        shadows: bool = False,
        ghosts: bool = True,
    ) -> None:
        self.level = level
        self.ghosts = ghosts  # leave ghosts (`gazed.vision.ghosts`) out, and learn them
        self.shadows = shadows  # leave cast shadows out of a colour frame's silhouettes
        self.scale = 1 << level
        self.history_frames = history_frames
        self.threshold = threshold
        self.min_area_px = min_area_px
        self.learning_frames = learning_frames
        self.person = person
        self.resets = 0
        self.ghost_px = 0  # model pixels left out as ghosts
        self._model: cv2.BackgroundSubtractorMOG2 | None = None
        self._shadow_test = False  # the model labels shadows (`shadows`, on a colour frame)
        self._learned = 0
        self._held: np.ndarray | None = None  # frames in a row each pixel has been held out
        self._learning: list[np.ndarray] = []  # the learning frames, until they are learnt
        self._tracks = RegionTracks(VELOCITY_POINTS)

    @property
    def started(self) -> bool:
        return self._model is not None

    def reset(self) -> None:
        """Forget the scene: the next frame starts learning it afresh."""
        self._model = None
        self._tracks.reset()

    def reset_tracks(self) -> None:
        """Nothing in view: no mover's track continues."""
        self._tracks.reset()

    def segment(self, image: np.ndarray) -> Foreground | None:
        """The silhouettes of a frame, grey (H, W) or colour (H, W, 3), or None while the model
        is still learning the scene."""
        small = image
        for _ in range(self.level):
            small = cv2.pyrDown(small)
        if self._learning and small.shape != self._learning[0].shape:
            self._model = None  # the frames changed size or channels while learning: start over
        if self._model is None:
            channels = 1 if image.ndim == 2 else image.shape[2]
            self._shadow_test = self.shadows and channels == 3
            self._model = cv2.createBackgroundSubtractorMOG2(
                history=self.history_frames,
                varThreshold=channel_threshold(self.threshold, channels),
                detectShadows=self._shadow_test,
            )
            self._learned = 0
            self._learning = []
            self.resets += 1
        self._learned += 1
        if self._learned <= self.learning_frames:
            self._learning.append(small)
            if self._learned == self.learning_frames or len(self._learning) == SCENE_BATCH_FRAMES:
                self._learn_scene()
            return None
        # the foreground against the model as it stands, then the model learns the frame with
        # the held pixels (under this frame's silhouettes) shown as the background it has
        rate = 1.0 / min(2 * self._learned, self.history_frames)
        mask = self._model.apply(small, learningRate=0.0)
        if self._shadow_test:
            mask = without_cast_shadows(mask)
        opened, mask = cleaned(mask)
        background = self._model.getBackgroundImage() if mask.any() else None
        area_scale = self.scale * self.scale
        found = blobs(
            mask,
            self.min_area_px / area_scale,
            split=True,
            evidence=opened,
            person_width=None if self.person is None else self._person_width,
        )
        if background is not None and self.ghosts:
            found = self._without_ghosts(found, mask, small, background)
        self._model.apply(self._held_out(small, mask, background), learningRate=rate)
        return Foreground(found, float(np.count_nonzero(mask)) * area_scale)

    def _learn_scene(self) -> None:
        """Learn the learning frames held, the people passing through them left out
        (`scene_learning`)."""
        assert self._model is not None
        frames, self._learning = self._learning, []
        channels = 1 if frames[0].ndim == 2 else frames[0].shape[2]
        area = self.min_area_px / (self.scale * self.scale)
        threshold = channel_threshold(self.threshold, channels)
        for frame in without_passers_by(frames, threshold, self._model.getVarMin(), area):
            self._model.apply(frame)
        self._held = np.zeros(frames[0].shape[:2], np.int32)

    def _without_ghosts(
        self,
        found: list[tuple[Blob, list[Blob]]],
        mask: np.ndarray,
        small: np.ndarray,
        background: np.ndarray,
    ) -> list[tuple[Blob, list[Blob]]]:
        """The blobs without their ghosts (`gazed.vision.ghosts`), whose pixels are cleared from
        `mask` so that they are not held out: a blob judged whole (`ghost_mask`, too small ones
        included), and each body of a blob split into several on its own (`is_ghost`)."""
        ghost = ghost_mask(mask, small, background)
        kept = []
        for blob, bodies in found:
            if len(bodies) == 1:
                if not ghost[blob.y, blob.x : blob.x + blob.width][blob.mask[0]].any():
                    kept.append((blob, bodies))
                continue
            _region(ghost, blob)[blob.mask] = False  # each of its bodies judged on its own
            walkers = []
            for body in bodies:
                if is_ghost(body.mask, body.x, body.y, small, background):
                    _region(ghost, body)[body.mask] = True
                else:
                    walkers.append(body)
            if walkers:
                kept.append((blob, walkers))
        if ghost.any():
            self.ghost_px += int(np.count_nonzero(ghost))
            mask[ghost] = 0
        return kept

    def _person_width(self, blob: Blob) -> float | None:
        """A person's width (model pixels) at the middle of the blob's bottom edge."""
        scale = self.scale
        size = self.person.at((blob.x + blob.width / 2.0) * scale, (blob.y + blob.height) * scale)
        return None if size is None else size[0] / scale

    def _held_out(
        self, small: np.ndarray, mask: np.ndarray, background: np.ndarray | None
    ) -> np.ndarray:
        """The frame to learn: under the silhouettes (grown by the closing's reach) the model's
        own background, for at most `history_frames` frames in a row per pixel; then the pixel
        is learnt as it is, as the model would learn anything that stays for its memory."""
        silhouettes = cv2.dilate(mask, CLOSING_KERNEL) > 0
        if self._held is None or self._held.shape != small.shape[:2]:
            self._held = np.zeros(small.shape[:2], np.int32)
        self._held = np.where(silhouettes, self._held + 1, 0)
        hold = self._held <= self.history_frames
        hold &= silhouettes
        if not hold.any():
            return small
        learnt = small.copy()
        learnt[hold] = background[hold]
        return learnt

    def point(self, blob: Blob, kind: PointKind) -> tuple[float, float]:
        """A blob's ground contact point or centroid in full-resolution pixels (level-k pixel
        i is centred on level-0 pixel scale*i and spans scale pixels)."""
        scale = self.scale
        if kind == "ground-contact":
            u, v = blob.ground_contact()
            return u * scale, v * scale + (scale - 1) / 2.0
        u, v = blob.centroid()
        return u * scale, v * scale

    def movers(
        self,
        foreground: Foreground,
        kind: PointKind,
        step: HeadStep,
        t_s: float,
        first_u_px: float | None = None,
    ) -> tuple[MoverRegion, ...]:
        """Every walker of every blob, each with the velocity of its own track; first the one
        of the largest blob nearest column `first_u_px` (the target's), when given."""
        bodies = [body for _, parts in foreground.found for body in parts]
        if first_u_px is not None and bodies:
            scale = self.scale
            first = min(
                range(len(foreground.found[0][1])),
                key=lambda i: abs((bodies[i].x + bodies[i].width / 2.0) * scale - first_u_px),
            )
            bodies.insert(0, bodies.pop(first))
        points = [self.point(body, kind) for body in bodies]
        boxes = [body.box_at(self.scale) for body in bodies]
        radii = [0.5 * max(box[2], box[3]) for box in boxes]
        area_scale = self.scale * self.scale
        areas = [float(body.area * area_scale) for body in bodies]
        velocities = self._tracks.update(step, points, radii, areas, t_s)
        total = max(foreground.total_px, 1.0)
        movers = []
        for (u, v), velocity, box, area in zip(points, velocities, boxes, areas, strict=True):
            movers.append(MoverRegion.tracked(u, v, velocity, box, area, min(1.0, area / total)))
        return tuple(movers)


def _region(image: np.ndarray, blob: Blob) -> np.ndarray:
    """The view of `image` over a blob's box."""
    return image[blob.y : blob.y + blob.height, blob.x : blob.x + blob.width]
