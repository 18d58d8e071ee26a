"""Association on synthetic scenes: two or three people who cross, pass and walk side by side at
0.5-1.5 m/s, seen at 7 Hz with a detector's noise; each person's track keeps its person."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from filterpy.common import Q_continuous_white_noise
from filterpy.kalman import KalmanFilter

from gazed.estimation.appearance_model import TrackAppearance, fits
from gazed.estimation.association import (
    associate,
    gate_threshold,
    group_prediction,
    hellinger_squared,
    load_solver,
    member_measurement,
    pair_costs,
    same_target,
)
from gazed.estimation.duplicates import PERSON_EXTENT_COV_M2, Takes, seen_apart
from gazed.estimation.measurement import Measurement
from gazed.estimation.results import PredictedState

RATE_HZ = 7.0
NOISE_M = 0.12  # a detector's ground error, 1 sigma per axis
Q_M2_S3 = 0.5  # walkers' white-noise acceleration
GATE = gate_threshold(0.997, 2)


def walker(start, velocity, seconds=8.0):
    t = np.arange(0.0, seconds, 1.0 / RATE_HZ)
    return np.asarray(start) + t[:, None] * np.asarray(velocity)


SCENES = {
    # two people crossing at right angles in the middle, 1.2 and 0.8 m/s
    "crossing": [walker((-4.8, 0.0), (1.2, 0.0)), walker((0.0, -3.2), (0.0, 0.8))],
    # passing each other in opposite directions, 0.5 m apart
    "passing": [walker((-5.0, 0.25), (1.3, 0.0)), walker((5.0, -0.25), (-1.1, 0.0))],
    # walking side by side, 0.6 m apart, 1.0 m/s, a third overtaking them at 1.5 m/s between
    "side by side": [
        walker((-4.0, 0.3), (1.0, 0.0)),
        walker((-4.0, -0.3), (1.0, 0.0)),
        walker((-7.0, 0.0), (1.5, 0.0)),
    ],
    # three crossing at one point at 0.5, 1.0 and 1.5 m/s
    "three crossing": [
        walker((-2.0, 0.0), (0.5, 0.0)),
        walker((0.0, -4.0), (0.0, 1.0)),
        walker((-4.2, -4.2), (1.5 / np.sqrt(2), 1.5 / np.sqrt(2))),
    ],
}


def track_for(first: np.ndarray, second: np.ndarray) -> KalmanFilter:
    dt = 1.0 / RATE_HZ
    kf = KalmanFilter(dim_x=4, dim_z=2)
    kf.F = np.kron(np.eye(2), np.array([[1.0, dt], [0.0, 1.0]]))
    kf.H = np.kron(np.eye(2), np.array([[1.0, 0.0]]))
    kf.R = np.eye(2) * NOISE_M**2
    kf.Q = np.kron(np.eye(2), Q_continuous_white_noise(2, dt, Q_M2_S3))
    v = (second - first) / dt
    kf.x = np.array([second[0], v[0], second[1], v[1]])
    r = NOISE_M**2
    kf.P = np.kron(np.eye(2), np.array([[r, r / dt], [r / dt, 2 * r / dt**2]]))
    return kf


def run(paths, seed: int, appearance: bool) -> list[list[int]]:
    """Each track's person frame by frame, from the third frame on (detections shuffled)."""
    rng = np.random.default_rng(seed)
    people = len(paths)
    colours = rng.dirichlet(np.ones(16) * 0.5, people)  # each person's own histogram
    seen = lambda i: rng.dirichlet(colours[i] * 200 + 0.1)  # noqa: E731  one frame's histogram
    # each track's appearance model, as the tracker learns it from 20 of its person's detections
    learnt = []
    for i in range(people):
        look = TrackAppearance(seen(i))
        for _ in range(19):
            look.take(seen(i))
        learnt.append(look)
    templates, means, shapes = fits(learnt, colours.shape[1])
    z = [p + rng.normal(0, NOISE_M, p.shape) for p in paths]
    tracks = [track_for(z[i][0], z[i][1]) for i in range(people)]
    owners: list[list[int]] = [[] for _ in range(people)]
    for k in range(2, len(paths[0])):
        order = rng.permutation(people)
        measured = np.array([z[i][k] for i in order])
        looks = np.array([seen(i) for i in order])
        for kf in tracks:
            kf.predict()
        predicted = np.array([kf.H @ kf.x for kf in tracks])
        S = np.array([kf.H @ kf.P @ kf.H.T + kf.R for kf in tracks])
        costs = pair_costs(
            predicted,
            S,
            measured,
            GATE,
            *((templates, looks, means, shapes) if appearance else ()),
        )
        result = associate(costs)
        for row, column in result.pairs:
            tracks[row].update(measured[column])
            owners[row].append(int(order[column]))
        for row in result.lone_tracks:
            owners[row].append(-1)
    return owners


