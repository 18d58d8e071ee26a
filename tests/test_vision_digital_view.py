"""The digital head's view against an independent re-projection of the wide frame: each view
pixel's ray turned by the head and projected by OpenCV's own lens model."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import FLIP_Y, HeadKinematics
from gazed.vision.digital_view import DigitalView, _monotonic_radius

WIDE = CameraModel.from_intrinsics(
    960, 540, 750.0, 752.0, 481.0, 268.0, (-0.157, 0.073, 0.0, 0.0, -0.0365)
)
VIEW = CameraModel.from_fov(320, 240, math.radians(30.0))
POSES = [(0.0, 0.0), (0.2, -0.1), (-0.35, 0.15), (0.5, 0.3), (-0.6, -0.2)]


def projected(view: CameraModel, wide: CameraModel, pan: float, tilt: float, kinematics):
    """Every third view pixel, its wide-frame pixel by cv2.projectPoints, and whether that is
    a real image of the ray (in front, inside the frame, where the lens polynomial still grows)."""
    u, v = np.meshgrid(np.arange(0, view.width_px, 3.0), np.arange(0, view.height_px, 3.0))
    rays = view.ray(u, v).reshape(-1, 3)
    turned = (FLIP_Y @ kinematics.rotation(pan, tilt) @ FLIP_Y @ rays.T).T
    front = turned[:, 2] > 0.1
    normalised = turned[:, :2] / np.where(front, turned[:, 2], 1.0)[:, None]
    wide_px, _ = cv2.projectPoints(
        np.column_stack([normalised, np.ones(len(normalised))]),
        np.zeros(3),
        np.zeros(3),
        wide.K,
        wide.distortion,
    )
    wide_px = wide_px.reshape(-1, 2)
    real = front & (np.hypot(*normalised.T) < _monotonic_radius(wide, 10.0))
    inside = (wide_px[:, 0] >= 0) & (wide_px[:, 0] <= wide.width_px - 1)
    inside &= (wide_px[:, 1] >= 0) & (wide_px[:, 1] <= wide.height_px - 1)
    return u.astype(int).ravel(), v.astype(int).ravel(), wide_px, real & inside


@pytest.fixture(scope="module")
def views() -> dict[str, DigitalView]:
    """One view per head kinematics: building the lens table is the slow part."""
    return {k: DigitalView(WIDE, VIEW, HeadKinematics(k)) for k in ("pan-tilt", "tilt-pan")}


@pytest.mark.parametrize("kinematics", ["pan-tilt", "tilt-pan"])
@pytest.mark.parametrize(("pan", "tilt"), POSES)
def test_source_pixels_agree_with_opencvs_projection(
    views: dict[str, DigitalView], kinematics: str, pan: float, tilt: float
) -> None:
    head = HeadKinematics(kinematics)
    source = views[kinematics].source_pixels(pan, tilt)
    u, v, expected, seen = projected(VIEW, WIDE, pan, tilt, head)
    assert seen.sum() > 500
    got = source[v, u]
    assert np.abs(got[seen] - expected[seen]).max() < 0.1
    # a ray that misses the frame samples nothing in it
    missed = ~seen & np.all(np.isfinite(expected), axis=1)
    inside = (got[:, 0] > 0.5) & (got[:, 0] < WIDE.width_px - 1.5)
    inside &= (got[:, 1] > 0.5) & (got[:, 1] < WIDE.height_px - 1.5)
    assert not np.any(missed & inside & (np.abs(got - expected).max(axis=1) > 2.0))


def test_without_distortion_the_view_is_the_rotation_homography() -> None:
    wide = CameraModel.from_fov(960, 540, math.radians(80.0))
    view = DigitalView(wide, VIEW)
    source = view.source_pixels(0.3, -0.2)
    u, v, expected, seen = projected(VIEW, wide, 0.3, -0.2, HeadKinematics())
    assert np.abs(source[v, u][seen] - expected[seen]).max() < 0.05


def test_render_samples_the_wide_frame_where_the_rays_land(views: dict[str, DigitalView]) -> None:
    # a smooth pattern whose value at any wide pixel is known
    vv, uu = np.mgrid[0 : WIDE.height_px, 0 : WIDE.width_px].astype(float)
    pattern = lambda u, v: 127.5 + 60 * np.sin(u / 23.0) + 60 * np.cos(v / 17.0)  # noqa: E731
    frame = np.clip(pattern(uu, vv), 0, 255).astype(np.float32)
    image = views["pan-tilt"].render(frame, 0.2, -0.1)
    assert image.shape == (VIEW.height_px, VIEW.width_px)
    u, v, expected, seen = projected(VIEW, WIDE, 0.2, -0.1, HeadKinematics())
    assert np.abs(image[v, u][seen] - pattern(*expected[seen].T)).max() < 1.0


def test_a_view_past_the_frame_is_black(views: dict[str, DigitalView]) -> None:
    frame = np.full((WIDE.height_px, WIDE.width_px, 3), 200, np.uint8)
    view = views["pan-tilt"]
    assert view.render(frame, 0.0, 0.0).min() == 200  # the centre sees only the frame
    assert view.render(frame, math.radians(170.0), 0.0).max() == 0  # looking backwards
    half = view.render(frame, math.radians(45.0), 0.0)
    assert half[:, :40].min() == 200 and half[:, -40:].max() == 0  # the frame's right edge


@pytest.mark.parametrize(("zoom", "pan", "tilt"), [(0.5, 0.2, -0.1), (1.0, -0.35, 0.15)])
def test_a_zoomed_view_agrees_with_opencvs_projection_through_the_zoomed_lens(
    zoom: float, pan: float, tilt: float
) -> None:
    from gazed.geometry.zoom import ZoomLens

    lens = ZoomLens(VIEW, [[0.0, VIEW.K[0, 0]], [1.0, 4.0 * VIEW.K[0, 0], 150.0, 125.0]])
    view = DigitalView(WIDE, VIEW, HeadKinematics(), lens)
    camera = lens.camera_at(zoom)
    u, v, expected, seen = projected(camera, WIDE, pan, tilt, HeadKinematics())
    assert seen.sum() > 500
    got = view.source_pixels(pan, tilt, zoom)[v, u]
    assert np.abs(got[seen] - expected[seen]).max() < 0.1


def test_the_angles_of_a_wide_pixel_centre_the_view_on_it(views: dict[str, DigitalView]) -> None:
    for kinematics, view in views.items():
        for u, v in [(0.0, 0.0), (959.0, 270.0), (300.0, 539.0), (700.0, 100.0)]:
            pan, tilt = view.angles_of(np.array([u]), np.array([v]))
            ideal = view.homography(float(pan[0]), float(tilt[0])) @ VIEW.K[:, 2]
            centre = WIDE.pixel(WIDE.K_inv @ (ideal / ideal[2]))  # the view's principal point
            assert np.abs(np.ravel(centre) - [u, v]).max() < 1e-6, kinematics


def test_the_wide_field_of_a_pinhole_is_its_frames_half_angles() -> None:
    wide = CameraModel.from_intrinsics(960, 540, 750.0, 752.0, 480.0, 268.0)
    pan_min, pan_max, tilt_min, tilt_max = DigitalView(wide, VIEW).wide_field_rad()
    assert pan_min == pytest.approx(-math.atan(480.0 / 750.0))
    assert pan_max == pytest.approx(math.atan(479.0 / 750.0))
    assert tilt_max == pytest.approx(math.atan(268.0 / 752.0))  # up: the top row's middle
    assert tilt_min == pytest.approx(-math.atan(271.0 / 752.0))


def test_the_pets_rigs_head_reaches_the_wide_cameras_field_and_no_further() -> None:
    from conftest import REPO

    from gazed.config import load_rig
    from gazed.vision.digital_camera import wide_camera

    rig = load_rig(REPO / "configs" / "pets.toml")
    view = DigitalView(wide_camera(rig.wide), VIEW, HeadKinematics.from_section(rig.head))
    field = np.degrees(view.wide_field_rad())
    head = rig.head
    limits = np.array([head.pan_min_deg, head.pan_max_deg, head.tilt_min_deg, head.tilt_max_deg])
    outwards = limits - field
    outwards[[0, 2]] *= -1
    assert np.all(outwards >= 0.0) and np.all(outwards < 0.1)  # rounded outwards to 0.1 deg
