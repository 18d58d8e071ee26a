"""Ghosts: where someone stood while a still camera's model learnt the scene, the bare ground
they leave is not a walker; a walker who stops still is."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from test_vision_shadows import BODY, HEIGHT, KINEMATICS, RED, WIDTH, ground

from gazed.config import VisionSection
from gazed.geometry.camera import CameraModel
from gazed.vision.digital_view import DigitalView
from gazed.vision.ghosts import edge_energy
from gazed.vision.pipeline import make_detector
from gazed.vision.silhouettes import SilhouetteModel
from gazed.vision.wide_movers import WideMovers

LEARNING = 10  # frames the model learns before it reports
FEET = 180  # the row their feet stand on


def frame(n: int, left_px: float | None, grey: bool = False) -> np.ndarray:
    """Frame n of the ground with a walker whose left edge is at `left_px` (None: nobody)."""
    rng = np.random.default_rng(200 + n)
    image = ground() + rng.normal(0.0, 1.5, (HEIGHT, WIDTH, 3))
    if left_px is not None:
        w, h = BODY
        x = round(left_px)
        image[FEET - h + 1 : FEET + 1, x : x + w] = RED
    image = np.clip(image, 0, 255).astype(np.uint8)
    return image.mean(axis=2).astype(np.uint8) if grey else image


def model(ghosts: bool) -> SilhouetteModel:
    return SilhouetteModel(
        level=1,
        history_frames=200,
        threshold=16.0,
        min_area_px=100,
        learning_frames=LEARNING,
        ghosts=ghosts,
    )


def lefts(found: list) -> list[float]:
    """The left edges (full-resolution pixels) of a frame's walkers, in order."""
    return sorted(body.box_at(2)[0] for _, bodies in found for body in bodies)


def walk_away(ghosts: bool, frames: int, grey: bool = False) -> tuple[list[list[float]], int]:
    """A walker stands at x = 60 while the model learns, then walks right at 4 px a frame:
    each frame's walkers' left edges, and the pixels the model left out as ghosts."""
    silhouettes = model(ghosts)
    seen = []
    for n in range(LEARNING + frames):
        left = 60.0 + 4.0 * max(0, n - LEARNING)
        foreground = silhouettes.segment(frame(n, left, grey))
        if foreground is not None:
            seen.append(lefts(foreground.found))
    return seen, silhouettes.ghost_px


@pytest.mark.parametrize("grey", [False, True], ids=["colour", "grey"])
def test_where_a_walker_stood_while_the_model_learnt_is_no_walker(grey: bool) -> None:
    seen, ghost_px = walk_away(ghosts=True, frames=40, grey=grey)
    assert ghost_px > 0
    # once they have cleared the place they stood, only the walker is seen, where they are
    for k, found in enumerate(seen[10:], start=10):
        assert found == pytest.approx([60.0 + 4.0 * k], abs=3.0), k


def test_without_the_ghost_test_the_place_stays_a_walker() -> None:
    seen, ghost_px = walk_away(ghosts=False, frames=40)
    assert ghost_px == 0
    assert all(any(abs(x - 60.0) <= 3.0 for x in found) for found in seen[10:])


@pytest.mark.parametrize("grey", [False, True], ids=["colour", "grey"])
def test_a_walker_beside_the_place_they_stood_is_kept_and_the_ghost_left_out(grey: bool) -> None:
    """One step to the side after the model learnt them, then slowly on: the walker and their
    ghost are one blob (the closing joins them across the gap), split in two, and each half is
    judged on its own outline: only the walker is seen, in every frame."""
    silhouettes = model(ghosts=True)
    for n in range(LEARNING + 10):
        left = 60.0 if n < LEARNING else 80.0 + 0.5 * (n - LEARNING)
        foreground = silhouettes.segment(frame(n, left, grey))
        if foreground is None:
            continue
        boxes = [body.box_at(2) for _, bodies in foreground.found for body in bodies]
        centre = left + BODY[0] / 2
        assert len(boxes) == 1 and boxes[0][0] <= centre <= boxes[0][0] + boxes[0][2], n
    assert silhouettes.ghost_px > 0


def test_a_ghost_is_learnt_as_the_ground_it_shows() -> None:
    """Not held out as a stopped walker is: the model learns the bare ground, and after a
    while there is no ghost left to leave out."""
    silhouettes = model(ghosts=True)
    for n in range(LEARNING + 40):
        silhouettes.segment(frame(n, 60.0 + 4.0 * max(0, n - LEARNING)))
    left_out = silhouettes.ghost_px
    for n in range(LEARNING + 40, LEARNING + 50):
        silhouettes.segment(frame(n, 60.0 + 4.0 * max(0, n - LEARNING)))
    assert silhouettes.ghost_px == left_out


@pytest.mark.parametrize("grey", [False, True], ids=["colour", "grey"])
def test_a_walker_who_stops_is_not_a_ghost(grey: bool) -> None:
    """A walker who walks in and stands still for longer than a ghost would last stays a
    walker, on textured ground: the held-out pixels are the walker's."""
    silhouettes = model(ghosts=True)
    stop_at = LEARNING + 20
    seen = []
    for n in range(stop_at + 60):
        left = None if n < LEARNING else 20.0 + 4.0 * (min(n, stop_at) - LEARNING)
        foreground = silhouettes.segment(frame(n, left, grey))
        if foreground is not None and n >= stop_at:
            seen.append(lefts(foreground.found))
    assert silhouettes.ghost_px == 0
    assert all(found == pytest.approx([100.0], abs=3.0) for found in seen)


def test_the_rig_key_reaches_both_background_models() -> None:
    """The view's own background detector, and a digital head's wide movers."""
    wide = CameraModel.from_fov(WIDTH, HEIGHT, math.radians(60))
    view = DigitalView(wide, CameraModel.from_fov(160, 120, math.radians(30)), KINEMATICS)
    for on in (True, False):
        vision = VisionSection(background_ghosts=on)
        assert make_detector("background", vision, wide).silhouettes.ghosts is on
        assert WideMovers(view, vision, "centroid").silhouettes.ghosts is on


@pytest.mark.parametrize("channels", [1, 3])
def test_edge_energy_is_opencvs_sobel(channels: int) -> None:
    """At any pixels, border ones too: the squared 3x3 Sobel gradient OpenCV gives, summed
    over the channels."""
    rng = np.random.default_rng(channels)
    shape = (30, 40) if channels == 1 else (30, 40, channels)
    image = rng.integers(0, 256, shape).astype(np.uint8)
    pixels = image.astype(np.float32)
    dx = cv2.Sobel(pixels, cv2.CV_32F, 1, 0, ksize=3, borderType=cv2.BORDER_REPLICATE)
    dy = cv2.Sobel(pixels, cv2.CV_32F, 0, 1, ksize=3, borderType=cv2.BORDER_REPLICATE)
    expected = dx * dx + dy * dy
    if channels > 1:
        expected = expected.sum(axis=2)
    rows, cols = np.nonzero(rng.random(shape[:2]) < 0.3)
    assert np.array_equal(edge_energy(image, rows, cols), expected[rows, cols].astype(np.int64))
