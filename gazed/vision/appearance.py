"""A mover's appearance: a colour histogram of the pixels it covers, for telling people apart
where their positions do not (`gazed.estimation.association`).

Hue and saturation only (HSV), so that the same clothes in sun and in shade compare alike;
pixels too dark or too grey to have a reliable hue are left out. The histogram is normalised to
sum to 1. A grey frame has no colours: its descriptor is the histogram of brightness instead.
"""

from __future__ import annotations

import cv2
import numpy as np

HUE_BINS = 8
SATURATION_BINS = 4
GREY_BINS = HUE_BINS * SATURATION_BINS  # the same length, so tracks compare whatever the frame
MIN_VALUE = 32  # darker pixels' hue is noise
MIN_SATURATION = 24  # greyer pixels' hue is noise
MIN_PIXELS = 16  # fewer usable pixels give no descriptor


def colour_histogram(
    frame: np.ndarray, box_px: tuple[float, float, float, float], encoding: str = "bgr8"
) -> np.ndarray | None:
    """The normalised histogram (GREY_BINS,) of the pixels in `box_px` = (centre u, centre v,
    width, height), or None where the box holds too few usable pixels."""
    u, v, w, h = box_px
    height, width = frame.shape[:2]
    left, right = max(0, round(u - w / 2)), min(width, round(u + w / 2))
    top, bottom = max(0, round(v - h / 2)), min(height, round(v + h / 2))
    if right <= left or bottom <= top:
        return None
    patch = frame[top:bottom, left:right]
    if patch.ndim == 2 or encoding == "gray8":
        counts = cv2.calcHist([patch.reshape(patch.shape[:2])], [0], None, [GREY_BINS], [0, 256])
    else:
        conversion = cv2.COLOR_BGR2HSV if encoding == "bgr8" else cv2.COLOR_RGB2HSV
        hsv = cv2.cvtColor(np.ascontiguousarray(patch), conversion)
        usable = ((hsv[..., 2] >= MIN_VALUE) & (hsv[..., 1] >= MIN_SATURATION)).astype(np.uint8)
        counts = cv2.calcHist([hsv], [0, 1], usable, [HUE_BINS, SATURATION_BINS], [0, 180, 0, 256])
    counts = counts.ravel()
    total = counts.sum()
    if total < MIN_PIXELS:
        return None
    return counts / total
