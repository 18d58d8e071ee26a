"""The flow detector while the lens zooms: the previous frame sampled at the zoom's scale."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from gazed.config import load_rig
from gazed.eval.zoom_score import zoom_scoring
from gazed.geometry.pose import CameraPose
from gazed.geometry.zoom import ZoomLens
from gazed.messages import HeadPose, SimTruth
from gazed.sim.renderer import Body, Renderer
from gazed.vision.detector import FramePair
from gazed.vision.ego_motion import EgoMotion
from gazed.vision.flow_constraints import window_offsets_px
from gazed.vision.normal_flow import NormalFlowDetector

RIG = Path(__file__).resolve().parents[1] / "configs" / "sim-zoom.toml"
DT_S = 0.04


def rig_zoom_rate_s() -> float:
    return load_rig(RIG).head.zoom_rate_max_s


def test_a_zooming_windows_sampling_leaves_no_displacement_of_static_points() -> None:
    rig = load_rig(RIG)
    lens = ZoomLens.from_section(rig.camera)
    ego = EgoMotion(lens.base, CameraPose.from_rig(rig).head, lens)
    one = HeadPose(pan_rad=0.1, tilt_rad=-0.2, zoom=0.30)
    two = HeadPose(pan_rad=0.1, tilt_rad=-0.2, zoom=0.32)  # the zoom alone
    step = ego.step(one, two, DT_S)
    assert step.scale == pytest.approx(lens.focal_px(0.30) / lens.focal_px(0.32))
    origin, side = (200, 150), 120
    centre = (origin[0] + (side - 1) / 2.0, origin[1] + (side - 1) / 2.0)
    shift = step.displacement(*centre)
    offsets = window_offsets_px(side)
    residual = step.sampled_less_displacement(shift, centre, origin, offsets)
    assert np.abs(residual).max() < 1e-6
    # a fixed lens: s - w, the shift less each pixel's displacement
    turn = ego.step(one, one.model_copy(update={"pan_rad": 0.11}), DT_S)
    assert turn.scale == 1.0
    shift = turn.displacement(*centre)
    du, dv = turn.displacement(origin[0] + offsets[..., 0], origin[1] + offsets[..., 1])
    expected = np.stack([shift[0] - du, shift[1] - dv], axis=-1)
    np.testing.assert_allclose(
        turn.sampled_less_displacement(shift, centre, origin, offsets), expected, atol=1e-9
    )


def test_a_walker_keeps_its_box_while_the_lens_zooms_out_at_the_mechanisms_rate() -> None:
    """The head follows a walker past the court's edge while the zoom goes out at the head's
    zoom_rate_max_s: the box stays the walker's (no edge behind it joins the region)."""
    rate_s = -rig_zoom_rate_s()
    rig = load_rig(RIG)
    lens, pose, sim, vision = (
        ZoomLens.from_section(rig.camera),
        CameraPose.from_rig(rig),
        rig.sim,
        rig.vision,
    )
    renderer = Renderer(
        lens.base, pose, seed=3, noise_std=sim.noise_std_levels, court_m=sim.court_m
    )
    detector = NormalFlowDetector(
        lens.base,
        fovea_rad=vision.fovea_rad,
        noise_px=vision.flow_noise_px,
        min_gradient=vision.flow_min_gradient,
        min_area_px=vision.flow_min_area_px,
    )
    ego, scoring = EgoMotion(lens.base, pose.head, lens), zoom_scoring(rig)
    assert scoring is not None
    zoom = 0.8
    previous = previous_head = None
    ratios = []
    for k in range(11):
        xy = (-2.5 + 0.6 * k * DT_S, 0.3 * k * DT_S)
        pan, tilt = (float(a) for a in pose.gaze_angles(np.array([xy[0], xy[1], 0.2])))
        zoom += rate_s * DT_S if k > 2 else 0.0
        head = HeadPose(pan_rad=pan, tilt_rad=tilt, zoom=zoom)
        body = Body(xy, height_m=sim.target_height_m, width_m=sim.target_width_m)
        image = renderer.render(k, pan, tilt, [body], camera=lens.at_pose(head))
        gray = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image
        if previous is not None:
            step = ego.step(previous_head, head, DT_S)
            found = detector.detect(FramePair(gray, k * DT_S, previous, step, True))
            if k > 4:
                assert found.found
                truth = SimTruth(
                    t_capture_ns=1,
                    seq=k,
                    target_xy_m=xy,
                    target_velocity_m_s=(0.6, 0.3),
                    target_height_m=sim.target_height_m,
                    head=head,
                )
                true_px = scoring.heights([truth])[0] * lens.base.height_px
                box_px = found.movers[0].box[3] - rig.gaze.zoom_box_margin_px
                ratios.append(box_px / true_px)
                assert math.hypot(found.u_px - 319.5, found.v_px - 239.5) < 8.0
        previous, previous_head = gray, head
    assert max(ratios) < 1.3
