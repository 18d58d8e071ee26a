"""The focal length at each frame's capture: the sim renders through the lens at its zoom, and
vision, the geometry and the estimator measure each frame through the same camera."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gazed.config import load_rig
from gazed.estimation.target_tracker import TargetTracker
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.pose import CameraPose
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Detection, HeadPose, Odometry
from gazed.sim.renderer import Body, Renderer
from gazed.vision.ego_motion import EgoMotion
from gazed.vision.normal_flow import NormalFlowDetector
from gazed.vision.odometry_history import OdometryHistory

SIM = Path(__file__).resolve().parents[1] / "configs" / "sim.toml"
TABLE = [[0.0, 554.0], [0.5, 1800.0], [1.0, 6000.0]]


def zoom_rig():
    rig = load_rig(SIM)
    camera = rig.camera.model_copy(update={"zoom_focal_px": TABLE})
    return rig.model_copy(update={"camera": camera})


def test_a_frame_at_zoom_gives_the_ground_point_the_renderer_put_the_target_at() -> None:
    rig = zoom_rig()
    lens, truth_pose = ZoomLens.from_section(rig.camera), CameraPose.from_rig(rig)
    tracker = TargetTracker(rig, "estimator")
    target_m = np.array([0.7, 1.2, rig.calibration.target_height_m])  # the tracked middle
    pan, tilt = (float(a) for a in truth_pose.gaze_angles(target_m))
    pan += 0.2 / lens.focal_px(0.6)  # a little off the axis: the focal length matters
    for zoom in (0.0, 0.3, 0.6, 0.9):
        head = HeadPose(pan_rad=pan, tilt_rad=tilt, zoom=zoom)
        u, v = truth_pose.pixels(target_m, pan, tilt, lens.camera_at(zoom))
        u, v = u + 40.0, v - 25.0  # and 40 px right, 25 up: off the principal point
        detection = Detection(
            t_capture_ns=1,
            seq=0,
            detector="flow",
            found=True,
            u_px=float(u),
            v_px=float(v),
            width_px=640,
            height_px=480,
            head=head,
        )
        measured = tracker._measure(detection)
        assert measured is not None
        # where the renderer's camera at this zoom puts that pixel on the ground plane at the
        # target's height
        centre = truth_pose.centre_m
        ray = truth_pose.base_to_world @ (
            truth_pose.head.camera_to_base(pan, tilt) @ lens.camera_at(zoom).ray(u, v)
        )
        along = (target_m[2] - centre[2]) / ray[2]
        expected = (centre + along * ray)[:2]
        assert np.hypot(*(measured.position - expected)) < 0.005
        if zoom > 0:  # the rig's fixed camera would put it elsewhere
            fixed = tracker._measure(
                detection.model_copy(update={"head": head.model_copy(update={"zoom": None})})
            )
            assert fixed is not None
            assert np.hypot(*(fixed.position - expected)) > 0.05


@pytest.mark.parametrize("zoom", [0.0, 0.4, 0.8])
def test_the_renderer_at_a_zoom_puts_a_body_where_a_pinhole_of_that_focal_length_does(
    zoom: float,
) -> None:
    lens = ZoomLens.from_section(zoom_rig().camera)
    camera = lens.camera_at(zoom)
    truth_pose = CameraPose(np.array([0.0, -5.0, 3.0]), math.radians(90), math.radians(-25))
    renderer = Renderer(lens.base, truth_pose, seed=2, noise_std=0.0)
    body = Body((0.3, 2.0), height_m=0.4, width_m=0.4)
    pan, tilt = (float(a) for a in truth_pose.gaze_angles(np.array([0.3, 2.0, 0.2])))
    with_body = renderer.render(0, pan, tilt, [body], camera=camera).astype(int)
    without = renderer.render(0, pan, tilt, [], camera=camera).astype(int)
    rows, cols = np.nonzero(np.abs(with_body - without).sum(axis=2) > 0)
    # the pinhole by hand, u = cx + f x / z, v = cy + f y / z in the camera frame, at the
    # body's corners (it faces the camera: its sides are square to the line of sight)
    f = float(np.interp(zoom, [r[0] for r in TABLE], [r[1] for r in TABLE]))
    dx, dy = 0.3 - truth_pose.centre_m[0], 2.0 - truth_pose.centre_m[1]
    right = np.array([dy, -dx, 0.0]) / math.hypot(dx, dy) * 0.2
    foot, top = np.array([0.3, 2.0, 0.0]), np.array([0.3, 2.0, 0.4])
    corners = np.array([top - right, top + right, foot + right, foot - right])
    xyz = truth_pose.camera_directions(corners, pan, tilt)
    u = 319.5 + f * xyz[:, 0] / xyz[:, 2]
    v = 239.5 + f * xyz[:, 1] / xyz[:, 2]
    assert rows.min() == pytest.approx(v.min(), abs=1.0)
    assert rows.max() == pytest.approx(v.max(), abs=1.0)
    assert cols.min() == pytest.approx(u.min(), abs=1.0)
    assert cols.max() == pytest.approx(u.max(), abs=1.0)


def test_the_warp_and_the_flow_between_frames_at_two_zooms_follow_static_points() -> None:
    lens = ZoomLens.from_section(zoom_rig().camera)
    kinematics = HeadKinematics()
    ego = EgoMotion(lens.base, kinematics, lens)
    one = HeadPose(pan_rad=0.100, tilt_rad=-0.200, zoom=0.300)
    two = HeadPose(pan_rad=0.101, tilt_rad=-0.201, zoom=0.302)
    step = ego.step(one, two, 0.04)
    for u, v in ((100.0, 80.0), (320.0, 240.0), (600.0, 400.0)):
        direction = kinematics.camera_to_base(one.pan_rad, one.tilt_rad) @ lens.at_pose(one).ray(
            u, v
        )
        expected = lens.at_pose(two).pixel(
            kinematics.camera_to_base(two.pan_rad, two.tilt_rad).T @ direction
        )
        np.testing.assert_allclose(step.transport(u, v), expected, atol=1e-6)
        # the flow matches the displacement over the interval (to first order in the step)
        du, dv = step.flow(np.array(expected[0]), np.array(expected[1]))
        moved = np.array(expected) - (u, v)
        assert np.hypot(*moved) > 0.5
        np.testing.assert_allclose(np.array([du, dv]) * 0.04, moved, atol=0.02)
    # the zoom alone: the image grows about the principal point
    still = ego.step(
        HeadPose(pan_rad=0.0, tilt_rad=0.0, zoom=0.3),
        two.model_copy(update={"pan_rad": 0.0, "tilt_rad": 0.0}),
        0.04,
    )
    assert still.zoom_rate_s == pytest.approx(
        math.log(lens.focal_px(0.302) / lens.focal_px(0.3)) / 0.04
    )


def test_the_flow_detectors_fovea_spans_its_angle_at_each_frames_focal_length() -> None:
    lens = ZoomLens.from_section(zoom_rig().camera)
    detector = NormalFlowDetector(
        lens.base, fovea_rad=math.radians(6.0), noise_px=1.0, min_gradient=4.0, min_area_px=20
    )
    wide = detector.side
    assert wide == round(2 * 554.0 * math.tan(math.radians(3.0)))
    detector._size_fovea(lens.camera_at(0.5).K)
    assert detector.side == round(2 * 1800.0 * math.tan(math.radians(3.0)))
    assert detector._offsets_px.shape == (detector.side, detector.side, 2)
    detector._size_fovea(lens.camera_at(1.0).K)
    assert detector.side == 480 - 12  # no wider than the frame, less its margins


def test_a_frames_pose_carries_the_zoom_interpolated_at_its_capture() -> None:
    history = OdometryHistory(span_s=1.0, max_gap_s=0.1)
    for t_ns, zoom in ((0, 0.2), (20_000_000, 0.3)):
        history.add(Odometry(t_capture_ns=t_ns, pan_rad=0.0, tilt_rad=0.0, zoom=zoom))
    assert history.pose_at(5_000_000).zoom == pytest.approx(0.225)
    assert history.pose_at(30_000_000).zoom == pytest.approx(0.3)  # held past the newest
    fixed = OdometryHistory(span_s=1.0, max_gap_s=0.1)
    for t_ns in (0, 20_000_000):
        fixed.add(Odometry(t_capture_ns=t_ns, pan_rad=0.0, tilt_rad=0.0))
    assert fixed.pose_at(5_000_000).zoom is None
