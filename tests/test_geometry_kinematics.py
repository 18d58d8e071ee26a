"""Head kinematics: the axis conventions, the frontal plane of DESIGN §4 / seed 000 §3, their
inverses, and every Jacobian against central finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gazed.config import HeadSection
from gazed.geometry.kinematics import HeadKinematics, device_from_joint, joint_from_device

KINEMATICS = ["pan-tilt", "tilt-pan"]
STEP = 1e-6


def random_angles(seed: int, n: int = 40, limit_deg: float = 75.0) -> np.ndarray:
    return np.radians(np.random.default_rng(seed).uniform(-limit_deg, limit_deg, (n, 2)))


def central_difference(f, x: np.ndarray, step: float = STEP) -> np.ndarray:
    columns = []
    for k in range(len(x)):
        dx = np.zeros(len(x))
        dx[k] = step
        columns.append((np.asarray(f(x + dx)) - np.asarray(f(x - dx))) / (2 * step))
    return np.stack(columns, axis=-1)


@pytest.mark.parametrize("kinematics", KINEMATICS)
def test_axis_signs_pan_right_tilt_up(kinematics: str) -> None:
    head = HeadKinematics(kinematics)
    assert head.gaze(0.0, 0.0) == pytest.approx([0, 0, 1])
    assert head.gaze(0.3, 0.0)[0] > 0  # pan > 0 looks towards +x (right)
    assert head.gaze(0.0, 0.3)[1] > 0  # tilt > 0 looks towards +y (up)
    # the camera's own axes: x right and y up at rest; OpenCV's y (down) flipped
    assert head.camera_to_base(0.0, 0.0) @ np.array([0, 1, 0]) == pytest.approx([0, -1, 0])


@pytest.mark.parametrize("kinematics", KINEMATICS)
def test_frontal_point_formula_of_design_section_4(kinematics: str) -> None:
    head = HeadKinematics(kinematics)
    for pan, tilt in random_angles(1):
        x, y = head.frontal_from_angles(pan, tilt)
        if kinematics == "pan-tilt":
            expected = (math.tan(pan), math.tan(tilt) / math.cos(pan))
        else:
            expected = (math.tan(pan) / math.cos(tilt), math.tan(tilt))
        assert (x, y) == pytest.approx(expected, rel=1e-12)
        gaze = head.gaze(pan, tilt)
        assert gaze[:2] / gaze[2] == pytest.approx([x, y], rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("kinematics", KINEMATICS)
def test_inverses_are_identities(kinematics: str) -> None:
    head = HeadKinematics(kinematics)
    angles = random_angles(2)
    for pan, tilt in angles:
        assert head.angles_from_frontal(*head.frontal_from_angles(pan, tilt)) == pytest.approx(
            (pan, tilt), abs=1e-12
        )
    # directions of any length, also behind the frontal plane, vectorised
    if kinematics == "pan-tilt":
        wide = np.column_stack([np.linspace(-3.0, 3.0, 40), angles[:, 1]])
    else:
        wide = np.column_stack([angles[:, 0], np.linspace(-3.0, 3.0, 40)])
    rays = np.array([3.7 * head.gaze(p, t) for p, t in wide])
    pan, tilt = head.angles_from_direction(rays)
    assert np.abs(pan - wide[:, 0]).max() < 1e-12 and np.abs(tilt - wide[:, 1]).max() < 1e-12


@pytest.mark.parametrize("kinematics", KINEMATICS)
def test_every_jacobian_matches_finite_differences(kinematics: str) -> None:
    head = HeadKinematics(kinematics)
    for pan, tilt in random_angles(3, n=15):
        x = np.array([pan, tilt])
        d_pan, d_tilt = head.rotation_derivatives(pan, tilt)
        numeric = central_difference(lambda a: head.rotation(*a), x)
        assert np.abs(numeric[..., 0] - d_pan).max() < 1e-8
        assert np.abs(numeric[..., 1] - d_tilt).max() < 1e-8
        assert (
            np.abs(
                central_difference(lambda a: head.frontal_from_angles(*a), x)
                - head.frontal_jacobian(pan, tilt)
            ).max()
            < 1e-7
        )
        frontal = np.array(head.frontal_from_angles(pan, tilt))
        analytic = head.angles_jacobian(*frontal)
        assert (
            np.abs(
                central_difference(lambda f: head.angles_from_frontal(*f), frontal) - analytic
            ).max()
            < 1e-8
        )
        assert analytic @ head.frontal_jacobian(pan, tilt) == pytest.approx(np.eye(2), abs=1e-9)
        ray = 2.5 * head.gaze(pan, tilt) + np.array([0.1, -0.2, 0.05])
        assert (
            np.abs(
                central_difference(lambda d: np.array(head.angles_from_direction(d)), ray)
                - head.direction_angles_jacobian(ray)
            ).max()
            < 1e-8
        )


@pytest.mark.parametrize("kinematics", KINEMATICS)
def test_gazes_that_miss_the_frontal_plane_are_refused(kinematics: str) -> None:
    head = HeadKinematics(kinematics)
    for pan, tilt in ((math.radians(90), 0.1), (0.1, math.radians(-95)), (math.radians(120), 0.0)):
        with pytest.raises(ValueError, match="frontal plane"):
            head.frontal_from_angles(pan, tilt)


def test_device_angles_round_trip_with_signs_and_zero_offsets() -> None:
    head = HeadSection(pan_sign=-1, tilt_sign=-1, pan_zero_deg=12.0, tilt_zero_deg=-3.0)
    pan, tilt = joint_from_device(head, math.radians(12.0 - 30.0), math.radians(-3.0 - 10.0))
    assert (pan, tilt) == pytest.approx((math.radians(30.0), math.radians(10.0)))
    assert device_from_joint(head, pan, tilt) == pytest.approx(
        (math.radians(-18.0), math.radians(-13.0))
    )
