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
—, or moving as it did in the last frame) and keeping the one that explains most pixels.

The window follows the target: it is centred on the predicted position while the target is
found, and returns to the principal point when it is lost.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.vision.detector import DetectorOutput, FramePair
from gazed.vision.ego_motion import HeadStep

SMOOTHING_SIGMA_PX = 1.5  # images are smoothed before differentiating (noise, aliasing)
MARGIN_PX = 6  # pixels around the window read for smoothing and gradients
HYPOTHESIS_ITERATIONS = 2  # fits from each starting hypothesis before choosing one
REFINE_ITERATIONS = 6  # further fits of the chosen hypothesis
CONVERGED_PX = 0.02  # stop refining when d changes by less than this (px per frame)
TRIM_MAD = 3.0  # constraints further than this many robust deviations are outliers


@dataclass(frozen=True)
class Fovea:
    """The foveal window: origin and side in pixels, and its pixel coordinate grids."""

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

    def grids(self) -> tuple[np.ndarray, np.ndarray]:
        r = np.arange(self.side, dtype=np.float64)
        return np.meshgrid(self.x0 + r, self.y0 + r)


@dataclass
class _Fit:
    d: np.ndarray  # independent displacement (px per frame)
    residual: np.ndarray  # per-pixel normal flow left over, v̂·d - v_ind
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
        self._track: tuple[float, float, np.ndarray] | None = None  # u, v, d (px/frame)

    def reset(self) -> None:
        self._track = None

    def detect(self, pair: FramePair) -> DetectorOutput:
        if pair.previous is None:
            self.reset()
            return DetectorOutput.nothing()
        fovea = self._place(pair.step, pair.gray.shape)
        measurement = _Measurement(pair, fovea, self.min_gradient)
        # seed 000 §2: background where the ego-compensated normal flow is within the noise
        v_ind = measurement.independent_flow(np.zeros(2))
        moving = measurement.valid & (np.abs(v_ind) > self.noise_px)
        region = self._regions(moving)
        if region is None:
            self.reset()
            return DetectorOutput.nothing(fovea.rect)
        fit = self._fit_velocity(measurement, region, v_ind)
        # the target: moving against the background, and explained by the fitted velocity
        explained = np.zeros_like(moving)
        explained[region & measurement.valid] = fit.inliers
        target = self._regions(moving & explained)
        if target is None:
            self.reset()
            return DetectorOutput.nothing(fovea.rect)
        u_grid, v_grid = fovea.grids()
        u, v = float(u_grid[target].mean()), float(v_grid[target].mean())
        self._track = (u, v, fit.d)
        dt = pair.step.dt_s
        return DetectorOutput(
            found=True,
            u_px=u,
            v_px=v,
            du_px_s=float(fit.d[0] / dt),
            dv_px_s=float(fit.d[1] / dt),
            area_px=float(np.count_nonzero(target)),
            confidence=fit.score,
            window=fovea.rect,
        )

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
        closed = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8))
        count, labels, stats, _ = cv2.connectedComponentsWithStats(closed, connectivity=8)
        keep = [i for i in range(1, count) if stats[i, cv2.CC_STAT_AREA] >= self.min_area_px]
        if not keep:
            return None
        return np.isin(labels, keep)

    def _fit_velocity(
        self, measurement: _Measurement, region: np.ndarray, v_ind: np.ndarray
    ) -> _Fit:
        """Least-squares image velocity of the region from its normal-flow constraints."""
        pixels = region & measurement.valid
        starts = [np.zeros(2), -measurement.centre_shift]
        if self._track is not None:
            starts.append(self._track[2])
        fits = []
        for start in starts:
            fit = measurement.fit(pixels, start, self.noise_px)
            for _ in range(HYPOTHESIS_ITERATIONS - 1):
                fit = measurement.fit(pixels, fit.d, self.noise_px)
            fits.append(fit)
        best = max(fits, key=lambda f: f.score)
        for _ in range(REFINE_ITERATIONS):
            refined = measurement.fit(pixels, best.d, self.noise_px)
            moved = float(np.hypot(*(refined.d - best.d)))
            best = refined
            if moved < CONVERGED_PX:
                break
        return best


