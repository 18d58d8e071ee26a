"""Frames as sources deliver them, and their check and conversion to grey.

A frame that cannot be used — empty, of the wrong element type, of a size other than the rig's
camera, or with a channel count its encoding does not have — raises `FrameError`, whose `reason`
names the counter the vision process increments; the frame is dropped and nothing else happens.
A live stream also drops a frame that is not newer than the last one taken (`FrameIntake`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from gazed.messages import HeadPose, Stamp

Encoding = str  # "bgr8", "rgb8" or "gray8" (FrameHeader.encoding)

_TO_GRAY = {"bgr8": cv2.COLOR_BGR2GRAY, "rgb8": cv2.COLOR_RGB2GRAY}


class FrameError(ValueError):
    """A frame that is dropped; `reason` is one of: empty, dtype, size, channels, encoding,
    stale."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


@dataclass(frozen=True)
class CapturedFrame:
    """Pixels and when the light hit the sensor (wall clock ns). `head`: the pose the frame was
    rendered at (a digital head's view); None for a camera's own frames, whose pose comes from
    odometry."""

    pixels: np.ndarray
    encoding: Encoding
    t_capture_ns: int
    seq: int
    stamps: tuple[Stamp, ...] = field(default=())
    head: HeadPose | None = None


def gray_frame(frame: CapturedFrame, width_px: int, height_px: int) -> np.ndarray:
    """The frame as uint8 grey (height, width), or FrameError saying why not."""
    pixels = checked_pixels(frame, width_px, height_px)
    if frame.encoding == "gray8":
        return np.ascontiguousarray(pixels.reshape(height_px, width_px))
    return cv2.cvtColor(pixels, _TO_GRAY[frame.encoding])


def checked_pixels(frame: CapturedFrame, width_px: int, height_px: int) -> np.ndarray:
    """The frame's pixels as they are, once they are uint8 of the rig's size with the channels
    its encoding says, or FrameError saying why not."""
    pixels = frame.pixels
    if pixels is None or pixels.size == 0:
        raise FrameError("empty", f"frame {frame.seq} is empty")
    if pixels.dtype != np.uint8:
        raise FrameError("dtype", f"frame {frame.seq} has {pixels.dtype} pixels, expected uint8")
    if pixels.shape[:2] != (height_px, width_px):
        size = "x".join(str(n) for n in pixels.shape[1::-1][:2])
        raise FrameError(
            "size", f"frame {frame.seq} is {size}, the rig's camera is {width_px}x{height_px}"
        )
    channels = 1 if pixels.ndim == 2 else pixels.shape[2]
    if frame.encoding == "gray8":
        if channels != 1:
            raise FrameError("channels", f"gray8 frame {frame.seq} has {channels} channels")
        return pixels
    if frame.encoding not in _TO_GRAY:
        raise FrameError("encoding", f"frame {frame.seq}: unknown encoding {frame.encoding!r}")
    if channels != 3:
        raise FrameError(
            "channels", f"{frame.encoding} frame {frame.seq} has {channels} channels, expected 3"
        )
    return pixels


class FrameIntake:
    """The frames of a live stream as grey: each newer than the last one taken, and valid."""

    def __init__(self, width_px: int, height_px: int) -> None:
        self.width_px = width_px
        self.height_px = height_px
        self._last_t_ns: int | None = None

    def take(self, frame: CapturedFrame) -> np.ndarray:
        """The frame as uint8 grey, or FrameError saying why it is dropped."""
        if self._last_t_ns is not None and frame.t_capture_ns <= self._last_t_ns:
            raise FrameError("stale", f"frame {frame.seq} is not newer than the last one processed")
        gray = gray_frame(frame, self.width_px, self.height_px)
        self._last_t_ns = frame.t_capture_ns
        return gray
