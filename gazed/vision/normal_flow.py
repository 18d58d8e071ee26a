"""The `flow` detector: foveal normal flow with ego-rotation compensation (seed 000 §2).

In a small foveal window (the paper's ~6°), the motion constraint `E_t + ṙ·∇E = 0` gives at
each pixel the edge-normal component of the image motion,

    v = -E_t ∇E / |∇E|²                                   (seed 000 §2)

and the head's own rotation adds a known flow `ṙ_rot` (seed 004 eq. 11, `ego_motion`), whose
normal component is removed:

    v_ind = v - [ṙ_rot · v̂] v̂                              (seed 000 §2)

Background is where |v_ind| is within `noise_px` per frame; the rest is grouped into regions
(8-connected after a 3x3 closing, at least `min_area_px`), all assumed to be the one target
(seed 000 §2). The target's velocity is the least-squares fit of a single image velocity d to
the regions' normal-flow constraints `v̂·d = |v_ind|` (each weighted by |∇E|², i.e.
`∇E·d = -E_t`), its position the centroid of the pixels that this velocity explains.

The linearised constraint holds only for displacements of about a pixel per frame, while a head
turning at 60°/s moves the background some 20 px per frame. So `E_t` is taken against the
previous frame sampled where the fovea was (shifted by the ego-rotation displacement of the
window's centre, `s`); the normal flow of that shifted pair plus `v̂·s` is the paper's `v`, and
the per-pixel ego flow is subtracted as above. The target's own displacement d is fitted the
same way, Lucas-Kanade style: the previous frame is re-sampled at `s + d` and the fit repeated,
starting from three hypotheses (still in the world, still in the image — the head pursuing it
—, or moving as it did in the last frame) and keeping the one that explains most pixels. When
none explains 30% of the region, the same fits on images smoothed more (σ = 4 px, a linear range
of about 5 px) give a fourth start. A fit explaining less than 20% is not reported.

The ego-rotation is only as good as the head pose at capture (a Dynamixel's encoder step is
0.088°, a quarter of a pixel here): on strong edges the residual then exceeds the noise, and a
fit can win that keeps its place in the world (|d| within the noise plus `EGO_ERROR` of the
head's displacement). That is background: its pixels are dropped and the rest fitted again; a
region with nothing else is not a target (a lone residual would otherwise be pursued as one).

The window follows the target: it is centred on the predicted position while the target is
found, and returns to the principal point when it is lost.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.vision.detector import DetectorOutput, FramePair
from gazed.vision.ego_motion import HeadStep

SMOOTHING_SIGMA_PX = 1.5  # images are smoothed before differentiating (noise, aliasing)
COARSE_SIGMA_PX = 4.0  # ... and more for the coarse fit, whose linear range is larger
MARGIN_PX = 6  # the window keeps this far from the image border
ACQUIRED_SCORE = 0.3  # a fit explaining less of the region than this tries the coarse scale
MIN_SCORE = 0.2  # ... and one explaining less than this is not reported
REFINE_ITERATIONS = 6  # further fits of the chosen hypothesis
CONVERGED_PX = 0.02  # stop refining when d changes by less than this (px per frame)
LINEAR_RANGE_PX = 2.0  # constraints this far from a hypothesis still pull it (px per frame)
REFINE_RANGE_PX = 1.0  # ... and once it is chosen
EGO_ERROR = 0.05  # the head's turn between frames is known to ~5 % (encoder step, timing)
_CLOSING_KERNEL = np.ones((3, 3), np.uint8)


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


def window_offsets_px(side: int) -> np.ndarray:
    """Each pixel's (column, row) offset from a window's origin, (side, side, 2) float64: the
    same for every placement of a window of that side."""
    r = np.arange(side, dtype=np.float64)
    offsets = np.empty((side, side, 2))
    offsets[..., 0] = r[None, :]
    offsets[..., 1] = r[:, None]
    return offsets


@dataclass
class _Fit:
    d: np.ndarray  # independent displacement (px per frame)
    inliers: np.ndarray  # bool mask of constraints the fit explains
    score: float  # fraction of the region's constraints explained


def fovea_side_px(camera: CameraModel, fovea_rad: float) -> int:
    """Side of a square window spanning `fovea_rad` at the image centre: 2 f tan(fovea/2)."""
    return max(8, round(2.0 * camera.focal_px * math.tan(fovea_rad / 2.0)))


class NormalFlowDetector:
    name = "flow"
    needs_energy = False

    def __init__(
        self,
        camera: CameraModel,
        *,
        fovea_rad: float,
        noise_px: float,
        min_gradient: float,
        min_area_px: int,
    ) -> None:
        self.camera = camera
        self.side = min(
            fovea_side_px(camera, fovea_rad),
            camera.width_px - 2 * MARGIN_PX,
            camera.height_px - 2 * MARGIN_PX,
        )
        self.noise_px = noise_px
        self.min_gradient = min_gradient
        self.min_area_px = min_area_px
        self._offsets_px = window_offsets_px(self.side)
        self._track: tuple[float, float, np.ndarray] | None = None  # u, v, d (px/frame)

    def reset(self) -> None:
        self._track = None

    def detect(self, pair: FramePair) -> DetectorOutput:
        if pair.previous is None:
            self.reset()
            return DetectorOutput.nothing()
        fovea = self._place(pair.step, pair.gray.shape)
        track = self._track[2] if self._track is not None else None
        measurement = _Measurement(
            pair, fovea, self._offsets_px, self.min_gradient, track, SMOOTHING_SIGMA_PX
        )
        # seed 000 §2: background where the ego-compensated normal flow is within the noise
        v_ind = measurement.independent_flow()
        moving = measurement.valid & (np.abs(v_ind) > self.noise_px)
        region = self._regions(moving)
        if region is None:
            self.reset()
            return DetectorOutput.nothing(fovea.rect)
        fit = self._fit_velocity(pair, measurement, region, track)
        still_px = self._still_px(pair.step, fovea)
        if math.hypot(*fit.d) <= still_px:
            # most of it keeps its place in the world: background the compensation missed
            # (odometry error); whatever moves is in the rest, if anything
            region = self._regions(region & ~self._explained(region, measurement, fit))
            if region is not None:
                fit = self._fit_velocity(pair, measurement, region, track)
            if region is None or math.hypot(*fit.d) <= still_px:
                self.reset()
                return DetectorOutput.nothing(fovea.rect)
        # the target: moving against the background, and explained by the fitted velocity
        target = self._regions(moving & self._explained(region, measurement, fit))
        if target is None:
            self.reset()
            return DetectorOutput.nothing(fovea.rect)
        # its centroid from the image moments: area m00, (m10, m01) / m00
        moments = cv2.moments(target.view(np.uint8), binaryImage=True)
        area = moments["m00"]
        u, v = fovea.x0 + moments["m10"] / area, fovea.y0 + moments["m01"] / area
        if fit.score < MIN_SCORE:
            # something moves there, but no single velocity explains it: look there again
            # next frame, with no trust in the velocity
            self._track = (u, v, np.zeros(2))
            return DetectorOutput.nothing(fovea.rect)
        self._track = (u, v, fit.d)
        dt = pair.step.dt_s
        return DetectorOutput(
            found=True,
            u_px=u,
            v_px=v,
            du_px_s=float(fit.d[0] / dt),
            dv_px_s=float(fit.d[1] / dt),
            area_px=area,
            confidence=fit.score,
            window=fovea.rect,
        )

    @staticmethod
    def _explained(region: np.ndarray, measurement: _Measurement, fit: _Fit) -> np.ndarray:
        """The pixels of the region whose constraints the fit explains."""
        explained = np.zeros_like(region)
        explained[region & measurement.valid] = fit.inliers
        return explained

    def _still_px(self, step: HeadStep, fovea: Fovea) -> float:
        """The largest displacement (px per frame) of a region that still counts as keeping its
        place in the world: the noise, plus the error of the ego-rotation displacement it was
        compensated by, a fraction EGO_ERROR of that displacement (head pose at capture)."""
        cu, cv = fovea.centre
        tu, tv = step.transport(cu, cv)
        return self.noise_px + EGO_ERROR * math.hypot(tu - cu, tv - cv)

    def _place(self, step: HeadStep, shape: tuple[int, ...]) -> Fovea:
        """Centre the fovea on the predicted target, or on the principal point."""
        if self._track is not None:
            u, v, d = self._track
            u, v = step.transport(u, v)
            cu, cv = u + d[0], v + d[1]
        else:
            cu, cv = self.camera.K[0, 2], self.camera.K[1, 2]
        h, w = shape[:2]
        x0 = round(cu - (self.side - 1) / 2.0)
        y0 = round(cv - (self.side - 1) / 2.0)
        x0 = min(max(x0, MARGIN_PX), w - MARGIN_PX - self.side)
        y0 = min(max(y0, MARGIN_PX), h - MARGIN_PX - self.side)
        return Fovea(x0, y0, self.side)

    def _regions(self, mask: np.ndarray) -> np.ndarray | None:
        """Seed 000 §2: group foreground pixels into regions; their union, or None."""
        closed = cv2.morphologyEx(mask.view(np.uint8), cv2.MORPH_CLOSE, _CLOSING_KERNEL)
        count, labels = cv2.connectedComponents(closed, connectivity=8)
        # each region's area: its label's pixel count (cheaper than OpenCV's full statistics)
        keep = np.bincount(labels.ravel(), minlength=count) >= self.min_area_px
        keep[0] = False  # the background label
        if not keep.any():
            return None
        return keep.take(labels)

    def _fit_velocity(
        self,
        pair: FramePair,
        measurement: _Measurement,
        region: np.ndarray,
        track: np.ndarray | None,
    ) -> _Fit:
        """Least-squares image velocity of the region from its normal-flow constraints: fits
        from each hypothesis; if none explains the region, the same at a coarser scale (a
        wider linear range) gives another start; then the best one refined."""
        constraints = measurement.constraints(region & measurement.valid)
        best = constraints.fit(measurement.hypotheses, LINEAR_RANGE_PX, self.noise_px)
        if best.score < ACQUIRED_SCORE:
            scale = COARSE_SIGMA_PX / SMOOTHING_SIGMA_PX
            coarse = _Measurement(
                pair,
                measurement.fovea,
                self._offsets_px,
                self.min_gradient / scale,
                track,
                COARSE_SIGMA_PX,
            )
            wide = coarse.constraints(region & coarse.valid)
            start = wide.fit(coarse.hypotheses, LINEAR_RANGE_PX * scale, self.noise_px * scale)
            for _ in range(REFINE_ITERATIONS):
                start = wide.fit(start.d[None], REFINE_RANGE_PX * scale, self.noise_px * scale)
            candidate = constraints.fit(start.d[None], LINEAR_RANGE_PX, self.noise_px)
            if candidate.score > best.score:
                best = candidate
        for _ in range(REFINE_ITERATIONS):
            refined = constraints.fit(best.d[None], REFINE_RANGE_PX, self.noise_px)
            moved = math.hypot(*(refined.d - best.d))
            best = refined
            if moved < CONVERGED_PX:
                break
        return best


class _Measurement:
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
        relative = pair.step.shift_less_displacement((su, sv), (fovea.x0, fovea.y0), offsets_px)
        nx, ny = self.normal
        self.ego_normal = nx * relative[..., 0] + ny * relative[..., 1]
        # starting hypotheses for the target's own displacement d (px per frame, (k, 2)): still
        # in the world, still in the image (pursued by the head), moving as in the last frame
        starts = [(0.0, 0.0), (-su, -sv)]
        if track is not None:
            starts.append(track.tolist())
        self.hypotheses = np.array(starts)
        self._previous_region(pair.previous, starts)

    def _previous_region(self, previous: np.ndarray, starts: Sequence[Sequence[float]]) -> None:
        """Smooth the part of the previous frame that the windows shifted by s + d cover, d
        from `starts`."""
        f, n = self.fovea, self.fovea.side
        su, sv = self.shift
        reach_x, reach_y = [su + du for du, _ in starts], [sv + dv for _, dv in starts]
        high_x, high_y, low_x, low_y = max(reach_x), max(reach_y), min(reach_x), min(reach_y)
        slack = self.margin + 2.0 * LINEAR_RANGE_PX * COARSE_SIGMA_PX / SMOOTHING_SIGMA_PX
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
        """The previous frame over the window, shifted by s + d (smoothed, float32)."""
        (cu, cv), (x0, y0) = self._shifted_centre, self._previous_origin
        centre = (cu - d[0] - x0, cv - d[1] - y0)
        return cv2.getRectSubPix(self._previous, (self.fovea.side,) * 2, centre)

    def constraints(self, pixels: np.ndarray) -> _Constraints:
        return _Constraints(self, pixels)


class _Constraints:
    """The normal-flow constraints v̂·d = v_ind of one region's pixels (the window's terms of
    `independent_flow` taken at those pixels once: a fit then works on the region alone)."""

    def __init__(self, measurement: _Measurement, pixels: np.ndarray) -> None:
        self.measurement = measurement
        self.index = i = pixels.ravel().nonzero()[0]  # into the window's pixels, row-major
        terms = measurement.terms.reshape(4, -1).take(i, axis=1).astype(float)
        # v̂, 1/|∇E| and |∇E| at the constraints, float64
        self.normal, self.inverse_gradient, gradient = terms[:2], terms[2], terms[3]
        # the terms of y (below) that no hypothesis changes: v̂·(s - w) - E/|∇E|
        current = measurement.current.take(i)
        self.offset = measurement.ego_normal.take(i) - current * self.inverse_gradient
        # the weighted terms of the normal equations, for every constraint: w v̂ and
        # w (nx², nx ny, ny²), w = |∇E|²
        self.wn = np.square(gradient) * self.normal
        self.products = self.wn[[0, 0, 1]] * self.normal[[0, 1, 1]]

    def fit(self, starts: np.ndarray, tolerance_px: float, noise_px: float) -> _Fit:
        """One Gauss-Newton step from each hypothesis d (the rows of `starts`, (k, 2)); the
        estimate that explains the most constraints. Re-sample the previous frame at s + d, keep
        the constraints within `tolerance_px` of the hypothesis (the linear range; the rest
        belong to something else), and fit v̂·d' = v_ind by least squares weighted by |∇E|²
        (i.e. ∇E·d' = -E_t), solved for the step δ = d' - d."""
        previous = np.empty((len(starts), self.index.size), np.float32)
        for row, d in zip(previous, starts.tolist(), strict=True):
            self.measurement.previous_at(d).take(self.index, out=row)
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
        return _Fit(starts[best] + step[best], inliers[best], score)
