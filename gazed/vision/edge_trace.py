"""The edge under the fovea, for tracing ground lines (seed 000 §3.2.1).

The paper runs Canny edge detection and hysteresis linking in the fovea, finds the edgel nearest
the fovea's centre and its parent string, and steps along the string to the n-th neighbour,
whose position becomes the next gaze demand; a corner (high curvature) ends the trace.

Here: Gaussian smoothing and Canny (hysteresis thresholds) in the foveal window; the edge
strings are the contours of the edge map, and the one followed is the string with the most
edgels near the centre (a long boundary, not a blob of texture). A total least squares line
through those edgels places the edge point nearest the centre to sub-pixel precision and gives
the points `step_px` ahead and behind along it; the line is then refined to sub-pixel
precision on the gradient magnitude's peaks across it. The angle between the lines fitted to
the two halves of the Canny string is the turn, large at a corner. Which way is "ahead" is
arbitrary: the tracer keeps its own direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from gazed.geometry.camera import CameraModel

REFINE_SPACING_PX = 2.0  # sub-pixel refinement: one cross-section every this many pixels
REFINE_SEARCH_PX = 3  # and this far either side of the Canny line


@dataclass(frozen=True)
class EdgePoint:
    """Pixels in the full image; `turn_rad` 0 on a straight edge."""

    found: bool
    u_px: float = 0.0
    v_px: float = 0.0
    ahead_px: tuple[float, float] = (0.0, 0.0)
    behind_px: tuple[float, float] = (0.0, 0.0)
    turn_rad: float = 0.0


class EdgeTracer:
    def __init__(
        self,
        camera: CameraModel,
        fovea_rad: float,
        *,
        step_px: int = 12,
        blur_sigma_px: float = 2.0,
        low_threshold: float = 60.0,
        high_threshold: float = 150.0,
    ) -> None:
        self.camera = camera
        self.fovea_rad = fovea_rad
        self.step_px = step_px
        self.blur_sigma_px = blur_sigma_px
        self.low_threshold = low_threshold
        self.high_threshold = high_threshold

    def observe(self, gray: np.ndarray, camera: CameraModel | None = None) -> EdgePoint:
        """The edge nearest the principal point of `camera` (the frame's, at its zoom; the
        rig's if not given), in a window spanning the fovea at its focal length."""
        camera = self.camera if camera is None else camera
        half_px = max(round(camera.focal_px * math.tan(self.fovea_rad / 2)), self.step_px + 4)
        h, w = gray.shape
        cu, cv = round(camera.K[0, 2]), round(camera.K[1, 2])
        x0, y0 = max(cu - half_px, 0), max(cv - half_px, 0)
        x1, y1 = min(cu + half_px + 1, w), min(cv + half_px + 1, h)
        window = cv2.GaussianBlur(gray[y0:y1, x0:x1], (0, 0), self.blur_sigma_px)
        edges = cv2.Canny(window, self.low_threshold, self.high_threshold, L2gradient=True)
        contours, _ = cv2.findContours(edges, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
        centre = np.array([camera.K[0, 2] - x0, camera.K[1, 2] - y0])
        # the string with the most edgels within a step of the centre's neighbourhood: a long
        # boundary, not a blob of texture
        reach = 2.0 * self.step_px
        best: np.ndarray | None = None
        for contour in contours:
            points = contour.reshape(-1, 2).astype(float)
            near = points[np.hypot(*(points - centre).T) <= reach]
            if len(near) >= 2 * self.step_px and (best is None or len(near) > len(best)):
                best = near
        if best is None:
            return EdgePoint(found=False)
        mean, along = _refine(window, best.mean(axis=0), _axis(best), reach)
        nearest = mean + along * float((centre - mean) @ along)
        # the two halves either side of the nearest point, each fitted on its own: their angle
        # is the turn (a corner ends a trace)
        side = (best - nearest) @ along
        halves = [best[side < 0], best[side > 0]]
        if min(len(h) for h in halves) < self.step_px // 2:
            return EdgePoint(found=False)  # the string ends at the centre
        cosine = abs(float(_axis(halves[0]) @ _axis(halves[1])))
        offset = np.array([x0, y0], dtype=float)
        ahead = nearest + self.step_px * along + offset
        behind = nearest - self.step_px * along + offset
        return EdgePoint(
            found=True,
            u_px=float(nearest[0] + offset[0]),
            v_px=float(nearest[1] + offset[1]),
            ahead_px=(float(ahead[0]), float(ahead[1])),
            behind_px=(float(behind[0]), float(behind[1])),
            turn_rad=math.acos(min(cosine, 1.0)),
        )


def _refine(
    window: np.ndarray, mean: np.ndarray, along: np.ndarray, reach: float
) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel edge line: at points every REFINE_SPACING_PX along the Canny line, the peak of
    the gradient magnitude across it (a parabola through the three samples about the largest);
    a line refitted through the peaks, dropping those off it by more than a pixel."""
    gx = cv2.Sobel(window, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(window, cv2.CV_32F, 0, 1, ksize=3)
    magnitude = cv2.magnitude(gx, gy)
    normal = np.array([-along[1], along[0]])
    positions = np.arange(-reach, reach + 1e-9, REFINE_SPACING_PX)
    offsets = np.arange(-REFINE_SEARCH_PX, REFINE_SEARCH_PX + 1)
    base = mean + positions[:, None] * along  # (P, 2)
    grid = base[:, None, :] + offsets[None, :, None] * normal  # (P, O, 2)
    samples = cv2.remap(
        magnitude,
        grid[..., 0].astype(np.float32),
        grid[..., 1].astype(np.float32),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=0.0,
    )
    peak = np.argmax(samples[:, 1:-1], axis=1) + 1
    rows = np.arange(len(positions))
    left, middle, right = samples[rows, peak - 1], samples[rows, peak], samples[rows, peak + 1]
    curvature = left - 2 * middle + right
    valid = (curvature < 0) & (middle > 0)
    shift = np.where(valid, 0.5 * (left - right) / np.where(valid, curvature, 1.0), 0.0)
    points = base + (offsets[peak] + shift)[:, None] * normal
    points = points[valid]
    if len(points) < 4:
        return mean, along
    for _ in range(2):  # refit without the peaks that lie off the line (texture)
        centre, axis = points.mean(axis=0), _axis(points)
        distance = np.abs((points - centre) @ np.array([-axis[1], axis[0]]))
        keep = distance <= 1.0
        if keep.sum() < 4:
            break
        points = points[keep]
    return points.mean(axis=0), _axis(points)


def _axis(points: np.ndarray) -> np.ndarray:
    """Unit direction of the total least squares line through points (its principal axis)."""
    centred = points - points.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    return vt[0]
