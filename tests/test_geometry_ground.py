"""GroundGeometry, what the estimator and gaze controller use: image measurements to the ground
and back, the height correction of seed 000 §3.1, every Jacobian against finite differences,
ground velocity against a moving target, and the propagated covariance against Monte Carlo."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_geometry_pose import RIG_IDS, RIGS, on_ground, synthetic_rig

from gazed.config import HeadSection, RigError, parse_rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.ground import (
    GazeSample,
    GroundGeometry,
    MeasurementNoise,
    MissingCalibrationError,
)
from gazed.geometry.height import HeightCorrection
from gazed.geometry.homography import HorizonError
from gazed.geometry.pose import CameraPose

PINHOLE = CameraModel.from_fov(640, 480, math.radians(60.0))
DISTORTED = CameraModel.from_intrinsics(
    640, 480, 560.0, 560.0, 322.0, 236.0, (-0.2, 0.05, 0.0, 0.0, 0.0)
)
CAMERAS = [PINHOLE, DISTORTED]
CAMERA_IDS = ["pinhole", "distorted"]


def look_at(
    pose: CameraPose, ground: np.ndarray, k: int, offset_rad: float = 0.03
) -> tuple[float, float]:
    """Head angles that look near (not exactly at) ground point k."""
    pan, tilt = pose.gaze_angles(on_ground(ground[k : k + 1]))
    return float(pan[0]) + offset_rad, float(tilt[0]) - offset_rad


def visible(
    pose: CameraPose, points: np.ndarray, pan: float, tilt: float, camera: CameraModel
) -> np.ndarray:
    """Points (..., 3) in front of the camera whose pixel falls inside the image."""
    points = points[pose.camera_directions(points, pan, tilt)[:, 2] > 0]
    pixels = pose.pixels(points, pan, tilt, camera)
    inside = (pixels[:, 0] > 0) & (pixels[:, 0] < 639) & (pixels[:, 1] > 0) & (pixels[:, 1] < 479)
    return points[inside]


@pytest.mark.parametrize("camera", CAMERAS, ids=CAMERA_IDS)
@pytest.mark.parametrize("rig", RIGS, ids=RIG_IDS)
def test_pixels_map_to_their_ground_points_and_back(rig, camera: CameraModel) -> None:
    pose, ground = synthetic_rig(*rig, n=40)
    geometry = pose.ground_geometry(camera)
    pan, tilt = look_at(pose, ground, 4)
    seen = visible(pose, on_ground(ground), pan, tilt, camera)
    assert len(seen) >= 10
    pixels = pose.pixels(seen, pan, tilt, camera)
    mapped = geometry.ground_from_gaze(pan, tilt, pixels[:, 0], pixels[:, 1])
    assert np.abs(mapped - seen[:, :2]).max() < 1e-8 * rig[2]
    for point, pixel in zip(seen, pixels, strict=True):
        assert geometry.pixel_from_ground(point[0], point[1], pan, tilt) == pytest.approx(
            pixel, abs=1e-7
        )
    # centring: gaze_from_ground and ground_from_gaze (optical axis) invert each other
    for x, y in ground:
        centre_pan, centre_tilt = geometry.gaze_from_ground(x, y)
        assert geometry.ground_from_gaze(centre_pan, centre_tilt) == pytest.approx(
            [x, y], abs=1e-9 * rig[2]
        )
        assert (centre_pan, centre_tilt) == pytest.approx(
            pose.gaze_angles(np.array([x, y, 0.0])), abs=1e-12
        )


@pytest.mark.parametrize("rig", RIGS, ids=RIG_IDS)
def test_height_correction_is_exact_for_targets_at_height(rig) -> None:
    pose, ground = synthetic_rig(*rig)
    height = 0.4 * rig[1]
    geometry = pose.ground_geometry(PINHOLE, target_height_m=height)
    targets = on_ground(ground, height)
    pan, tilt = pose.gaze_angles(targets)
    for k, target in enumerate(targets):
        assert geometry.ground_from_gaze(pan[k], tilt[k]) == pytest.approx(
            target[:2], abs=1e-9 * rig[2]
        )
        assert geometry.gaze_from_ground(*target[:2]) == pytest.approx((pan[k], tilt[k]), abs=1e-12)
        # the paper's form: X' = X + h cot(alpha) (Xc - X) / |Xc - X|, alpha the gaze depression
        hit = pose.frontal_to_ground().ground_from_direction(pose.head.gaze(pan[k], tilt[k]))
        ray = pose.base_to_world @ pose.head.gaze(pan[k], tilt[k])
        alpha = math.asin(-ray[2] / np.linalg.norm(ray))
        towards_camera = pose.centre_m[:2] - hit
        paper = hit + height / math.tan(alpha) * towards_camera / np.linalg.norm(towards_camera)
        assert paper == pytest.approx(target[:2], abs=1e-9 * rig[2])
    # and for a target seen off the image centre
    look_pan, look_tilt = look_at(pose, ground, 5, 0.02)
    seen = visible(pose, targets, look_pan, look_tilt, PINHOLE)
    pixels = pose.pixels(seen, look_pan, look_tilt, PINHOLE)
    mapped = geometry.ground_from_gaze(look_pan, look_tilt, pixels[:, 0], pixels[:, 1])
    assert np.abs(mapped - seen[:, :2]).max() < 1e-8 * rig[2]


def test_height_correction_refuses_a_target_above_the_camera() -> None:
    with pytest.raises(ValueError, match="below the camera's height"):
        HeightCorrection(np.array([0.0, 0.0, 2.0]), 2.5)


def central_difference(f, x: np.ndarray, steps: np.ndarray) -> np.ndarray:
    columns = []
    for k, step in enumerate(steps):
        dx = np.zeros(len(x))
        dx[k] = step
        columns.append((np.asarray(f(*(x + dx))) - np.asarray(f(*(x - dx)))) / (2 * step))
    return np.column_stack(columns)


@pytest.mark.parametrize("camera", CAMERAS, ids=CAMERA_IDS)
@pytest.mark.parametrize("rig", RIGS, ids=RIG_IDS)
def test_jacobians_match_finite_differences(rig, camera: CameraModel) -> None:
    pose, ground = synthetic_rig(*rig)
    for geometry in (pose.ground_geometry(camera), pose.ground_geometry(camera, 0.3 * rig[1])):
        pan, tilt = look_at(pose, ground, 4, 0.01)
        for u, v in ((320.0, 240.0), (100.0, 400.0), (500.0, 300.0)):
            z = np.array([pan, tilt, u, v])
            analytic = geometry.ground_jacobian(*z)
            numeric = central_difference(
                geometry.ground_from_gaze, z, np.array([1e-7, 1e-7, 1e-3, 1e-3])
            )
            assert np.abs(numeric - analytic).max() <= 1e-6 * np.abs(analytic).max()
        for x, y in ground[:4]:
            analytic = geometry.gaze_jacobian(x, y)
            numeric = central_difference(
                geometry.gaze_from_ground, np.array([x, y]), np.array([1e-5, 1e-5])
            )
            assert np.abs(numeric - analytic).max() <= 1e-6 * np.abs(analytic).max()
            rates = geometry.gaze_rates_from_ground(x, y, 1.2, -0.7)
            assert rates == pytest.approx(analytic @ [1.2, -0.7], rel=1e-12)
            motion = geometry.gaze_motion_from_ground(x, y, 1.2, -0.7)
            assert motion == (*geometry.gaze_from_ground(x, y), *rates)


@pytest.mark.parametrize("camera", CAMERAS, ids=CAMERA_IDS)
def test_measured_velocity_is_the_targets_ground_velocity(camera: CameraModel) -> None:
    pose, ground = synthetic_rig("tilt-pan", 4.0, 20.0, -20.0, 2)
    height = 1.0
    geometry = pose.ground_geometry(camera, height)
    start, velocity = np.array([ground[4, 0], ground[4, 1], height]), np.array([1.3, -0.6, 0.0])
    pan0, tilt0 = look_at(pose, ground, 4, 0.02)
    pan_rate, tilt_rate = 0.15, -0.08  # the head turns, not quite following

    def pixel(t: float) -> np.ndarray:
        return pose.pixels(start + velocity * t, pan0 + pan_rate * t, tilt0 + tilt_rate * t, camera)

    dt = 1e-4
    u, v = pixel(0.0)
    u_rate, v_rate = (pixel(dt) - pixel(-dt)) / (2 * dt)
    sample = GazeSample(pan0, tilt0, u, v, pan_rate, tilt_rate, u_rate, v_rate)
    measured = geometry.measure(sample, MeasurementNoise(1e-3, 1e-2, 0.5, 2.0))
    assert measured.position_m == pytest.approx(start[:2], abs=1e-8)
    assert measured.velocity_m_s == pytest.approx(velocity[:2], abs=1e-6)


def test_covariance_matches_monte_carlo() -> None:
    pose, ground = synthetic_rig("pan-tilt", 12.0, 60.0, -30.0, 3)
    geometry = pose.ground_geometry(DISTORTED, 1.0)
    pan, tilt = look_at(pose, ground, 4, 0.02)
    sample = GazeSample(pan, tilt, 400.0, 150.0, 0.2, -0.1, 35.0, -20.0)
    noise = MeasurementNoise(math.radians(0.05), math.radians(0.5), 1.0, 5.0)
    predicted = geometry.measure(sample, noise).covariance
    rng = np.random.default_rng(17)
    z = np.array([sample.pan_rad, sample.tilt_rad, sample.u_px, sample.v_px])
    r = np.array(
        [sample.pan_rate_rad_s, sample.tilt_rate_rad_s, sample.u_rate_px_s, sample.v_rate_px_s]
    )
    stds = np.sqrt(noise.variances())
    outcomes = []
    for _ in range(3000):
        zn = z + rng.normal(0, stds[:4])
        rn = r + rng.normal(0, stds[4:])
        outcomes.append(
            np.concatenate([geometry.ground_from_gaze(*zn), geometry.ground_jacobian(*zn) @ rn])
        )
    empirical = np.cov(np.array(outcomes).T)
    scale = np.sqrt(np.outer(np.diag(predicted), np.diag(predicted)))
    # 3000 samples: standard errors of variances ~2.6 %, of correlations ~0.02
    assert np.abs((empirical - predicted) / scale).max() < 0.08
    # the velocity block depends on the position noise through the rates (the cross term)
    jacobian = geometry.ground_jacobian(*z)
    without_cross = jacobian @ np.diag(noise.variances()[4:]) @ jacobian.T
    assert not np.allclose(predicted[2:, 2:], without_cross, rtol=0.02)


@pytest.mark.parametrize("camera", CAMERAS, ids=CAMERA_IDS)
@pytest.mark.parametrize(
    "rates", [(0.2, -0.1, 35.0, -20.0), (0.0, 0.0, 0.0, 0.0), (0.0, 0.3, 0.0, 0.0)]
)
def test_covariance_is_the_first_order_propagation(camera: CameraModel, rates) -> None:
    """measure's F Σ Fᵀ against F built from central differences of `ground_jacobian` by each
    input in turn (the velocity's derivative by the position inputs, column by column)."""
    pose, ground = synthetic_rig("pan-tilt", 12.0, 60.0, -30.0, 3)
    geometry = pose.ground_geometry(camera, 1.0)
    pan, tilt = look_at(pose, ground, 4, 0.02)
    sample = GazeSample(pan, tilt, 400.0, 150.0, *rates)
    noise = MeasurementNoise(math.radians(0.05), math.radians(0.5), 1.0, 5.0)
    z, r = np.array([pan, tilt, 400.0, 150.0]), np.array(rates)
    jacobian = geometry.ground_jacobian(*z)
    velocity_by_z = central_difference(
        lambda *zi: geometry.ground_jacobian(*zi) @ r, z, np.array([1e-5, 1e-5, 1e-2, 1e-2])
    )
    f = np.block([[jacobian, np.zeros((2, 4))], [velocity_by_z, jacobian]])
    expected = f @ np.diag(noise.variances()) @ f.T
    measured = geometry.measure(sample, noise).covariance
    scale = np.sqrt(np.outer(np.diag(expected), np.diag(expected)))
    assert np.abs((measured - expected) / scale).max() < 1e-5


def test_a_gaze_above_the_horizon_is_an_error_not_nan() -> None:
    geometry = CameraPose(np.array([0.0, -6.0, 4.0]), math.radians(90)).ground_geometry(PINHOLE)
    with pytest.raises(HorizonError, match="does not meet the ground"):
        geometry.ground_from_gaze(0.0, math.radians(2.0))
    with pytest.raises(HorizonError, match="1 of 2 rays"):
        geometry.ground_from_gaze(
            0.0, math.radians(-2.0), np.array([320.0, 320.0]), np.array([470.0, 5.0])
        )


RIG_TEXT = """
[rig]
name = "geometry-test"
[calibration]
homography = {homography}
camera_xyz_m = [0.0, -6.0, 4.0]
target_height_m = 1.2
[head]
angle_noise_deg = 0.1
angle_rate_noise_deg_s = 2.0
"""


def test_from_rig_reads_the_calibration_and_refuses_a_missing_homography() -> None:
    pose = CameraPose(np.array([0.0, -6.0, 4.0]), math.radians(90))
    matrix = pose.frontal_to_ground().matrix.tolist()
    rig = parse_rig(RIG_TEXT.format(homography=matrix))
    geometry = GroundGeometry.from_rig(rig)
    truth = pose.ground_geometry(CameraModel.from_section(rig.camera), 1.2)
    for x, y in ((0.0, 0.0), (3.0, 8.0), (-4.0, 2.0)):
        assert geometry.gaze_from_ground(x, y) == pytest.approx(
            truth.gaze_from_ground(x, y), abs=1e-12
        )
    noise = MeasurementNoise.from_head(rig.head, pixel_px=1.0, pixel_rate_px_s=4.0)
    assert noise.angle_rad == pytest.approx(math.radians(0.1))
    assert noise.angle_rate_rad_s == pytest.approx(math.radians(2.0))
    with pytest.raises(
        MissingCalibrationError, match=r"rig 'geometry-test': \[calibration\] homography is missing"
    ):
        GroundGeometry.from_rig(parse_rig('[rig]\nname = "geometry-test"\n'))


def test_rig_refuses_a_singular_homography_and_a_target_above_the_camera() -> None:
    with pytest.raises(RigError, match=r"calibration\.homography: singular"):
        parse_rig(RIG_TEXT.format(homography=[[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    with pytest.raises(RigError, match=r"calibration\.target_height_m: not below the camera"):
        parse_rig(
            '[rig]\nname = "x"\n[calibration]\ncamera_xyz_m = [0.0, 0.0, 1.0]\n'
            "target_height_m = 1.5\n"
        )
    assert HeadSection().angle_noise_rad == pytest.approx(math.radians(0.05))


def test_a_regions_extent_widens_its_points_noise_per_axis() -> None:
    """A region w by h whose extent is uncertain by a fraction f of itself: its point's pixel
    variance is the detector's plus (f w)² along u and (f h)² along v, taken to the ground
    through the pixel Jacobian."""
    pose, ground = synthetic_rig("pan-tilt", 12.0, 60.0, -30.0, 3)
    geometry = pose.ground_geometry(PINHOLE, 1.0)
    pan, tilt = look_at(pose, ground, 4, 0.02)
    sample = GazeSample(pan, tilt, 320.0, 240.0)
    point = MeasurementNoise(0.0, 0.0, 2.0, 5.0)
    region = point.for_region(20.0, 60.0, (0.15, 0.15))
    assert region.pixel_variances() == pytest.approx([4.0 + 3.0**2, 4.0 + 9.0**2])
    assert point.for_region(0.0, 0.0, (0.15, 0.15)).pixel_variances() == pytest.approx([4.0, 4.0])
    pixel = geometry.ground_jacobian(pan, tilt, 320.0, 240.0)[:, 2:]
    expected = pixel @ np.diag(region.pixel_variances()) @ pixel.T
    measured = geometry.measure(sample, region).covariance[:2, :2]
    assert measured == pytest.approx(expected, rel=1e-9)
    assert np.linalg.det(measured) > np.linalg.det(
        geometry.measure(sample, point).covariance[:2, :2]
    )
