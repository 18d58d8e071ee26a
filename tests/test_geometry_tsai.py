"""Tsai's camera model: the PETS calibration against its own annotated ground truth, the
conversion to a pinhole with OpenCV distortion, and the ground homography of the frontal plane."""

from __future__ import annotations

import csv
import math
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import SHARED_DATA

from gazed.geometry.kinematics import FLIP_Y, rot_x, rot_y
from gazed.geometry.tsai import TsaiCamera, TsaiError, tsai_rotation

PETS = SHARED_DATA / "footage" / "pets09-s2l1"
XML = """<?xml version="1.0" encoding="UTF-8"?>
<Camera name="synthetic">
  <Geometry width="640" height="480" dpx="0.005" dpy="0.005"/>
  <Intrinsic focal="4.0" kappa1="{kappa1}" cx="330.0" cy="235.0" sx="1.02"/>
  <Extrinsic tx="500.0" ty="-1200.0" tz="20000.0" rx="2.1" ry="-0.4" rz="0.3"/>
</Camera>
"""


def synthetic(tmp_path: Path, kappa1: float = 4e-3) -> TsaiCamera:
    path = tmp_path / "camera.xml"
    path.write_text(XML.format(kappa1=kappa1))
    return TsaiCamera.from_xml(path)


def test_rotation_is_rz_ry_rx_in_willsons_order() -> None:
    rx, ry, rz = 0.3, -0.7, 1.1
    c, s = math.cos(rz), math.sin(rz)
    rot_z = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    # kinematics' rot_y is the right-handed rotation about y; rot_x likewise about x
    expected = rot_z @ rot_y(ry) @ rot_x(rx)
    R = tsai_rotation(rx, ry, rz)
    assert np.allclose(R, expected, atol=1e-12)
    assert not np.allclose(R, rot_x(rx) @ rot_y(ry) @ rot_z, atol=1e-3)  # the order matters
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-12)


def test_world_pixel_world_round_trip_with_distortion(tmp_path: Path) -> None:
    camera = synthetic(tmp_path)
    rng = np.random.default_rng(7)
    world = np.column_stack([rng.uniform(-8, 8, 200), rng.uniform(-8, 8, 200), np.zeros(200)])
    pixels = camera.pixel_from_world(world)
    back = camera.world_from_pixel(pixels)
    assert np.abs(back - world).max() < 1e-9
    # the distortion is not negligible: without it the pixels move by pixels
    straight = replace(camera, kappa1_per_mm2=0.0)
    assert np.abs(straight.pixel_from_world(world) - pixels).max() > 1.0


def test_points_off_the_ground_plane(tmp_path: Path) -> None:
    camera = synthetic(tmp_path)
    world = np.array([[1.0, 2.0, 1.5], [-3.0, 0.5, 1.5]])
    assert np.allclose(camera.world_from_pixel(camera.pixel_from_world(world), 1.5), world)


def test_pinhole_intrinsics_and_fitted_opencv_distortion_reproduce_the_lens(
    tmp_path: Path,
) -> None:
    camera = synthetic(tmp_path)
    distortion, fit_error_px = camera.opencv_distortion()
    assert fit_error_px < 0.05
    rng = np.random.default_rng(3)
    world = np.column_stack([rng.uniform(-6, 6, 300), rng.uniform(-6, 6, 300), np.zeros(300)])
    pixels = camera.pixel_from_world(world)
    inside = (pixels[:, 0] >= 0) & (pixels[:, 0] < 640) & (pixels[:, 1] >= 0) & (pixels[:, 1] < 480)
    rvec, _ = cv2.Rodrigues(camera.rotation)
    projected, _ = cv2.projectPoints(
        world[inside], rvec, camera.translation_m, camera.K, np.array(distortion)
    )
    assert inside.sum() > 50
    assert np.abs(projected.reshape(-1, 2) - pixels[inside]).max() < 0.05


def test_ground_homography_maps_the_frontal_plane_to_the_ground(tmp_path: Path) -> None:
    camera = synthetic(tmp_path)
    M = camera.ground_homography()
    assert M[2, 2] == pytest.approx(1.0)
    rng = np.random.default_rng(11)
    world = np.column_stack([rng.uniform(-5, 5, 50), rng.uniform(-5, 5, 50), np.zeros(50)])
    rays_camera = world @ camera.rotation.T + camera.translation_m  # OpenCV frame, y down
    frontal = (rays_camera / rays_camera[:, 2:3]) @ FLIP_Y  # gazed's frame: y up, z = 1
    ground = frontal @ M.T
    assert np.all(ground[:, 2] > 0)  # lambda > 0: below the horizon
    assert np.allclose(ground[:, :2] / ground[:, 2:3], world[:, :2], atol=1e-9)


def test_bad_files_name_what_is_wrong(tmp_path: Path) -> None:
    path = tmp_path / "bad.xml"
    path.write_text(XML.format(kappa1=1e-3).replace('focal="4.0"', 'focal="four"'))
    with pytest.raises(TsaiError, match=r"bad\.xml: <Intrinsic focal=…>"):
        TsaiCamera.from_xml(path)
    path.write_text("<Camera><Geometry")
    with pytest.raises(TsaiError, match="cannot read"):
        TsaiCamera.from_xml(path)
    with pytest.raises(TsaiError, match="cannot read"):
        TsaiCamera.from_xml(tmp_path / "missing.xml")


@pytest.mark.skipif(not PETS.is_dir(), reason=f"the PETS 2009 footage is not at {PETS}")
def test_pets_calibration_projects_the_annotated_feet_onto_their_ground_positions() -> None:
    camera = TsaiCamera.from_xml(PETS / "View_001.xml").scaled(480, 360)
    with (PETS / "truth_frames_0000-0399.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    ground = np.array([[float(r["x_m"]), float(r["y_m"]), 0.0] for r in rows])
    feet = np.array([[float(r["foot_u_px"]), float(r["foot_v_px"])] for r in rows])
    assert np.hypot(*(camera.pixel_from_world(ground) - feet).T).max() < 0.5
    assert np.hypot(*(camera.world_from_pixel(feet)[:, :2] - ground[:, :2]).T).max() < 0.02
    # a camera on a mast beside the path, some metres up
    assert 3.0 < camera.camera_xyz_m[2] < 20.0
