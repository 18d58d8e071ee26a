"""The flow detector against the background's leftover motion: with the odometry off by about a
pixel per frame, still textured ground is no target, and a real mover is still found."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from gazed.config import VisionSection
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.vision.pipeline import VisionPipeline
from gazed.vision.synthetic import SceneTruth, SyntheticScene, pursuing_head

RATE_HZ = 25.0
CAMERA = CameraModel.from_fov(640, 480, math.radians(60))
KINEMATICS = HeadKinematics("pan-tilt")
PAN_RATE_RAD_S = math.radians(10.0)  # the head turns slowly: a small step, a large error share
ODOMETRY_ERROR_PX = 1.0  # per frame, in the head's step
FRAMES = 20

Frames = list[tuple[np.ndarray, SceneTruth]]


def turning_head():
    return pursuing_head(0.0, 0.0, PAN_RATE_RAD_S, 0.0, wobble_rad=0.0)


def detections(frames: Frames) -> list:
    """Each frame through the flow detector, with a reported pan that drifts from the true one
    by ODOMETRY_ERROR_PX every frame."""
    drift_rad_s = ODOMETRY_ERROR_PX / CAMERA.focal_px * RATE_HZ
    pipeline = VisionPipeline(CAMERA, KINEMATICS, VisionSection(), "flow")
    outputs = []
    for image, truth in frames:
        head = truth.head.model_copy(
            update={
                "pan_rad": truth.head.pan_rad + drift_rad_s * truth.t_s,
                "pan_rate_rad_s": truth.head.pan_rate_rad_s + drift_rad_s,
            }
        )
        gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        outputs.append(pipeline.process(gray, round(truth.t_s * 1e9), head).output)
    return outputs


def test_still_ground_under_an_odometry_error_is_no_target() -> None:
    frames = SyntheticScene(
        CAMERA, KINEMATICS, turning_head(), None, seed=21, field_rad=0.75
    ).frames(RATE_HZ, FRAMES)
    assert sum(out.found for out in detections(frames)) == 0


@pytest.mark.parametrize("speed_px", [2.0, 3.0, 4.0])
def test_a_mover_is_found_under_the_same_error(speed_px: float) -> None:
    """The target moves `speed_px` per frame against the world, right and a little down."""
    rate = speed_px / CAMERA.focal_px * RATE_HZ

    def target(t_s: float) -> tuple[float, float]:
        return -0.03 + PAN_RATE_RAD_S * t_s + rate * t_s, 0.01 - 0.3 * rate * t_s

    scene = SyntheticScene(CAMERA, KINEMATICS, turning_head(), target, seed=22, field_rad=0.75)
    frames = scene.frames(RATE_HZ, FRAMES)
    found = [
        math.hypot(out.u_px - truth.u_px, out.v_px - truth.v_px)
        for out, (_, truth) in zip(detections(frames), frames, strict=True)
        if out.found
    ]
    assert len(found) >= 0.8 * FRAMES
    assert np.median(found) <= 2.0
