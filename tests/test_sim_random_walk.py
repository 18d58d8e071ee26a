"""The random walker: human maneuvers, within the rig's field of regard whatever the seed."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gazed.config import load_rig
from gazed.sim.random_walk import random_walk
from gazed.sim.reach import FieldOfRegard
from gazed.sim.world import trajectories

SIM_RIG = Path(__file__).resolve().parent.parent / "configs" / "sim.toml"
SEEDS = range(1, 21)
WALK_S = 150.0
STEP_S = 0.1


@pytest.fixture(scope="module")
def reach() -> FieldOfRegard:
    return FieldOfRegard.for_walker(load_rig(SIM_RIG))


def sampled(seed: int, reach: FieldOfRegard | None) -> tuple[np.ndarray, list]:
    walk = random_walk(seed, duration_s=WALK_S, reach=reach)
    states = [walk.state(t) for t in np.arange(0.0, WALK_S, STEP_S)]
    return np.array([s.xy_m for s in states]), states


@pytest.fixture(scope="module")
def walks(reach: FieldOfRegard) -> dict[int, tuple[np.ndarray, list]]:
    """Each seed's walk within the reach, sampled once for the tests that read it."""
    return {seed: sampled(seed, reach) for seed in SEEDS}


def test_the_walk_never_leaves_the_heads_reach(
    reach: FieldOfRegard, walks: dict[int, tuple[np.ndarray, list]]
) -> None:
    for seed in SEEDS:
        xy, _ = walks[seed]
        assert reach.contains(xy).all(), f"seed {seed} leaves the head's reach"
    # the same walks without the region: the camera's foot is within the walk's area
    assert not all(reach.contains(sampled(seed, None)[0]).all() for seed in SEEDS)


def test_the_walk_keeps_human_maneuvers(walks: dict[int, tuple[np.ndarray, list]]) -> None:
    speeds, turns, stops_s = [], [], 0.0
    for seed in SEEDS:
        _, states = walks[seed]
        speeds += [s.speed_m_s for s in states]
        turns += [abs(s.turn_rate_rad_s) for s in states if s.model == "CS"]
        stops_s += STEP_S * sum(s.model == "stop" for s in states)
    speeds_m_s, turns_deg_s = np.array(speeds), np.degrees(turns)
    assert speeds_m_s.max() <= 1.5 + 1e-9
    moving = speeds_m_s[speeds_m_s > 0.05]
    assert np.mean((moving >= 0.5) & (moving <= 1.5)) > 0.8
    assert turns_deg_s.max() <= 60.0 + 1e-6
    assert np.mean(turns_deg_s >= 20.0 - 1e-6) > 0.9  # homing turns are 60°/s too
    assert 0.03 < stops_s / (len(SEEDS) * WALK_S) < 0.3


def test_the_sim_rigs_random_target_keeps_within_reach(reach: FieldOfRegard) -> None:
    rig = load_rig(SIM_RIG)
    rig = rig.model_copy(update={"sim": rig.sim.model_copy(update={"trajectory": "random"})})
    target, _ = trajectories(rig)
    xy = np.array([target.state(t).xy_m for t in np.arange(0.0, 120.0, 0.1)])
    assert reach.contains(xy).all()


def test_a_centre_out_of_reach_is_refused(reach: FieldOfRegard) -> None:
    with pytest.raises(ValueError, match="out of the head's reach"):
        random_walk(1, centre_xy_m=(0.0, -5.0), reach=reach)


def test_the_region_is_the_limits_less_the_fovea_and_the_stopping_distance(
    reach: FieldOfRegard,
) -> None:
    rig = load_rig(SIM_RIG)
    tilt_margin = math.radians(rig.gaze.fovea_half_angle_deg) + math.radians(
        rig.head.tilt_rate_max_deg_s
    ) ** 2 / (2 * math.radians(rig.head.tilt_accel_max_deg_s2))
    assert reach.inset_rad[1] == pytest.approx(tilt_margin)
    lowest = rig.head.tilt_limits_rad[0] + tilt_margin
    assert reach.contains_angles(np.array(0.0), np.array(lowest + 1e-6))
    assert not reach.contains_angles(np.array(0.0), np.array(lowest - 1e-6))
    scoring = FieldOfRegard.for_scoring(rig)
    assert scoring.contains_angles(np.array(0.0), np.array(rig.head.tilt_limits_rad[0] - 0.01))
    # straight below the camera is out of reach; the middle of the area is not
    assert not reach.contains(np.array([0.0, -5.0]))
    assert reach.contains(np.array([0.0, 0.0]))
