"""The digital head's camera: the frames of a fixed wide camera, each rendered as the head's view
at the head's pose when it was captured (DESIGN §11: the wide frames stay in the vision process).

    camera = DigitalCamera(wide_source, DigitalView(wide, view), pose_at, frame_delay_s=0.15)
    frame = camera.read()        # the view, its capture time the wide frame's, `head` its pose

Each wide frame is held back `frame_delay_s` after its capture, as a camera pipeline would, and
then rendered (`DigitalView`) at the pose the head's odometry gives for its capture instant
(`pose_at`, the vision stage's `OdometryHistory`). That pose travels with the frame
(`CapturedFrame.head`), so the detection reports the very pose its view was rendered at. A frame
whose capture instant odometry does not cover yet (before the servo's first reading, or a
stalled servo) cannot be rendered: it is dropped and counted. Of the frames due at once only
the newest is rendered. Every rendered view goes to `on_view` (the MJPEG stream).

A video file plays from `[wide] start_frame` and loops from its first frame (`WideCapture`),
and each of its frames is numbered by its index in the file, so a view's sequence number is its
wide frame's index: that is how a score against the footage's annotations (`gazed eval loop
--truth`) knows the frame it was rendered from, and how the wide frame's movers
(`wide_movers`, which see the frames as they are read) are found for the view rendered from
it.
"""

from __future__ import annotations

import threading
import time
from collections import Counter, deque
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from gazed.config import Rig, WideSection
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import HeadPose
from gazed.vision.digital_view import DigitalView
from gazed.vision.frames import CapturedFrame
from gazed.vision.opencv_camera import OpenCvCamera, capture_target
from gazed.vision.source import FrameSource, SourceError, SourceStatus

PENDING_MAX = 64  # wide frames held back at most (a frame delay of seconds at a high rate)
PASSES_KEPT = 4  # a file's passes remembered for numbering (frames in flight span one or two)


def wide_camera(wide: WideSection) -> CameraModel:
    """The wide camera of `[wide]` (principal point at the image centre where not given)."""
    w, h = wide.width_px, wide.height_px
    return CameraModel.from_intrinsics(
        w,
        h,
        wide.fx_px,
        wide.fy_px if wide.fy_px is not None else wide.fx_px,
        wide.cx_px if wide.cx_px is not None else (w - 1) / 2.0,
        wide.cy_px if wide.cy_px is not None else (h - 1) / 2.0,
        tuple(wide.distortion),
    )


class DigitalCamera(FrameSource):
    """Views rendered from `wide`'s frames; see the module docstring."""

    def __init__(
        self,
        wide: FrameSource,
        view: DigitalView,
        pose_at: Callable[[int], HeadPose | None],
        *,
        frame_delay_s: float = 0.0,
        on_view: Callable[[np.ndarray], None] | None = None,
        clock_ns: Callable[[], int] = time.time_ns,
    ) -> None:
        self.wide = wide
        self.view = view
        self.pose_at = pose_at
        self.frame_delay_ns = round(frame_delay_s * 1e9)
        self.on_view = on_view
        self.clock_ns = clock_ns
        self.description = f"digital head over {wide.description}"
        self.counters: Counter[str] = Counter()
        self._pending: deque[CapturedFrame] = deque(maxlen=PENDING_MAX)

    @property
    def is_connected(self) -> bool:
        return self.wide.is_connected

    def connect(self) -> None:
        self.wide.connect()

    def disconnect(self) -> None:
        self.wide.disconnect()
        self._pending.clear()

    def status(self) -> SourceStatus:
        return self.wide.status()

    def due_in_s(self) -> float | None:
        """How long until the oldest frame held back is due (None: none held)."""
        if not self._pending:
            return None
        due_ns = self._pending[0].t_capture_ns + self.frame_delay_ns
        return max(0.0, (due_ns - self.clock_ns()) * 1e-9)

    def read(self) -> CapturedFrame | None:
        self._require_connected()
        frame = self.wide.read()
        if frame is not None:
            self._pending.append(frame)
        now_ns = self.clock_ns()
        due = None
        while self._pending and self._pending[0].t_capture_ns + self.frame_delay_ns <= now_ns:
            if due is not None:
                self.counters["wide_frames_skipped"] += 1
            due = self._pending.popleft()
        return None if due is None else self._render(due)

    def _render(self, frame: CapturedFrame) -> CapturedFrame | None:
        pose = self.pose_at(frame.t_capture_ns)
        if pose is None:
            self.counters["wide_frames_without_pose"] += 1
            return None
        pixels = self.view.render(frame.pixels, pose.pan_rad, pose.tilt_rad, pose.zoom)
        if self.on_view is not None:
            self.on_view(pixels)
        self.counters["views_rendered"] += 1
        return CapturedFrame(
            pixels, frame.encoding, frame.t_capture_ns, frame.seq, frame.stamps, head=pose
        )


