"""Synthetic image sequences with known truth, for the detectors' tests and benchmarks.

A textured background lies on the frontal plane z = 1 of the head base frame (directions only,
so a rotating camera sees it move exactly by K R K^-1, as a distant scene does); a textured disc
(the target) moves over it in the world. Each frame is rendered from the head pose at its
capture time, with seeded sensor noise, and comes with the truth: the target's pixel and its
independent image velocity (its motion against the world, in pixels per second, the head held
still: the velocity the detectors report). With a zoom `lens`, each frame is seen through the
lens at the zoom of its head pose (the target's disc keeps its size in pixels).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import HeadPose

# t_s -> HeadPose (angles and rates); t_s -> target direction as joint angles (pan, tilt)
HeadPath = Callable[[float], HeadPose]
TargetPath = Callable[[float], tuple[float, float]]


@dataclass(frozen=True)
class SceneTruth:
    """What a frame shows: the head pose, and the target (if any) in the image."""

    t_s: float
    head: HeadPose
    target_visible: bool
    u_px: float = float("nan")
    v_px: float = float("nan")
    du_px_s: float = float("nan")
    dv_px_s: float = float("nan")


# textures already made in this process: (size, scales, the generator's state before) ->
# (the texture, the generator's state after); the newest few, as scenes repeat their seeds
_TEXTURES: dict[tuple, tuple[np.ndarray, dict]] = {}
_TEXTURES_KEPT = 8


def texture(
    height_px: int,
    width_px: int,
    rng: np.random.Generator,
    scales_px: tuple[float, float, float] = (1.5, 4.0, 12.0),
) -> np.ndarray:
    """A natural-looking grey texture (uint8): noise smoothed at three scales (fine to coarse,
    weighted 1:2:3), std ~45. Read-only: one made before from the same generator state is
    handed out again, and `rng` is left where making it would have left it."""
    key = (height_px, width_px, scales_px, repr(rng.bit_generator.state))
    made = _TEXTURES.get(key)
    if made is None:
        image = _texture(height_px, width_px, rng, scales_px)
        image.flags.writeable = False
        made = _TEXTURES[key] = (image, rng.bit_generator.state)
        if len(_TEXTURES) > _TEXTURES_KEPT:
            del _TEXTURES[next(iter(_TEXTURES))]
    else:
        rng.bit_generator.state = made[1]
    return made[0]


def _texture(
    height_px: int, width_px: int, rng: np.random.Generator, scales_px: tuple[float, float, float]
) -> np.ndarray:
    image = np.zeros((height_px, width_px), np.float32)
    for sigma_px, weight in zip(scales_px, (1.0, 2.0, 3.0), strict=True):
        noise = rng.standard_normal((height_px, width_px)).astype(np.float32)
        layer = cv2.GaussianBlur(noise, (0, 0), sigma_px)
        image += weight * layer / max(float(layer.std()), 1e-6)
    image *= 45.0 / float(image.std())
    return np.clip(image + 128.0, 0, 255).astype(np.uint8)


def still_head(pan_rad: float = 0.0, tilt_rad: float = 0.0) -> HeadPath:
    return lambda t_s: HeadPose(pan_rad=pan_rad, tilt_rad=tilt_rad)


def pursuing_head(
    pan0_rad: float,
    tilt0_rad: float,
    pan_rate_rad_s: float,
    tilt_rate_rad_s: float,
    wobble_rad: float = math.radians(1.2),
    wobble_hz: float = 2.5,
) -> HeadPath:
    """A head pursuing at constant rates from (pan0, tilt0), with a circular wobble of
    `wobble_rad` at `wobble_hz` on top (rates up to the pursuit rate + 2π f·wobble)."""
    w = 2 * math.pi * wobble_hz

    def head(t_s: float) -> HeadPose:
        return HeadPose(
            pan_rad=pan0_rad + pan_rate_rad_s * t_s + wobble_rad * math.sin(w * t_s),
            tilt_rad=tilt0_rad + tilt_rate_rad_s * t_s + wobble_rad * math.cos(w * t_s),
            pan_rate_rad_s=pan_rate_rad_s + wobble_rad * w * math.cos(w * t_s),
            tilt_rate_rad_s=tilt_rate_rad_s - wobble_rad * w * math.sin(w * t_s),
        )

    return head


def sinusoidal_head(
    pan_amplitude_rad: float,
    tilt_amplitude_rad: float,
    pan_frequency_hz: float,
    tilt_frequency_hz: float,
    phase_rad: float = 0.0,
) -> HeadPath:
    """pan = A sin(2π f t), tilt = B sin(2π g t + φ); peak rates 2π f A and 2π g B."""
    wp, wt = 2 * np.pi * pan_frequency_hz, 2 * np.pi * tilt_frequency_hz

    def head(t_s: float) -> HeadPose:
        return HeadPose(
            pan_rad=pan_amplitude_rad * np.sin(wp * t_s),
            tilt_rad=tilt_amplitude_rad * np.sin(wt * t_s + phase_rad),
            pan_rate_rad_s=pan_amplitude_rad * wp * np.cos(wp * t_s),
            tilt_rate_rad_s=tilt_amplitude_rad * wt * np.cos(wt * t_s + phase_rad),
        )

    return head


class SyntheticScene:
    """Renders frames of a textured target over a textured background seen by a rotating head."""

    def __init__(
        self,
        camera: CameraModel,
        kinematics: HeadKinematics,
        head: HeadPath,
        target: TargetPath | None,
        *,
        seed: int = 0,
        target_radius_px: float = 16.0,
        target_brightness: float = 0.0,
        noise_std: float = 1.5,
        field_rad: float = 1.2,
        lens: ZoomLens | None = None,
    ) -> None:
        """`target_brightness` shifts the target's grey levels (a walker in dark clothes: < 0);
        `field_rad`: the background covers directions up to this angle from the rest gaze."""
        self.camera = camera
        self.lens = ZoomLens.fixed(camera) if lens is None else lens
        self.kinematics = kinematics
        self.head = head
        self.target = target
        self.seed = seed
        self.noise_std = noise_std
        self.target_radius_px = target_radius_px
        rng = np.random.default_rng(seed)
        # background texture on the frontal plane, about one texel per pixel at the image centre
        self._scale_px = camera.focal_px
        half = int(np.ceil(np.tan(field_rad) * self._scale_px))
        self._background = texture(2 * half + 1, 2 * half + 1, rng)
        self._half = half
        side = int(2 * np.ceil(target_radius_px) + 5)
        sprite = texture(side, side, rng, (1.0, 2.0, 4.0)).astype(np.float32)
        self._sprite = np.clip(sprite + target_brightness, 0, 255)
        yy, xx = np.mgrid[0:side, 0:side].astype(np.float32) - (side - 1) / 2.0
        self._alpha = np.clip(target_radius_px + 0.5 - np.hypot(xx, yy), 0.0, 1.0)

    def _camera_to_base(self, head: HeadPose) -> np.ndarray:
        return self.kinematics.camera_to_base(head.pan_rad, head.tilt_rad)

    def _pixel_of_direction(self, head: HeadPose, direction: np.ndarray) -> np.ndarray:
        return self.lens.at_pose(head).pixel(self._camera_to_base(head).T @ direction)

    def _target_direction(self, t_s: float) -> np.ndarray:
        assert self.target is not None
        pan, tilt = self.target(t_s)
        return self.kinematics.gaze(pan, tilt)

    def truth(self, t_s: float) -> SceneTruth:
        head = self.head(t_s)
        if self.target is None:
            return SceneTruth(t_s, head, False)
        uv = self._pixel_of_direction(head, self._target_direction(t_s))
        h_s = 1e-4  # independent velocity: the target's motion with the head held at `head`
        ahead = self._pixel_of_direction(head, self._target_direction(t_s + h_s))
        behind = self._pixel_of_direction(head, self._target_direction(t_s - h_s))
        duv = (ahead - behind) / (2 * h_s)
        r = self.target_radius_px
        visible = bool(
            r <= uv[0] <= self.camera.width_px - 1 - r
            and r <= uv[1] <= self.camera.height_px - 1 - r
        )
        return SceneTruth(t_s, head, visible, uv[0], uv[1], duv[0], duv[1])

    def render(self, t_s: float, index: int) -> tuple[np.ndarray, SceneTruth]:
        """The bgr8 frame captured at `t_s` (frame `index` seeds its noise) and its truth."""
        truth = self.truth(t_s)
        w, h = self.camera.width_px, self.camera.height_px
        s, c = self._scale_px, float(self._half)
        # pixel -> base direction -> frontal plane (X, Y) -> texel (c + s X, c - s Y)
        to_texel = np.array([[s, 0.0, c], [0.0, -s, c], [0.0, 0.0, 1.0]])
        M = to_texel @ self._camera_to_base(truth.head) @ self.lens.at_pose(truth.head).K_inv
        gray = cv2.warpPerspective(
            self._background,
            M,
            (w, h),
            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_REFLECT,
        ).astype(np.float32)
        if truth.target_visible:
            self._paste_target(gray, truth.u_px, truth.v_px)
        rng = np.random.default_rng((self.seed, index))
        gray += np.float32(self.noise_std) * rng.standard_normal(gray.shape, dtype=np.float32)
        gray8 = np.clip(gray + 0.5, 0, 255).astype(np.uint8)
        # a colour frame whose grey conversion is the rendered grey
        return cv2.cvtColor(gray8, cv2.COLOR_GRAY2BGR), truth

    def _paste_target(self, gray: np.ndarray, u_px: float, v_px: float) -> None:
        side = self._sprite.shape[0]
        x0, y0 = int(np.floor(u_px)) - side // 2 - 1, int(np.floor(v_px)) - side // 2 - 1
        x1, y1 = x0 + side + 3, y0 + side + 3
        if x0 < 0 or y0 < 0 or x1 > gray.shape[1] or y1 > gray.shape[0]:
            return
        # sprite centre ((side-1)/2) lands on (u, v) in ROI coordinates
        shift = np.array(
            [[1.0, 0.0, u_px - x0 - (side - 1) / 2.0], [0.0, 1.0, v_px - y0 - (side - 1) / 2.0]]
        )
        size = (x1 - x0, y1 - y0)
        sprite = cv2.warpAffine(self._sprite, shift, size)
        alpha = cv2.warpAffine(self._alpha, shift, size)
        roi = gray[y0:y1, x0:x1]
        roi += alpha * (sprite - roi)

    def frames(
        self, rate_hz: float, count: int, t0_s: float = 0.0
    ) -> list[tuple[np.ndarray, SceneTruth]]:
        """`count` frames at `rate_hz` from `t0_s`."""
        return [self.render(t0_s + i / rate_hz, i) for i in range(count)]
