"""The true camera pose: the frontal->ground homography it implies, the angles that centre a
world point, pixels, the ground->image homography and the horizon — all checked against each
other on synthetic rigs of both kinematics, 1-30 m high, over ground areas 5-60 m across.

`synthetic_rig` is shared with the other geometry tests (imported from this module)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gazed.config import load_rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.homography import GroundHomography, HorizonError
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.pose import CameraPose

REPO = Path(__file__).resolve().parents[1]
CAMERA = CameraModel.from_fov(640, 480, math.radians(60.0))

# (kinematics, camera height m, ground area across m, base pitch deg, seed)
RIGS = [
    ("pan-tilt", 1.0, 5.0, 0.0, 1),
    ("tilt-pan", 4.0, 20.0, -20.0, 2),
    ("pan-tilt", 12.0, 60.0, -30.0, 3),
    ("tilt-pan", 30.0, 60.0, -45.0, 4),
    ("pan-tilt", 30.0, 5.0, -70.0, 5),
    ("tilt-pan", 2.0, 60.0, 3.0, 6),
]
RIG_IDS = [f"{k}-{z:g}m-{a:g}m-pitch{p:g}" for k, z, a, p, _ in RIGS]


def synthetic_rig(
    kinematics: str, height_m: float, area_m: float, pitch_deg: float, seed: int, n: int = 8
) -> tuple[CameraPose, np.ndarray]:
    """A head `height_m` up, standing back from a square ground area `area_m` across centred on
    the origin, looking at it with a random yaw offset and roll; and n ground points in the area
    (its four corners first) that the head can centre with |pan|, |tilt| < 80°."""
    rng = np.random.default_rng(seed)
    distance = area_m + height_m
    bearing = rng.uniform(-math.pi, math.pi)
    centre = np.array([distance * math.cos(bearing), distance * math.sin(bearing), height_m])
    yaw = bearing + math.pi + math.radians(rng.uniform(-10, 10))
    pose = CameraPose(
        centre,
        yaw,
        math.radians(pitch_deg),
        math.radians(rng.uniform(-3, 3)),
        HeadKinematics(kinematics),
    )
    half = area_m / 2
    corners = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
    points = np.vstack([corners, rng.uniform(-half, half, (n - 4, 2))])
    pan, tilt = pose.gaze_angles(np.hstack([points, np.zeros((n, 1))]))
    assert np.all(np.abs(pan) < math.radians(80)) and np.all(np.abs(tilt) < math.radians(80))
    return pose, points


def on_ground(points: np.ndarray, height_m: float = 0.0) -> np.ndarray:
    return np.hstack([points, np.full((len(points), 1), height_m)])


def unit(matrix: np.ndarray) -> np.ndarray:
    return matrix / np.linalg.norm(matrix)


@pytest.mark.parametrize("rig", RIGS, ids=RIG_IDS)
def test_true_homography_maps_each_centred_gaze_to_its_ground_point(rig) -> None:
    pose, points = synthetic_rig(*rig, n=20)
    homography = pose.frontal_to_ground()
    pan, tilt = pose.gaze_angles(on_ground(points))
    frontal = np.array(
        [pose.head.frontal_from_angles(p, t) for p, t in zip(pan, tilt, strict=True)]
    )
    assert np.abs(homography.ground_from_frontal(frontal) - points).max() < 1e-9 * rig[2]
    # and back: M^-1 gives the same frontal points, and the angles from its rays are the same
    assert np.abs(homography.frontal_from_ground(points) - frontal).max() < 1e-12
    back_pan, back_tilt = pose.head.angles_from_direction(homography.direction_from_ground(points))
    assert np.abs(back_pan - pan).max() < 1e-12 and np.abs(back_tilt - tilt).max() < 1e-12


@pytest.mark.parametrize("rig", RIGS, ids=RIG_IDS)
def test_a_centred_point_lands_on_the_principal_point_at_any_height(rig) -> None:
    pose, points = synthetic_rig(*rig)
    for height in (0.0, 0.5 * rig[1]):
        world = on_ground(points, height)
        pan, tilt = pose.gaze_angles(world)
        for k in range(len(world)):
            pixel = pose.pixels(world[k], pan[k], tilt[k], CAMERA)
            assert pixel == pytest.approx([319.5, 239.5], abs=1e-9)


@pytest.mark.parametrize("rig", RIGS, ids=RIG_IDS)
def test_ground_to_image_homography_agrees_with_pixels(rig) -> None:
    pose, points = synthetic_rig(*rig, n=12)
    pan, tilt = pose.gaze_angles(on_ground(points[4:5]))
    image_from_ground = pose.ground_to_image(pan[0], tilt[0], CAMERA)
    projected = np.hstack([points, np.ones((len(points), 1))]) @ image_from_ground.T
    in_front = pose.camera_directions(on_ground(points), pan[0], tilt[0])[:, 2] > 0
    assert np.array_equal(projected[:, 2] > 0, in_front) and in_front.sum() >= 5
    pixels = pose.pixels(on_ground(points[in_front]), pan[0], tilt[0], CAMERA)
    assert np.abs(projected[in_front, :2] / projected[in_front, 2:] - pixels).max() < 1e-8


def test_horizon_line_separates_ground_from_sky() -> None:
    pose, points = synthetic_rig("pan-tilt", 10.0, 40.0, -5.0, 7)
    pan, tilt = pose.gaze_angles(on_ground(points[4:5]))
    # look a little higher, so the horizon crosses the image
    tilt_up = tilt[0] + math.radians(12)
    line = pose.horizon_line(pan[0], tilt_up, CAMERA)
    assert math.hypot(line[0], line[1]) == pytest.approx(1.0)
    ground = pose.pixels(on_ground(points), pan[0], tilt_up, CAMERA)
    sky_points = on_ground(points, 3 * pose.centre_m[2])  # above the camera: seen above the horizon
    sky = pose.pixels(sky_points, pan[0], tilt_up, CAMERA)
    assert np.all(np.hstack([ground, np.ones((len(ground), 1))]) @ line < 0)
    assert np.all(np.hstack([sky, np.ones((len(sky), 1))]) @ line > 0)
    # a point at the camera's own height, far away, lies on the horizon
    far = pose.centre_m + 1e7 * pose.base_to_world[:, 2] * np.array([1, 1, 0])
    far_pixel = pose.pixels(far, pan[0], tilt_up, CAMERA)
    assert abs(np.append(far_pixel, 1.0) @ line) < 1e-3


@pytest.mark.parametrize("rig", RIGS, ids=RIG_IDS)
def test_a_calibrated_matrix_implies_the_camera_position(rig) -> None:
    pose, _ = synthetic_rig(*rig)
    assert pose.frontal_to_ground().implied_camera_xyz_m() == pytest.approx(
        pose.centre_m, abs=1e-9 * rig[2]
    )


def test_canonical_scale_is_m33_one_only_when_the_rest_gaze_meets_the_ground() -> None:
    for pitch_deg, rest_meets_ground in (
        (-30.0, True),
        (-0.6, True),
        (-0.4, False),
        (0.0, False),
        (10.0, False),
    ):
        pose = CameraPose(np.array([0.0, -6.0, 4.0]), math.radians(90), math.radians(pitch_deg))
        matrix = pose.frontal_to_ground().matrix
        assert pose.frontal_to_ground().rest_gaze_meets_ground is rest_meets_ground
        if rest_meets_ground:
            assert matrix[2, 2] == 1.0
        else:
            assert np.linalg.norm(matrix[2]) == pytest.approx(1.0)
            # the third row is minus the world's up axis in base coordinates: sin(pitch) at [2, 2]
            assert matrix[2, 2] == pytest.approx(-math.sin(math.radians(pitch_deg)), abs=1e-15)
    # a level head's M33 is exactly zero, written without a negative zero
    level = CameraPose(np.array([0.0, -6.0, 4.0]), math.radians(90)).frontal_to_ground().matrix
    assert level[2, 2] == 0.0 and math.copysign(1.0, level[2, 2]) == 1.0


def test_rays_above_the_horizon_are_refused_and_points_behind_the_frontal_plane_still_centre() -> (
    None
):
    pose = CameraPose(np.array([0.0, -6.0, 4.0]), math.radians(90), head=HeadKinematics("pan-tilt"))
    homography = pose.frontal_to_ground()
    with pytest.raises(HorizonError, match="horizon"):
        homography.ground_from_direction(pose.head.gaze(0.2, 0.01))
    with pytest.raises(HorizonError, match="horizon"):
        homography.ground_from_frontal(np.array([[0.1, -0.2], [0.0, 0.3]]))
    behind = np.array([0.0, -12.0])  # 6 m behind the camera: pan 180°
    with pytest.raises(HorizonError, match="behind the frontal plane"):
        homography.frontal_from_ground(behind)
    pan, tilt = pose.head.angles_from_direction(homography.direction_from_ground(behind))
    assert abs(pan) == pytest.approx(math.pi) and tilt == pytest.approx(-math.atan2(4.0, 6.0))
    true_pan, true_tilt = pose.gaze_angles(np.array([0.0, -12.0, 0.0]))
    assert (pan, tilt) == pytest.approx((true_pan, true_tilt))


def test_singular_or_non_finite_matrices_are_refused() -> None:
    with pytest.raises(ValueError, match="singular"):
        GroundHomography(np.array([[1.0, 0, 0], [0, 1.0, 0], [1.0, 0, 0]]))
    with pytest.raises(ValueError, match="finite"):
        GroundHomography(np.array([[1.0, 0, 0], [0, np.nan, 0], [0, 0, 1.0]]))


def test_pose_from_the_sim_rig_and_its_geometry() -> None:
    rig = load_rig(REPO / "configs" / "sim.toml")
    pose = CameraPose.from_rig(rig)
    assert pose.centre_m == pytest.approx(rig.sim.camera_xyz_m)
    rest_gaze = pose.base_to_world[:, 2]
    yaw = math.radians(rig.sim.camera_yaw_deg)
    pitch = math.radians(rig.sim.camera_pitch_deg)
    expected = [math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), math.sin(pitch)]
    assert rest_gaze == pytest.approx(expected, abs=1e-15)
    assert pose.head.kinematics == rig.head.kinematics
    # base axes: x right of the rest gaze and level (no roll), columns orthonormal
    assert pose.base_to_world[2, 0] == pytest.approx(0.0, abs=1e-15)
    assert pose.base_to_world.T @ pose.base_to_world == pytest.approx(np.eye(3))
    geometry = pose.ground_geometry(CAMERA, target_height_m=1.0)
    target = np.array([2.0, 5.0, 1.0])
    pan, tilt = pose.gaze_angles(target)
    assert geometry.ground_from_gaze(float(pan), float(tilt)) == pytest.approx(target[:2], abs=1e-9)


def test_pose_refuses_a_camera_on_or_below_the_ground() -> None:
    with pytest.raises(ValueError, match="Z > 0"):
        CameraPose(np.array([0.0, 0.0, 0.0]), 0.0)
