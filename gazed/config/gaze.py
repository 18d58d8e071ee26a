"""`[gaze]`: the saccade/pursuit controller, lost search, line tracing and which track to follow."""

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
        description="'pursuit': continuous smooth pursuit (dynamic look-and-move); 'look-and-move': "
        "move, settle, then look (PTZ cameras that cannot image while moving). The peers' laws, "
        "to compare with: 'pid': a PID on the pixel error with a deadband, no prediction; "
        "'move-wait-move': move to where the target was seen, wait until the head stops, look again.",
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
        description="control 'pid': an error within this many pixels of the image centre counts as none.",
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
        description="No detection for this long in pursuit -> lost (coast on prediction).",
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
        description="Pursuit feedback: share of the smoothed prediction residual added to the demand.",
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
        description="Line tracing: a sample this far off the line through the earlier ones means the edge turned.",
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