def swaps(scene: str, appearance: bool, seeds: range = range(10)) -> int:
    """Frames in which a track took another person's detection, over all seeds."""
    total = 0
    for seed in seeds:
        for person, frames in enumerate(run(SCENES[scene], seed, appearance)):
            total += sum(o not in (person, -1) for o in frames)
            assert frames.count(-1) <= 2  # a detection lost to the gate now and then at most
    return total


@pytest.mark.parametrize("scene", SCENES)
def test_each_track_keeps_its_person(scene: str) -> None:
    assert swaps(scene, appearance=True) == 0


def test_at_an_exact_crossing_it_is_the_appearance_that_keeps_them_apart() -> None:
    # three people at one point at one instant: positions alone cannot tell them apart there
    assert swaps("three crossing", appearance=False) > 0


def test_the_gate_and_the_joint_assignment() -> None:
    predicted = np.array([[0.0, 0.0], [1.0, 0.0]])
    S = np.array([np.eye(2) * 0.04, np.eye(2) * 0.04])
    # detection 0 is nearest to track 0 but detection 1 is only reachable by track 0 as well:
    # jointly, track 0 takes detection 1? No — track 1 takes 0.55, track 0 takes 0.05
    measured = np.array([[0.55, 0.0], [0.05, 0.0], [9.0, 9.0]])
    result = associate(pair_costs(predicted, S, measured, gate_threshold(0.99, 2)))
    assert sorted(result.pairs) == [(0, 1), (1, 0)]
    assert result.lone_detections == (2,)  # far outside every gate
    assert np.isinf(result.costs[:, 2]).all()


def test_a_wide_prediction_does_not_win_by_its_width() -> None:
    # the same distance to both; the confident track's likelihood is higher
    predicted = np.array([[0.0, 0.0], [0.0, 0.0]])
    S = np.array([np.eye(2) * 0.01, np.eye(2) * 1.0])
    costs = pair_costs(predicted, S, np.array([[0.05, 0.0]]), gate_threshold(0.99, 2))
    assert associate(costs).pairs == ((0, 0),)


def test_appearance_decides_where_positions_are_ambiguous() -> None:
    predicted = np.array([[0.0, 0.3], [0.0, -0.3]])
    S = np.array([np.eye(2) * 0.09, np.eye(2) * 0.09])
    red, blue = np.array([0.9, 0.1]), np.array([0.1, 0.9])
    measured = np.array([[0.0, 0.02], [0.0, -0.02]])  # nearly on top of each other
    colours = np.array([red, blue])
    costs = pair_costs(
        predicted,
        S,
        measured,
        gate_threshold(0.99, 2),
        colours,
        colours[::-1],
        np.full(2, 0.02),
        np.ones(2),
    )
    assert sorted(associate(costs).pairs) == [(0, 1), (1, 0)]


