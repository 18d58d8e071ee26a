"""Zoom control: the decisions that hold the target's height in the frame."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from gazed.config import CameraSection, GazeSection, Rig
from gazed.gaze.sightings import Sightings
from gazed.gaze.zoom import ZoomControl, target_height_px
from gazed.geometry.kinematics import HeadKinematics
from gazed.geometry.zoom import ZoomLens
from gazed.messages import Detection, GazeDemand, HeadPose, Mover, Odometry

W, H = 640, 480
TABLE = [[0.0, 500.0], [1.0, 5000.0]]  # f = 500 + 4500 z
S = 1_000_000_000  # ns per second


def lens(table: list[list[float]] = TABLE) -> ZoomLens:
    return ZoomLens.from_section(
        CameraSection(width_px=W, height_px=H, fx_px=500.0, zoom_focal_px=table)
    )


def control(table: list[list[float]] = TABLE, **gaze: object) -> ZoomControl:
    section = GazeSection(**{"zoom_control": True, "zoom_in_steady_ms": 500.0, **gaze})
    zoom_lens = lens(table)
    sightings = Sightings(section, 0.04, zoom_lens, HeadKinematics())
    return ZoomControl(section, zoom_lens, sightings)


def seen(
    t_s: float,
    height_px: float,
    zoom: float = 0.0,
    uv: tuple[float, float] = (320.0, 240.0),
    velocity_px_s: tuple[float, float] = (0.0, 0.0),
) -> Detection:
    mover = Mover(u_px=uv[0], v_px=uv[1], box_width_px=10.0, box_height_px=height_px)
    other = Mover(u_px=10.0, v_px=10.0, box_height_px=300.0)
    return Detection(
        t_capture_ns=round(t_s * S),
        seq=0,
        detector="flow",
        found=True,
        u_px=uv[0],
        v_px=uv[1],
        du_px_s=velocity_px_s[0],
        dv_px_s=velocity_px_s[1],
        width_px=W,
        height_px=H,
        head=HeadPose(pan_rad=0.0, tilt_rad=0.0, zoom=zoom),
        movers=(other, mover),
    )


def demand() -> GazeDemand:
    return GazeDemand(t_capture_ns=0, kind="pursuit", pan_rad=0.0, tilt_rad=0.0)


def odometry(zoom: float | None) -> Odometry:
    return Odometry(t_capture_ns=0, pan_rad=0.0, tilt_rad=0.0, zoom=zoom)


def run(zc: ZoomControl, state: str, t_s: float, zoom_now: float | None = 0.0) -> float | None:
    """One tick at `t_s` (wall and monotonic clocks alike); the zoom demanded."""
    out = zc.apply(demand(), state, odometry(zoom_now), round(t_s * S), t_s)  # type: ignore[arg-type]
    assert out is not None
    return out.zoom


def test_off_or_with_a_fixed_lens_the_demand_goes_out_unchanged() -> None:
    for zc in (control(zoom_control=False), control(table=[])):
        zc.sightings.found = seen(0.0, 20.0)
        d = demand()
        assert zc.apply(d, "pursuit", odometry(0.3), 0, 0.0) is d
        assert zc.apply(d, "search", odometry(0.3), S, 1.0) is d
    assert control().apply(None, "pursuit", odometry(0.3), 0, 0.0) is None


def test_a_small_steady_target_is_zoomed_in_to_the_setpoint_at_the_zoom_in_rate() -> None:
    zc = control(zoom_target_height=0.25, zoom_in_rate_s=0.1)
    assert run(zc, "search", 0.0) == 0.0  # reacquiring: the widest
    # the target is 48 px of 480 (0.1 of the frame) at zoom 0 (f = 500): the setpoint wants
    # f = 1250, zoom 1/6; it was seen steady, but only just after pursuit began
    zc.sightings.found = seen(0.2, 48.0)
    assert run(zc, "pursuit", 0.2) == 0.0  # not steady for zoom_in_steady_ms yet
    zc.sightings.found = seen(0.7, 48.0)
    assert run(zc, "pursuit", 0.7) == pytest.approx(0.05)  # 0.5 s at 0.1 per second
    zc.sightings.found = seen(0.74, 48.0)
    assert run(zc, "pursuit", 1.0) == pytest.approx(0.08)
    zc.sightings.found = seen(1.4, 48.0)
    assert run(zc, "pursuit", 1.5) == pytest.approx(0.13)
    # a frame seen at zoom 0.13 (f = 1085) with the target at 104 px: the goal is still 1/6,
    # whatever zoom the frame was captured at (no overshoot from the loop's latency)
    zc.sightings.found = seen(1.6, 0.25 * H * 1085.0 / 1250.0, zoom=0.13)
    assert run(zc, "pursuit", 1.9) == pytest.approx(1.0 / 6.0, abs=1e-3)


def test_a_target_taller_than_the_deadband_is_zoomed_out_at_once() -> None:
    zc = control(zoom_target_height=0.25, zoom_out_rate_s=0.5, zoom_deadband=0.1)
    zc.sightings.found = seen(0.0, 0.25 * H, zoom=0.5)
    assert run(zc, "pursuit", 0.0, zoom_now=0.5) == 0.5  # on the setpoint: stays
    zc.sightings.found = seen(0.05, 0.26 * H, zoom=0.5)
    assert run(zc, "pursuit", 0.1, zoom_now=0.5) == 0.5  # within the deadband: stays
    # twice the setpoint at zoom 0.5 (f = 2750): the goal is f = 1375, zoom 0.19444; once
    # it is the median of the sightings' sizes (one frame's box does not move the zoom)
    zc.sightings.found = seen(0.12, 0.5 * H, zoom=0.5)
    assert run(zc, "pursuit", 0.15, zoom_now=0.5) == 0.5
    zc.on_detection(seen(0.13, 0.5 * H, zoom=0.5))
    zc.sightings.found = seen(0.14, 0.5 * H, zoom=0.5)
    assert run(zc, "pursuit", 0.2, zoom_now=0.5) == pytest.approx(0.475)  # 0.05 s at 0.5 /s
    assert run(zc, "pursuit", 0.6, zoom_now=0.475) == pytest.approx(0.275)
    zc.sightings.found = seen(0.9, 0.5 * H, zoom=0.5)  # the frames still lag the zoom
    assert run(zc, "pursuit", 1.0, zoom_now=0.275) == pytest.approx(0.19444, abs=1e-4)


def test_a_nearing_target_is_sized_for_the_instant_the_demand_acts() -> None:
    """A target nearing the camera grows as it comes: its height doubles in 1.4 s here, and the
    zoom is sized for when the demand acts (the tick, 0.2 s after the last sighting, plus the
    actuation latency), not for the sightings' middle, 0.58 s earlier."""
    zc = control(zoom_target_height=0.25, zoom_out_rate_s=100.0, zoom_deadband=0.02)
    growth_s = 0.5  # d ln h / dt
    for k in range(15):  # a full window of sightings at zoom 0.5 (f = 2750), 25 Hz
        t_s = 0.04 * k
        zc.on_detection(seen(t_s, 0.25 * H * math.exp(growth_s * t_s), zoom=0.5))
    zc.sightings.found = None
    assert run(zc, "pursuit", 0.75, zoom_now=0.5) == 0.5  # the first tick: no time to move
    zoom = zc.apply(demand(), "pursuit", odometry(0.5), round(0.76 * S), 0.76, actuation_s=0.1)
    assert zoom is not None
    # at 0.86 s the target is 0.25 exp(0.43) of the frame at f = 2750: the setpoint's focal
    # length is 2750 exp(-0.43), zoom (2750 exp(-0.43) - 500) / 4500
    assert zoom.zoom == pytest.approx((2750.0 * math.exp(-0.43) - 500.0) / 4500.0, abs=1e-6)


