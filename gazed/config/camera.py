"""`[camera]`: the frame source, the image size and the lens."""

from __future__ import annotations

from pydantic import Field, model_validator

from gazed.config.section import Section


class CameraSection(Section):
    source: str = Field(
        "sim",
        description="'sim' (frames from the simulator on the bus), a device index such as '0', "
        "a video file path, or an rtsp:// / http:// URL. Unused by a digital head, whose view "
        "is rendered from [wide] source.",
    )
    width_px: int = Field(640, ge=16, le=8192, description="Image width in pixels.")
    height_px: int = Field(480, ge=16, le=8192, description="Image height in pixels.")
    rate_hz: float = Field(25.0, gt=0, le=1000, description="Frame rate the camera delivers.")
    hfov_deg: float | None = Field(
        60.0,
        gt=0,
        lt=180,
        description="Horizontal field of view; used when fx_px/fy_px are not given.",
    )
    fx_px: float | None = Field(
        None, gt=0, description="Focal length along u in pixels (overrides hfov_deg)."
    )
    fy_px: float | None = Field(
        None, gt=0, description="Focal length along v in pixels (defaults to fx_px)."
    )
    cx_px: float | None = Field(
        None, description="Principal point u in pixels (default: image centre)."
    )
    cy_px: float | None = Field(
        None, description="Principal point v in pixels (default: image centre)."
    )
    distortion: list[float] = Field(
        default_factory=list,
        max_length=8,
        description="OpenCV distortion coefficients k1, k2, p1, p2[, k3…]; empty for none.",
    )
    zoom_focal_px: list[list[float]] = Field(
        default_factory=list,
        max_length=64,
        description="A zoom lens: rows [zoom, fx_px] or [zoom, fx_px, cx_px, cy_px], the zoom "
        "position (0 widest, 1 longest) increasing, the focal length interpolated linearly "
        "between rows; `gazed calibrate zoom` measures it. Empty: a fixed lens, as fx_px or "
        "hfov_deg say.",
    )
    reopen_max_s: float = Field(
        10.0,
        gt=0,
        le=600,
        description="Longest wait before reopening a failed camera, stream or file (the wait "
        "starts at 0.5 s and doubles).",
    )
    timeout_ms: float = Field(
        5000.0,
        gt=0,
        le=60000,
        description="How long a source may stay silent: the open/read timeout of streams and "
        "files; no simulator frame for this long reports the link down.",
    )
    delay_ms: float = Field(
        0.0,
        ge=0,
        le=2000,
        description="The camera's delay from exposure to a frame's arrival (its stamp), where "
        "known; the online estimate starts from it.",
    )
    delay_estimate: bool = Field(
        False,
        description="Estimate the camera's delay online from the image's global motion against "
        "odometry whenever the head moves, and correct each frame's capture stamp with it. Off "
        "by default: until the estimate has converged the stamps are wrong, and a target taken "
        "up meanwhile can be lost; `gazed calibrate latency` measures the delay for `delay_ms`.",
    )

    @model_validator(mode="after")
    def _zoom_table(self) -> CameraSection:
        rows = self.zoom_focal_px
        for i, row in enumerate(rows):
            if len(row) not in (2, 4):
                raise ValueError(f"zoom_focal_px: row {i} has {len(row)} numbers (expected 2 or 4)")
            if not 0.0 <= row[0] <= 1.0 or row[1] <= 0:
                raise ValueError(f"zoom_focal_px: row {i} needs 0 <= zoom <= 1 and fx_px > 0")
            if i and row[0] <= rows[i - 1][0]:
                raise ValueError(f"zoom_focal_px: row {i}'s zoom does not increase")
        if len(rows) == 1:
            raise ValueError("zoom_focal_px: one row (expected at least two, or none)")
        return self

    @model_validator(mode="after")
    def _focal_length(self) -> CameraSection:
        if self.fx_px is None and self.hfov_deg is None:
            raise ValueError("hfov_deg: missing (expected hfov_deg or fx_px, the focal length)")
        if self.fy_px is not None and self.fx_px is None:
            raise ValueError("fx_px: missing (expected fx_px whenever fy_px is given)")
        return self

    @property
    def frame_period_s(self) -> float:
        return 1.0 / self.rate_hz