class _Measurement:
    """The current window, its gradients and the ego-rotation displacement over it."""

    def __init__(self, pair: FramePair, fovea: Fovea, min_gradient: float) -> None:
        self.previous = pair.previous
        self.fovea = fovea
        m, n = MARGIN_PX, fovea.side
        crop = pair.gray[fovea.y0 - m : fovea.y0 + n + m, fovea.x0 - m : fovea.x0 + n + m]
        current = cv2.GaussianBlur(crop.astype(np.float32), (0, 0), SMOOTHING_SIGMA_PX)
        gx = cv2.Sobel(current, cv2.CV_32F, 1, 0, ksize=3, scale=0.125)[m:-m, m:-m]
        gy = cv2.Sobel(current, cv2.CV_32F, 0, 1, ksize=3, scale=0.125)[m:-m, m:-m]
        self.current = current
        self.gradient = np.hypot(gx, gy)
        self.valid = self.gradient > min_gradient
        safe = np.where(self.valid, self.gradient, 1.0)
        self.nx, self.ny = gx / safe, gy / safe
        u, v = fovea.grids()
        wu, wv = pair.step.displacement(u, v)  # ego-rotation displacement, px per frame
        cu, cv = fovea.centre
        su, sv = pair.step.displacement(np.array(cu), np.array(cv))
        self.centre_shift = np.array([float(su), float(sv)])
        # v̂·(s - w): the ego flow's normal component, relative to the window's shift
        self._ego_normal = self.nx * (self.centre_shift[0] - wu) + self.ny * (
            self.centre_shift[1] - wv
        )

    def independent_flow(self, d: np.ndarray) -> np.ndarray:
        """v_ind along v̂ (px per frame) with the previous window shifted by s + d:
        v = -E_t/|∇E| + v̂·(s + d), then minus v̂·w (seed 000 §2)."""
        m, n = MARGIN_PX, self.fovea.side
        cu, cv = self.fovea.centre
        shift = self.centre_shift + d
        patch = cv2.getRectSubPix(
            self.previous,
            (n + 2 * m, n + 2 * m),
            (float(cu - shift[0]), float(cv - shift[1])),
            patchType=cv2.CV_32F,
        )
        previous = cv2.GaussianBlur(patch, (0, 0), SMOOTHING_SIGMA_PX)
        e_t = (self.current - previous)[m:-m, m:-m]
        safe = np.where(self.valid, self.gradient, 1.0)
        return -e_t / safe + self.nx * d[0] + self.ny * d[1] + self._ego_normal

    def fit(self, pixels: np.ndarray, d: np.ndarray, noise_px: float) -> _Fit:
        """One Gauss-Newton step: re-sample at s + d, fit v̂·d' = v_ind by weighted least
        squares (weights |∇E|²), drop outliers, fit again."""
        r = self.independent_flow(d)[pixels]
        nx, ny, g2 = self.nx[pixels], self.ny[pixels], self.gradient[pixels] ** 2
        inliers = np.ones(r.shape, bool)
        estimate = np.asarray(d, float)
        for _ in range(2):
            A = np.stack([nx[inliers], ny[inliers]], axis=1)
            W = g2[inliers]
            normal = (A * W[:, None]).T @ A
            if A.shape[0] < 2 or np.linalg.cond(normal) > 1e6:
                break
            estimate = np.linalg.solve(normal, (A * W[:, None]).T @ r[inliers])
            residual = nx * estimate[0] + ny * estimate[1] - r
            spread = 1.4826 * float(np.median(np.abs(residual)))
            inliers = np.abs(residual) <= max(TRIM_MAD * spread, noise_px)
        residual = nx * estimate[0] + ny * estimate[1] - r
        inliers = np.abs(residual) <= noise_px
        score = float(np.count_nonzero(inliers)) / max(r.size, 1)
        return _Fit(estimate, residual, inliers, score)
