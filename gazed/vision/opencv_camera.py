"""A camera, stream or video file read through OpenCV's `VideoCapture` (DESIGN §6).

A grab thread opens the capture, reads frames as they come, stamps each with the wall clock the
moment `read()` returns it (the closest this side of the driver gets to the capture time; a
camera's own exposure-to-delivery delay is not included), and keeps only the newest. A video
file is paced at its own frame rate (or `file_rate_hz` where its container says otherwise),
so it behaves like a camera. When opening fails or a read returns nothing (device unplugged,
stream dropped, file ended) the capture is released and reopened after a backoff delay (doubling up
to `reopen_max_s`); files therefore loop. Streams get FFmpeg open/read timeouts, so a dead URL never
blocks the thread for long, and the process never waits on the thread at all.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from gazed.backoff import Backoff
from gazed.messages import ARRIVAL_STAGE
from gazed.vision.frames import CapturedFrame
from gazed.vision.source import FrameSource, LinkState, SourceStatus

FIRST_REOPEN_S = 0.5
JOIN_TIMEOUT_S = 2.0


def capture_target(source: str) -> int | str:
    """A rig's `[camera] source`: digits are a device index, anything else a path or URL."""
    return int(source) if source.isdigit() else source


class OpenCvCamera(FrameSource):
    def __init__(
        self,
        target: int | str,
        *,
        width_px: int,
        height_px: int,
        rate_hz: float,
        reopen_max_s: float,
        timeout_ms: float,
        on_frame: Callable[[], None] | None = None,
        file_rate_hz: float | None = None,
    ) -> None:
        self.target = target
        self.file_rate_hz = file_rate_hz
        self.width_px = width_px
        self.height_px = height_px
        self.rate_hz = rate_hz
        self.timeout_ms = timeout_ms
        self.on_frame = on_frame
        self.description = f"camera {target!r}"
        self._is_file = isinstance(target, str) and Path(target).is_file()
        self._backoff = Backoff(min(FIRST_REOPEN_S, reopen_max_s), reopen_max_s)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._newest: CapturedFrame | None = None
        self._returned_seq = -1
        self._frames = 0
        self._reopens = 0
        self._link: LinkState = "down"
        self._last_error: str | None = None

    @property
    def is_connected(self) -> bool:
        return self._thread is not None

    def connect(self) -> None:
        if self._thread is not None:
            return
        self._stop.clear()
        self._link = "connecting"
        self._thread = threading.Thread(target=self._run, name="camera-grab", daemon=True)
        self._thread.start()

    def disconnect(self) -> None:
        thread, self._thread = self._thread, None
        if thread is None:
            return
        self._stop.set()
        thread.join(JOIN_TIMEOUT_S)  # a read stuck in a driver is left to its timeout
        self._link = "down"

    def read(self) -> CapturedFrame | None:
        self._require_connected()
        with self._lock:
            frame = self._newest
            if frame is None or frame.seq == self._returned_seq:
                return None
            self._returned_seq = frame.seq
            return frame

    def status(self) -> SourceStatus:
        with self._lock:
            return SourceStatus(self._link, self._frames, self._reopens, self._last_error)

    def _open(self) -> cv2.VideoCapture | None:
        if isinstance(self.target, int):
            capture = cv2.VideoCapture(self.target)
            if capture.isOpened():
                capture.set(cv2.CAP_PROP_FRAME_WIDTH, self.width_px)
                capture.set(cv2.CAP_PROP_FRAME_HEIGHT, self.height_px)
                capture.set(cv2.CAP_PROP_FPS, self.rate_hz)
        else:
            timeout = int(self.timeout_ms)
            capture = cv2.VideoCapture(
                self.target,
                cv2.CAP_ANY,
                [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, timeout, cv2.CAP_PROP_READ_TIMEOUT_MSEC, timeout],
            )
        if not capture.isOpened():
            capture.release()
            return None
        return capture

    def _run(self) -> None:
        while not self._stop.is_set():
            capture = self._open()
            if capture is None:
                self._failed(f"cannot open {self.target!r}")
                continue
            reason = self._grab(capture)
            capture.release()
            if self._stop.is_set():
                break
            self._failed(reason)

    def _grab(self, capture: cv2.VideoCapture) -> str:
        """Read until the capture fails or we are stopped; the reason it ended."""
        period_s = 0.0
        if self._is_file:
            fps = self.file_rate_hz or capture.get(cv2.CAP_PROP_FPS)
            period_s = 1.0 / fps if fps and fps > 0 else 1.0 / self.rate_hz
        due_s = time.monotonic()
        while not self._stop.is_set():
            ok, pixels = capture.read()
            t_ns = time.time_ns()
            if not ok or pixels is None:
                return "file ended" if self._is_file else "no frame (unplugged or stream dropped)"
            self._store(pixels, t_ns)
            if period_s:
                due_s += period_s
                self._stop.wait(max(0.0, due_s - time.monotonic()))
        return "stopped"

    def _store(self, pixels: np.ndarray, t_ns: int) -> None:
        encoding = "gray8" if pixels.ndim == 2 else "bgr8"
        with self._lock:
            arrival = ((ARRIVAL_STAGE, t_ns),)  # read() returned it: it is here, just captured
            self._newest = CapturedFrame(pixels, encoding, t_ns, self._frames, arrival)
            self._frames += 1
            self._link = "connected"
            self._backoff.reset()
        if self.on_frame is not None:
            self.on_frame()

    def _failed(self, reason: str) -> None:
        with self._lock:
            self._link = "down"
            self._last_error = reason
            self._reopens += 1
        self._stop.wait(self._backoff.next_delay_s())
