"""The normal-flow constraints of a foveal window, and the fit of one image velocity to them
(seed 000 §2).

`FlowWindow` holds the current frame's window, its gradients ∇E, the ego-rotation displacement
over it and the part of the previous frame the hypotheses can reach. Each pixel with a usable
gradient gives one constraint on the target's displacement d (px per frame),

    v̂·d = v_ind,    v_ind = -E_t/|∇E| + v̂·(s - w)

with `E_t` taken against the previous frame shifted by s (by s + d where a fit re-samples it
at hypothesis d), s the ego-rotation displacement of the window's centre and w that of the
pixel. A zooming lens scales the image about its principal point between the frames, a flow
that grows across the window beyond the linear range of the constraints: the previous frame
is then sampled at its scale about the window's centre too (`HeadStep.scale`), and v̂·(s - w)
becomes v̂·(H⁻¹x - P(x)), P(x) the pixel sampled (`HeadStep.sampled_less_displacement`).
`FlowConstraints` gathers a region's
constraints once and fits d by Gauss-Newton steps from several hypotheses, keeping the
estimate that explains the most constraints.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from gazed.vision.detector import FramePair

SMOOTHING_SIGMA_PX = 1.5  # images are smoothed before differentiating (noise, aliasing)
COARSE_SIGMA_PX = 4.0  # ... and more for the coarse fit, whose linear range is larger
LINEAR_RANGE_PX = 2.0  # constraints this far from a hypothesis still pull it (px per frame)


@dataclass(frozen=True)
class Fovea:
    """The foveal window: origin and side in pixels."""

    x0: int
    y0: int
    side: int

    @property
    def centre(self) -> tuple[float, float]:
        half = (self.side - 1) / 2.0
        return self.x0 + half, self.y0 + half

    @property
    def rect(self) -> tuple[int, int, int, int]:
        return (self.x0, self.y0, self.side, self.side)


@functools.lru_cache(maxsize=4)
def window_offsets_px(side: int) -> np.ndarray:
    """Each pixel's (column, row) offset from a window's origin, (side, side, 2) float64: the
    same for every placement of a window of that side."""
    r = np.arange(side, dtype=np.float64)
    offsets = np.empty((side, side, 2))
    offsets[..., 0] = r[None, :]
    offsets[..., 1] = r[:, None]
    offsets.flags.writeable = False  # shared by every window of that side
    return offsets


@dataclass
class FlowFit:
    """One fit: the displacement, the constraints it explains, and their share."""

    d: np.ndarray  # independent displacement (px per frame)
    inliers: np.ndarray  # bool mask of constraints the fit explains
    score: float  # fraction of the region's constraints explained


class FlowWindow:
    """The current window, its gradients, the ego-rotation displacement over it, and the part of
    the previous frame the hypotheses can reach (smoothed once)."""

    def __init__(
        self,
        pair: FramePair,
        fovea: Fovea,
        offsets_px: np.ndarray,
        min_gradient: float,
        track: np.ndarray | None,
        sigma_px: float,
    ) -> None:
        assert pair.previous is not None
        self.fovea = fovea
        self.background = (0.0, 0.0)  # b: the background's own displacement (`register`)
        self._track = track
        self._source = pair.previous
        self.sigma_px = sigma_px
        self.margin = math.ceil(3.0 * sigma_px) + 1
        m, n = self.margin, fovea.side
        cu, cv = fovea.centre
        crop = cv2.getRectSubPix(pair.gray, (n + 2 * m,) * 2, (cu, cv), patchType=cv2.CV_32F)
        smoothed = cv2.GaussianBlur(crop, (0, 0), sigma_px)
        self.current = smoothed[m:-m, m:-m]
        # ∇E over the window: the 3x3 Sobel kernels need it and a one-pixel ring only; both
        # components written into one array, so that v̂ is one division
        ring = smoothed[m - 1 : 1 - m, m - 1 : 1 - m]
        ring_gradient = np.empty((2, n + 2, n + 2), np.float32)
        cv2.Sobel(ring, cv2.CV_32F, 1, 0, ring_gradient[0], ksize=3, scale=0.125)
        cv2.Sobel(ring, cv2.CV_32F, 0, 1, ring_gradient[1], ksize=3, scale=0.125)
        gradient_xy = ring_gradient[:, 1:-1, 1:-1]
        # the per-pixel terms the constraints gather, in one array so that one `take` gathers
        # them all: v̂ (x, y), 1/|∇E| (1 where the gradient is too weak), |∇E|
        self.terms = np.empty((4, n, n), np.float32)
        self.normal = self.terms[:2]  # v̂, (2, side, side)
        self.inverse_gradient = self.terms[2]
        self.gradient = self.terms[3]
        cv2.magnitude(gradient_xy[0], gradient_xy[1], self.gradient)
        self.valid = self.gradient > min_gradient
        safe = np.where(self.valid, self.gradient, 1.0)
        np.divide(1.0, safe, out=self.inverse_gradient)
        np.divide(gradient_xy, safe, out=self.normal)
        su, sv = pair.step.displacement(cu, cv)  # s: the ego-rotation displacement of the centre
        self.shift = su, sv
        # v̂·(s - w), w the ego-rotation displacement of each pixel (px per frame): the ego
        # flow's normal component, relative to the window's shift
        self.scale = pair.step.scale  # of the previous frame's sampling: a zoom's, or 1
        relative = pair.step.sampled_less_displacement(
            (su, sv), (cu, cv), (fovea.x0, fovea.y0), offsets_px
        )
        nx, ny = self.normal
        self.ego_normal = nx * relative[..., 0] + ny * relative[..., 1]
        self._start()

    def register(self, background: Sequence[float]) -> None:
        """Take the background's own displacement b (the head poses' error, which moves the
        whole small window alike) into the ego-rotation: the shift becomes s + b and each
        pixel's w moves by b with it, so v̂·(s - w) stands, and a displacement d is then one
        against the background as imaged."""
        s0, s1 = self.shift[0] - self.background[0], self.shift[1] - self.background[1]
        self.background = (float(background[0]), float(background[1]))
        self.shift = (s0 + self.background[0], s1 + self.background[1])
        self._start()

    def _start(self) -> None:
        """The starting hypotheses for the target's own displacement d (px per frame, (k, 2)):
        still in the world, still in the image (pursued by the head), moving as in the last
        frame; and the part of the previous frame they reach."""
        su, sv = self.shift
        starts = [(0.0, 0.0), (-su, -sv)]
        if self._track is not None:
            starts.append(self._track.tolist())
        self.hypotheses = np.array(starts)
        self._previous_region(self._source, starts)

    def _previous_region(self, previous: np.ndarray, starts: Sequence[Sequence[float]]) -> None:
        """Smooth the part of the previous frame that the windows shifted by s + d cover, d
        from `starts`."""
        f, n = self.fovea, self.fovea.side
        su, sv = self.shift
        reach_x, reach_y = [su + du for du, _ in starts], [sv + dv for _, dv in starts]
        high_x, high_y, low_x, low_y = max(reach_x), max(reach_y), min(reach_x), min(reach_y)
        slack = self.margin + 2.0 * LINEAR_RANGE_PX * COARSE_SIGMA_PX / SMOOTHING_SIGMA_PX
        slack += max(self.scale - 1.0, 0.0) * n / 2.0  # a zoom out samples a wider patch
        h, w = previous.shape
        x0 = max(0, math.floor(f.x0 - high_x - slack))
        y0 = max(0, math.floor(f.y0 - high_y - slack))
        x1 = min(w, math.ceil(f.x0 + n - low_x + slack))
        y1 = min(h, math.ceil(f.y0 + n - low_y + slack))
        region = previous[y0:y1, x0:x1].astype(np.float32)
        self._previous = cv2.GaussianBlur(region, (0, 0), self.sigma_px)
        cu, cv = f.centre
        self._shifted_centre = (cu - su, cv - sv)  # the window's centre less s
        self._previous_origin = (x0, y0)

    def independent_flow(self) -> np.ndarray:
        """v_ind along v̂ (px per frame) over the window, the previous frame shifted by s:
        v = -E_t/|∇E| + v̂·s, then minus v̂·w (seed 000 §2)."""
        minus_e_t = self.previous_at((0.0, 0.0)) - self.current
        return minus_e_t * self.inverse_gradient + self.ego_normal

    def previous_at(self, d: Sequence[float]) -> np.ndarray:
        """The previous frame over the window, shifted by s + d, at the lens's scale about the
        window's centre (smoothed, float32)."""
        (cu, cv), (x0, y0) = self._shifted_centre, self._previous_origin
        centre = (cu - d[0] - x0, cv - d[1] - y0)
        n, k = self.fovea.side, self.scale
        if k == 1.0:
            return cv2.getRectSubPix(self._previous, (n, n), centre)
        # window pixel j -> the previous region's centre + k (j - (n - 1) / 2)
        half = (n - 1) / 2.0
        to_previous = np.array([[k, 0.0, centre[0] - k * half], [0.0, k, centre[1] - k * half]])
        return cv2.warpAffine(
            self._previous,
            to_previous,
            (n, n),
            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_REPLICATE,
        )

    def constraints(self, pixels: np.ndarray) -> FlowConstraints:
        return FlowConstraints(self, pixels)


