"""The `sim` process: the simulated world (DESIGN §9).

Inputs: the serial bytes the `servo` process writes to the emulated head's pty (the rig's
`[servo] port` is a symlink to it; the head answers in the rig's protocol).
Outputs: `sim/frame` (what the camera sees, published `[sim] visual_latency_ms` after capture
but stamped with the true capture time) and `sim/truth` (the target's ground position and
velocity, its height, the true head pose, at the capture time of every frame, published at once).
Settings: [camera] size, intrinsics and rate; [head] kinematics and limits (the emulated axes);
[servo] protocol and port; [sim] seed, trajectory and its speed/scale/centre, target size,
frame encoding,
distractor, the true camera pose, latency, noise, flicker, blur, the court (ground lines to
trace), and the emulated head's keys.

Frames are captured at their instants on the camera's clock: the head's true pose at that
instant (`HeadEmulator.pose_at`) and the targets' states are taken then, and the truth is
published then; a capture that falls more than a frame behind (an overloaded machine) is
skipped and counted, never queued. The pixels are rendered from that snapshot half a frame
before the frame is due on the bus, not at capture: with the visual latency not a whole number
of frames, rendering at capture put the simulator's busiest 2 ms on a core while the loop
worked on the frame published just before. For the same reason the renderer's thread runs at
a lower priority (`SIM_NICENESS`): the world is a test harness, and on a real rig the loop has
the machine to itself. The emulated head's thread keeps the normal priority: it is the head the
servo talks to, part of the loop.
"""

from __future__ import annotations

import os
import threading
import time
from collections import deque
from dataclasses import dataclass

import cv2
import numpy as np

from gazed.bus import Bus
from gazed.config import Rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.pose import CameraPose
from gazed.messages import FrameHeader, HeadPose, SimTruth
from gazed.sim.head_emulator import HeadEmulator
from gazed.sim.renderer import Body, Renderer
from gazed.sim.trajectories import Trajectory, make_trajectory
from gazed.topics import SIM_FRAME, SIM_TRUTH
from services.runtime import HealthReport, Now, main

STAGE = "sim"
SIM_NICENESS = 10  # added to the renderer thread's nice value (lower priority than the loop's)


@dataclass(frozen=True)
class Scene:
    """A captured instant waiting to be rendered: the head's true pose and the bodies then."""

    render_at_s: float
    t_s: float  # capture, monotonic
    header: FrameHeader
    head: HeadPose
    bodies: tuple[Body, ...]


@dataclass(frozen=True)
class Pending:
    """A rendered frame waiting out the rest of the visual latency."""

    publish_at_s: float
    header: FrameHeader
    pixels: np.ndarray


def trajectories(rig: Rig) -> tuple[Trajectory, Trajectory | None]:
    """The target's trajectory and the distractor's (None without one), from [sim]."""
    sim = rig.sim
    base_dir = rig.source_path.parent if rig.source_path is not None else None

    def build(spec: str, seed: int) -> Trajectory:
        return make_trajectory(
            spec,
            seed=seed,
            speed_m_s=sim.trajectory_speed_m_s,
            scale=sim.trajectory_scale,
            centre_xy_m=sim.area_centre_xy_m,
            base_dir=base_dir,
        )

    return build(sim.trajectory, sim.seed), (
        build(sim.distractor, sim.seed + 1) if sim.distractor else None
    )


