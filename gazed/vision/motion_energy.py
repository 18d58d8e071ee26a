"""Motion energy of a frame pair and its Gaussian pyramid (seed 004 §2.1, Fig. 4; §5).

The previous frame is first laid over the current one by the head's pure rotation K R K^-1
(seed 004 §5, "compensation of image itself"), so a static background cancels in the
difference. Then, as in seed 004 §2.1: the difference of the two frames, the level-0 band of
its Laplacian pyramid `L0 = D - expand(reduce(D))`, its absolute value as the motion energy,
and the Gaussian pyramid of that energy as the locally integrated measure at every resolution.

Level-k pixel (i, j) is centred on level-0 pixel (2^k i, 2^k j) (OpenCV's pyrDown).
Pixels the warped previous frame does not cover carry no energy.
"""

from __future__ import annotations

import cv2
import numpy as np

# The warp's bilinear interpolation smooths the previous frame; smoothing both frames the same
# way first keeps that from showing up as energy on a textured background.
PRESMOOTH_SIGMA_PX = 1.0
# Pixels this close to the border of the warped previous frame get no energy (the Laplacian's
# 5x5 support reaches this far).
BORDER_MARGIN_PX = 3
STILL_PX = 0.01  # a warp moving no corner further than this is skipped
FIXED_POINT_BITS = 2
UNITS_PER_GREY = 1 << FIXED_POINT_BITS  # the pyramid is int16 in quarter grey levels


def presmooth(gray: np.ndarray) -> np.ndarray:
    """The frame as the energy computation sees it (uint8, Gaussian σ = 1 px)."""
    return cv2.GaussianBlur(gray, (5, 5), PRESMOOTH_SIGMA_PX)


def energy_pyramid(
    current: np.ndarray, previous: np.ndarray, H: np.ndarray | None, levels: int
) -> list[np.ndarray]:
    """Motion-energy pyramid (int16, `UNITS_PER_GREY` per grey level, level 0 first) of two
    presmoothed uint8 frames.

    `H` maps previous pixels to current ones (None: the head did not move)."""
    h, w = current.shape
    if H is not None and _moves_less_than(H, w, h, STILL_PX):
        H = None  # a still head: nothing to warp
    if H is not None:
        previous = cv2.warpPerspective(previous, H, (w, h), flags=cv2.INTER_LINEAR)
    # fixed point: int16 in quarter grey levels, exact for D, fine enough for the energies
    difference = cv2.subtract(current, previous, dtype=cv2.CV_16S)
    difference <<= FIXED_POINT_BITS
    band = cv2.pyrUp(cv2.pyrDown(difference), dstsize=(w, h))
    energy = cv2.absdiff(difference, band)  # |L0|, L0 = D - expand(reduce(D))
    if H is not None:
        _clear_uncovered(energy, H)
    pyramid = [energy]
    for _ in range(levels - 1):
        pyramid.append(cv2.pyrDown(pyramid[-1]))
    return pyramid


def _moves_less_than(H: np.ndarray, w: int, h: int, tolerance_px: float) -> bool:
    """Does H move every corner of the image by less than `tolerance_px`?"""
    corners = np.array([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1]], float)
    moved = cv2.perspectiveTransform(corners.reshape(-1, 1, 2), H).reshape(-1, 2)
    return bool(np.abs(moved - corners).max() < tolerance_px)


def _clear_uncovered(energy: np.ndarray, H: np.ndarray) -> None:
    """Zero the border strips the warped previous frame does not cover (its image quadrilateral
    shrunk by the margin; the strips are as wide as the quadrilateral's deepest edge point, so
    a slanted edge clears a few covered pixels too)."""
    h, w = energy.shape
    corners = np.array([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1]], float)
    x, y = cv2.perspectiveTransform(corners.reshape(-1, 1, 2), H).reshape(-1, 2).T
    m = BORDER_MARGIN_PX
    left = int(np.clip(np.ceil(max(x[0], x[3])) + m, 0, w))
    right = int(np.clip(np.floor(min(x[1], x[2])) - m + 1, 0, w))
    top = int(np.clip(np.ceil(max(y[0], y[1])) + m, 0, h))
    bottom = int(np.clip(np.floor(min(y[2], y[3])) - m + 1, 0, h))
    energy[:, :left] = 0
    energy[:, right:] = 0
    energy[:top, :] = 0
    energy[bottom:, :] = 0


class MotionEnergy:
    """Keeps the previous presmoothed frame and turns each new frame into an energy pyramid."""

    def __init__(self, levels: int) -> None:
        self.levels = levels
        self._previous: np.ndarray | None = None

    def update(self, gray: np.ndarray, H: np.ndarray | None) -> list[np.ndarray] | None:
        """The pyramid of (previous, this frame); None for the first frame after a reset."""
        current = presmooth(gray)
        previous, self._previous = self._previous, current
        if previous is None or previous.shape != current.shape:
            return None
        return energy_pyramid(current, previous, H, self.levels)

    def reset(self) -> None:
        self._previous = None
