"""A mover's appearance: colour histograms of the upper and lower halves of its box, for telling
people apart where their positions do not (`gazed.estimation.association`).

Each half is an HSV histogram in the form of Pérez, Hue, Vermaak & Gangnet ("Color-based
probabilistic tracking", ECCV 2002): a pixel with a reliable hue (bright and saturated enough)
goes to a hue-saturation bin, so that the same clothes in sun and in shade compare alike; a
pixel too dark or too grey to have one goes to a bin of its brightness instead, so that dark,
grey and white clothes are told apart rather than left out. A grey frame has no hue at all: all
its pixels go to the brightness bins, and its descriptor has the same length as a colour one.

The two halves are kept apart because a person's clothes differ between the upper and lower
body (a light shirt over dark trousers and the reverse hold the same colours in one histogram),
the division by body part used to tell people apart in re-identification (Farenzena et al.,
"Person re-identification by symmetry-driven accumulation of local features", CVPR 2010). Each
half sums to 1/2, so the whole sums to 1 and its squared Hellinger distance to another is the
mean of the halves'.
"""

from __future__ import annotations

import cv2
import numpy as np

HUE_BINS = 8
SATURATION_BINS = 3
VALUE_BINS = 8  # the brightness of pixels without a reliable hue
HALF_BINS = HUE_BINS * SATURATION_BINS + VALUE_BINS
BINS = 2 * HALF_BINS  # upper half, then lower half
MIN_VALUE = 32  # darker pixels' hue is noise
MIN_SATURATION = 24  # greyer pixels' hue is noise
MIN_PIXELS = 8  # fewer pixels in a half give no descriptor


def colour_histogram(
    frame: np.ndarray, box_px: tuple[float, float, float, float], encoding: str = "bgr8"
) -> np.ndarray | None:
    """The normalised histogram (BINS,) of the pixels in `box_px` = (centre u, centre v,
    width, height), or None where a half of the box holds too few pixels in the frame."""
    u, v, w, h = box_px
    height, width = frame.shape[:2]
    left, right = max(0, round(u - w / 2)), min(width, round(u + w / 2))
    top, bottom = max(0, round(v - h / 2)), min(height, round(v + h / 2))
    middle = max(top, min(bottom, round(v)))  # the box's middle row, where it lies in the frame
    halves = [
        _half(frame[rows, left:right], encoding)
        for rows in (slice(top, middle), slice(middle, bottom))
    ]
    if any(half is None for half in halves):
        return None
    return np.concatenate(halves) / 2.0


def _half(patch: np.ndarray, encoding: str) -> np.ndarray | None:
    """One half's histogram (HALF_BINS,), summing to 1; None where it has too few pixels."""
    if patch.shape[0] * patch.shape[1] < MIN_PIXELS:
        return None
    if patch.ndim == 2 or encoding == "gray8":
        grey = np.ascontiguousarray(patch.reshape(patch.shape[:2]))
        hue = np.zeros(HUE_BINS * SATURATION_BINS, np.float32)
        value = cv2.calcHist([grey], [0], None, [VALUE_BINS], [0, 256]).ravel()
    else:
        conversion = cv2.COLOR_BGR2HSV if encoding == "bgr8" else cv2.COLOR_RGB2HSV
        hsv = cv2.cvtColor(np.ascontiguousarray(patch), conversion)
        chromatic = (hsv[..., 2] >= MIN_VALUE) & (hsv[..., 1] >= MIN_SATURATION)
        hue = cv2.calcHist(
            [hsv], [0, 1], chromatic.astype(np.uint8), [HUE_BINS, SATURATION_BINS], [0, 180, 0, 256]
        ).ravel()
        value = cv2.calcHist(
            [hsv], [2], (~chromatic).astype(np.uint8), [VALUE_BINS], [0, 256]
        ).ravel()
    counts = np.concatenate([hue, value]).astype(float)
    return counts / counts.sum()
