"""The learning frames of a background model, with the people who pass through them left out.

A background model started with people in view learns them as the scene: Gaussian mixtures
(MOG2) take as background the components that together weigh `backgroundRatio` (0.9), so the
colours of a walker who covers a pixel in a few of the learning frames are learnt beside the
ground's. Where the walker then stands, or another person in such colours passes, nothing is
seen; where the walker stood is a ghost (`gazed.vision.ghosts`).

Over the learning frames a pixel shows the scene in most of them and a passer-by in a few. So
each pixel's median over the frames is the scene, and its spread the median absolute deviation
(MAD, 1.4826 MAD estimating a Gaussian's σ), which is robust to the same few: a pixel where the
scene itself moves (foliage in the wind, flicker) has a wide spread in most frames, and a pixel
a walker crosses a narrow one. A frame's pixel is an outlier where its squared distance from the
median, over that spread (at least the model's own floor `var_min`) and summed over the
channels, exceeds the model's threshold (`channel_threshold`). The outliers are cleaned as the
silhouettes are (an opening drops speckle, a closing joins a body's parts), and the blobs of at
least `min_area` pixels are the passers-by. Before the model learns a frame, a passer-by's
pixels are shown as the nearest frame in time shows them without one: a sample of the scene with
its own noise (the median, one value repeated, would teach the model a variance below the
camera's noise, and those pixels would be foreground ever after). The rest of the frame, foliage
included, is learnt as it is, so the mixture keeps the scene's own motion as several modes
(Rousseeuw & Croux, "Alternatives to the median absolute deviation", JASA 88(424), 1993, for the
MAD; the median background of Cucchiara, Grana, Piccardi & Prati, "Detecting moving objects,
ghosts, and shadows in video streams", IEEE PAMI 25(10), 2003).

A person who stands through most of the learning frames is the median, and learnt as the
scene.
"""

from __future__ import annotations

import cv2
import numpy as np

from gazed.vision.movers import cleaned

MAD_TO_SIGMA = 1.4826  # a Gaussian's σ over its median absolute deviation


def without_passers_by(
    frames: list[np.ndarray], threshold: float, var_min: float, min_area: float
) -> list[np.ndarray]:
    """The frames (each (H, W) or (H, W, C), uint8) with the pixels of the blobs that differ
    from the frames' median by more than `threshold` (squared, summed over the channels, in
    units of each pixel's robust variance, at least `var_min`) shown as the nearest frame in
    time in which that pixel is no passer-by's; blobs of fewer than `min_area` pixels, and a
    pixel that is a passer-by's in every frame, are kept as they are."""
    if len(frames) < 3:  # no majority to tell the scene by
        return frames
    stack = np.stack(frames).astype(np.float32)
    median = np.median(stack, axis=0)
    deviation = np.abs(stack - median)
    variance = np.maximum((MAD_TO_SIGMA * np.median(deviation, axis=0)) ** 2, var_min)
    distance = deviation**2 / variance
    if distance.ndim == 4:  # colour: summed over the channels, as the model does
        distance = distance.sum(axis=3)
    passers = [_passers(far, min_area) for far in distance > threshold]
    learnt = []
    for k, frame in enumerate(frames):
        out = frame.copy()
        missing = passers[k].copy()
        for j in sorted(range(len(frames)), key=lambda j: (abs(j - k), j))[1:]:
            if not missing.any():
                break
            take = missing & ~passers[j]
            out[take] = frames[j][take]
            missing &= ~take
        learnt.append(out)
    return learnt


def _passers(far: np.ndarray, min_area: float) -> np.ndarray:
    """The blobs of at least `min_area` pixels of one frame's outliers `far` (bool), cleaned
    as the silhouettes are."""
    _, mask = cleaned(far.astype(np.uint8))
    _, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    large = np.flatnonzero(stats[1:, cv2.CC_STAT_AREA] >= min_area) + 1
    return np.isin(labels, large)
