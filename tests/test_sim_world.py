"""The simulated world's snapshots without a bus or an emulator: the truth of each capture on the
rig's trajectories, frames numbered in order, pixels in the frame's encoding."""

from __future__ import annotations

from pathlib import Path

import pytest

from gazed.config import load_rig
from gazed.messages import HeadPose
from gazed.sim.world import SimWorld, trajectories

SIM_RIG = Path(__file__).resolve().parents[1] / "configs" / "sim.toml"
T0_S = 50.0


def head(t_s: float) -> HeadPose:
    return HeadPose(pan_rad=0.01 * (t_s - T0_S), tilt_rad=-0.3, pan_rate_rad_s=0.01)


def test_a_capture_is_the_world_at_its_instant() -> None:
    rig = load_rig(SIM_RIG)
    world = SimWorld(rig, head, T0_S)
    target, _ = trajectories(rig)
    scenes = []
    for k in range(3):
        t_s = T0_S + 0.5 * k
        scene, truth = world.capture(t_s, 1_000 + k)
        scenes.append(scene)
        assert scene.header.seq == truth.seq == k
        assert scene.header.t_capture_ns == truth.t_capture_ns == 1_000 + k
        assert truth.head == scene.head == head(t_s)
        state = target.state(0.5 * k)
        assert truth.target_xy_m == pytest.approx(state.xy_m)
        assert truth.target_velocity_m_s == pytest.approx(state.velocity_m_s)
        assert scene.bodies[0].xy_m == pytest.approx(state.xy_m)
        assert truth.target_height_m == rig.sim.target_height_m
    pixels = world.render(scenes[-1])
    assert pixels.shape[:2] == (rig.camera.height_px, rig.camera.width_px)
    assert pixels.ndim == (2 if rig.sim.frame_encoding == "gray8" else 3)


def test_gray8_frames_are_rendered_grey_and_a_distractor_is_a_second_body() -> None:
    rig = load_rig(SIM_RIG)
    sim = rig.sim.model_copy(update={"frame_encoding": "gray8", "distractor": "figure-eight"})
    world = SimWorld(rig.model_copy(update={"sim": sim}), head, T0_S)
    scene, _ = world.capture(T0_S, 1)
    assert len(scene.bodies) == 2 and scene.bodies[1].texture == 1
    assert world.render(scene).shape == (rig.camera.height_px, rig.camera.width_px)


def test_a_hidden_camera_delay_stamps_the_frame_on_arrival_and_the_truth_at_exposure() -> None:
    rig = load_rig(SIM_RIG)
    sim = rig.sim.model_copy(update={"camera_delay_ms": 150.0})
    world = SimWorld(rig.model_copy(update={"sim": sim}), head, T0_S)
    scene, truth = world.capture(T0_S + 1.0, 1_000_000_000)
    assert truth.t_capture_ns == 1_000_000_000
    assert scene.header.t_capture_ns == 1_150_000_000
    assert scene.head == truth.head == head(T0_S + 1.0)  # rendered at the exposure
