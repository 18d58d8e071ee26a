"""The image scale between zoom positions: known zooms of a texture and of a video frame
measured, a simulated ten-times zoom lens's table measured by chaining, and views that are not
a zoom of each other refused."""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np
import pytest
from conftest import REPO, SHARED_DATA

from gazed.calibrate.zoom_scale import ZoomMatchError, match_zoom, zoom_table
from gazed.config import load_rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.pose import CameraPose
from gazed.sim.renderer import Renderer, ground_texture

SIZE = (320, 240)


def zoomed(view: np.ndarray, scale: float, centre: tuple[float, float]) -> np.ndarray:
    """`view` zoomed by `scale` about the pixel `centre` (which stays where it is)."""
    c = np.array(centre)
    affine = np.hstack([np.eye(2) * scale, (c * (1.0 - scale))[:, None]])
    return cv2.warpAffine(view, affine, (view.shape[1], view.shape[0]), flags=cv2.INTER_CUBIC)


@functools.cache
def yard(seed: int) -> np.ndarray:
    """A view-sized patch of the simulated yard's texture (made once per seed: read-only)."""
    patch = ground_texture(seed)[400 : 400 + SIZE[1], 500 : 500 + SIZE[0]].copy()
    patch.flags.writeable = False
    return patch


def texture() -> np.ndarray:
    return yard(3)


@pytest.mark.parametrize(
    ("scale", "centre"), [(1.05, (160.0, 120.0)), (1.6, (170.0, 112.0)), (2.8, (150.0, 125.0))]
)
def test_a_known_zoom_of_the_ground_texture_is_measured(
    scale: float, centre: tuple[float, float]
) -> None:
    wide = texture()
    match = match_zoom(wide, zoomed(wide, scale, centre))
    assert match.scale == pytest.approx(scale, rel=1e-3)
    # the centre of the zoom is the fixed point of x -> A x + t
    fixed = np.linalg.solve(np.eye(2) - match.affine[:, :2], match.affine[:, 2])
    assert np.allclose(fixed, centre, atol=0.5)
    assert match.correlation > 0.95


def test_a_known_zoom_of_a_video_frame_is_measured() -> None:
    path = SHARED_DATA / "video" / "vtest_480x360.avi"
    if not path.is_file():
        pytest.skip(f"{path} is absent (the shared data sits beside the repository only in CI)")
    capture = cv2.VideoCapture(str(path))
    ok, frame = capture.read()
    capture.release()
    assert ok
    wide = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
    match = match_zoom(wide, zoomed(wide, 1.7, (250.0, 170.0)))
    assert match.scale == pytest.approx(1.7, rel=1e-3)


def test_a_ten_times_zoom_lens_s_table_is_measured_by_chaining() -> None:
    """The simulated yard seen through a lens whose focal length grows ten times and whose
    principal point wanders, at six zoom positions: the table matches the lens's."""
    rig = load_rig(REPO / "configs" / "sim.toml")
    pose = CameraPose.from_rig(rig)
    fx_wide = CameraModel.from_fov(*SIZE, math.radians(60.0)).K[0, 0]
    zooms = list(np.linspace(0.0, 1.0, 6))
    ratios = np.geomspace(1.0, 10.0, 6)
    truth = [(fx_wide * r, 160.0 + 4.0 * (r - 1), 120.0 - 3.0 * (r - 1)) for r in ratios]
    cameras = [CameraModel.from_intrinsics(*SIZE, fx, fx, cx, cy, ()) for fx, cx, cy in truth]
    # one yard rendered through each zoom's camera (of the same size: same frames as a
    # renderer made for that camera)
    renderer = Renderer(cameras[0], pose, seed=1)
    views = []
    for k, camera in enumerate(cameras):
        frame = renderer.render(k, math.radians(-30), math.radians(-20), [], camera=camera)
        views.append(cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY))
    rows = zoom_table(zooms, views, fx_wide, (160.0, 120.0))
    assert [row.zoom for row in rows] == zooms
    for row, (fx, cx, cy) in zip(rows, truth, strict=True):
        assert row.fx_px == pytest.approx(fx, rel=0.005)
        assert (row.cx_px, row.cy_px) == pytest.approx((cx, cy), abs=1.0)


def test_views_of_different_scenes_are_refused() -> None:
    other = yard(4)
    with pytest.raises(ZoomMatchError, match="do not align"):
        match_zoom(texture(), other)


def test_a_stretch_that_no_zoom_makes_is_refused() -> None:
    wide = texture()
    stretched = cv2.warpAffine(wide, np.array([[1.3, 0.0, -48.0], [0.0, 1.5, -60.0]]), SIZE)
    with pytest.raises(ZoomMatchError, match="more than a zoom"):
        match_zoom(wide, stretched)


def test_the_chain_names_the_pair_that_failed() -> None:
    wide = texture()
    other = yard(4)
    views = [wide, zoomed(wide, 1.5, (160.0, 120.0)), other]
    with pytest.raises(ZoomMatchError, match=r"zoom 0\.500 -> 1\.000"):
        zoom_table([0.0, 0.5, 1.0], views, 300.0, (160.0, 120.0))
