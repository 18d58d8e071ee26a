"""The target's height learnt from its boxes and its distance, and the zoom's size from it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_gaze_zoom import H, S, lens, run, seen

from gazed.config import GazeSection
from gazed.gaze.median_error import median_and_error
from gazed.gaze.pursuit import Pursuit
from gazed.gaze.sightings import Sightings
from gazed.gaze.target_height import (
    TargetHeight,
    angular_height_rad,
    body_height_m,
)
from gazed.gaze.zoom import ZoomControl
from gazed.geometry.image_roll import rolled_box
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import Detection, HeadPose, Mover, Prediction

CAMERA_XYZ_M = (1.0, -2.0, 3.0)
PERSON_M = 1.7


def spanned_rad(camera_xyz_m: tuple[float, float, float], feet_xy_m: tuple[float, float]) -> float:
    """The angle between the camera's rays to a person's feet and head, from the vectors."""
    camera = np.array(camera_xyz_m)
    feet = np.array([*feet_xy_m, 0.0]) - camera
    head = np.array([*feet_xy_m, PERSON_M]) - camera
    return math.acos(feet @ head / (np.linalg.norm(feet) * np.linalg.norm(head)))


@pytest.mark.parametrize("feet_xy_m", [(1.0, 0.5), (4.0, 10.0), (-20.0, 30.0)])
def test_the_angle_a_body_spans_and_the_height_a_box_says_invert_each_other(
    feet_xy_m: tuple[float, float],
) -> None:
    distance_m = TargetHeight(CAMERA_XYZ_M).distance_m(feet_xy_m)
    angle = angular_height_rad(CAMERA_XYZ_M[2], distance_m, PERSON_M)
    assert angle == pytest.approx(spanned_rad(CAMERA_XYZ_M, feet_xy_m), rel=1e-9)
    assert body_height_m(CAMERA_XYZ_M[2], distance_m, angle) == pytest.approx(PERSON_M)
    # a box spanning more than the ground's below-the-camera to the zenith is no body
    assert body_height_m(CAMERA_XYZ_M[2], distance_m, math.pi) is None


def test_a_tracks_height_is_the_median_of_its_sightings_and_another_track_starts_afresh() -> None:
    height = TargetHeight(CAMERA_XYZ_M)
    assert height.height_m() == (pytest.approx(math.nan, nan_ok=True), math.inf)
    rng = np.random.default_rng(2)
    for k in range(60):
        feet = (float(rng.uniform(-5, 5)), float(rng.uniform(3, 15)))
        angle = spanned_rad(CAMERA_XYZ_M, feet)
        # a quarter of the boxes are a standing person's hand: a fifth of the body
        height.learn(7, feet, angle * (0.2 if k % 4 == 0 else 1.0))
    at_m, error = height.height_m()
    assert at_m == pytest.approx(PERSON_M)
    assert error == pytest.approx(0.0)
    angle, _ = height.angle_rad((2.0, 9.0))
    assert angle == pytest.approx(spanned_rad(CAMERA_XYZ_M, (2.0, 9.0)))
    height.learn(8, (2.0, 9.0), spanned_rad(CAMERA_XYZ_M, (2.0, 9.0)) / 2.0)
    assert len(height.log_heights) == 1 and height.height_m()[0] < PERSON_M / 1.9


def prediction(t_s: float, y_m: float, speed_m_s: float) -> Prediction:
    return Prediction(
        t_capture_ns=round(t_s * S),
        filter="imm",
        t_effect_ns=round(t_s * S),
        horizon_s=0.2,
        pan_rad=0.0,
        tilt_rad=0.0,
        pan_rate_rad_s=0.0,
        tilt_rate_rad_s=0.0,
        ground_xy_m=(CAMERA_XYZ_M[0], y_m),
        ground_velocity_m_s=(0.0, speed_m_s),
        visual_latency_s=0.15,
        actuation_latency_s=0.03,
        track_id=3,
    )


@pytest.mark.parametrize("ground", [True, False], ids=["at its distance", "by its boxes alone"])
def test_a_person_who_stops_is_sized_by_their_distance_not_by_what_still_moves(
    ground: bool,
) -> None:
    """A person walks away for 4 s with whole boxes, then stands 12 m from below the camera,
    where the zoom already shows them at the setpoint; standing, the motion detector's boxes
    are what still moves of them, a third of the body frame after frame. Sized at their
    distance, by the height their walking taught, the zoom stays; by the boxes alone it goes in
    on the third."""
    zoom, f_px = 0.3, 500.0 + 4500.0 * 0.3  # the lens of tests/test_gaze_zoom.py
    section = GazeSection(
        zoom_control=True, zoom_in_steady_ms=0.0, zoom_deadband=0.05, zoom_box_margin_px=0.0
    )
    zoom_lens = lens()
    kinematics = HeadKinematics()
    pursuit = Pursuit(section, 0.05, zoom_lens, kinematics)
    zc = ZoomControl(
        section.model_copy(
            update={"zoom_target_height": 2 * f_px * math.tan(standing_rad() / 2) / H}
        ),
        zoom_lens,
        Sightings(section, 0.04, zoom_lens, kinematics),
        pursuit,
        CAMERA_XYZ_M if ground else None,
    )

    def box_px(y_m: float) -> float:
        return 2.0 * f_px * math.tan(spanned_rad(CAMERA_XYZ_M, (CAMERA_XYZ_M[0], y_m)) / 2.0)

    for k in range(100):  # walking from 8 m to 12 m away at 1 m/s, 25 Hz
        t_s, y_m = 0.04 * k, CAMERA_XYZ_M[1] + 8.0 + 0.04 * k
        pursuit.on_prediction(prediction(t_s, y_m, 1.0))
        zc.on_detection(seen(t_s, box_px(y_m), zoom=zoom))
    y_m = CAMERA_XYZ_M[1] + 12.0
    demanded = []
    for k in range(100, 150):  # standing: a third of the body, frame after frame
        t_s = 0.04 * k
        pursuit.on_prediction(prediction(t_s, y_m, 0.0))
        zc.sightings.found = seen(t_s, box_px(y_m) / 3.0, zoom=zoom)
        demanded.append(run(zc, "pursuit", t_s, zoom_now=zoom))
    if ground:
        assert demanded == [zoom] * len(demanded)
    else:
        assert demanded[-1] > zoom + 0.1  # on its way in


def standing_rad() -> float:
    return spanned_rad(CAMERA_XYZ_M, (CAMERA_XYZ_M[0], CAMERA_XYZ_M[1] + 12.0))


def test_the_median_error_is_a_medians_standard_error_on_a_normal_sample() -> None:
    rng = np.random.default_rng(4)
    sigma, n = 0.3, 4000
    at, error = median_and_error(1.5 + sigma * rng.standard_normal(n))
    assert at == pytest.approx(1.5, abs=3 * error)
    assert error == pytest.approx(1.2533 * sigma / math.sqrt(n), rel=0.05)
    assert median_and_error(np.array([2.0, 2.0, 2.0, 40.0])) == (2.0, 0.0)  # one wild value


@pytest.mark.parametrize("rolled", [True, False], ids=["rolled", "taken upright"])
def test_a_body_seen_rolled_is_sized_rolled_where_it_stops(rolled: bool) -> None:
    """A head whose image rolls as it pans (here the roll is the pan): a body as wide as tall
    (the simulator's target) walks away with the head at pan 0, unrolled, then stands 12 m
    away with the head panned 0.5 rad, where the box of the rolled body is taller than the
    upright body's and the zoom shows it at the setpoint; standing, the boxes are a third of
    it. With the roll, the size at the distance is the rolled box's, and the zoom stays;
    taking the body upright, it is the upright body's, smaller, and the zoom goes in."""
    zoom, f_px = 0.3, 500.0 + 4500.0 * 0.3
    aspect, pan_standing = 1.0, 0.5  # rolled 0.5 rad, its box is 1.36 times its height
    section = GazeSection(
        zoom_control=True, zoom_in_steady_ms=0.0, zoom_deadband=0.05, zoom_box_margin_px=0.0
    )
    zoom_lens, kinematics = lens(), HeadKinematics()
    pursuit = Pursuit(section, 0.05, zoom_lens, kinematics)

    def box_px(y_m: float, pan_rad: float) -> tuple[float, float]:
        height = 2.0 * f_px * math.tan(spanned_rad(CAMERA_XYZ_M, (CAMERA_XYZ_M[0], y_m)) / 2.0)
        return rolled_box(height, aspect * height, pan_rad)

    standing_box = box_px(CAMERA_XYZ_M[1] + 12.0, pan_standing)
    zc = ZoomControl(
        section.model_copy(update={"zoom_target_height": standing_box[0] / H}),
        zoom_lens,
        Sightings(section, 0.04, zoom_lens, kinematics),
        pursuit,
        CAMERA_XYZ_M,
        (lambda pan_rad, tilt_rad: pan_rad) if rolled else None,
    )

    def sighting(t_s: float, box: tuple[float, float], pan_rad: float) -> Detection:
        mover = Mover(u_px=320.0, v_px=240.0, box_width_px=box[1], box_height_px=box[0])
        return seen(t_s, box[0], zoom=zoom).model_copy(
            update={"movers": (mover,), "head": HeadPose(pan_rad=pan_rad, tilt_rad=0.0, zoom=zoom)}
        )

    for k in range(100):  # walking from 8 m to 12 m away at 1 m/s, 25 Hz, unrolled
        t_s, y_m = 0.04 * k, CAMERA_XYZ_M[1] + 8.0 + 0.04 * k
        pursuit.on_prediction(prediction(t_s, y_m, 1.0))
        zc.on_detection(sighting(t_s, box_px(y_m, 0.0), 0.0))
    y_m = CAMERA_XYZ_M[1] + 12.0
    demanded = []
    for k in range(100, 150):  # standing, the head panned: a third of the rolled box
        t_s = 0.04 * k
        pursuit.on_prediction(
            prediction(t_s, y_m, 0.0).model_copy(update={"pan_rad": pan_standing})
        )
        third = (standing_box[0] / 3.0, standing_box[1] / 3.0)
        zc.sightings.found = sighting(t_s, third, pan_standing)
        demanded.append(run(zc, "pursuit", t_s, zoom_now=zoom))
    if rolled:
        assert demanded == [zoom] * len(demanded)
    else:
        assert demanded[-1] > zoom + 0.1  # on its way in, to 1.36 times the focal length
