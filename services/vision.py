"""The vision process: frames -> detector -> `vision/detection` and `vision/candidates`.
The work per frame is `gazed.vision.stage`.

Inputs:  frames from the rig's `[camera] source` — the simulator's `sim/frame` for 'sim', else
         OpenCV (device index, file, RTSP/HTTP URL); with a digital head (`[servo] protocol =
         "digital"`) the views rendered from `[wide]`'s frames, also served as MJPEG on
         `[wide] stream_host:stream_port` —, `servo/odometry` and `gaze/state`.
Outputs: `vision/detection` for every frame processed, found or not, with the head pose
         interpolated at capture time, `compensated` telling whether the head's rotation
         was removed, and the movers (a digital head's: every mover its still wide camera
         segments); `vision/candidates` (when `[vision] candidates`, and not while
         `gaze/state` says the controller pursues, saccades or traces); while it traces a ground
         line (`trace`), `vision/edge` instead: the edge under the fovea.
Settings: [camera] (source, size, intrinsics, reopen_max_s, timeout_ms, delay_ms,
         delay_estimate), [head] kinematics,
         [servo] protocol, [wide] (the digital head's wide camera and stream),
         [vision] (detector and its thresholds, odometry interpolation).

It runs at the camera's rate: each step takes the newest frame (older ones are skipped, never
queued). Frames that cannot be used are dropped and counted (`dropped:<reason>`). Health
carries the source's link state and the last error, whether compensation is on, the
detector's time per frame, and the camera delay taken off the capture stamps
(`gazed.vision.capture_stamp`).
"""

from __future__ import annotations

from gazed.bus import Bus
from gazed.config import Rig, exit_if_cannot_start
from gazed.topics import (
    GAZE_STATE,
    SERVO_ODOMETRY,
    VISION_CANDIDATES,
    VISION_DETECTION,
    VISION_EDGE,
)
from gazed.vision.digital_camera import DigitalCamera, open_digital_camera
from gazed.vision.mjpeg import MjpegServer
from gazed.vision.rig_camera import rig_camera
from gazed.vision.source import FrameSource
from gazed.vision.stage import VisionStage
from services.runtime import HealthReport, Now, main

STAGE = "vision"
IDLE_WAIT_S = 1.0  # no frame: sleep until one arrives (sources wake the loop) or this long


def open_source(rig: Rig, bus: Bus, stage: VisionStage, stream: MjpegServer | None) -> FrameSource:
    """The rig's camera: a digital head's view of the wide camera, the simulator's frames on
    the bus, or an OpenCV capture."""
    if rig.servo.protocol == "digital":
        digital = open_digital_camera(
            rig,
            stage.history.pose_at,
            on_frame=bus.notify,
            on_view=stream.publish if stream is not None else None,
        )
        stage.watch_wide(digital)
        return digital
    return rig_camera(rig, bus)


class VisionService:
    def __init__(self, rig: Rig, bus: Bus, source: FrameSource | None = None) -> None:
        self.rig = rig
        self.stage = VisionStage(rig, STAGE)
        self.odometry = bus.subscribe(SERVO_ODOMETRY)
        self.gaze_states = bus.subscribe(GAZE_STATE, capacity=8)
        self.edges = bus.publisher(VISION_EDGE)
        self.detections = bus.publisher(VISION_DETECTION)
        self.candidates = bus.publisher(VISION_CANDIDATES) if rig.vision.candidates else None
        self.stream = open_stream(rig)
        self.source = (
            source if source is not None else open_source(rig, bus, self.stage, self.stream)
        )
        self.source.connect()
        digital = rig.servo.protocol == "digital"
        self.source_name = f"wide {rig.wide_source}" if digital else rig.camera.source

    def step(self, now: Now) -> float:
        for odometry in self.odometry.take():
            self.stage.add_odometry(odometry, now.wall_ns)
        for state in self.gaze_states.take():
            self.stage.gaze_state = state.state
        frame = self.source.read()
        if frame is None:
            due_s = self.source.due_in_s()
            return IDLE_WAIT_S if due_s is None else min(IDLE_WAIT_S, due_s)
        output = self.stage.process(frame)
        if output.edge is not None:
            self.edges.put(output.edge)
        if output.detection is not None:
            self.detections.put(output.detection)
            candidates = self.stage.candidates(output) if self.candidates is not None else None
            if candidates is not None:
                self.candidates.put(candidates)
        return 0.0

    def health(self) -> HealthReport:
        status = self.source.status()
        counters = dict(self.stage.counters)
        counters["source_reopens"] = status.reopens
        counters["source_frames"] = status.frames
        counters["detector_restarts"] = self.stage.pipeline.restarts
        if isinstance(self.source, DigitalCamera):
            counters.update(self.source.counters)
        notes = {
            "detector": self.stage.pipeline.detector.name,
            "source": f"{self.source_name} ({status.link})",
            "compensation": self.stage.compensation_note(),
            "camera_delay": self.stage.capture_stamp.note(),
        }
        if status.last_error:
            notes["source_error"] = status.last_error
        if self.stream is not None:
            notes["stream"] = self.stream.url
        if self.stage.last_drop:
            notes["last_drop"] = self.stage.last_drop
        stage_ms = {**self.stage.times_ms(), **self.stage.capture_stamp.stage_ms()}
        return HealthReport(counters=counters, stage_ms=stage_ms, notes=notes)

    def close(self) -> None:
        self.source.disconnect()
        if self.stream is not None:
            self.stream.stop()


def open_stream(rig: Rig) -> MjpegServer | None:
    """The MJPEG stream of a digital head's view, where the rig gives it a port."""
    if rig.servo.protocol != "digital" or rig.wide.stream_port is None:
        return None
    stream = MjpegServer(rig.wide.stream_port, rig.wide.stream_host)
    stream.start()
    return stream


def build(rig: Rig, bus: Bus) -> VisionService:
    exit_if_cannot_start(rig)
    return VisionService(rig, bus)


if __name__ == "__main__":
    raise SystemExit(main("vision", build))
