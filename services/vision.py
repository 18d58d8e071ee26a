"""The vision process: frames -> detector -> `vision/detection` and `vision/candidates`.

Inputs:  frames from the rig's `[camera] source` — the simulator's `sim/frame` for 'sim', else
         OpenCV (device index, file, RTSP/HTTP URL) —, `servo/odometry` and `gaze/state`.
Outputs: `vision/detection` for every frame processed, found or not, with the head pose
         interpolated at capture time and `compensated` telling whether the head's rotation
         was removed; `vision/candidates` (when `[vision] candidates`, and not while `gaze/state`
         says the controller pursues, saccades or traces: it has no use for them then, and the
         whole-frame motion energy is the most expensive part of a frame); while it traces a
         ground line (`trace`), `vision/edge` instead: the edge under the fovea.
Settings: [camera] (source, size, intrinsics, reopen_max_s, timeout_ms), [head] kinematics,
         [vision] (detector and its thresholds, odometry interpolation).

It runs at the camera's rate: each step takes the newest frame (older ones are skipped, never
queued; a frame older than the last one processed is dropped as stale). A frame of the wrong
size, type or channel count is dropped and counted (`dropped:<reason>`); so is one whose result
is not finite. Health carries the source's link state and the last error, whether compensation
is on, and the detector's time per frame.
"""

from __future__ import annotations

import time
from collections import Counter, deque

import numpy as np

from gazed.bus import Bus
from gazed.config import Rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import Candidate, Candidates, Detection, EdgeObservation, HeadPose
from gazed.topics import (
    GAZE_STATE,
    SERVO_ODOMETRY,
    VISION_CANDIDATES,
    VISION_DETECTION,
    VISION_EDGE,
)
from gazed.vision.bus_frames import BusFrameSource
from gazed.vision.edge_trace import EdgePoint, EdgeTracer
from gazed.vision.frames import CapturedFrame, FrameError, gray_frame
from gazed.vision.odometry_history import OdometryHistory
from gazed.vision.opencv_camera import OpenCvCamera, capture_target
from gazed.vision.pipeline import VisionPipeline, VisionResult
from gazed.vision.source import FrameSource
from services.runtime import HealthReport, Now, main

IDLE_WAIT_S = 1.0  # no frame: sleep until one arrives (sources wake the loop) or this long
TIMING_WINDOW = 100  # frames over which health reports the stage times
CANDIDATES_UNUSED = ("pursuit", "saccade", "trace")  # gaze states that ignore candidates


def open_source(rig: Rig, bus: Bus) -> FrameSource:
    """The rig's camera: the simulator's frames on the bus, or an OpenCV capture."""
    camera = rig.camera
    if camera.source == "sim":
        return BusFrameSource(bus, silence_s=camera.timeout_ms * 1e-3)
    return OpenCvCamera(
        capture_target(camera.source),
        width_px=camera.width_px,
        height_px=camera.height_px,
        rate_hz=camera.rate_hz,
        reopen_max_s=camera.reopen_max_s,
        timeout_ms=camera.timeout_ms,
        on_frame=bus.notify,
    )


