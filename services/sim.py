"""The `sim` process: the simulated world (DESIGN §9).

Inputs: the serial bytes the `servo` process writes to the emulated head's pty (the rig's
`[servo] port` is a symlink to it; the head answers in the rig's protocol,
`gazed.sim.head_emulator`).
Outputs: `sim/frame` (what the camera sees, stamped on arrival `[sim] camera_delay_ms` after
its exposure, a delay gazed is not told, and published `[sim] visual_latency_ms` after that) and
`sim/truth` (the target's ground position and velocity, its height, the true head pose, at the
exposure of every frame, published at once).
Settings: [camera] size, intrinsics and rate; [head] kinematics and limits (the emulated axes);
[servo] protocol and port; [sim] seed, trajectory and its speed/scale/centre, target size,
frame encoding, distractor, the true camera pose, latency and hidden camera delay, noise, flicker,
blur, the court (ground lines to trace), and the emulated head's keys.

The world's snapshots and pixels are `gazed.sim.world`; when frames are captured, rendered and
published is `gazed.sim.camera_schedule`.
"""

from __future__ import annotations

import time

import numpy as np

from gazed.bus import Bus
from gazed.config import Rig
from gazed.messages import FrameHeader
from gazed.sim.camera_schedule import CameraSchedule, lower_render_priority
from gazed.sim.head_emulator import HeadEmulator
from gazed.sim.head_onvif import OnvifEmulator, head_emulator
from gazed.sim.world import Scene, SimWorld
from gazed.topics import SIM_FRAME, SIM_TRUTH
from services.runtime import HealthReport, Now, main

STAGE = "sim"


class SimService:
    def __init__(
        self, rig: Rig, bus: Bus, emulator: HeadEmulator | OnvifEmulator | None = None
    ) -> None:
        self.rig = rig
        self.emulator = emulator if emulator is not None else head_emulator(rig)
        if emulator is None:
            self.emulator.open()
            self.emulator.start()
        self.frames = bus.publisher(SIM_FRAME)
        self.truth = bus.publisher(SIM_TRUTH)
        t0_s = time.monotonic()
        self.world = SimWorld(rig, self.emulator.pose_at, t0_s)
        self.schedule: CameraSchedule[Scene, tuple[FrameHeader, np.ndarray]] = CameraSchedule(
            rig.camera.frame_period_s,
            (rig.sim.camera_delay_ms + rig.sim.visual_latency_ms) / 1000.0,
            t0_s,
        )
        self.published = 0
        self.render_ms = 0.0

    def step(self, now: Now) -> float:
        for t_s in self.schedule.captures_due(now.mono_s):
            t_capture_ns = now.wall_ns - round((now.mono_s - t_s) * 1e9)
            scene, truth = self.world.capture(t_s, t_capture_ns)
            self.schedule.captured(t_s, scene)
            self.truth.put(truth.stamped(STAGE, t_capture_ns))
        while (scene := self.schedule.next_render()) is not None:
            started = time.perf_counter()
            pixels = self.world.render(scene)
            self.render_ms = (time.perf_counter() - started) * 1e3
            self.schedule.rendered(scene.t_s, (scene.header, pixels))
        while (frame := self.schedule.next_publish()) is not None:
            header, pixels = frame
            self.frames.put_frame(header.stamped(STAGE), pixels)
            self.published += 1
        return self.schedule.wait_s()

    def health(self) -> HealthReport:
        return HealthReport(
            counters={"frames": self.published, "skipped": self.schedule.skipped},
            stage_ms={"render": round(self.render_ms, 3)},
            notes={"trajectory": self.rig.sim.trajectory, "serial": str(self.emulator.link_path)},
        )

    def close(self) -> None:
        self.emulator.close()


def build(rig: Rig, bus: Bus) -> SimService:
    service = SimService(rig, bus)
    lower_render_priority()  # this thread renders; the emulated head's, started above, does not
    return service


if __name__ == "__main__":
    raise SystemExit(main("sim", build))
