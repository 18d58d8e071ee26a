"""The simulated world at one instant, and what the camera sees of it (DESIGN §9).

At a capture instant the world takes a snapshot: the head's true pose then (from the head
emulator's `pose_at`), the target and the distractor on their `[sim]` trajectories, and the
truth published for that frame. The pixels are rendered from the snapshot later
(`camera_schedule`), so the snapshot holds everything the renderer needs. With a zoom lens the
head's pose carries the zoom at capture, and the frame is rendered through the lens at that
zoom (`ZoomLens.at_pose`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from gazed.config import Rig
from gazed.geometry.pose import CameraPose
from gazed.geometry.zoom import ZoomLens
from gazed.messages import FrameHeader, HeadPose, SimTruth
from gazed.sim.reach import FieldOfRegard
from gazed.sim.renderer import Body, Renderer
from gazed.sim.scenarios import Trajectory, make_trajectory


def trajectories(rig: Rig) -> tuple[Trajectory, Trajectory | None]:
    """The target's trajectory and the distractor's (None without one), from [sim]; a random
    walk keeps within the head's reach (`FieldOfRegard.for_walker`)."""
    sim = rig.sim
    base_dir = rig.source_path.parent if rig.source_path is not None else None
    reach = FieldOfRegard.for_walker(rig)

    def build(spec: str, seed: int) -> Trajectory:
        return make_trajectory(
            spec,
            seed=seed,
            speed_m_s=sim.trajectory_speed_m_s,
            scale=sim.trajectory_scale,
            centre_xy_m=sim.area_centre_xy_m,
            base_dir=base_dir,
            reach=reach,
        )

    return build(sim.trajectory, sim.seed), (
        build(sim.distractor, sim.seed + 1) if sim.distractor else None
    )


@dataclass(frozen=True)
class Scene:
    """A captured instant waiting to be rendered: the head's true pose and the bodies then."""

    t_s: float  # capture, monotonic
    header: FrameHeader
    head: HeadPose
    bodies: tuple[Body, ...]


class SimWorld:
    """The rig's simulated world; `pose_at(t_s)` is the head's true pose at monotonic `t_s`, and
    the trajectories start at monotonic `t0_s`."""

    def __init__(self, rig: Rig, pose_at: Callable[[float], HeadPose], t0_s: float) -> None:
        sim = rig.sim
        self.camera_delay_ns = round(sim.camera_delay_ms * 1e6)
        self.lens = ZoomLens.from_section(rig.camera)
        self.camera = self.lens.base
        self.renderer = Renderer(
            self.camera,
            CameraPose.from_rig(rig),
            seed=sim.seed,
            noise_std=sim.noise_std_levels,
            flicker_amplitude=sim.flicker_amplitude,
            motion_blur_exposure_s=sim.motion_blur_exposure_ms / 1000.0,
            court_m=sim.court_m,
        )
        self.target, self.distractor = trajectories(rig)
        self.pose_at = pose_at
        self.t0_s = t0_s
        self.height_m = sim.target_height_m
        self.width_m = sim.target_width_m
        self.encoding = sim.frame_encoding
        self.seq = 0

    def capture(self, t_s: float, t_capture_ns: int) -> tuple[Scene, SimTruth]:
        """The next frame's snapshot at monotonic `t_s` (its exposure, wall clock `t_capture_ns`),
        and its truth. The frame is stamped as a camera pipeline stamps it, on arrival: the
        hidden `camera_delay_ms` after the exposure; the truth keeps the exposure time."""
        world_t_s = t_s - self.t0_s
        head = self.pose_at(t_s)
        target = self.target.state(world_t_s)
        bodies = [Body(target.xy_m, self.height_m, self.width_m, texture=0)]
        if self.distractor is not None:
            other = self.distractor.state(world_t_s)
            bodies.append(Body(other.xy_m, self.height_m, self.width_m, texture=1))
        header = FrameHeader(
            t_capture_ns=t_capture_ns + self.camera_delay_ns,
            seq=self.seq,
            width=self.camera.width_px,
            height=self.camera.height_px,
            encoding=self.encoding,
        )
        truth = SimTruth(
            t_capture_ns=t_capture_ns,
            seq=self.seq,
            target_xy_m=target.xy_m,
            target_velocity_m_s=target.velocity_m_s,
            target_height_m=self.height_m,
            head=head,
        )
        self.seq += 1
        return Scene(t_s, header, head, tuple(bodies)), truth

    def render(self, scene: Scene) -> np.ndarray:
        """The pixels of a captured scene, in the frame's encoding."""
        pixels = self.renderer.render(
            scene.header.seq,
            scene.head.pan_rad,
            scene.head.tilt_rad,
            list(scene.bodies),
            t_s=scene.t_s - self.t0_s,
            pan_rate_rad_s=scene.head.pan_rate_rad_s,
            tilt_rate_rad_s=scene.head.tilt_rate_rad_s,
            camera=self.lens.at_pose(scene.head),
        )
        if scene.header.encoding == "gray8":
            pixels = cv2.cvtColor(pixels, cv2.COLOR_BGR2GRAY)
        return pixels
