"""Cast shadows: a still camera's silhouettes leave out the ground a walker darkens, so a walker's
box is their body's and two walkers joined only by their shadows are two movers."""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np
import pytest

from gazed.config import VisionSection
from gazed.estimation.chi_square import log_upper_tail
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.vision.digital_view import DigitalView
from gazed.vision.frames import CapturedFrame
from gazed.vision.silhouettes import SilhouetteModel, channel_threshold
from gazed.vision.wide_movers import WideMovers

ENTER = 12  # frames of the empty scene the model learns first
WIDTH, HEIGHT = 320, 240
BODY = (14, 40)  # a walker's width and height, pixels
SHADOW_PX = 30  # how far a shadow reaches to the right of the feet
DARKENING = 0.6  # a shadow's brightness against the sunlit ground


@functools.cache
def ground() -> np.ndarray:
    """A textured, coloured ground (BGR, float)."""
    rng = np.random.default_rng(11)
    base = np.array([90.0, 120.0, 150.0])
    texture = rng.uniform(0.8, 1.2, (HEIGHT, WIDTH, 1))
    return base * texture


def scene(
    n: int, walkers: list[tuple[float, tuple[int, int, int]]], grey_legs: bool = False
) -> np.ndarray:
    """Frame n: each walker (left edge in px, BGR colour) stands with their feet on row 180,
    their shadow a strip along the ground to the right of their feet. `grey_legs`: their lower
    half is the ground's own colour, darker, as a shadow would be."""
    rng = np.random.default_rng(100 + n)
    frame = ground() + rng.normal(0.0, 1.5, (HEIGHT, WIDTH, 3))
    if n >= ENTER:
        w, h = BODY
        for left, colour in walkers:
            x = round(left)
            frame[180 - 6 : 181, x : x + w + SHADOW_PX] *= DARKENING
            frame[180 - h + 1 : 181, x : x + w] = colour
            if grey_legs:
                legs = frame[180 - h // 2 : 181, x : x + w]
                legs[:] = ground()[180 - h // 2 : 181, x : x + w] * DARKENING
    return np.clip(frame, 0, 255).astype(np.uint8)


def silhouettes(
    walkers: list[tuple[float, tuple[int, int, int]]],
    shadows: bool,
    grey_legs: bool = False,
    grey: bool = False,
) -> list[list[tuple[float, float, float, float]]]:
    """The blobs of the scene's last frame, each as its bodies' full-resolution boxes; `grey`:
    the frames given without their colour."""
    model = SilhouetteModel(
        level=1,
        history_frames=200,
        threshold=16.0,
        min_area_px=100,
        learning_frames=10,
        shadows=shadows,
    )
    foreground = None
    for n in range(ENTER + 3):
        frame = scene(n, walkers, grey_legs)
        foreground = model.segment(cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if grey else frame)
    assert foreground is not None
    return [[body.box_at(model.scale) for body in parts] for _, parts in foreground.found]


RED, DARK = (40, 40, 200), (25, 25, 25)
KINEMATICS = HeadKinematics("pan-tilt")


@pytest.mark.parametrize("colour", [RED, DARK], ids=["red", "dark"])
def test_a_walkers_box_leaves_their_shadow_out(colour) -> None:
    [[(x, _, w, h)]] = silhouettes([(100.0, colour)], shadows=True)
    assert abs(x - 100) <= 2 and abs(w - BODY[0]) <= 4  # the body, not its shadow
    assert abs(h - BODY[1]) <= 4  # dark clothes are not taken for a shadow


def test_without_the_shadow_test_the_box_takes_the_shadow_in() -> None:
    [[box]] = silhouettes([(100.0, RED)], shadows=False)
    assert box[2] >= BODY[0] + SHADOW_PX - 4


def test_walkers_joined_only_by_their_shadows_are_two() -> None:
    walkers = [(100.0, RED), (100.0 + BODY[0] + 20, (200, 80, 40))]
    assert len(silhouettes(walkers, shadows=False)) == 1  # one blob, its shadows joining them
    blobs = silhouettes(walkers, shadows=True)
    assert [len(parts) for parts in blobs] == [1, 1]
    boxes = sorted(parts[0] for parts in blobs)
    for (x, _, w, _), (left, _) in zip(boxes, walkers, strict=True):
        assert abs(x - left) <= 2 and abs(w - BODY[0]) <= 4


def test_legs_the_colour_of_a_shadow_stay_with_the_body_above_them() -> None:
    [[(x, _, w, h)]] = silhouettes([(100.0, RED)], shadows=True, grey_legs=True)
    assert abs(x - 100) <= 2 and abs(w - BODY[0]) <= 4
    assert abs(h - BODY[1]) <= 4  # the legs too, not only the torso


def test_a_grey_frame_keeps_its_shadows() -> None:
    """Without colour, a shadow and dark clothes are alike: nothing is taken for a shadow."""
    [[box]] = silhouettes([(100.0, RED)], shadows=True, grey=True)
    assert box[2] >= BODY[0] + SHADOW_PX - 4


def test_a_colour_threshold_has_one_grey_channels_false_alarm_rate() -> None:
    assert channel_threshold(16.0, 1) == 16.0
    colour = channel_threshold(16.0, 3)
    assert colour > 16.0
    assert math.isclose(log_upper_tail(colour, 3), log_upper_tail(16.0, 1), rel_tol=1e-9)


@pytest.mark.parametrize("shadows", [True, False])
def test_a_digital_heads_wide_movers_follow_the_rigs_shadow_setting(shadows) -> None:
    wide_camera = CameraModel.from_fov(WIDTH, HEIGHT, math.radians(60))
    view = DigitalView(wide_camera, CameraModel.from_fov(160, 120, math.radians(30)), KINEMATICS)
    movers = WideMovers(view, VisionSection(background_shadows=shadows), "centroid")
    walkers = [(100.0, RED)]
    for n in range(ENTER + 3):
        movers.observe(CapturedFrame(scene(n, walkers), "bgr8", n * 100_000_000, n))
    [mover] = movers._movers[ENTER + 2]
    width = mover.box[2]
    assert abs(width - BODY[0]) <= 4 if shadows else width >= BODY[0] + SHADOW_PX - 4
