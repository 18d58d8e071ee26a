"""What the simulated camera sees: a textured ground plane warped by the ground->image
homography of the true head pose, upright textured bodies standing on their ground points, sky
above the horizon, sensor noise, optional flicker and motion blur.

Everything random comes from the seed: the textures at construction, the noise of frame `seq`
from (seed, seq), so the same seed, head angles and target states give the same frames bit for
bit. A zoom lens renders each frame through the camera at its zoom (`render(camera=...)`),
of the same size as the rig's.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.geometry.pose import CameraPose

SKY_BGR = (235, 206, 160)
SUBPIXEL_BITS = 4  # fillConvexPoly's fixed-point vertices
SUBPIXEL = 1 << SUBPIXEL_BITS
COURT_BRIGHTENING = 110  # grey levels added inside the court
COURT_SMOOTHING_TEXELS = 4.0  # the court's paving is the gravel smoothed this much
HAZE_START_TEXELS = 1.5  # texels per pixel where the ground starts fading to its mean colour
HAZE_FULL_TEXELS = 4.0
NOISE_POOL = 8


@dataclass(frozen=True)
class Body:
    """An upright body seen by the camera: its ground point and size."""

    xy_m: tuple[float, float]
    height_m: float
    width_m: float
    texture: int = 0  # which of the renderer's body textures


@functools.lru_cache(maxsize=4)
def ground_texture(seed: int, size_px: int = 1536) -> np.ndarray:
    """A seeded gravel yard: sums of blurred noise at several scales (features of 4 to 64
    texels, enough for optical flow at every distance, none so fine that it aliases early).
    Grey uint8: one channel warps faster than three. A pure function of its arguments, so each
    yard is made once in a process and shared, read-only."""
    yard = _ground_texture(seed, size_px)
    yard.flags.writeable = False
    return yard


def _ground_texture(seed: int, size_px: int) -> np.ndarray:
    rng = np.random.default_rng([seed, 1])
    height = np.zeros((size_px, size_px), np.float32)
    for octave, weight in ((4, 0.35), (8, 0.3), (16, 0.2), (64, 0.15)):
        small = rng.standard_normal((size_px // octave, size_px // octave)).astype(np.float32)
        big = cv2.resize(
            np.pad(small, 1, mode="wrap"), None, fx=octave, fy=octave, interpolation=cv2.INTER_CUBIC
        )
        height += weight * big[octave : octave + size_px, octave : octave + size_px]
    height = (height - height.mean()) / (height.std() + 1e-6)
    return np.clip(100 + 32 * height, 0, 255).astype(np.uint8)


def body_texture(seed: int, index: int, size_px: tuple[int, int] = (48, 128)) -> np.ndarray:
    """A seeded, patterned body: a dark base colour under a dense pattern of small bright
    patches (clothes with a print), textured evenly all over so that a motion detector's region
    has its centroid at the body's middle, not wherever a few large patches happen to lie.
    (h, w, 3) BGR uint8."""
    rng = np.random.default_rng([seed, 2, index])
    w, h = size_px
    cell = 6
    cells = rng.integers(0, 256, (h // cell + 1, w // cell + 1, 3)).astype(np.uint8)
    pattern = cv2.resize(cells, None, fx=cell, fy=cell, interpolation=cv2.INTER_NEAREST)[:h, :w]
    base = rng.integers(20, 90, 3).astype(np.int16)
    texture = (base + pattern.astype(np.int16)) // 2 + rng.integers(-20, 21, (h, w, 1))
    return np.clip(texture, 0, 255).astype(np.uint8)


class Renderer:
    """Renders frames for one camera and pose; `render(seq, pan, tilt, bodies)` -> BGR uint8.

    The ground is textured over a square of `texel_m` x 1536 (46 m at 3 cm) centred on the world
    origin; beyond it the ground has its mean grey."""

    def __init__(
        self,
        camera: CameraModel,
        pose: CameraPose,
        *,
        seed: int,
        texel_m: float = 0.03,
        noise_std: float = 2.0,
        flicker_amplitude: float = 0.0,
        flicker_hz: float = 2.0,
        motion_blur_exposure_s: float = 0.0,
        court_m: tuple[float, float, float, float] | None = None,
    ) -> None:
        self.camera = camera
        self.pose = pose
        self.seed = seed
        self.texel_m = texel_m
        self.flicker_amplitude = flicker_amplitude
        self.flicker_hz = flicker_hz
        self.motion_blur_exposure_s = motion_blur_exposure_s
        self.ground = ground_texture(seed)
        self._far_ground = float(self.ground.mean())
        self.bodies = [body_texture(seed, i) for i in range(2)]
        size = self.ground.shape[0]
        if court_m is not None:
            self._paint_court(court_m, size)
        # texture pixel (tx, ty) -> ground (X, Y): tx right = +X, ty down = -Y, centred on the
        # origin
        self._texture_to_ground = np.array(
            [
                [texel_m, 0.0, -texel_m * size / 2],
                [0.0, -texel_m, texel_m * size / 2],
                [0.0, 0.0, 1.0],
            ]
        )
        h, w = camera.height_px, camera.width_px
        self._noise = self._noise_pool(noise_std, (h, w, 3))
        # the haze's coarse grid over the image: pixel corners and a step of about 16 px
        self._haze_shape = (h // 16 + 1, w // 16 + 1)
        us = np.linspace(0, w - 1, self._haze_shape[1])
        vs = np.linspace(0, h - 1, self._haze_shape[0])
        uu, vv = np.meshgrid(us, vs)
        self._haze_grid = np.stack([uu.ravel(), vv.ravel(), np.ones(uu.size)])
        self._haze_image = np.full((h, w), round(self._far_ground), np.uint8)
        self._columns = np.arange(w, dtype=np.float32)[None, :]
        self._rows = np.arange(h, dtype=np.float32)[:, None]

    def _paint_court(self, court_m: tuple[float, float, float, float], size: int) -> None:
        """Pave the ground inside the rectangle X0 <= X <= X1, Y0 <= Y <= Y1 (smoother and
        brighter than the gravel around it): its four sides are straight ground edges at known
        places, for the line calibration (seed 000 §3.2: the lawn's edges). Texel (tx, ty) lies at
        X = texel tx - half, Y = half - texel ty (`_texture_to_ground`); a texel the edge crosses
        is paved by the share of it inside, so the rendered edge sits on the line to a small
        fraction of a texel."""
        x0, y0, x1, y1 = court_m
        half = self.texel_m * size / 2
        centres = np.arange(size) * self.texel_m - half

        def covered(low: float, high: float, at: np.ndarray) -> np.ndarray:
            left = np.clip((at + self.texel_m / 2 - low) / self.texel_m, 0.0, 1.0)
            right = np.clip((high - (at - self.texel_m / 2)) / self.texel_m, 0.0, 1.0)
            return np.minimum(left, right)

        share = covered(y0, y1, -centres)[:, None] * covered(x0, x1, centres)[None, :]
        paving = (
            cv2.GaussianBlur(self.ground, (0, 0), COURT_SMOOTHING_TEXELS).astype(float)
            + COURT_BRIGHTENING
        )
        court = share * paving + (1.0 - share) * self.ground
        self.ground = np.clip(np.rint(court), 0, 255).astype(np.uint8)

    def _noise_pool(
        self, std: float, shape: tuple[int, int, int]
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Pairs (positive part, negative part) of Gaussian noise images, for saturating add.
        The rounding and clipping work in place and split the signs in int16, the smallest
        type that holds both."""
        if std <= 0:
            return []
        rng = np.random.default_rng([self.seed, 3])
        pool = []
        for _ in range(NOISE_POOL):
            noise = rng.standard_normal(shape)
            noise *= std
            np.rint(noise, out=noise)
            np.clip(noise, -255, 255, out=noise)
            signed = noise.astype(np.int16)
            pool.append(
                (np.maximum(signed, 0).astype(np.uint8), np.maximum(-signed, 0).astype(np.uint8))
            )
        return pool

    def render(
        self,
        seq: int,
        pan_rad: float,
        tilt_rad: float,
        bodies: list[Body],
        *,
        t_s: float = 0.0,
        pan_rate_rad_s: float = 0.0,
        tilt_rate_rad_s: float = 0.0,
        camera: CameraModel | None = None,
    ) -> np.ndarray:
        """The frame at joint angles (pan, tilt) through `camera` (the rig's if not given; a
        zoom lens's at another zoom has the same size)."""
        camera = self.camera if camera is None else camera
        size = (camera.width_px, camera.height_px)
        image_from_ground = self.pose.ground_to_image(pan_rad, tilt_rad, camera)
        ground = cv2.warpPerspective(
            self.ground,
            image_from_ground @ self._texture_to_ground,
            size,
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,  # beyond the textured area: the ground's mean grey
            borderValue=self._far_ground,
        )
        self._haze(ground, image_from_ground)
        frame = cv2.cvtColor(ground, cv2.COLOR_GRAY2BGR)
        self._paint_sky(frame, pan_rad, tilt_rad, camera)
        for body in sorted(bodies, key=lambda b: -self._distance_m(b)):  # far ones first
            self._paint_body(frame, body, pan_rad, tilt_rad, camera)
        if self.motion_blur_exposure_s > 0:
            frame = self._blur(frame, pan_rate_rad_s, tilt_rate_rad_s, camera.focal_px)
        if self.flicker_amplitude > 0:
            gain = 1.0 + self.flicker_amplitude * math.sin(2 * math.pi * self.flicker_hz * t_s)
            frame = cv2.convertScaleAbs(frame, alpha=gain)
        if self._noise:
            pick = int(np.random.default_rng([self.seed, 4, seq]).integers(len(self._noise)))
            positive, negative = self._noise[pick]
            cv2.add(frame, positive, dst=frame)
            cv2.subtract(frame, negative, dst=frame)
        return frame

    def _haze(self, frame: np.ndarray, image_from_ground: np.ndarray) -> None:
        """Fade the ground to its mean colour where a pixel covers more than HAZE_START_TEXELS
        texels (fully at HAZE_FULL_TEXELS): a texture sampled that sparsely would alias, and
        shimmer with false motion as the head turns. The footprint is the largest singular
        value of d(ground)/d(pixel) of the image->ground homography, on a coarse grid."""
        g = np.linalg.inv(image_from_ground)
        q = g @ self._haze_grid  # (3, n): ground point times 1/depth
        w = q[2]
        ground = q[:2] / np.where(np.abs(w) > 1e-12, w, 1e-12)
        # d(ground)/d(pixel) = (G[:2] - ground ⊗ G[2]) / w, one 2x2 [[a, b], [c, d]] per grid point
        a = (g[0, 0] - ground[0] * g[2, 0]) / w
        b = (g[0, 1] - ground[0] * g[2, 1]) / w
        c = (g[1, 0] - ground[1] * g[2, 0]) / w
        d = (g[1, 1] - ground[1] * g[2, 1]) / w
        # its largest singular value, in closed form
        half_sum = 0.5 * (a * a + b * b + c * c + d * d)
        determinant = a * d - b * c
        sigma = np.sqrt(
            half_sum + np.sqrt(np.maximum(half_sum * half_sum - determinant * determinant, 0.0))
        )
        footprint = sigma / self.texel_m
        footprint[w <= 0] = HAZE_FULL_TEXELS  # above the horizon: painted as sky anyway
        weight = np.clip(
            (footprint - HAZE_START_TEXELS) / (HAZE_FULL_TEXELS - HAZE_START_TEXELS), 0.0, 1.0
        )
        coarse = weight.reshape(self._haze_shape).astype(np.float32)
        hazy = np.nonzero(coarse.max(axis=1) > 0)[0]
        if hazy.size == 0:
            return
        h, w_px = frame.shape[:2]
        step = h / (self._haze_shape[0] - 1)
        # rows whose coarse neighbours are all fully hazed take the colour; the rest blend
        full_rows = coarse.min(axis=1) >= 1.0
        solid = 0
        while solid < len(full_rows) and full_rows[solid]:
            solid += 1
        top = max(int((solid - 1) * step), 0) if solid else 0
        if top:
            frame[:top] = self._haze_image[:top]
        bottom = min(int(hazy.max() * step + step) + 1, h)
        weights = cv2.resize(coarse, (w_px, h), interpolation=cv2.INTER_LINEAR)[top:bottom]
        roi = frame[top:bottom]
        roi[:] = cv2.blendLinear(roi, self._haze_image[top:bottom], 1.0 - weights, weights)

    def _paint_sky(
        self, frame: np.ndarray, pan_rad: float, tilt_rad: float, camera: CameraModel
    ) -> None:
        """Pixels above the horizon see sky, not the mirror image of the ground behind the
        camera: the image rectangle clipped to the horizon's sky side, filled."""
        line = self.pose.horizon_line(pan_rad, tilt_rad, camera)
        w, h = camera.width_px - 0.5, camera.height_px - 0.5
        rectangle = [(-0.5, -0.5), (w, -0.5), (w, h), (-0.5, h)]
        polygon = _clip_to_half_plane(rectangle, line)
        if len(polygon) >= 3:
            points = np.round(np.array(polygon) * SUBPIXEL).astype(np.int32)
            cv2.fillConvexPoly(frame, points, SKY_BGR, lineType=cv2.LINE_8, shift=SUBPIXEL_BITS)

    def _distance_m(self, body: Body) -> float:
        return float(
            math.hypot(body.xy_m[0] - self.pose.centre_m[0], body.xy_m[1] - self.pose.centre_m[1])
        )

    def _paint_body(
        self, frame: np.ndarray, body: Body, pan_rad: float, tilt_rad: float, camera: CameraModel
    ) -> None:
        """A vertical textured rectangle facing the camera, feet on the ground point."""
        x, y = body.xy_m
        dx, dy = x - self.pose.centre_m[0], y - self.pose.centre_m[1]
        norm = math.hypot(dx, dy)
        if norm < 1e-6:
            return
        right = np.array([dy / norm, -dx / norm, 0.0]) * body.width_m / 2
        foot = np.array([x, y, 0.0])
        top = foot + np.array([0.0, 0.0, body.height_m])
        corners_m = np.array([top - right, top + right, foot + right, foot - right])
        try:
            corners_px = self.pose.pixels(corners_m, pan_rad, tilt_rad, camera).astype(np.float32)
        except ValueError:
            return  # behind the camera
        x0, y0 = np.floor(corners_px.min(axis=0)).astype(int)
        x1, y1 = np.ceil(corners_px.max(axis=0)).astype(int) + 1
        x0, y0 = max(x0, 0), max(y0, 0)
        x1, y1 = min(x1, frame.shape[1]), min(y1, frame.shape[0])
        if x1 <= x0 or y1 <= y0:
            return
        texture = self.bodies[body.texture % len(self.bodies)]
        th, tw = texture.shape[:2]
        source = np.array([[0, 0], [tw - 1, 0], [tw - 1, th - 1], [0, th - 1]], np.float32)
        target = corners_px - np.array([x0, y0], np.float32)
        transform = cv2.getPerspectiveTransform(source, target)
        roi = frame[y0:y1, x0:x1]
        cv2.warpPerspective(
            texture,
            transform,
            (x1 - x0, y1 - y0),
            dst=roi,
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_TRANSPARENT,
        )

    def _blur(
        self, frame: np.ndarray, pan_rate_rad_s: float, tilt_rate_rad_s: float, f: float
    ) -> np.ndarray:
        """Linear motion blur along the image motion the head's rotation causes during exposure
        (focal length `f` in pixels)."""
        du = f * pan_rate_rad_s * self.motion_blur_exposure_s
        dv = -f * tilt_rate_rad_s * self.motion_blur_exposure_s
        length = round(math.hypot(du, dv))
        if length < 2:
            return frame
        kernel = np.zeros((2 * length + 1, 2 * length + 1), np.float32)
        c = length
        cv2.line(
            kernel,
            (round(c - du / 2), round(c - dv / 2)),
            (round(c + du / 2), round(c + dv / 2)),
            1.0,
        )
        kernel /= kernel.sum()
        return cv2.filter2D(frame, -1, kernel)


def _clip_to_half_plane(
    polygon: list[tuple[float, float]], line: np.ndarray
) -> list[tuple[float, float]]:
    """The part of a convex polygon where line · (u, v, 1) > 0 (one Sutherland-Hodgman pass)."""

    def side(p: tuple[float, float]) -> float:
        return float(line[0] * p[0] + line[1] * p[1] + line[2])

    clipped = []
    for i, p in enumerate(polygon):
        q = polygon[(i + 1) % len(polygon)]
        sp, sq = side(p), side(q)
        if sp > 0:
            clipped.append(p)
        if (sp > 0) != (sq > 0):
            t = sp / (sp - sq)
            clipped.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])))
    return clipped
