"""A calibration's hold on a running rig: the bus, the camera's frames, the odometry, and the
head driven by `gaze/demand` demands to the servo process.

The rig runs with its gaze process off (`[services.gaze] enabled = false`: it would fight for
the head); the session refuses to drive the head while another process sends demands. The
frames are the simulator's `sim/frame`, or the rig's `[camera] source` opened a second time (an
RTSP stream takes a second client; a local device must be freed by stopping the vision
process).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator

from gazed.bus import Bus
from gazed.bustools.tool_session import NoRunningRig, tool_session
from gazed.config import Rig
from gazed.messages import GazeDemand, Odometry
from gazed.topics import GAZE_DEMAND, SERVO_ODOMETRY
from gazed.vision.frames import CapturedFrame
from gazed.vision.rig_camera import rig_camera
from gazed.vision.source import FrameSource
from gazed.wakeup import Wakeup

START_WAIT_S = 10.0  # for the first odometry
QUIET_S = 1.0  # listened to before driving: nobody else may drive the head
DEMAND_PERIOD_S = 0.02  # well within the servo's command timeout
POLL_S = 0.005  # between looks at the frames and odometry: well under a frame period


class CalibrationError(RuntimeError):
    """The measurement cannot be made; the message says why."""


@contextlib.contextmanager
def head_session(rig: Rig) -> Iterator[HeadSession]:
    """A session on the running rig's bus and camera for the `with` block."""
    try:
        with tool_session(rig, "calibrate") as (bus, wakeup):
            frames = rig_camera(rig, bus)
            frames.connect()
            try:
                yield HeadSession(rig, bus, wakeup, frames)
            finally:
                frames.disconnect()
    except NoRunningRig as exc:
        raise CalibrationError(str(exc)) from exc


class HeadSession:
    """Sends demands and collects the odometry and every frame meanwhile."""

    def __init__(self, rig: Rig, bus: Bus, wakeup: Wakeup, frames: FrameSource) -> None:
        self.rig = rig
        self.wakeup = wakeup
        self.frames = frames
        self.odometry_sub = bus.subscribe(SERVO_ODOMETRY, capacity=10_000, immediate=True)
        self.others = bus.subscribe(GAZE_DEMAND, capacity=100)
        self.demands = bus.publisher(GAZE_DEMAND)
        self.odometry: list[Odometry] = []
        self.frames_seen = 0

    def start(self, on_frame: Callable[[CapturedFrame], None]) -> Odometry:
        """The head's pose once it reports one, after listening `QUIET_S` for anyone else
        driving it, and once a frame has come (a rig just started may take a while)."""
        deadline = time.monotonic() + START_WAIT_S
        while not self.odometry:
            if time.monotonic() > deadline:
                raise CalibrationError(
                    f"rig '{self.rig.name}': no {SERVO_ODOMETRY.suffix} (is the servo process up?)"
                )
            self.wakeup.wait(0.1)
            self.odometry.extend(self.odometry_sub.take())
        self.others.take()
        self.pump(QUIET_S, None, on_frame)
        if self.others.take():
            raise CalibrationError(
                "another process drives the head (gaze/demand): turn the gaze process off "
                "([services.gaze] enabled = false) and restart the rig"
            )
        if not self.frames_seen and not self.pump(
            START_WAIT_S, None, on_frame, lambda: self.frames_seen > 0
        ):
            raise CalibrationError(f"no frames from the camera ({self.rig.camera.source})")
        return self.odometry[-1]

    def pump(
        self,
        duration_s: float,
        demand: GazeDemand | None,
        on_frame: Callable[[CapturedFrame], None],
        done: Callable[[], bool] = lambda: False,
    ) -> bool:
        """For `duration_s` or until `done()`: the demand repeated (restamped), the odometry
        and every frame taken. Whether `done()` ended it."""
        end_s = time.monotonic() + duration_s
        next_demand_s = 0.0
        while (now_s := time.monotonic()) < end_s:
            if demand is not None and now_s >= next_demand_s:
                self.demands.put(demand.model_copy(update={"t_capture_ns": time.time_ns()}))
                next_demand_s = now_s + DEMAND_PERIOD_S
            self.odometry.extend(self.odometry_sub.take())
            if (frame := self.frames.read()) is not None:
                self.frames_seen += 1
                on_frame(frame)
            if done():
                return True
            self.wakeup.wait(POLL_S)
        return False


def position_demand(pan_rad: float, tilt_rad: float, zoom: float | None = None) -> GazeDemand:
    return GazeDemand(
        t_capture_ns=time.time_ns(), kind="position", pan_rad=pan_rad, tilt_rad=tilt_rad, zoom=zoom
    )