def test_a_few_merged_boxes_do_not_move_the_zoom_even_the_newest() -> None:
    zc = control(zoom_target_height=0.25, zoom_deadband=0.05)
    for k in range(15):  # the last three boxes merged with an edge behind the target
        zc.on_detection(seen(0.04 * k, (0.6 if k >= 12 else 0.25) * H, zoom=0.5))
    zc.sightings.found = None
    assert run(zc, "pursuit", 0.65, zoom_now=0.5) == 0.5
    assert run(zc, "pursuit", 0.7, zoom_now=0.5) == 0.5  # 0.05 s at 0.5 /s would show


@pytest.mark.parametrize("scatter", [0.0, 1.0], ids=["steady boxes", "a standing target's"])
def test_the_zoom_goes_in_only_on_a_size_known_within_the_deadband(scatter: float) -> None:
    """A motion detector's boxes of a person standing still are what still moves of them, a
    hand or a shoulder, from frame to frame: their sizes scatter by factors, and the zoom does
    not go in on them; the same boxes of a walker, all alike, take it in."""
    zc = control(zoom_target_height=0.25, zoom_in_steady_ms=0.0, zoom_deadband=0.05)
    rng = np.random.default_rng(5)
    for k in range(30):  # a tenth of the frame on average at zoom 0.5: the setpoint is far in
        t_s = 0.04 * k
        height_px = 0.1 * H * math.exp(scatter * rng.standard_normal())
        zc.sightings.found = seen(t_s, height_px, zoom=0.5)
        zoom = run(zc, "pursuit", t_s, zoom_now=0.5)
    error = zc.size(round(1.16 * S))[1]
    if scatter == 0.0:
        assert error == pytest.approx(0.0) and zoom > 0.5
    else:
        assert error > 0.05 and zoom == 0.5