class FlowConstraints:
    """The normal-flow constraints v̂·d = v_ind of one region's pixels (the window's terms of
    `independent_flow` taken at those pixels once: a fit then works on the region alone)."""

    def __init__(self, window: FlowWindow, pixels: np.ndarray) -> None:
        self.window = window
        self.index = i = pixels.ravel().nonzero()[0]  # into the window's pixels, row-major
        terms = window.terms.reshape(4, -1).take(i, axis=1).astype(float)
        # v̂, 1/|∇E| and |∇E| at the constraints, float64
        self.normal, self.inverse_gradient, gradient = terms[:2], terms[2], terms[3]
        # the terms of y (below) that no hypothesis changes: v̂·(s - w) - E/|∇E|
        current = window.current.take(i)
        self.offset = window.ego_normal.take(i) - current * self.inverse_gradient
        # the weighted terms of the normal equations, for every constraint: w v̂ and
        # w (nx², nx ny, ny²), w = |∇E|²
        self.wn = np.square(gradient) * self.normal
        self.products = self.wn[[0, 0, 1]] * self.normal[[0, 1, 1]]

    def fit(self, starts: np.ndarray, tolerance_px: float, noise_px: float) -> FlowFit:
        """One Gauss-Newton step from each hypothesis d (the rows of `starts`, (k, 2)); the
        estimate that explains the most constraints. Re-sample the previous frame at s + d, keep
        the constraints within `tolerance_px` of the hypothesis (the linear range; the rest
        belong to something else), and fit v̂·d' = v_ind by least squares weighted by |∇E|²
        (i.e. ∇E·d' = -E_t), solved for the step δ = d' - d."""
        previous = np.empty((len(starts), self.index.size), np.float32)
        for row, d in zip(previous, starts.tolist(), strict=True):
            self.window.previous_at(d).take(self.index, out=row)
        # y = v_ind - v̂·d = -E_t/|∇E| + v̂·(s - w), each constraint's distance from d: (k, N)
        y = previous * self.inverse_gradient + self.offset
        near = (np.abs(y) < tolerance_px).astype(float)
        # normal equations of Σ w (v̂·δ - y)² over the near constraints, for all k at once:
        # [a b; b c] δ = (p, q), with (a, b, c) = Σ w (nx², nx ny, ny²) and (p, q) = Σ w v̂ y
        abc = near @ self.products.T  # (k, 3)
        pq = (near * y) @ self.wn.T  # (k, 2)
        steps = []
        for (a, b, c), (p, q) in zip(abc.tolist(), pq.tolist(), strict=True):
            det = a * c - b * b
            if det > 1e-9 * (a + c) ** 2 and a + c > 0:
                steps.append(((c * p - b * q) / det, (a * q - b * p) / det))
            else:  # singular (the aperture problem, or nothing near): d stays
                steps.append((0.0, 0.0))
        step = np.array(steps)
        # the constraints each estimate explains: |v̂·d' - v_ind| = |v̂·δ - y| within the noise
        inliers = np.abs(step @ self.normal - y) <= noise_px
        counts = [np.count_nonzero(row) for row in inliers]
        best = counts.index(max(counts))  # the first of equals: the earlier hypothesis
        score = counts[best] / max(self.index.size, 1)
        return FlowFit(starts[best] + step[best], inliers[best], score)