def test_hellinger_distance() -> None:
    a = np.array([[0.5, 0.5], [1.0, 0.0], [0.0, 1.0]])
    h2 = hellinger_squared(a, a)
    assert np.allclose(np.diag(h2), 0.0)
    assert h2[0, 1] == pytest.approx(1.0 - np.sqrt(0.5))
    assert h2[1, 2] == pytest.approx(1.0)


def test_empty_sides() -> None:
    result = associate(pair_costs(np.zeros((0, 2)), np.zeros((0, 2, 2)), np.ones((2, 2)), 9.0))
    assert result.pairs == () and result.lone_detections == (0, 1)


def test_one_track_or_one_detection_takes_its_least_cost_in_the_gate() -> None:
    one_track = np.array([[4.0, np.inf, 1.5, 2.0]])
    assert associate(one_track).pairs == ((0, 2),)
    assert associate(one_track).lone_detections == (0, 1, 3)
    one_detection = np.array([[np.inf], [3.0], [0.5]])
    assert associate(one_detection).pairs == ((2, 0),)
    assert associate(one_detection).lone_tracks == (0, 1)
    assert associate(np.full((1, 3), np.inf)).pairs == ()


def test_the_solver_is_imported_on_a_thread_of_its_own() -> None:
    thread = load_solver()
    thread.join(timeout=30.0)
    assert not thread.is_alive() and "scipy.optimize" in sys.modules


def state(xy: tuple[float, float], v: tuple[float, float], sd_m: float = 0.03) -> PredictedState:
    cov = np.diag([sd_m**2, sd_m**2, (2 * sd_m) ** 2, (2 * sd_m) ** 2])
    return PredictedState(0.0, np.array(xy), np.array(v), cov)


def test_same_target_is_the_track_to_track_test_with_the_extent() -> None:
    gate = gate_threshold(0.999, 4)
    extent = np.eye(2) * 0.5**2 / 12
    walking = state((0.0, 1.0), (1.0, 0.0))
    part = state((0.0, 1.25), (1.0, 0.05))  # another part of the same walker
    assert not same_target(walking, part, gate)  # 0.25 m apart: 6 sigma without the extent
    assert same_target(walking, part, gate, extent)
    assert not same_target(walking, state((0.0, 2.2), (1.0, 0.0)), gate, extent)  # someone else
    crossing = state((0.0, 1.0), (-1.0, 0.0))  # the same place, the other way
    assert not same_target(walking, crossing, gate, extent)
    assert walking.covariance[0, 0] == pytest.approx(0.03**2)  # the inputs are left alone


def test_same_target_where_no_state_has_a_spread_on_an_axis() -> None:
    gate = gate_threshold(0.999, 4)
    flat = np.diag([0.01, 0.01, 0.01, 0.0])  # a model without spread in the y velocity
    a = PredictedState(0.0, np.array([0.0, 1.0]), np.array([1.0, 0.0]), flat)
    near = PredictedState(0.0, np.array([0.0, 1.1]), np.array([1.0, 0.0]), flat.copy())
    turning = PredictedState(0.0, np.array([0.0, 1.1]), np.array([1.0, 0.1]), flat.copy())
    assert same_target(a, near, gate)
    assert not same_target(a, turning, gate)


def test_a_blob_of_two_is_their_centroid_widened_by_their_unknown_shares() -> None:
    predicted = np.array([[0.0, 0.0], [1.0, 0.0]])
    P = np.array([np.eye(2) * 0.04, np.eye(2) * 0.01])
    R = np.eye(2) * 0.0025
    mean, S = group_prediction(predicted, P, R)
    delta = predicted[1] - predicted[0]
    assert mean == pytest.approx([0.5, 0.0])
    # the share w of a blob, uniform on [0, 1]: var(w Δ) = ΔΔᵀ/12
    assert pytest.approx(P.sum(axis=0) / 4 + R + np.outer(delta, delta) / 12) == S
    z = Measurement.ground(1.0, (0.6, 0.1), R)
    states = [PredictedState(1.0, p, np.zeros(2), np.eye(4) * 0.04) for p in predicted]
    states[1] = PredictedState(1.0, predicted[1], np.zeros(2), np.diag([0.01, 0.01, 1.0, 1.0]))
    y = z.position - mean
    blob_d2 = y @ np.linalg.solve(S, y)
    for k, state in enumerate(states):  # each member's own d² is the blob's
        m = member_measurement(z, k, states)
        own = m.position - state.position
        d2 = own @ np.linalg.solve(state.covariance[:2, :2] + m.position_cov, own)
        assert d2 == pytest.approx(blob_d2)
    assert member_measurement(z, 0, states).position == pytest.approx([0.2, 0.2])


