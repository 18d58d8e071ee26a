"""CP / CV / CA of seed 003 Tables 1-2, and the linear Kalman filter against filterpy."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import KalmanFilter

from gazed.config import EstimatorSection
from gazed.estimation import Measurement, build_estimator
from gazed.estimation.kinematic_models import KinematicModelBank, kinematic_model

T = 0.25
BANK = KinematicModelBank(
    (kinematic_model("CP", 0.04), kinematic_model("CV", 0.25), kinematic_model("CA", 0.36))
)


def test_transition_matrices_are_table_2() -> None:
    F, _ = BANK.matrices(np.array(T))
    cp, cv, ca = F[:, :3, :3]
    np.testing.assert_array_equal(cp, [[1, 0, 0], [0, 0, 0], [0, 0, 0]])
    np.testing.assert_array_equal(cv, [[1, T, 0], [0, 1, 0], [0, 0, 0]])
    np.testing.assert_array_equal(ca, [[1, T, T * T / 2], [0, 1, T], [0, 0, 1]])
    np.testing.assert_array_equal(F[:, 3:, 3:], F[:, :3, :3])  # y axis
    assert not F[:, :3, 3:].any() and not F[:, 3:, :3].any()  # axes independent


def test_process_noise_is_table_1_gain_squared() -> None:
    _, Q = BANK.matrices(np.array(T))
    for m, (q, C) in enumerate(
        [
            (0.04, [T, 0, 0]),
            (0.25, [T * T / 2, T, 0]),
            (0.36, [T**3 / 6, T * T / 2, T]),
        ]
    ):
        C = np.array(C)
        np.testing.assert_allclose(Q[m, :3, :3], q * np.outer(C, C), atol=1e-16)
        np.testing.assert_allclose(Q[m, 3:, 3:], q * np.outer(C, C), atol=1e-16)
    # the CV block is filterpy's discrete white-noise acceleration model
    np.testing.assert_allclose(Q[1, :2, :2], Q_discrete_white_noise(2, T, 0.25), atol=1e-16)


def test_matrices_take_a_batch_of_intervals() -> None:
    dts = np.array([0.1, 0.5, 2.0])
    F, Q = BANK.matrices(dts)
    assert F.shape == (3, 3, 6, 6)
    for i, dt in enumerate(dts):
        Fi, Qi = BANK.matrices(np.array(dt))
        np.testing.assert_allclose(F[i], Fi)
        np.testing.assert_allclose(Q[i], Qi)


@pytest.mark.parametrize("mode", ["cv", "ca"])
def test_linear_filter_matches_filterpy(mode: str) -> None:
    """Same F, Q, H, R and start: our batched Kalman filter equals filterpy's to 1e-9."""
    section = EstimatorSection(gate_probability=0.999999)
    ours = build_estimator(section, mode=mode)
    rng = np.random.default_rng(3)
    R = np.diag([0.04, 0.09])
    dt = 0.1
    t = 0.0
    kf = None
    for k in range(150):
        t += dt
        z = np.array([0.3 * t + 0.05 * t * t, -0.2 * t]) + rng.normal(0, [0.2, 0.3])
        ours.update(Measurement.ground(t, z, R))
        if k == 1:  # started from two points: copy that start into filterpy
            kf = KalmanFilter(6, 2)
            kf.F, kf.Q = (a[0] for a in ours.bank.matrices(np.array(dt)))
            kf.H = np.zeros((2, 6))
            kf.H[0, 0] = kf.H[1, 3] = 1.0
            kf.R = R
            kf.x, kf.P = ours.x[0, 0].copy(), ours.P[0, 0].copy()
        elif kf is not None:
            kf.predict()
            kf.update(z)
            np.testing.assert_allclose(ours.x[0, 0], kf.x, rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(ours.P[0, 0], kf.P, rtol=1e-9, atol=1e-12)
    assert ours.health()["accepted"] == 148