class WideCapture(OpenCvCamera):
    """The wide camera, read as `OpenCvCamera` reads it; a video file's first pass starts at
    `start_frame` and the file loops from its first frame. Each frame read is numbered by its
    index in the file (a camera's or stream's: the capture's own count).

    The capture numbers frames as it reads them, across passes; each opening of a file notes the
    number its pass begins at and the file frame it begins with."""

    def __init__(self, target: int | str, *, start_frame: int = 0, **options: Any) -> None:
        super().__init__(target, **options)
        self.start_frame = start_frame
        self._passes: deque[tuple[int, int]] = deque(maxlen=PASSES_KEPT)
        self._passes_lock = threading.Lock()

    def read(self) -> CapturedFrame | None:
        frame = super().read()
        return None if frame is None else replace(frame, seq=self._frame_index(frame.seq))

    def _frame_index(self, seq: int) -> int:
        """The file's frame index of a number the capture handed out."""
        with self._passes_lock:
            for first_seq, first_index in reversed(self._passes):
                if seq >= first_seq:
                    return first_index + seq - first_seq
        return seq

    def _open(self) -> cv2.VideoCapture | None:
        capture = super()._open()
        if capture is None or not self._is_file:
            return capture
        with self._passes_lock:
            first_index = 0 if self._passes else self.start_frame
            self._passes.append((self._frames, first_index))
        if first_index:
            capture.set(cv2.CAP_PROP_POS_FRAMES, first_index)
        return capture


def rig_view(rig: Rig, *, zoom: bool = True) -> DigitalView:
    """The digital head's view of `rig`: `[camera]` rendered from `[wide]` under `[head]`'s
    kinematics, through `[camera]`'s zoom lens (`zoom=False`: a fixed lens, the view at its
    widest, as the footage's scoring takes it)."""
    camera = CameraModel.from_section(rig.camera)
    lens = ZoomLens.from_section(rig.camera) if zoom else None
    return DigitalView(wide_camera(rig.wide), camera, HeadKinematics.from_section(rig.head), lens)


def file_frame_count(path: str) -> int | None:
    """The number of frames a video file holds, as its container says (None: not a file, or
    not said)."""
    if not Path(path).is_file():
        return None
    capture = cv2.VideoCapture(path)
    try:
        count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) if capture.isOpened() else 0
    finally:
        capture.release()
    return count if count > 0 else None


def open_digital_camera(
    rig: Rig,
    pose_at: Callable[[int], HeadPose | None],
    *,
    on_frame: Callable[[], None] | None = None,
    on_view: Callable[[np.ndarray], None] | None = None,
) -> DigitalCamera:
    """The rig's digital head camera: `[wide]`'s source (a file plays at `[wide] rate_hz` from
    `[wide] start_frame` and loops), rendered to `[camera]`'s view."""
    wide = rig.wide
    if rig.wide_source is None:
        raise SourceError("[wide] source: missing (the digital head needs a wide camera)")
    frames = file_frame_count(rig.wide_source)
    if frames is not None and wide.start_frame >= frames:
        raise SourceError(
            f"[wide] start_frame = {wide.start_frame}: {rig.wide_source} has {frames} frames"
        )
    source = WideCapture(
        capture_target(rig.wide_source),
        start_frame=wide.start_frame,
        width_px=wide.width_px,
        height_px=wide.height_px,
        rate_hz=wide.rate_hz,
        reopen_max_s=rig.camera.reopen_max_s,
        timeout_ms=rig.camera.timeout_ms,
        on_frame=on_frame,
        file_rate_hz=wide.rate_hz,
    )
    view = rig_view(rig)
    return DigitalCamera(
        source,
        view,
        pose_at,
        frame_delay_s=wide.frame_delay_ms * 1e-3,
        on_view=on_view,
    )
