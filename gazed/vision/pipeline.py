"""One frame through the vision stage: pose at capture, ego-motion, detector, candidates.

Shared by the `vision` process and `gazed detect`. The caller gives a grey frame, its capture
time and the head pose at that time (None without odometry); the pipeline pairs it with the
previous frame, works out the head's rotation between the two (or an identity step when
compensation is off: no pose for either frame, or `[vision] compensate_ego_motion = false`),
computes the motion-energy pyramid once if the detector or the candidates need it, and runs
both. Frames out of time order or further apart than `frame_gap_max_ms` restart the detectors.
With a zoom `lens`, each frame's camera is the lens at the zoom of its pose (`ego_motion`).
A camera with lens distortion has its frames remapped to the ideal pinhole first and the results
mapped back to its own pixels (see `undistort`). The movers' appearance is the colour histogram
of each one's box (`appearance`) in the frame as captured, which the caller passes beside the
grey one: vision converts to grey on intake, and only the boxes are looked at in colour.
"""

from __future__ import annotations

import dataclasses
import time
from collections import deque
from dataclasses import dataclass

import numpy as np

from gazed.config import VisionSection
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import HeadPose
from gazed.vision.appearance import colour_histogram
from gazed.vision.background import BackgroundDetector
from gazed.vision.candidates import CandidateFinder, MotionRegion
from gazed.vision.detector import BASELINE_FRAMES, Detector, DetectorOutput, FramePair
from gazed.vision.ego_motion import EgoMotion
from gazed.vision.motion_energy import MotionEnergy
from gazed.vision.movers import MoverRegion
from gazed.vision.normal_flow import NormalFlowDetector
from gazed.vision.pyramid_search import PyramidDetector
from gazed.vision.undistort import Undistortion


def make_detector(
    name: str, vision: VisionSection, camera: CameraModel, pose_noise_rad: float = 0.0
) -> Detector:
    """The detector `name` ('flow', 'pyramid', 'background') with the rig's settings
    (`pose_noise_rad`: the std of the head pose, `Rig.pose_noise_rad`)."""
    if name == "flow":
        return NormalFlowDetector(
            camera,
            pose_noise_rad=pose_noise_rad,
            fovea_rad=vision.fovea_rad,
            noise_px=vision.flow_noise_px,
            min_gradient=vision.flow_min_gradient,
            min_area_px=vision.flow_min_area_px,
        )
    if name == "pyramid":
        return PyramidDetector(
            vision.pyramid_search,
            window_px=vision.pyramid_window_px,
            energy_threshold=vision.energy_threshold,
            fill_fraction=vision.pyramid_fill_fraction,
        )
    if name == "background":
        return BackgroundDetector(
            level=vision.background_level,
            history_frames=vision.background_history_frames,
            threshold=vision.background_threshold,
            min_area_px=vision.background_min_area_px,
            learning_frames=vision.background_learning_frames,
            still_px=vision.background_still_px,
            ghosts=vision.background_ghosts,
        )
    raise ValueError(f"unknown detector {name!r} (expected flow, pyramid or background)")


@dataclass(frozen=True)
class VisionResult:
    """The detector's answer (`processing_ms` filled in), the candidates (None when off), and
    whether the head's rotation was compensated for this frame."""

    output: DetectorOutput
    candidates: list[MotionRegion] | None
    compensated: bool
    candidates_ms: float = 0.0


def with_appearance(
    movers: tuple[MoverRegion, ...], frame: np.ndarray, encoding: str
) -> tuple[MoverRegion, ...]:
    """The movers, each with the colour histogram of its box in `frame` (none where the box
    holds too few usable pixels)."""
    described = []
    for mover in movers:
        x, y, w, h = mover.box
        histogram = colour_histogram(frame, (x + w / 2.0, y + h / 2.0, w, h), encoding)
        appearance = () if histogram is None else tuple(histogram.tolist())
        described.append(dataclasses.replace(mover, appearance=appearance))
    return tuple(described)


