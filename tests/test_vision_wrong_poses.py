"""Head poses that are off, not noisy, do not make the background a target (the flow detector,
`gazed.vision.normal_flow`).

A pose read at the wrong instant while the head turns (a frame before any odometry, a polled
camera's lagging odometry, a glitch, a camera delay fitted a few tens of milliseconds off)
misregisters the whole view, and the fovea's background moves like a target. The surround
shows it: it moves together further than the poses' noise allows, and the detector then
reports nothing for that frame. On synthetic frames with no target while the head turns (up to
7°/s), the background is found in no frame whichever way the poses are off. On the simulator's
own frames through its first saccade (about 9° in 0.3 s, 56°/s at its peak), with every pose
read 19 ms off each frame's exposure, no detection lies off the target. Where the surround
cannot show it (too plain, or misregistered past its reach), the background is seen for a few
frames, and it is not held as a standing target once the poses are right (`still_target`: a
move counts only where the background bears the poses out).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np
import pytest
from conftest import REPO

from gazed.config import VisionSection, load_rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.pose import CameraPose
from gazed.geometry.zoom import ZoomLens
from gazed.messages import HeadPose
from gazed.sim.renderer import Body, Renderer
from gazed.vision.normal_flow import NOT_REGISTERED, NormalFlowDetector, Registration
from gazed.vision.pipeline import VisionPipeline
from gazed.vision.synthetic import SyntheticScene, sinusoidal_head

RATE_HZ = 25.0
CAMERA = CameraModel.from_fov(640, 480, math.radians(30))
KINEMATICS = HeadKinematics("pan-tilt")
POSE_NOISE_RAD = math.radians(0.05)  # [head] angle_noise_deg's default

Told = Callable[[int, list[HeadPose]], HeadPose | None]


def background_found(told: Told) -> list[bool]:
    """Each frame's `found` on a scene with no target while the head turns (up to 7°/s, about
    6 px per frame), the flow detector told `told(index, true poses so far)` as the head pose
    (with the pose noise added)."""
    scene = SyntheticScene(
        CAMERA, KINEMATICS, sinusoidal_head(0.04, 0.02, 0.5, 0.4), None, seed=3, field_rad=0.6
    )
    pipeline = VisionPipeline(
        CAMERA, KINEMATICS, VisionSection(), "flow", pose_noise_rad=POSE_NOISE_RAD
    )
    rng = np.random.default_rng(5)
    poses: list[HeadPose] = []
    found = []
    for index, (image, truth) in enumerate(scene.frames(RATE_HZ, 75)):
        poses.append(truth.head)
        head = told(index, poses)
        if head is not None:
            pan, tilt = rng.normal(0.0, POSE_NOISE_RAD, 2)
            head = head.model_copy(
                update={"pan_rad": head.pan_rad + pan, "tilt_rad": head.tilt_rad + tilt}
            )
        gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        found.append(pipeline.process(gray, round(truth.t_s * 1e9), head).output.found)
    return found


def turned(pose: HeadPose, pan_rad: float, tilt_rad: float) -> HeadPose:
    return pose.model_copy(
        update={"pan_rad": pose.pan_rad + pan_rad, "tilt_rad": pose.tilt_rad + tilt_rad}
    )


def glitch(index: int, poses: list[HeadPose]) -> HeadPose:
    """Frame 30's pose 0.5° off in pan (odometry late at a start)."""
    return turned(poses[-1], math.radians(0.5) if index == 30 else 0.0, 0.0)


def no_pose_at_first(index: int, poses: list[HeadPose]) -> HeadPose | None:
    """A replay's start: the first 10 frames come before any odometry."""
    return poses[-1] if index >= 10 else None


def lagging(index: int, poses: list[HeadPose]) -> HeadPose:
    """A polled camera's odometry: frames 10-29 told the pose of three frames before (up to
    18 px off)."""
    return poses[-4] if 10 <= index < 30 else poses[-1]


def jittered(index: int, poses: list[HeadPose]) -> HeadPose:
    """Frames 10-29 each told a pose up to 0.3° off on each axis (seeded per frame): odometry
    stamped with jitter while the head turns."""
    if not 10 <= index < 30:
        return poses[-1]
    pan, tilt = np.random.default_rng(index).uniform(-1.0, 1.0, 2) * math.radians(0.3)
    return turned(poses[-1], pan, tilt)