def test_movers_taken_in_the_same_frames_tell_two_people_apart() -> None:
    """Pooled over the frames both tracks took a mover: parts of one person (0.25 m apart,
    within a person's extent) are one, people 1 m apart are two, and tracks that never took a
    mover in the same frame are not told apart by their movers."""
    cov = np.eye(2) * 0.01
    a, near, far, later = Takes(), Takes(), Takes(), Takes()
    for k in range(4):
        t = k / 7.0
        a.add(Measurement.ground(t, (t, 0.0), cov), cov)
        near.add(Measurement.ground(t, (t, 0.25), cov), cov)
        far.add(Measurement.ground(t, (t, 1.0), cov), cov)
        later.add(Measurement.ground(t + 10.0, (t, 0.0), cov), cov)
    assert not seen_apart(a, near, PERSON_EXTENT_COV_M2, 0.999)
    assert seen_apart(a, far, PERSON_EXTENT_COV_M2, 0.999)
    assert not seen_apart(a, later, PERSON_EXTENT_COV_M2, 0.999)


def test_frames_with_two_movers_tell_two_people_apart_where_a_detector_seldom_splits_one() -> None:
    """Where the detector reports two movers near one person in a frame with probability q, and
    again in the next with r, n frames in which two tracks each took one are q r^(n-1) likely
    for one person; times the chance of their movers lying as far apart (the χ² tail of their
    summed d², C = 0.0617 I per frame here), against 0.001. Movers 0.25 m apart: one frame is
    one person's at q = 0.03 (0.03 x 0.60); three are two people's where splits do not persist
    (r = q: 2.7e-5 x 0.80) and one person's where they do (r = 0.37: 0.0041 x 0.80), and five
    are two people's even then (5.6e-4 x 0.89); with q = r = 1 the distance alone decides.
    Movers 0.5 m apart in two frames at q = r = 0.05 are two people's (0.0025 x 0.088), which
    neither the distance (q = r = 1: 0.088) nor the count (0.25 m apart: 0.0025 x 0.73) tells
    alone; movers in no common frame say nothing."""
    cov = np.eye(2) * 0.01

    def takes(frames: int, y_m: float) -> Takes:
        taken = Takes()
        for k in range(frames):
            taken.add(Measurement.ground(k / 7.0, (k / 7.0, y_m), cov), cov)
        return taken

    def apart(frames: int, y_m: float, q: float, r: float) -> bool:
        return seen_apart(takes(5, 0.0), takes(frames, y_m), PERSON_EXTENT_COV_M2, 0.999, q, r)

    assert not apart(1, 0.25, 0.03, 0.37)
    assert apart(3, 0.25, 0.03, 0.03)
    assert not apart(3, 0.25, 0.03, 0.37)
    assert apart(5, 0.25, 0.03, 0.37)
    assert not apart(5, 0.25, 1.0, 1.0)
    assert apart(2, 0.5, 0.05, 0.05)
    assert not apart(2, 0.5, 1.0, 1.0)
    assert not apart(2, 0.25, 0.05, 0.05)
    assert not seen_apart(Takes(), takes(3, 0.25), PERSON_EXTENT_COV_M2, 0.999, 0.03, 0.03)