class VisionPipeline:
    def __init__(
        self,
        camera: CameraModel,
        kinematics: HeadKinematics,
        vision: VisionSection,
        detector: str | None = None,
        lens: ZoomLens | None = None,
        pose_noise_rad: float = 0.0,
    ) -> None:
        self.camera = camera
        self.vision = vision
        self.ego = EgoMotion(camera, kinematics, lens)
        self.detector = make_detector(detector or vision.detector, vision, camera, pose_noise_rad)
        self.candidates = (
            CandidateFinder(
                level=vision.candidates_level,
                energy_threshold=vision.energy_threshold,
                min_area_px=vision.candidate_min_area_px,
                max_count=vision.candidates_max,
            )
            if vision.candidates
            else None
        )
        self.undistortion = Undistortion(camera) if camera.has_distortion else None
        self._energy = MotionEnergy(vision.pyramid_levels)
        # the last frames (grey, capture ns, head pose), the newest last: the previous one, and
        # the one BASELINE_FRAMES back for `FramePair.older`
        self._history: deque[tuple[np.ndarray, int, HeadPose | None]] = deque(
            maxlen=BASELINE_FRAMES
        )
        self.restarts = 0

    def reset(self) -> None:
        self._history.clear()
        self._energy.reset()
        self.detector.reset()
        if self.candidates is not None:
            self.candidates.reset()

    def process(
        self,
        gray: np.ndarray,
        t_capture_ns: int,
        head: HeadPose | None,
        *,
        with_candidates: bool = True,
        colour: np.ndarray | None = None,
        encoding: str = "bgr8",
    ) -> VisionResult:
        """Run the detector (and candidates, unless `with_candidates` is false — the gaze
        controller needs none while it pursues) on one grey frame captured at `t_capture_ns`.
        `colour`: the same frame as captured (`encoding`), where the movers' appearance is
        taken; the grey frame's brightness without it."""
        started = time.perf_counter()
        if self.undistortion is not None:
            gray = self.undistortion.frame(gray)
        undistort_s = time.perf_counter() - started
        previous = self._history[-1] if self._history else None
        if previous is not None:
            dt_s = (t_capture_ns - previous[1]) * 1e-9
            if not 0.0 < dt_s <= self.vision.frame_gap_max_ms * 1e-3:
                self.reset()
                self.restarts += 1
                previous = None
        oldest = self._history[0] if len(self._history) == BASELINE_FRAMES else None
        self._history.append((gray, t_capture_ns, head))
        if previous is None:  # nothing to compare with: no interval, no rotation
            dt_s = 0.0
            prev_gray, prev_head = None, None
        else:
            prev_gray, _, prev_head = previous
        compensated = (
            self.vision.compensate_ego_motion and head is not None and prev_head is not None
        )
        if compensated:
            assert head is not None and prev_head is not None
            step = self.ego.step(prev_head, head, dt_s)
        else:
            step = self.ego.still_step(dt_s, head)
        started = time.perf_counter()
        energy = None
        candidates_wanted = self.candidates is not None and with_candidates
        if self.detector.needs_energy or candidates_wanted:
            energy = self._energy.update(gray, step.H if compensated else None)
        else:
            self._energy.reset()  # skipped frames break the chain of differences
        energy_s = time.perf_counter() - started
        older = None
        if compensated and oldest is not None and oldest[2] is not None:
            assert head is not None
            older_step = self.ego.step(oldest[2], head, (t_capture_ns - oldest[1]) * 1e-9)
            older = FramePair(gray, t_capture_ns * 1e-9, oldest[0], older_step, True)
        pair = FramePair(
            gray, t_capture_ns * 1e-9, prev_gray, step, compensated, energy, older=older
        )
        started = time.perf_counter()
        output = self.detector.detect(pair)
        if self.undistortion is not None:
            output = self.undistortion.output(output)
        if output.movers:
            frame, kind = (gray, "gray8") if colour is None else (colour, encoding)
            output = dataclasses.replace(output, movers=with_appearance(output.movers, frame, kind))
        detector_s = time.perf_counter() - started + undistort_s
        if self.detector.needs_energy:
            detector_s += energy_s
        output = dataclasses.replace(output, processing_ms=detector_s * 1e3)
        candidates = None
        candidates_s = 0.0
        if self.candidates is not None and candidates_wanted:
            started = time.perf_counter()
            candidates = self.candidates.find(pair)
            if self.undistortion is not None:
                candidates = [self.undistortion.region(c) for c in candidates]
            candidates_s = time.perf_counter() - started + energy_s
        return VisionResult(output, candidates, compensated, candidates_s * 1e3)