@pytest.mark.parametrize(
    "told", [glitch, no_pose_at_first, lagging, jittered], ids=lambda told: told.__name__
)
def test_poses_the_surround_contradicts_show_nothing(told: Told) -> None:
    assert not any(background_found(told))


@pytest.fixture
def unmeasured_surround(monkeypatch: pytest.MonkeyPatch) -> None:
    """A surround that does not show the poses are off: where it would, it is left
    unregistered instead, and the fovea's background moves like a target."""
    background = NormalFlowDetector._background

    def unregistered(self: NormalFlowDetector, *args: Any) -> Registration:
        registration = background(self, *args)
        return NOT_REGISTERED if registration.poses_off else registration

    monkeypatch.setattr(NormalFlowDetector, "_background", unregistered)


def test_a_background_seen_through_wrong_poses_is_not_held(unmeasured_surround: None) -> None:
    """Its look moves with the wrong poses as a target's would; once they are right it stands
    still in the world, and it is not held as a target that stopped."""
    found = background_found(jittered)
    assert sum(found[10:30]) >= 3  # the background seen as motion
    assert not any(found[34:])


def minimum_jerk(s: float) -> float:
    s = min(max(s, 0.0), 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s * s)


@pytest.mark.parametrize("seed", [2, 3, 4])
def test_the_first_saccade_seen_through_poses_read_off_its_frames_shows_no_background(
    seed: int,
) -> None:
    """configs/sim.toml's camera and court; a walker (seeded start and velocity) whom the head,
    still until 0.6 s, turns to in one saccade of 0.3 s (minimum jerk; the sim head's
    acceleration), every frame told the pose 19 ms after its exposure (a first camera delay
    fit that far off), with the head's pose noise. Where the flow detector finds something, it
    is the walker: within 20 px of their middle."""
    rig = load_rig(REPO / "configs" / "sim.toml")
    lens, pose, sim = ZoomLens.from_section(rig.camera), CameraPose.from_rig(rig), rig.sim
    camera = lens.base
    renderer = Renderer(
        camera, pose, seed=seed, noise_std=sim.noise_std_levels, court_m=sim.court_m
    )
    pipeline = VisionPipeline(
        camera, pose.head, rig.vision, "flow", pose_noise_rad=rig.pose_noise_rad
    )
    rng = np.random.default_rng(seed)
    start_m, velocity_m_s = rng.uniform((-2.0, 0.0), (2.0, 3.0)), rng.normal(0.0, 0.6, 2)
    onset_s, duration_s, stamp_error_s = 0.6 + rng.uniform(0.0, 0.04), 0.3, 0.019

    def middle(t_s: float) -> np.ndarray:
        return np.array([*(start_m + velocity_m_s * t_s), 0.5 * sim.target_height_m])

    aim = np.array([float(a) for a in pose.gaze_angles(middle(onset_s + duration_s))])

    def head(t_s: float) -> np.ndarray:
        return aim * minimum_jerk((t_s - onset_s) / duration_s)

    assert math.degrees(float(np.max(np.abs(aim)))) > 5.0  # a saccade, not a nudge
    errors_px = []
    for k in range(30):
        t_s = k / RATE_HZ
        pan, tilt = head(t_s)
        xy = tuple(start_m + velocity_m_s * t_s)
        body = Body(xy, height_m=sim.target_height_m, width_m=sim.target_width_m)
        gray = cv2.cvtColor(renderer.render(k, pan, tilt, [body]), cv2.COLOR_BGR2GRAY)
        noise = rng.normal(0.0, rig.pose_noise_rad, 2)
        told_pan, told_tilt = head(t_s + stamp_error_s) + noise
        told = HeadPose(pan_rad=told_pan, tilt_rad=told_tilt)
        output = pipeline.process(gray, round(t_s * 1e9), told).output
        if output.found:
            u, v = pose.pixels(middle(t_s), pan, tilt, camera)
            errors_px.append(math.hypot(output.u_px - u, output.v_px - v))
    assert len(errors_px) >= 5
    assert max(errors_px) <= 20.0
