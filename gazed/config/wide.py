"""`[wide]`: the fixed wide camera a digital head (`[servo] protocol = "digital"`) looks through,
and the MJPEG stream of the head's view."""

from __future__ import annotations

from pathlib import Path

from pydantic import Field

from gazed.config.section import Section


class WideSection(Section):
    source: str | None = Field(
        None,
        min_length=1,
        description="The wide camera: a device index such as '0', a video file (relative to the "
        "rig file's folder; files loop) or an rtsp:// / http:// URL. Needed by the digital head.",
    )
    width_px: int = Field(1920, ge=16, le=8192, description="Wide image width in pixels.")
    height_px: int = Field(1080, ge=16, le=8192, description="Wide image height in pixels.")
    fx_px: float = Field(1400.0, gt=0, description="Focal length along u in pixels.")
    fy_px: float | None = Field(None, gt=0, description="Focal length along v (default: fx_px).")
    cx_px: float | None = Field(None, description="Principal point u (default: image centre).")
    cy_px: float | None = Field(None, description="Principal point v (default: image centre).")
    distortion: list[float] = Field(
        default_factory=list,
        max_length=8,
        description="OpenCV distortion coefficients k1, k2, p1, p2[, k3…]; empty for none. "
        "Written by `gazed calibrate tsai`.",
    )
    rate_hz: float = Field(
        25.0,
        gt=0,
        le=1000,
        description="Frame rate of the camera; a file plays at this rate, whatever its "
        "container says.",
    )
    start_frame: int = Field(
        0,
        ge=0,
        description="A video file's first pass starts at this frame (0-based); it loops from its "
        "first frame. Each view's sequence number is its frame's index in the file.",
    )
    frame_delay_ms: float = Field(
        0.0,
        ge=0,
        le=5000,
        description="Each frame is held back this long after capture, as a camera pipeline "
        "would; its capture time stays true.",
    )
    stream_port: int | None = Field(
        8090,
        ge=1,
        le=65535,
        description="Port of the MJPEG-over-HTTP stream of the head's view; none: no stream.",
    )
    stream_host: str = Field(
        "127.0.0.1",
        description="Address the stream listens on: loopback unless the rig says otherwise.",
    )

    def source_in(self, folder: Path) -> str | None:
        """The source with a relative file path taken from `folder` (devices and URLs as they
        are)."""
        source = self.source
        if source is None or source.isdigit() or "://" in source:
            return source
        path = Path(source)
        return str(path if path.is_absolute() else folder / path)
