"""What the simulated camera sees: a textured ground plane warped by the ground->image
homography of the true head pose, upright textured bodies standing on their ground points, sky
above the horizon, sensor noise, optional flicker and motion blur.

Everything random comes from the seed: the textures at construction, the noise of frame `seq`
from (seed, seq), so the same seed, head angles and target states give the same frames bit for
bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.geometry.pose import CameraPose

SKY_BGR = (235, 206, 160)
NOISE_POOL = 8


@dataclass(frozen=True)
class Body:
    """An upright body seen by the camera: its ground point and size."""

    xy_m: tuple[float, float]
    height_m: float
    width_m: float
    texture: int = 0  # which of the renderer's body textures


def ground_texture(seed: int, size_px: int = 1536) -> np.ndarray:
    """A seeded lawn: sums of blurred noise at several scales (features of 2 to 64 texels,
    enough for optical flow at every distance), green. BGR uint8."""
    rng = np.random.default_rng([seed, 1])
    height = np.zeros((size_px, size_px), np.float32)
    for octave, weight in ((2, 0.25), (4, 0.3), (8, 0.2), (16, 0.15), (64, 0.1)):
        small = rng.standard_normal((size_px // octave, size_px // octave)).astype(np.float32)
        big = cv2.resize(
            np.pad(small, 1, mode="wrap"), None, fx=octave, fy=octave, interpolation=cv2.INTER_CUBIC
        )
        height += weight * big[octave : octave + size_px, octave : octave + size_px]
    height = (height - height.mean()) / (height.std() + 1e-6)
    value = np.clip(110 + 45 * height, 0, 255)
    texture = np.stack([0.45 * value, 0.85 * value, 0.6 * value], axis=-1)
    return np.clip(texture, 0, 255).astype(np.uint8)


def body_texture(seed: int, index: int, size_px: tuple[int, int] = (48, 128)) -> np.ndarray:
    """A seeded, high-contrast body (clothes-like blocks and stripes): (h, w, 3) BGR uint8."""
    rng = np.random.default_rng([seed, 2, index])
    w, h = size_px
    base = rng.integers(30, 120, 3)
    texture = np.empty((h, w, 3), np.uint8)
    texture[:] = base
    for _ in range(12):
        x0, y0 = int(rng.integers(0, w)), int(rng.integers(0, h))
        x1, y1 = x0 + int(rng.integers(4, w // 2)), y0 + int(rng.integers(4, h // 4))
        cv2.rectangle(
            texture, (x0, y0), (x1, y1), tuple(int(c) for c in rng.integers(0, 256, 3)), -1
        )
    noise = rng.integers(-25, 26, (h, w, 1))
    return np.clip(texture.astype(np.int16) + noise, 0, 255).astype(np.uint8)


class Renderer:
    """Renders frames for one camera and pose; `render(seq, pan, tilt, bodies)` -> BGR uint8.

    The lawn is textured over a square of `texel_m` x 1536 (46 m at 3 cm) centred on the world
    origin; beyond it the ground has the lawn's mean colour."""

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
    ) -> None:
        self.camera = camera
        self.pose = pose
        self.seed = seed
        self.texel_m = texel_m
        self.flicker_amplitude = flicker_amplitude
        self.flicker_hz = flicker_hz
        self.motion_blur_exposure_s = motion_blur_exposure_s
        self.ground = ground_texture(seed)
        self._far_ground = tuple(float(c) for c in self.ground.reshape(-1, 3).mean(axis=0))
        self.bodies = [body_texture(seed, i) for i in range(2)]
        size = self.ground.shape[0]
        # texture pixel (tx, ty) -> ground (X, Y): tx right = +X, ty down = -Y, centred on the origin
        self._texture_to_ground = np.array(
            [
                [texel_m, 0.0, -texel_m * size / 2],
                [0.0, -texel_m, texel_m * size / 2],
                [0.0, 0.0, 1.0],
            ]
        )
        h, w = camera.height_px, camera.width_px
        self._noise = self._noise_pool(noise_std, (h, w, 3))
        self._columns = np.arange(w, dtype=np.float32)[None, :]
        self._rows = np.arange(h, dtype=np.float32)[:, None]

    def _noise_pool(
        self, std: float, shape: tuple[int, int, int]
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Pairs (positive part, negative part) of Gaussian noise images, for saturating add."""
        if std <= 0:
            return []
        rng = np.random.default_rng([self.seed, 3])
        pool = []
        for _ in range(NOISE_POOL):
            noise = np.rint(rng.standard_normal(shape) * std)
            pool.append(
                (np.clip(noise, 0, 255).astype(np.uint8), np.clip(-noise, 0, 255).astype(np.uint8))
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
    ) -> np.ndarray:
        camera = self.camera
        size = (camera.width_px, camera.height_px)
        image_from_ground = self.pose.ground_to_image(pan_rad, tilt_rad, camera)
        frame = cv2.warpPerspective(
            self.ground,
            image_from_ground @ self._texture_to_ground,
            size,
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,  # beyond the textured area: the lawn's mean colour
            borderValue=self._far_ground,
        )
        self._paint_sky(frame, pan_rad, tilt_rad)
        for body in sorted(bodies, key=lambda b: -self._distance_m(b)):  # far ones first
            self._paint_body(frame, body, pan_rad, tilt_rad)
        if self.motion_blur_exposure_s > 0:
            frame = self._blur(frame, pan_rate_rad_s, tilt_rate_rad_s)
        if self.flicker_amplitude > 0:
            gain = 1.0 + self.flicker_amplitude * math.sin(2 * math.pi * self.flicker_hz * t_s)
            frame = cv2.convertScaleAbs(frame, alpha=gain)
        if self._noise:
            pick = int(np.random.default_rng([self.seed, 4, seq]).integers(len(self._noise)))
            positive, negative = self._noise[pick]
            cv2.add(frame, positive, dst=frame)
            cv2.subtract(frame, negative, dst=frame)
        return frame

    def _paint_sky(self, frame: np.ndarray, pan_rad: float, tilt_rad: float) -> None:
        """Pixels above the horizon see sky, not the mirror image of the ground behind the camera."""
        line = self.pose.horizon_line(pan_rad, tilt_rad, self.camera)
        w, h = self.camera.width_px - 1, self.camera.height_px - 1
        corners = [line @ np.array([u, v, 1.0]) for u in (0, w) for v in (0, h)]
        if max(corners) <= 0:  # all ground
            return
        if min(corners) > 0:
            frame[:] = SKY_BGR
            return
        sky = (line[0] * self._columns + line[1] * self._rows + line[2]) > 0
        frame[sky] = SKY_BGR

    def _distance_m(self, body: Body) -> float:
        return float(
            math.hypot(body.xy_m[0] - self.pose.centre_m[0], body.xy_m[1] - self.pose.centre_m[1])
        )

    def _paint_body(self, frame: np.ndarray, body: Body, pan_rad: float, tilt_rad: float) -> None:
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
            corners_px = self.pose.pixels(corners_m, pan_rad, tilt_rad, self.camera).astype(
                np.float32
            )
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

    def _blur(self, frame: np.ndarray, pan_rate_rad_s: float, tilt_rate_rad_s: float) -> np.ndarray:
        """Linear motion blur along the image motion the head's rotation causes during exposure."""
        f = self.camera.focal_px
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
