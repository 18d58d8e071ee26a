"""The simulated camera: targets land where the geometry says, the ground moves as the
rotational flow formula says, and the same seed gives the same frames bit for bit."""

from __future__ import annotations

import hashlib
import math

import cv2
import numpy as np
import pytest

from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.pose import CameraPose
from gazed.sim.renderer import SKY_BGR, Body, Renderer

CAMERA = CameraModel.from_fov(640, 480, math.radians(60))


def pose(kinematics: str = "pan-tilt") -> CameraPose:
    return CameraPose(np.array([1.0, -6.0, 4.0]), math.radians(80), head=HeadKinematics(kinematics))


@pytest.mark.parametrize("kinematics", ["pan-tilt", "tilt-pan"])
@pytest.mark.parametrize("offset_deg", [(0.0, 0.0), (4.0, -3.0), (-9.0, 5.0), (12.0, 8.0)])
def test_target_foot_lands_on_the_predicted_pixel(
    kinematics: str, offset_deg: tuple[float, float]
) -> None:
    camera_pose = pose(kinematics)
    renderer = Renderer(CAMERA, camera_pose, seed=3, noise_std=0.0)
    pan, tilt = (float(a) for a in camera_pose.gaze_angles(np.array([2.0, 1.0, 0.0])))
    pan += math.radians(offset_deg[0])
    tilt += math.radians(offset_deg[1])
    body = Body((2.0, 1.0), height_m=1.7, width_m=0.5)
    with_body = renderer.render(0, pan, tilt, [body]).astype(int)
    without = renderer.render(0, pan, tilt, []).astype(int)
    mask = (np.abs(with_body - without).sum(axis=2) > 0).astype(np.uint8)
    # the body is a quadrilateral (perspective slants it); its two lowest corners are the feet
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    outline = cv2.approxPolyDP(max(contours, key=cv2.contourArea), 2.0, True).reshape(-1, 2)
    assert len(outline) == 4
    feet = outline[np.argsort(outline[:, 1])[-2:]].astype(float)
    measured = feet.mean(axis=0)  # pixel indices are pixel centres (OpenCV convention)
    # the prediction by another route than the renderer's: the ground -> image homography
    h = camera_pose.ground_to_image(pan, tilt, CAMERA) @ np.array([2.0, 1.0, 1.0])
    predicted = h[:2] / h[2]
    assert np.hypot(*(measured - predicted)) <= 1.0


def test_ground_image_motion_matches_the_rotational_flow_formula() -> None:
    camera_pose = pose()
    renderer = Renderer(CAMERA, camera_pose, seed=4, noise_std=0.0)
    pan, tilt = 0.0, math.radians(-30.0)
    step = math.radians(0.4)
    for d_pan, d_tilt in ((step, 0.0), (0.0, step), (-step, step)):
        a = cv2.cvtColor(renderer.render(0, pan, tilt, []), cv2.COLOR_BGR2GRAY).astype(np.float32)
        b = cv2.cvtColor(
            renderer.render(1, pan + d_pan, tilt + d_tilt, []), cv2.COLOR_BGR2GRAY
        ).astype(np.float32)
        window = np.s_[140:340, 220:420]  # 200 px about the image centre
        (du, dv), _ = cv2.phaseCorrelate(
            a[window], b[window], cv2.createHanningWindow((200, 200), cv2.CV_32F)
        )
        # rotational flow at the principal point of a pan-tilt head (pan outer):
        #   du = -f * d_pan * cos(tilt),  dv = +f * d_tilt  (v grows downwards, tilt up)
        f = CAMERA.focal_px
        expected = (-f * d_pan * math.cos(tilt), f * d_tilt)
        assert du == pytest.approx(expected[0], abs=0.15)
        assert dv == pytest.approx(expected[1], abs=0.15)


def test_same_seed_same_frames_bit_for_bit() -> None:
    angles = [(0.01 * k, -0.5 + 0.005 * k) for k in range(4)]
    bodies = [Body((0.5 * k, 0.2), 1.7, 0.5) for k in range(4)]

    def digest(seed: int) -> str:
        renderer = Renderer(CAMERA, pose(), seed=seed, noise_std=3.0, flicker_amplitude=0.1)
        h = hashlib.sha256()
        for seq, ((pan, tilt), body) in enumerate(zip(angles, bodies, strict=True)):
            h.update(renderer.render(seq, pan, tilt, [body], t_s=0.04 * seq).tobytes())
        return h.hexdigest()

    assert digest(11) == digest(11)
    assert digest(11) != digest(12)


def test_sky_above_the_horizon() -> None:
    renderer = Renderer(CAMERA, pose(), seed=1, noise_std=0.0)
    frame = renderer.render(0, 0.0, math.radians(5.0), [])
    # camera 4 m up, tilted 5° up: the horizon is below the image centre
    assert tuple(frame[10, 320]) == SKY_BGR
    assert tuple(frame[470, 320]) != SKY_BGR
    horizon_v = CAMERA.K[1, 2] + CAMERA.K[1, 1] * math.tan(math.radians(5.0))
    column = frame[:, 320]
    first_ground = int(np.argmax([tuple(p) != SKY_BGR for p in column]))
    assert abs(first_ground - horizon_v) <= 1.5


def test_noise_has_the_configured_strength() -> None:
    clean = Renderer(CAMERA, pose(), seed=2, noise_std=0.0).render(0, 0.0, -0.5, [])
    noisy = Renderer(CAMERA, pose(), seed=2, noise_std=4.0).render(0, 0.0, -0.5, [])
    difference = noisy.astype(float) - clean.astype(float)
    assert difference.std() == pytest.approx(4.0, rel=0.1)
