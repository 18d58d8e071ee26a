"""Camera model: intrinsics from a field of view or from the rig, rays and pixels round-trip
(with OpenCV distortion, to round-off), and the ray Jacobian against finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gazed.config import CameraSection
from gazed.geometry.camera import CameraModel

PINHOLE = CameraModel.from_fov(640, 480, math.radians(60.0))
DISTORTED = CameraModel.from_intrinsics(
    640, 480, 500.0, 505.0, 321.0, 238.0, (-0.25, 0.08, 0.001, -0.001, 0.0)
)
PIXELS = np.array(
    [[0.0, 0.0], [639.0, 0.0], [639.0, 479.0], [0.0, 479.0], [320.0, 240.0], [100.5, 400.25]]
)


def test_focal_length_from_the_field_of_view() -> None:
    assert PINHOLE.K[0, 0] == pytest.approx(320.0 / math.tan(math.radians(30.0)))
    assert PINHOLE.K[0, 2] == 319.5 and PINHOLE.K[1, 2] == 239.5
    section = CameraSection(width_px=800, height_px=600, fx_px=700.0, cx_px=401.0)
    camera = CameraModel.from_section(section)
    assert camera.K[0, 0] == camera.K[1, 1] == 700.0 and camera.K[0, 2] == 401.0
    assert camera.K[1, 2] == 299.5


@pytest.mark.parametrize("camera", [PINHOLE, DISTORTED], ids=["pinhole", "distorted"])
def test_rays_and_pixels_round_trip(camera: CameraModel) -> None:
    rays = camera.ray(PIXELS[:, 0], PIXELS[:, 1])
    assert np.all(rays[:, 2] == 1.0)
    assert np.abs(camera.pixel(rays) - PIXELS).max() < 1e-8
    assert np.abs(camera.pixel(3.0 * rays) - PIXELS).max() < 1e-8


@pytest.mark.parametrize("camera", [PINHOLE, DISTORTED], ids=["pinhole", "distorted"])
def test_ray_jacobian_matches_finite_differences(camera: CameraModel) -> None:
    step = 1e-3
    for u, v in PIXELS:
        numeric = np.column_stack(
            [
                (camera.ray(u + step, v) - camera.ray(u - step, v)) / (2 * step),
                (camera.ray(u, v + step) - camera.ray(u, v - step)) / (2 * step),
            ]
        )
        ray, jacobian = camera.ray_with_jacobian(u, v)
        assert np.array_equal(ray, camera.ray(u, v))
        assert np.abs(numeric - jacobian).max() < 1e-9


def test_directions_behind_the_camera_have_no_pixel() -> None:
    with pytest.raises(ValueError, match="behind the camera"):
        PINHOLE.pixel(np.array([[0.1, 0.0, 1.0], [0.0, 0.0, -1.0]]))
