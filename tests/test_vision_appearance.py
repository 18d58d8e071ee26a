"""Colour histograms: the same clothes match in sun and shade, different clothes do not."""

from __future__ import annotations

import cv2
import numpy as np

from gazed.estimation.association import hellinger_squared
from gazed.vision.appearance import GREY_BINS, colour_histogram


def person(bgr: tuple[int, int, int], brightness: float = 1.0, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    frame = np.full((120, 160, 3), 90, np.uint8)  # a grey pavement
    body = np.clip(np.array(bgr) * brightness + rng.normal(0, 6, (60, 20, 3)), 0, 255)
    frame[30:90, 70:90] = body.astype(np.uint8)
    return frame


BOX = (80.0, 60.0, 20.0, 60.0)


def test_same_clothes_in_sun_and_shade_match_and_others_do_not() -> None:
    red_sun = colour_histogram(person((40, 40, 200)), BOX)
    red_shade = colour_histogram(person((40, 40, 200), brightness=0.5, seed=1), BOX)
    blue = colour_histogram(person((200, 60, 30), seed=2), BOX)
    assert red_sun is not None and red_shade is not None and blue is not None
    assert red_sun.shape == (GREY_BINS,)
    assert abs(float(red_sun.sum()) - 1.0) < 1e-6
    h2 = hellinger_squared(np.array([red_sun]), np.array([red_shade, blue]))[0]
    assert h2[0] < 0.1 < 0.5 < h2[1]


def test_rgb_frames_and_grey_frames() -> None:
    bgr = person((40, 40, 200))
    rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
    assert np.allclose(colour_histogram(bgr, BOX), colour_histogram(rgb, BOX, "rgb8"))
    grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    histogram = colour_histogram(grey, BOX, "gray8")
    assert histogram is not None and histogram.shape == (GREY_BINS,)


def test_boxes_off_the_frame_or_without_colour_give_none() -> None:
    frame = person((40, 40, 200))
    assert colour_histogram(frame, (-50.0, -50.0, 20.0, 20.0)) is None
    grey_clothes = np.full((120, 160, 3), 120, np.uint8)
    assert colour_histogram(grey_clothes, BOX) is None  # no pixel with a reliable hue
    clipped = colour_histogram(frame, (5.0, 60.0, 40.0, 60.0))  # half off the left edge
    assert clipped is None or abs(float(clipped.sum()) - 1.0) < 1e-6
