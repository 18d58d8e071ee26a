"""Drawing a detector's answer on a frame, for a person to look at (`gazed detect --annotate`).

Yellow: the window searched (fovea, search window or blob box). Magenta: every mover's box,
numbered in the detector's order (0: the target's own). Green: the detection — a circle at a
centroid or a bar at a ground-contact point — and its velocity as an arrow showing where it
would be in `ARROW_S`. Blue dots: the motion candidates, numbered by rank.
"""

from __future__ import annotations

import cv2
import numpy as np

from gazed.vision.candidates import MotionRegion
from gazed.vision.detector import DetectorOutput

ARROW_S = 0.5
YELLOW, GREEN, BLUE, WHITE = (0, 220, 255), (0, 230, 0), (255, 140, 0), (255, 255, 255)
MAGENTA = (255, 0, 255)


def annotate(
    frame_bgr: np.ndarray,
    output: DetectorOutput,
    candidates: list[MotionRegion] | None,
    caption: str,
) -> np.ndarray:
    """A copy of the frame with the detection, its window, velocity, movers and candidates
    drawn."""
    image = frame_bgr.copy()
    for rank, c in enumerate(candidates or [], start=1):
        centre = (round(c.u_px), round(c.v_px))
        cv2.circle(image, centre, 3, BLUE, -1, cv2.LINE_AA)
        cv2.putText(image, str(rank), (centre[0] + 4, centre[1] - 4), 0, 0.4, BLUE, 1)
    if output.window is not None:
        x, y, w, h = output.window
        cv2.rectangle(image, (x, y), (x + w - 1, y + h - 1), YELLOW, 1)
    for index, mover in enumerate(output.movers):
        x, y, w, h = (round(c) for c in mover.box)
        cv2.rectangle(image, (x, y), (x + w - 1, y + h - 1), MAGENTA, 1)
        cv2.putText(image, str(index), (x + 1, y + 10), 0, 0.35, MAGENTA, 1, cv2.LINE_AA)
    if output.found:
        u, v = round(output.u_px), round(output.v_px)
        if output.point == "ground-contact":
            cv2.line(image, (u - 8, v), (u + 8, v), GREEN, 2, cv2.LINE_AA)
        else:
            cv2.circle(image, (u, v), 6, GREEN, 2, cv2.LINE_AA)
        tip = (
            round(output.u_px + output.du_px_s * ARROW_S),
            round(output.v_px + output.dv_px_s * ARROW_S),
        )
        cv2.arrowedLine(image, (u, v), tip, GREEN, 2, cv2.LINE_AA, tipLength=0.2)
    cv2.putText(image, caption, (6, 16), 0, 0.45, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(image, caption, (6, 16), 0, 0.45, WHITE, 1, cv2.LINE_AA)
    return image