class VisionService:
    def __init__(self, rig: Rig, bus: Bus, source: FrameSource | None = None) -> None:
        self.rig = rig
        vision = rig.vision
        self.camera = CameraModel.from_section(rig.camera)
        self.pipeline = VisionPipeline(self.camera, HeadKinematics.from_section(rig.head), vision)
        self.history = OdometryHistory(
            vision.odometry_history_ms * 1e-3, vision.odometry_max_gap_ms * 1e-3
        )
        self.odometry = bus.subscribe(SERVO_ODOMETRY)
        self.gaze_states = bus.subscribe(GAZE_STATE, capacity=8)
        self.gaze_state: str | None = None
        self.edges = EdgeTracer(
            self.camera,
            vision.fovea_rad,
            step_px=vision.edge_step_px,
            low_threshold=vision.edge_canny_low,
            high_threshold=vision.edge_canny_high,
        )
        self.edge_publisher = bus.publisher(VISION_EDGE)
        self.detections = bus.publisher(VISION_DETECTION)
        self.candidates = bus.publisher(VISION_CANDIDATES) if vision.candidates else None
        self.source = source if source is not None else open_source(rig, bus)
        self.source.connect()
        self.counters: Counter[str] = Counter()
        self.last_drop: str | None = None
        self._last_t_ns: int | None = None
        self._compensated: bool | None = None
        self._detector_ms: deque[float] = deque(maxlen=TIMING_WINDOW)
        self._candidates_ms: deque[float] = deque(maxlen=TIMING_WINDOW)

    def step(self, now: Now) -> float:
        for odometry in self.odometry.take():
            if not self.history.add(odometry, now.wall_ns):
                self._drop(
                    "odometry_from_the_future",
                    f"odometry stamped {odometry.t_capture_ns} is ahead of now",
                )
        for state in self.gaze_states.take():
            self.gaze_state = state.state
        frame = self.source.read()
        if frame is None:
            return IDLE_WAIT_S
        self.counters["frames"] += 1
        if self._last_t_ns is not None and frame.t_capture_ns <= self._last_t_ns:
            self._drop("stale", f"frame {frame.seq} is not newer than the last one processed")
            return 0.0
        try:
            gray = gray_frame(frame, self.camera.width_px, self.camera.height_px)
        except FrameError as exc:
            self._drop(exc.reason, str(exc))
            return 0.0
        self._last_t_ns = frame.t_capture_ns
        head = self.history.pose_at(frame.t_capture_ns)
        if self.gaze_state == "trace":  # line calibration: the edge under the fovea, nothing else
            self._publish_edge(frame, head, self.edges.observe(gray))
            return 0.0
        wanted = self.gaze_state not in CANDIDATES_UNUSED
        result = self.pipeline.process(gray, frame.t_capture_ns, head, with_candidates=wanted)
        self._publish(frame, head, result)
        return 0.0

    def _publish_edge(self, frame: CapturedFrame, head: HeadPose | None, edge: EdgePoint) -> None:
        self.counters["edges_found"] += int(edge.found)
        self.edge_publisher.put(
            EdgeObservation(
                t_capture_ns=frame.t_capture_ns,
                stamps=(*frame.stamps, ("vision", time.time_ns())),
                seq=frame.seq,
                found=edge.found,
                u_px=edge.u_px,
                v_px=edge.v_px,
                ahead_px=edge.ahead_px,
                behind_px=edge.behind_px,
                turn_rad=edge.turn_rad,
                head=head,
            )
        )

    def _drop(self, reason: str, message: str) -> None:
        self.counters[f"dropped:{reason}"] += 1
        self.last_drop = message

    def _publish(self, frame: CapturedFrame, head: HeadPose | None, result: VisionResult) -> None:
        out = result.output
        values = (out.u_px, out.v_px, out.du_px_s, out.dv_px_s, out.area_px, out.confidence)
        if out.found and not np.all(np.isfinite(values)):
            self._drop("nonfinite", f"frame {frame.seq}: the detector's result is not finite")
            return
        self._compensated = result.compensated
        self._detector_ms.append(out.processing_ms)
        stamps = (*frame.stamps, ("vision", time.time_ns()))
        self.counters["found"] += int(out.found)
        self.detections.put(
            Detection(
                t_capture_ns=frame.t_capture_ns,
                stamps=stamps,
                seq=frame.seq,
                detector=self.pipeline.detector.name,
                found=out.found,
                u_px=out.u_px if out.found else 0.0,
                v_px=out.v_px if out.found else 0.0,
                du_px_s=out.du_px_s if out.found else 0.0,
                dv_px_s=out.dv_px_s if out.found else 0.0,
                area_px=out.area_px if out.found else 0.0,
                confidence=min(max(out.confidence, 0.0), 1.0) if out.found else 0.0,
                point=out.point,
                compensated=result.compensated,
                width_px=self.camera.width_px,
                height_px=self.camera.height_px,
                processing_ms=out.processing_ms,
                head=head,
            )
        )
        if self.candidates is None or result.candidates is None:
            return
        self._candidates_ms.append(result.candidates_ms)
        self.candidates.put(
            Candidates(
                t_capture_ns=frame.t_capture_ns,
                stamps=stamps,
                seq=frame.seq,
                width_px=self.camera.width_px,
                height_px=self.camera.height_px,
                candidates=tuple(
                    Candidate(
                        u_px=c.u_px,
                        v_px=c.v_px,
                        du_px_s=c.du_px_s,
                        dv_px_s=c.dv_px_s,
                        area_px=c.area_px,
                        energy=c.energy,
                        score=c.score,
                    )
                    for c in result.candidates
                    if np.all(np.isfinite((c.u_px, c.v_px, c.du_px_s, c.dv_px_s, c.energy)))
                ),
                head=head,
            )
        )

    def health(self) -> HealthReport:
        status = self.source.status()
        counters = dict(self.counters)
        counters["source_reopens"] = status.reopens
        counters["source_frames"] = status.frames
        counters["detector_restarts"] = self.pipeline.restarts
        notes = {
            "detector": self.pipeline.detector.name,
            "source": f"{self.rig.camera.source} ({status.link})",
            "compensation": self._compensation_note(),
        }
        if status.last_error:
            notes["source_error"] = status.last_error
        if self.last_drop:
            notes["last_drop"] = self.last_drop
        stage_ms = {}
        if self._detector_ms:
            stage_ms["detector_median"] = float(np.median(self._detector_ms))
            stage_ms["detector_max"] = float(np.max(self._detector_ms))
        if self._candidates_ms:
            stage_ms["candidates_median"] = float(np.median(self._candidates_ms))
        return HealthReport(counters=counters, stage_ms=stage_ms, notes=notes)

    def _compensation_note(self) -> str:
        if not self.rig.vision.compensate_ego_motion:
            return "off ([vision] compensate_ego_motion = false)"
        if self._compensated is None:
            return "no frame yet"
        if self._compensated:
            return "on"
        return "off (no odometry at the frames' capture times)"

    def close(self) -> None:
        self.source.disconnect()


def build(rig: Rig, bus: Bus) -> VisionService:
    return VisionService(rig, bus)


if __name__ == "__main__":
    raise SystemExit(main("vision", build))
