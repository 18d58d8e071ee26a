"""`[gaze]`: the saccade/pursuit controller, lost search, line tracing, which track to follow and
the zoom control."""

from __future__ import annotations

import math
from typing import Annotated, Literal, Self

from pydantic import Field, model_validator

from gazed.config.section import Section

SelectRule = Literal["first", "nearest-centre", "largest", "longest-seen"]

GroundPoint = Annotated[list[float], Field(min_length=2, max_length=2)]


class GazeSection(Section):
    control: Literal["pursuit", "look-and-move", "pid", "move-wait-move"] = Field(
        "pursuit",
        description="'pursuit': continuous smooth pursuit (dynamic look-and-move); "
        "'look-and-move': move, settle, then look (PTZ cameras that cannot image while moving). "
        "The peers' laws, to compare with: "
        "'pid': a PID on the pixel error with a deadband, no prediction; "
        "'move-wait-move': move to where the target was seen, "
        "wait until the head stops, look again.",
    )
    pid_kp_per_s: float = Field(
        4.0,
        ge=0,
        le=100,
        description="control 'pid': proportional gain, head rate (rad/s) per rad of error.",
    )
    pid_ki_per_s2: float = Field(
        4.0, ge=0, le=1000, description="control 'pid': integral gain (rad/s per rad·s)."
    )
    pid_kd_s: float = Field(
        0.0, ge=0, le=10, description="control 'pid': derivative gain (rad/s per rad/s)."
    )
    pid_deadband_px: float = Field(
        10.0,
        ge=0,
        description="control 'pid': an error within this many pixels of the image centre "
        "counts as none.",
    )
    rate_hz: float = Field(
        50.0, gt=0, le=1000, description="Rate of the gaze controller's demands."
    )
    fovea_half_angle_deg: float = Field(
        3.0,
        gt=0,
        le=45,
        description="Target within this angle of the optical axis counts as foveated.",
    )
    settle_ms: float = Field(
        80.0, ge=0, description="After a saccade, detections are ignored for this long."
    )
    lost_after_ms: float = Field(
        600.0,
        gt=0,
        description="No detection for this long in pursuit -> lost (coast on prediction). "
        "Counted in the capture times of the frames vision has reported on, so the camera's "
        "and vision's latency do not shorten it.",
    )
    saccade_tolerance_deg: float = Field(
        0.5,
        gt=0,
        le=20,
        description="A saccade has arrived when the head is this close to its goal, at rest.",
    )
    saccade_timeout_ms: float = Field(
        3000.0, gt=0, description="A saccade not settled after this -> search."
    )
    candidate_min_score: float = Field(
        0.0, description="Motion candidates scoring below this do not draw a saccade."
    )
    residual_gain: float = Field(
        0.3,
        ge=0,
        le=1,
        description="Pursuit feedback: share of the smoothed prediction residual "
        "added to the demand.",
    )
    residual_smoothing: float = Field(
        0.2,
        gt=0,
        le=1,
        description="Weight of each new residual in its running mean (1: no smoothing).",
    )
    lost_search_growth_deg_s: float = Field(
        2.0,
        ge=0,
        le=180,
        description=(
            "Lost: the search region around the prediction grows this fast at least; once it is"
            " wider than the fovea, the fovea tours its edge, a look at each stop."
        ),
    )
    lost_search_max_deg: float = Field(
        10.0,
        ge=0,
        le=90,
        description=(
            "Lost: largest search radius; a region growing past it (the prediction says too"
            " little) sends the gaze back to search."
        ),
    )
    trace_max_turn_deg: float = Field(
        30.0,
        gt=0,
        le=180,
        description="Line tracing: an edge turning more than this is a corner: the trace ends.",
    )
    trace_line_tolerance_deg: float = Field(
        0.3,
        gt=0,
        le=10,
        description="Line tracing: a sample this far off the line through the earlier ones "
        "means the edge turned.",
    )
    trace_misses: int = Field(
        3,
        ge=1,
        le=100,
        description="Line tracing: looks in a row without an edge before the trace ends.",
    )
    search_after_ms: float = Field(
        3000.0, gt=0, description="Lost for this long -> back to search."
    )
    reacquire_detections: int = Field(
        3,
        ge=1,
        le=25,
        description=(
            "Park, search and lost take a detection up only after this many in a row (one per"
            " frame): a lone false detection while the head scans is not the target."
        ),
    )
    select_rule: SelectRule = Field(
        "first",
        description="Which confirmed track the gaze follows until it ends (unless an operator "
        "chooses on gaze/select): 'first' the one that appeared first, 'nearest-centre' the one "
        "nearest the optical axis, 'largest' the tallest box, 'longest-seen' the one with the most "
        "detections.",
    )
    select_zone_xy_m: list[GroundPoint] | None = Field(
        None,
        min_length=3,
        max_length=64,
        description="The rule picks only tracks inside this ground polygon ([[x, y], ...] in "
        "metres, the rig's ground frame); none: anywhere.",
    )

    zoom_control: bool = Field(
        False,
        description="Hold the target's height in the frame with the zoom (a rig with a zoom "
        "lens: [camera] zoom_focal_px); off, the gaze never moves the zoom.",
    )
    zoom_target_height: float = Field(
        0.25,
        gt=0,
        le=1,
        description="zoom_control: the target's height to hold, as a fraction of the frame's.",
    )
    zoom_box_margin_px: float = Field(
        0.0,
        ge=0,
        le=100,
        description="zoom_control: how much taller than the target its detected box is (the "
        "detector's smoothing reaches past its edges: about 6 px for `flow`); taken off the box.",
    )
    zoom_deadband: float = Field(
        0.1,
        ge=0,
        lt=1,
        description="zoom_control: a height within this fraction of zoom_target_height is left.",
    )
    zoom_min: float = Field(
        0.0, ge=0, le=1, description="zoom_control: the widest zoom position it goes to."
    )
    zoom_max: float = Field(
        1.0, ge=0, le=1, description="zoom_control: the longest zoom position it goes to."
    )
    zoom_in_rate_s: float = Field(
        0.1,
        gt=0,
        le=100,
        description="zoom_control: zooming in, the demand moves this fraction of the zoom range "
        "per second at most.",
    )
    zoom_out_rate_s: float = Field(
        0.5,
        gt=0,
        le=100,
        description="zoom_control: zooming out (too big, escaping, or reacquiring), this fast.",
    )
    zoom_out_edge: float = Field(
        0.15,
        ge=0,
        lt=0.5,
        description="zoom_control: zoom out while the target's centre is within this fraction "
        "of the frame's size of its edge.",
    )
    zoom_out_speed: float = Field(
        1.0,
        gt=0,
        description="zoom_control: zoom out while the target moves faster than this many frame "
        "heights per second in the image (its independent image velocity).",
    )
    zoom_in_steady_ms: float = Field(
        1000.0,
        ge=0,
        description="zoom_control: zoom in only once the target has been neither near the edge "
        "nor fast for this long in pursuit.",
    )

    @model_validator(mode="after")
    def _zoom_range(self) -> Self:
        if self.zoom_min >= self.zoom_max:
            raise ValueError(
                f"zoom_min ({self.zoom_min:g}) must be less than zoom_max ({self.zoom_max:g})"
            )
        return self

    @model_validator(mode="after")
    def _zone(self) -> Self:
        zone = self.select_zone_xy_m
        if zone is not None:
            if not all(math.isfinite(v) for point in zone for v in point):
                raise ValueError("select_zone_xy_m: not finite (expected [[x, y], ...] in metres)")
            twice_area = sum(
                x0 * y1 - x1 * y0
                for (x0, y0), (x1, y1) in zip(zone, zone[1:] + zone[:1], strict=True)
            )
            if abs(twice_area) < 1e-9:
                raise ValueError("select_zone_xy_m: the polygon has no area")
        return self