def test_the_box_margin_is_taken_off_the_detected_box() -> None:
    zc = control(zoom_target_height=0.25, zoom_box_margin_px=9.0, zoom_deadband=0.02)
    zc.sightings.found = seen(0.0, 0.25 * H + 9.0, zoom=0.5)
    assert run(zc, "pursuit", 0.0, zoom_now=0.5) == 0.5
    zc.sightings.found = seen(0.1, 0.25 * H + 9.0, zoom=0.5)
    assert run(zc, "pursuit", 0.2, zoom_now=0.5) == 0.5  # on the setpoint: stays


@pytest.mark.parametrize(
    ("uv", "velocity_px_s"),
    [((20.0, 240.0), (0.0, 0.0)), ((320.0, 460.0), (0.0, 0.0)), ((320.0, 240.0), (600.0, 0.0))],
    ids=["left edge", "bottom edge", "fast"],
)
def test_an_escaping_target_is_zoomed_out_and_zoom_in_waits_until_it_is_steady(
    uv: tuple[float, float], velocity_px_s: tuple[float, float]
) -> None:
    zc = control(zoom_out_edge=0.1, zoom_out_speed=1.0, zoom_out_rate_s=0.5, zoom_min=0.1)
    # the target's size is that of 0.1 of the frame's height at zoom 0.1 throughout
    size = {"height_px": 0.1 * H * 4100 / 950, "zoom": 0.8}
    zc.sightings.found = seen(0.0, **size)
    assert run(zc, "pursuit", 0.0, zoom_now=0.8) == 0.8
    zc.sightings.found = seen(0.1, **size, uv=uv, velocity_px_s=velocity_px_s)
    assert run(zc, "pursuit", 0.4, zoom_now=0.8) == pytest.approx(0.6)
    for k in range(1, 37):  # escaping all along: out to zoom_min
        t_s = 0.4 + 0.1 * k
        zc.sightings.found = seen(t_s, 0.1 * H, zoom=0.1, uv=uv, velocity_px_s=velocity_px_s)
        zoom = run(zc, "pursuit", t_s, zoom_now=0.5)
    assert zoom == pytest.approx(0.1)
    # back in the middle, small: zoom in only once steady for zoom_in_steady_ms (0.5 s)
    zc.sightings.found = seen(4.1, 0.1 * H, zoom=0.1)
    assert run(zc, "pursuit", 4.2, zoom_now=0.1) == pytest.approx(0.1)
    zc.sightings.found = seen(4.7, 0.1 * H, zoom=0.1)
    assert run(zc, "pursuit", 4.8, zoom_now=0.1) > 0.1


@pytest.mark.parametrize(
    ("uv", "velocity_px_s", "room"),
    [((320.0, 240.0), (600.0, 0.0), 0.8), ((32.0, 240.0), (0.0, 0.0), 224.0 / 287.5)],
    ids=["fast", "near the edge"],
)
def test_an_escaping_target_is_zoomed_out_just_enough_for_the_frame_to_hold_it(
    uv: tuple[float, float], velocity_px_s: tuple[float, float], room: float
) -> None:
    """At zoom 0.5 (f = 2750) and on the setpoint: 1.25 frame heights a second where 1.0 is
    allowed, or 288 px from the centre where 224 are (0.5 - 0.15 of 640): the focal length
    shrinks by that room, not to the widest."""
    zc = control(zoom_target_height=0.25, zoom_out_rate_s=10.0, zoom_deadband=0.05)
    zc.sightings.found = seen(0.0, 0.25 * H, zoom=0.5, uv=uv, velocity_px_s=velocity_px_s)
    run(zc, "pursuit", 0.0, zoom_now=0.5)
    for k in range(1, 6):
        zc.sightings.found = seen(0.1 * k, 0.25 * H, zoom=0.5, uv=uv, velocity_px_s=velocity_px_s)
        zoom = run(zc, "pursuit", 0.1 * k, zoom_now=0.5)
    assert zoom == pytest.approx((2750.0 * room - 500.0) / 4500.0)


