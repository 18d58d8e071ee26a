"""Colour histograms: the same clothes match in sun and shade; different clothes, dark or light
ones, and the same colours worn the other way up, do not."""

from __future__ import annotations

import cv2
import numpy as np

from gazed.estimation.association import hellinger_squared
from gazed.vision.appearance import BINS, HALF_BINS, HUE_BINS, SATURATION_BINS, colour_histogram


def person(
    top: tuple[int, int, int],
    bottom: tuple[int, int, int] | None = None,
    brightness: float = 1.0,
    seed: int = 0,
) -> np.ndarray:
    """A grey pavement with a person: `top` over the upper half of the body, `bottom` (default
    the same) over the lower half."""
    rng = np.random.default_rng(seed)
    frame = np.full((120, 160, 3), 90, np.uint8)
    clothes = np.zeros((60, 20, 3))
    clothes[:30], clothes[30:] = top, top if bottom is None else bottom
    body = np.clip(clothes * brightness + rng.normal(0, 6, (60, 20, 3)), 0, 255)
    frame[30:90, 70:90] = body.astype(np.uint8)
    return frame


BOX = (80.0, 60.0, 20.0, 60.0)


def h2(a: np.ndarray | None, b: np.ndarray | None) -> float:
    assert a is not None and b is not None
    return float(hellinger_squared(a[None], b[None])[0, 0])


def test_same_clothes_in_sun_and_shade_match_and_others_do_not() -> None:
    red_sun = colour_histogram(person((40, 40, 200)), BOX)
    red_shade = colour_histogram(person((40, 40, 200), brightness=0.5, seed=1), BOX)
    blue = colour_histogram(person((200, 60, 30), seed=2), BOX)
    assert red_sun is not None and red_sun.shape == (BINS,)
    assert abs(float(red_sun.sum()) - 1.0) < 1e-6
    assert h2(red_sun, red_shade) < 0.1 < 0.5 < h2(red_sun, blue)


def test_dark_grey_and_white_clothes_are_told_apart_by_their_brightness() -> None:
    dark = colour_histogram(person((25, 25, 25)), BOX)
    dark_again = colour_histogram(person((25, 25, 25), seed=1), BOX)
    white = colour_histogram(person((230, 230, 230), seed=2), BOX)
    grey = colour_histogram(person((128, 128, 128), seed=3), BOX)
    assert h2(dark, dark_again) < 0.1
    assert h2(dark, white) > 0.5 and h2(dark, grey) > 0.5 and h2(grey, white) > 0.5


def test_a_light_shirt_over_dark_trousers_is_not_the_reverse() -> None:
    light, dark = (40, 40, 200), (30, 30, 30)
    shirt = colour_histogram(person(light, dark), BOX)
    shirt_again = colour_histogram(person(light, dark, seed=1), BOX)
    reverse = colour_histogram(person(dark, light, seed=2), BOX)
    assert h2(shirt, shirt_again) < 0.1 < 0.5 < h2(shirt, reverse)
    assert shirt is not None and abs(float(shirt[:HALF_BINS].sum()) - 0.5) < 1e-6


def test_rgb_frames_and_grey_frames() -> None:
    bgr = person((40, 40, 200))
    rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
    assert np.allclose(colour_histogram(bgr, BOX), colour_histogram(rgb, BOX, "rgb8"))
    grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    histogram = colour_histogram(grey, BOX, "gray8")
    assert histogram is not None and histogram.shape == (BINS,)
    hues = HUE_BINS * SATURATION_BINS
    assert histogram[:hues].sum() == 0 and histogram[HALF_BINS : HALF_BINS + hues].sum() == 0
    assert abs(float(histogram.sum()) - 1.0) < 1e-6  # all of it in the brightness bins


def test_boxes_off_the_frame_give_none() -> None:
    frame = person((40, 40, 200))
    assert colour_histogram(frame, (-50.0, -50.0, 20.0, 20.0)) is None
    assert colour_histogram(frame, (80.0, -25.0, 20.0, 60.0)) is None  # its upper half off
    clipped = colour_histogram(frame, (5.0, 60.0, 40.0, 60.0))  # half off the left edge
    assert clipped is not None and abs(float(clipped.sum()) - 1.0) < 1e-6