class SimService:
    def __init__(self, rig: Rig, bus: Bus, emulator: HeadEmulator | None = None) -> None:
        self.rig = rig
        sim = rig.sim
        self.camera = CameraModel.from_section(rig.camera)
        self.pose = CameraPose.from_rig(rig)
        self.renderer = Renderer(
            self.camera,
            self.pose,
            seed=sim.seed,
            noise_std=sim.noise_std_levels,
            flicker_amplitude=sim.flicker_amplitude,
            motion_blur_exposure_s=sim.motion_blur_exposure_ms / 1000.0,
            court_m=sim.court_m,
        )
        self.target, self.distractor = trajectories(rig)
        self.emulator = emulator if emulator is not None else HeadEmulator(rig)
        if emulator is None:
            self.emulator.open()
            self.emulator.start()
        self.frames = bus.publisher(SIM_FRAME)
        self.truth = bus.publisher(SIM_TRUTH)
        self.period_s = rig.camera.frame_period_s
        self.latency_s = sim.visual_latency_ms / 1000.0
        self.t0_s = time.monotonic()
        self.next_capture_s = self.t0_s
        self.seq = 0
        # a frame is rendered this long before it is due on the bus
        self.render_lead_s = min(self.latency_s, 0.5 * self.period_s)
        self.scenes: deque[Scene] = deque()
        self.pending: deque[Pending] = deque()
        self.counts = {"frames": 0, "skipped": 0}
        self.render_ms = 0.0

    def step(self, now: Now) -> float:
        if now.mono_s - self.next_capture_s > self.period_s:  # fell behind: skip, never queue
            missed = int((now.mono_s - self.next_capture_s) / self.period_s)
            self.counts["skipped"] += missed
            self.next_capture_s += missed * self.period_s
        while now.mono_s >= self.next_capture_s:
            self._capture(self.next_capture_s, now)
            self.next_capture_s += self.period_s
        while self.scenes and self.scenes[0].render_at_s <= time.monotonic():
            self._render(self.scenes.popleft())
        while self.pending and self.pending[0].publish_at_s <= time.monotonic():
            frame = self.pending.popleft()
            self.frames.put_frame(frame.header.stamped(STAGE), frame.pixels)
            self.counts["frames"] += 1
        wake = [self.next_capture_s]
        wake += [self.scenes[0].render_at_s] if self.scenes else []
        wake += [self.pending[0].publish_at_s] if self.pending else []
        return max(0.0, min(wake) - time.monotonic())

    def _capture(self, t_s: float, now: Now) -> None:
        """The scene whose light hits the sensor at monotonic `t_s`, kept for rendering; its
        truth published at once."""
        world_t_s = t_s - self.t0_s
        t_capture_ns = now.wall_ns - round((now.mono_s - t_s) * 1e9)
        head = self.emulator.pose_at(t_s)
        target = self.target.state(world_t_s)
        bodies = [
            Body(target.xy_m, self.rig.sim.target_height_m, self.rig.sim.target_width_m, texture=0)
        ]
        if self.distractor is not None:
            other = self.distractor.state(world_t_s)
            bodies.append(
                Body(
                    other.xy_m, self.rig.sim.target_height_m, self.rig.sim.target_width_m, texture=1
                )
            )
        header = FrameHeader(
            t_capture_ns=t_capture_ns,
            seq=self.seq,
            width=self.camera.width_px,
            height=self.camera.height_px,
            encoding=self.rig.sim.frame_encoding,
        )
        render_at_s = t_s + self.latency_s - self.render_lead_s
        self.scenes.append(Scene(render_at_s, t_s, header, head, tuple(bodies)))
        self.truth.put(
            SimTruth(
                t_capture_ns=t_capture_ns,
                seq=self.seq,
                target_xy_m=target.xy_m,
                target_velocity_m_s=target.velocity_m_s,
                target_height_m=self.rig.sim.target_height_m,
                head=head,
            ).stamped(STAGE, t_capture_ns)
        )
        self.seq += 1

    def _render(self, scene: Scene) -> None:
        """The pixels of a captured scene, queued until the visual latency has passed."""
        started = time.perf_counter()
        pixels = self.renderer.render(
            scene.header.seq,
            scene.head.pan_rad,
            scene.head.tilt_rad,
            list(scene.bodies),
            t_s=scene.t_s - self.t0_s,
            pan_rate_rad_s=scene.head.pan_rate_rad_s,
            tilt_rate_rad_s=scene.head.tilt_rate_rad_s,
        )
        if scene.header.encoding == "gray8":
            pixels = cv2.cvtColor(pixels, cv2.COLOR_BGR2GRAY)
        self.render_ms = (time.perf_counter() - started) * 1e3
        self.pending.append(Pending(scene.t_s + self.latency_s, scene.header, pixels))

    def health(self) -> HealthReport:
        return HealthReport(
            counters=dict(self.counts),
            stage_ms={"render": round(self.render_ms, 3)},
            notes={"trajectory": self.rig.sim.trajectory, "serial": str(self.emulator.link_path)},
        )

    def close(self) -> None:
        self.emulator.close()


def build(rig: Rig, bus: Bus) -> SimService:
    service = SimService(rig, bus)
    # the renderer's thread (this one) yields to the loop; the emulated head answers the servo
    # from its own thread, started above, which keeps its priority (Linux sets nice per thread)
    me = threading.get_native_id()
    os.setpriority(os.PRIO_PROCESS, me, os.getpriority(os.PRIO_PROCESS, me) + SIM_NICENESS)
    return service


if __name__ == "__main__":
    raise SystemExit(main("sim", build))
