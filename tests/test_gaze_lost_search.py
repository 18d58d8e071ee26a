"""The lost search (gazed.gaze.lost_search): the region's growth with time and with the
prediction's covariance, and the tour of its edge, stop by stop, against closed forms."""

from __future__ import annotations

import math

import pytest
from test_gaze_controller import Clock, prediction

from gazed.config import parse_rig
from gazed.gaze.aim import MoveLimits
from gazed.gaze.lost_search import LostSearch
from gazed.messages import Prediction

# fovea 3°, settle 100 ms, 3 detections at 25 Hz; pan 120°/s, 600°/s²; tilt 90°/s, 600°/s²
RIG = parse_rig(
    '[rig]\nname = "l"\n[camera]\nrate_hz = 25\n'
    "[head]\npan_rate_max_deg_s = 120\npan_accel_max_deg_s2 = 600\n"
    "tilt_rate_max_deg_s = 90\ntilt_accel_max_deg_s2 = 600\n"
    "[gaze]\nfovea_half_angle_deg = 3\nsettle_ms = 100\nreacquire_detections = 3\n"
    "lost_search_growth_deg_s = 10\nlost_search_max_deg = 40\n"
)
DEG = math.radians(1.0)
T0 = 10**18
MONO0 = 50.0
LATENCY_S = 0.15
LOOK_FRAMES_S = (3 + 1) * 0.04


def search(camera_xyz_m: tuple[float, float, float] | None = (0.0, 0.0, 3.0)) -> LostSearch:
    limits = MoveLimits(RIG.head.rate_max_rad_s, RIG.head.accel_max_rad_s2)
    return LostSearch(RIG.gaze, 3 * DEG, camera_xyz_m, limits, RIG.camera.frame_period_s)


def coasting(cov=None) -> Prediction:
    """A prediction 5 m ahead of the camera, with a position covariance or without one."""
    return prediction(Clock(), 0.0, 0.0).model_copy(
        update={"ground_xy_m": (0.0, 5.0), "position_cov_m2": cov}
    )


def test_the_region_grows_with_time_without_a_covariance() -> None:
    s = search()
    assert s.radius_rad(None, 0.5) == pytest.approx(5 * DEG)
    assert s.radius_rad(coasting(), 1.2) == pytest.approx(12 * DEG)
    assert s.max_radius_rad == pytest.approx(40 * DEG)


def test_the_region_is_the_covariance_seen_from_the_camera_where_that_is_wider() -> None:
    """Covariance [[3, 1], [1, 3]] m²: largest eigenvalue 4, 2 m; 5 m ahead of a camera 3 m
    up, that is 2 / sqrt(34) rad."""
    s = search()
    p = coasting(cov=((3.0, 1.0), (1.0, 3.0)))
    assert s.radius_rad(p, 0.1) == pytest.approx(2.0 / math.sqrt(34.0))
    assert s.radius_rad(p, 3.0) == pytest.approx(30 * DEG)  # time has outgrown it
    # without the camera's position the covariance cannot be turned into an angle
    assert search(camera_xyz_m=None).radius_rad(p, 0.1) == pytest.approx(1 * DEG)


def test_no_tour_while_the_region_fits_in_the_fovea() -> None:
    s = search()
    assert s.stop(3 * DEG, LATENCY_S, T0, MONO0) == (None, False)
    assert s.scan is None and not s.from_the_move(T0 - 1)


def test_the_tour_stops_a_fovea_apart_on_the_ring_each_held_for_a_look() -> None:
    s = search()
    # region 5°: a ring of 2° around the prediction; the first stop is straight right
    first, began = s.stop(5 * DEG, LATENCY_S, T0, MONO0)
    assert began and first is not None
    assert first.offset_rad == pytest.approx((2 * DEG, 0.0))
    move_s = 2 * math.sqrt(2 / 600)  # 2° of pan, a triangle profile
    look_s = move_s + 0.1
    assert first.look_from_ns == T0 + round(look_s * 1e9)
    assert first.next_s == pytest.approx(MONO0 + look_s + LOOK_FRAMES_S + LATENCY_S)
    # detections captured on the way there come from the move
    assert s.from_the_move(first.look_from_ns - 1) and not s.from_the_move(first.look_from_ns)
    # the stop is held for its look, whatever the region does meanwhile
    held, began = s.stop(7 * DEG, LATENCY_S, T0 + 10**8, first.next_s - 1e-3)
    assert held is first and not began
    # then the next stop: 2 fovea / ring round (1.5 rad on a ring of 4°)
    second, began = s.stop(7 * DEG, LATENCY_S, T0 + 10**9, first.next_s)
    assert began and second is not None
    assert second.phase_rad == pytest.approx(1.5)
    assert second.offset_rad == pytest.approx((4 * DEG * math.cos(1.5), 4 * DEG * math.sin(1.5)))
    pan_move, tilt_move = 4 * math.cos(1.5) - 2, 4 * math.sin(1.5)  # degrees
    move_s = max(2 * math.sqrt(abs(pan_move) / 600), 2 * math.sqrt(tilt_move / 600))
    assert second.look_from_ns == T0 + 10**9 + round((move_s + 0.1) * 1e9)


def test_a_small_ring_is_toured_in_at_least_three_stops() -> None:
    s = search()
    first, _ = s.stop(3.5 * DEG, LATENCY_S, T0, MONO0)
    assert first is not None
    second, _ = s.stop(3.5 * DEG, LATENCY_S, T0, first.next_s)
    assert second is not None
    assert second.phase_rad == pytest.approx(2 * math.pi / 3)  # not 2 fovea / 0.5°: 12 rad


def test_a_reset_starts_the_tour_again() -> None:
    s = search()
    s.stop(5 * DEG, LATENCY_S, T0, MONO0)
    s.reset()
    assert s.scan is None and not s.from_the_move(T0)
    again, began = s.stop(6 * DEG, LATENCY_S, T0, MONO0 + 0.01)
    assert began and again is not None and again.phase_rad == 0.0