@pytest.mark.parametrize("state", ["search", "saccade", "lost", "park"])
def test_reacquiring_zooms_out_first(state: str) -> None:
    zc = control(zoom_out_rate_s=0.5, zoom_min=0.05)
    assert run(zc, state, 0.0, zoom_now=0.9) == 0.9
    assert run(zc, state, 0.5, zoom_now=0.9) == pytest.approx(0.65)
    assert run(zc, state, 1.0, zoom_now=0.65) == pytest.approx(0.4)
    assert run(zc, state, 1.5, zoom_now=0.4) == pytest.approx(0.15)
    assert run(zc, state, 2.0, zoom_now=0.15) == pytest.approx(0.05)


def test_tracing_a_line_an_unknown_zoom_or_a_stale_detection_leave_the_zoom() -> None:
    zc = control()
    zc.sightings.found = seen(0.0, 20.0)
    d = demand()
    assert zc.apply(d, "trace", odometry(0.4), 0, 0.0) is d
    assert zc.apply(d, "pursuit", odometry(None), 0, 0.0) is d  # zoom's position never read
    zc = control(lost_after_ms=600.0, zoom_in_steady_ms=0.0)
    zc.sightings.found = seen(0.0, 20.0)
    assert run(zc, "pursuit", 1.0, zoom_now=0.3) == 0.3
    assert run(zc, "pursuit", 1.4, zoom_now=0.3) == 0.3  # over a second old: stays


def test_the_target_height_is_the_box_of_the_mover_at_the_detection_pixel() -> None:
    d = seen(0.0, 77.0)
    assert target_height_px(d) == 77.0
    assert target_height_px(d.model_copy(update={"u_px": 1.0})) is None
    assert target_height_px(d.model_copy(update={"movers": ()})) is None


def test_zoom_control_needs_a_zoom_lens_and_a_range() -> None:
    with pytest.raises(ValidationError, match="zoom_focal_px"):
        Rig(rig={"name": "z"}, gaze={"zoom_control": True})
    with pytest.raises(ValidationError, match="zoom_min"):
        GazeSection(zoom_min=0.6, zoom_max=0.5)
    rig = Rig(
        rig={"name": "z"},
        camera={"hfov_deg": 60.0, "zoom_focal_px": TABLE},
        gaze={"zoom_control": True},
    )
    assert rig.gaze.zoom_control


def test_lost_the_view_widens_only_as_far_as_the_search_region_needs() -> None:
    """Lost, the frame holds the search region around its centre inside the edge margin: a
    frame 480 px high with a 0.15 margin holds a circle of atan(168 / f); the zoom goes out
    to the longest f that holds the region, as the region grows, and never in."""
    zc = control(zoom_out_rate_s=0.5, zoom_out_edge=0.15)

    def lost(t_s: float, region_deg: float, zoom_now: float) -> float | None:
        out = zc.apply(
            demand(), "lost", odometry(zoom_now), round(t_s * S), t_s, 0.0, math.radians(region_deg)
        )
        assert out is not None
        return out.zoom

    # zoom 0.9, f = 4550: the frame holds 2.11°; a region of 1° fits, and the view stays
    assert lost(0.0, 1.0, 0.9) == 0.9
    assert lost(0.5, 2.0, 0.9) == 0.9
    # a region of 4° needs f <= 168 / tan 4°, zoom (f - 500) / 4500, reached at 0.5 per second
    goal = (168.0 / math.tan(math.radians(4.0)) - 500.0) / 4500.0
    assert lost(1.0, 4.0, 0.9) == pytest.approx(0.65)
    assert lost(1.5, 4.0, 0.65) == pytest.approx(goal)
    assert lost(2.0, 4.0, goal) == pytest.approx(goal)
    # the region never narrows the view while lost
    assert lost(2.5, 1.0, goal) == pytest.approx(goal)
    # without a region (no prediction to coast on), the widest, as when reacquiring
    assert run(zc, "lost", 3.0, zoom_now=goal) == pytest.approx(goal - 0.25)
