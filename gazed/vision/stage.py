"""The vision process's work per frame: from a frame and the head's odometry to the messages it
yields (DESIGN §6).

Each frame taken is checked (`FrameIntake`: a frame of the wrong size, type or channel count,
or one not newer than the last one processed, is dropped and counted as `dropped:<reason>`),
given the head pose interpolated at its capture (`OdometryHistory`; a digital head's view
carries the pose it was rendered at, which is that), and then, by what the gaze
controller does (`gaze/state`):
- while it traces a ground line (`trace`): the edge under the fovea (`EdgeTracer`), nothing else;
- otherwise the detector, and the candidates unless the controller pursues or saccades: it has
  no use for them then, and the whole-frame motion energy is the most expensive part of a frame.
A detection whose result is not finite is dropped and counted; candidates and movers that are
not finite are left out. The movers' appearance is taken from the frame as captured (in colour
where it has colour), which the stage hands to the pipeline beside the grey one. With a digital
head (`watch_wide`) the movers are those of its still wide camera (`wide_movers`), seen from
the view.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from gazed.config import Rig
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.latency import LatencyWindow
from gazed.messages import (
    Candidate,
    Candidates,
    Detection,
    EdgeObservation,
    HeadPose,
    Mover,
    Odometry,
)
from gazed.vision.candidates import MotionRegion
from gazed.vision.capture_stamp import CaptureStampCorrection
from gazed.vision.detector import DetectorOutput
from gazed.vision.digital_camera import DigitalCamera
from gazed.vision.edge_trace import EdgePoint, EdgeTracer
from gazed.vision.frames import CapturedFrame, FrameError, FrameIntake
from gazed.vision.movers import MAX_MOVERS, MoverRegion
from gazed.vision.odometry_history import OdometryHistory
from gazed.vision.person_size import PersonSize
from gazed.vision.pipeline import VisionPipeline, VisionResult
from gazed.vision.wide_movers import WideMovers, target_first

CANDIDATES_UNUSED = ("pursuit", "saccade", "trace")  # gaze states that ignore candidates
TIMING_WINDOW = 100  # frames over which the stage times are reported


@dataclass(frozen=True)
class VisionOutput:
    """What one frame yields: a detection (and the motion regions its candidates are made of,
    None when they are off), or an edge, or nothing (dropped)."""

    detection: Detection | None = None
    regions: list[MotionRegion] | None = None
    edge: EdgeObservation | None = None


class VisionStage:
    """Frames -> detections, candidates or edges. `stage` is the name the messages are stamped
    with, `clock_ns` the wall clock of those stamps."""

    def __init__(
        self, rig: Rig, stage: str = "vision", clock_ns: Callable[[], int] = time.time_ns
    ) -> None:
        vision = rig.vision
        self.stage = stage
        self.clock_ns = clock_ns
        self.compensate = vision.compensate_ego_motion
        self.rig = rig
        self.lens = ZoomLens.from_section(rig.camera)
        self.camera = self.lens.base
        kinematics = HeadKinematics.from_section(rig.head)
        self.pipeline = VisionPipeline(
            self.camera, kinematics, vision, lens=self.lens, pose_noise_rad=rig.pose_noise_rad
        )
        self.history = OdometryHistory(
            vision.odometry_history_ms * 1e-3, vision.odometry_max_gap_ms * 1e-3
        )
        self.edges = EdgeTracer(
            self.camera,
            vision.fovea_rad,
            step_px=vision.edge_step_px,
            low_threshold=vision.edge_canny_low,
            high_threshold=vision.edge_canny_high,
        )
        self.intake = FrameIntake(self.camera.width_px, self.camera.height_px)
        self.capture_stamp = CaptureStampCorrection(rig.camera)
        self.gaze_state: str | None = None
        self.counters: Counter[str] = Counter()
        self.last_drop: str | None = None
        self.compensated: bool | None = None
        self.wide_movers: WideMovers | None = None
        self.detector_time = LatencyWindow(default_s=0.0, size=TIMING_WINDOW)
        self.candidates_time = LatencyWindow(default_s=0.0, size=TIMING_WINDOW)

    def watch_wide(self, camera: DigitalCamera) -> None:
        """Take the movers from a digital head's wide frames (`wide_movers`): its wide camera
        is still, so it sees every walker; they are segmented as its frames are read, judged
        against a person's size where the rig's ground geometry gives it (`person_size`)."""
        detector = self.pipeline.detector.name
        point = "ground-contact" if detector == "background" else "centroid"
        person = PersonSize.from_rig(self.rig, camera.view.wide)
        self.wide_movers = WideMovers(camera.view, self.pipeline.vision, point, person)
        camera.wide = self.wide_movers.tap(camera.wide)

    def add_odometry(self, odometry: Odometry, now_ns: int) -> None:
        """A head pose; one stamped ahead of `now_ns` is dropped and counted."""
        if self.history.add(odometry, now_ns):
            self.capture_stamp.add_odometry(odometry)
        else:
            self._drop(
                "odometry_from_the_future",
                f"odometry stamped {odometry.t_capture_ns} is ahead of now",
            )

    def process(self, frame: CapturedFrame) -> VisionOutput:
        self.counters["frames"] += 1
        try:
            gray = self.intake.take(frame)
        except FrameError as exc:
            self._drop(exc.reason, str(exc))
            return VisionOutput()
        frame = self.capture_stamp.frame(frame, gray)  # stamped at exposure, not arrival
        pose_ns = self.capture_stamp.pose_ns or frame.t_capture_ns
        head = frame.head if frame.head is not None else self.history.pose_at(pose_ns)
        if not self.capture_stamp.pose_known:  # the delay not estimated yet, the head moving
            head = None
        if self.gaze_state == "trace":  # line calibration: the edge under the fovea, nothing else
            edge = self.edges.observe(gray, self.lens.at_pose(head))
            return VisionOutput(edge=self._edge(frame, head, edge))
        wanted = self.gaze_state not in CANDIDATES_UNUSED
        result = self.pipeline.process(
            gray,
            frame.t_capture_ns,
            head,
            with_candidates=wanted,
            colour=frame.pixels,
            encoding=frame.encoding,
        )
        return self._detection(frame, head, result)

    def candidates(self, output: VisionOutput) -> Candidates | None:
        """The candidates of a frame's output, made after its detection is on its way (the
        estimator waits for the detection, nobody waits for the candidates)."""
        detection, regions = output.detection, output.regions
        if detection is None or regions is None:
            return None
        return Candidates(
            t_capture_ns=detection.t_capture_ns,
            stamps=detection.stamps,
            seq=detection.seq,
            width_px=detection.width_px,
            height_px=detection.height_px,
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
                for c in regions
                if np.all(np.isfinite((c.u_px, c.v_px, c.du_px_s, c.dv_px_s, c.energy)))
            ),
            head=detection.head,
        )

    def compensation_note(self) -> str:
        """Whether the head's rotation is removed from the frames, and if not, why."""
        if not self.compensate:
            return "off ([vision] compensate_ego_motion = false)"
        if self.compensated is None:
            return "no frame yet"
        if self.compensated:
            return "on"
        return "off (no odometry at the frames' capture times)"

    def times_ms(self) -> dict[str, float]:
        """The detector's median and longest time per frame, the candidates' median."""
        times = {}
        if self.detector_time.count:
            times["detector_median"] = self.detector_time.median_s * 1e3
            times["detector_max"] = self.detector_time.max_s * 1e3
        if self.candidates_time.count:
            times["candidates_median"] = self.candidates_time.median_s * 1e3
        return times

    def _drop(self, reason: str, message: str) -> None:
        self.counters[f"dropped:{reason}"] += 1
        self.last_drop = message

    def _edge(
        self, frame: CapturedFrame, head: HeadPose | None, edge: EdgePoint
    ) -> EdgeObservation:
        self.counters["edges_found"] += int(edge.found)
        return EdgeObservation(
            t_capture_ns=frame.t_capture_ns,
            stamps=(*frame.stamps, (self.stage, self.clock_ns())),
            seq=frame.seq,
            found=edge.found,
            u_px=edge.u_px,
            v_px=edge.v_px,
            ahead_px=edge.ahead_px,
            behind_px=edge.behind_px,
            turn_rad=edge.turn_rad,
            head=head,
        )

    def _movers(
        self, frame: CapturedFrame, head: HeadPose | None, out: DetectorOutput
    ) -> tuple[MoverRegion, ...]:
        """The detector's movers, or a digital head's wide movers with the target's first (the
        detector's own are not added to those: `gazed.vision.wide_movers`)."""
        movers = out.movers if out.found else ()
        if self.wide_movers is None or head is None:
            return movers
        wide = self.wide_movers.in_view(frame.seq, head)
        if wide is None:
            return movers
        target = (out.u_px, out.v_px) if out.found else None
        return target_first(target, wide)

    def _detection(
        self, frame: CapturedFrame, head: HeadPose | None, result: VisionResult
    ) -> VisionOutput:
        out = result.output
        values = (out.u_px, out.v_px, out.du_px_s, out.dv_px_s, out.area_px, out.confidence)
        if out.found and not np.all(np.isfinite(values)):
            self._drop("nonfinite", f"frame {frame.seq}: the detector's result is not finite")
            return VisionOutput()
        self.compensated = result.compensated
        self.detector_time.add(out.processing_ms * 1e-3)
        stamps = (*frame.stamps, (self.stage, self.clock_ns()))
        self.counters["found"] += int(out.found)
        detection = Detection(
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
            delay_ms=self.capture_stamp.applied_ms,
            movers=tuple(mover_message(m) for m in self._movers(frame, head, out) if _finite(m))[
                :MAX_MOVERS
            ],
        )
        if result.candidates is not None:
            self.candidates_time.add(result.candidates_ms * 1e-3)
        return VisionOutput(detection, result.candidates)


def _finite(mover: MoverRegion) -> bool:
    values = (mover.u_px, mover.v_px, mover.du_px_s, mover.dv_px_s, *mover.box, mover.area_px)
    return bool(np.all(np.isfinite(values)))


def mover_message(mover: MoverRegion) -> Mover:
    """A mover as `Detection.movers` carries it."""
    return Mover(
        u_px=mover.u_px,
        v_px=mover.v_px,
        du_px_s=mover.du_px_s,
        dv_px_s=mover.dv_px_s,
        velocity_known=mover.velocity_known,
        box_width_px=mover.box[2],
        box_height_px=mover.box[3],
        area_px=mover.area_px,
        confidence=min(max(mover.confidence, 0.0), 1.0),
        appearance=mover.appearance,
    )
