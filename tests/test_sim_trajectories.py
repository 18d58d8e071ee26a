"""Each trajectory has the speed, turn rate and segment lengths it claims."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gazed.sim.scenarios import NAMES, make_trajectory
from gazed.sim.trajectories import read_pedestrians

DT = 0.01


def sample(trajectory, t_end_s: float, t0_s: float = 0.0):
    times = np.arange(t0_s, t_end_s, DT)
    return times, [trajectory.state(t) for t in times]


@pytest.mark.parametrize("name", NAMES)
def test_velocity_is_the_derivative_of_position(name: str) -> None:
    trajectory = make_trajectory(name, seed=5)
    _, states = sample(trajectory, 40.0)
    xy = np.array([s.xy_m for s in states])
    velocity = np.array([s.velocity_m_s for s in states])
    numeric = (xy[2:] - xy[:-2]) / (2 * DT)
    assert np.abs(numeric - velocity[1:-1]).max() < 0.01
    speed = np.array([s.speed_m_s for s in states])
    np.testing.assert_allclose(np.hypot(velocity[:, 0], velocity[:, 1]), speed, atol=1e-9)


def test_rounded_square_matches_seed_000() -> None:
    trajectory = make_trajectory("rounded-square", speed_m_s=1.2)
    assert trajectory.period_s == pytest.approx(16.0)  # 4 x (50 + 50) observations of 40 ms
    _, states = sample(trajectory, 16.0)
    assert all(s.speed_m_s == pytest.approx(1.2) for s in states)
    models = [s.model for s in states]
    # 2 s straight (CSD), 2 s turning (CS), four times
    expected = (["CSD"] * 200 + ["CS"] * 200) * 4
    assert models == expected
    turns = [s.turn_rate_rad_s for s in states if s.model == "CS"]
    assert turns == pytest.approx([math.radians(45.0)] * len(turns))
    start, end = trajectory.state(0.0), trajectory.state(16.0)
    assert end.xy_m == pytest.approx(start.xy_m, abs=1e-9)
    assert end.heading_rad % (2 * math.pi) == pytest.approx(
        start.heading_rad % (2 * math.pi), abs=1e-9
    )
    straight = np.subtract(trajectory.state(2.0).xy_m, trajectory.state(0.0).xy_m)
    assert np.hypot(*straight) == pytest.approx(2.4)


def test_oval_matches_seed_000_section_6() -> None:
    trajectory = make_trajectory("oval")
    assert trajectory.period_s == pytest.approx(14.0)
    # straight: 0.4 -> 0.5 m/s over 0.9 m in 2 s
    assert trajectory.state(0.0).speed_m_s == pytest.approx(0.4)
    assert trajectory.state(2.0 - 1e-9).speed_m_s == pytest.approx(0.5)
    straight = np.subtract(trajectory.state(2.0).xy_m, trajectory.state(0.0).xy_m)
    assert np.hypot(*straight) == pytest.approx(0.9)
    assert trajectory.state(1.0).model == "CD" and trajectory.state(4.0).model == "CS"
    # a semicircle in 5 s: heading turns by pi, mean turn rate 2 pi / 10
    turned = trajectory.state(7.0 - 1e-9).heading_rad - trajectory.state(2.0).heading_rad
    assert turned == pytest.approx(math.pi, abs=1e-6)
    rates = [trajectory.state(t).turn_rate_rad_s for t in np.arange(2.0, 7.0, DT)]
    assert np.mean(rates) == pytest.approx(2 * math.pi / 10, rel=0.01)
    speeds = [trajectory.state(t).speed_m_s for t in np.arange(0.0, 14.0, DT)]
    assert np.abs(np.diff(speeds)).max() < 0.001  # continuous


def test_stop_and_go_stands_and_walks() -> None:
    trajectory = make_trajectory("stop-and-go", speed_m_s=1.0)
    assert trajectory.period_s == pytest.approx(24.0)
    assert trajectory.state(2.5).speed_m_s == pytest.approx(1.0)
    assert trajectory.state(2.5).model == "CSD"
    assert trajectory.state(0.5).model == "CD" and trajectory.state(3.5).model == "CD"
    standing = [trajectory.state(t) for t in np.arange(4.01, 6.0, 0.1)]
    assert all(s.speed_m_s == 0.0 and s.model == "stop" for s in standing)
    assert len({s.xy_m for s in standing}) == 1
    side = np.subtract(trajectory.state(6.0).xy_m, trajectory.state(0.0).xy_m)
    assert np.hypot(*side) == pytest.approx(3.0)  # 0.5 + 2 + 0.5 m
    assert trajectory.state(6.5).heading_rad == pytest.approx(math.pi / 2)


def test_figure_eight_turns_both_ways_at_v_over_r() -> None:
    trajectory = make_trajectory("figure-eight", speed_m_s=1.0, scale=1.0)
    lap = 2 * math.pi * 2.0
    assert trajectory.state(1.0).turn_rate_rad_s == pytest.approx(0.5)
    assert trajectory.state(lap + 1.0).turn_rate_rad_s == pytest.approx(-0.5)
    assert trajectory.state(lap).xy_m == pytest.approx((0.0, 0.0), abs=1e-9)
    assert trajectory.state(2 * lap).xy_m == pytest.approx((0.0, 0.0), abs=1e-9)


def test_random_is_seeded_and_stays_near_its_area() -> None:
    a = make_trajectory("random", seed=7, speed_m_s=1.0, centre_xy_m=(1.0, 2.0))
    b = make_trajectory("random", seed=7, speed_m_s=1.0, centre_xy_m=(1.0, 2.0))
    c = make_trajectory("random", seed=8, speed_m_s=1.0, centre_xy_m=(1.0, 2.0))
    times = np.arange(0.0, 600.0, 0.1)
    xy_a = np.array([a.state(t).xy_m for t in times])
    assert np.array_equal(xy_a, np.array([b.state(t).xy_m for t in times]))
    assert not np.array_equal(xy_a, np.array([c.state(t).xy_m for t in times]))
    distance = np.hypot(xy_a[:, 0] - 1.0, xy_a[:, 1] - 2.0)
    assert distance.max() < 1.5 * 4.0 + 1.5  # 1.5 radius, plus a homing turn's swing
    states = [a.state(t) for t in times]
    assert max(abs(s.turn_rate_rad_s) for s in states) <= math.radians(60.0) + 1e-9
    assert {s.model for s in states} >= {"CSD", "CS", "CD", "stop"}
    assert min(s.speed_m_s for s in states) >= 0.0


def test_recorded_track_passes_through_its_samples(tmp_path: Path) -> None:
    path = tmp_path / "peds.txt"
    rows = [(f, 3.0, 1.0 + 0.05 * f, 2.0 - 0.02 * f) for f in range(100, 300, 10)]
    rows += [(f, 4.0, 5.0, 5.0) for f in range(100, 130, 10)]
    path.write_text("".join(f"{f}\t{p}\t{x:.2f}\t{y:.2f}\n" for f, p, x, y in sorted(rows)))
    tracks = read_pedestrians(path)
    assert sorted(tracks) == [3, 4]
    trajectory = make_trajectory(f"file:{path}#3", centre_xy_m=(10.0, 0.0))
    times, xy = tracks[3]
    shifted = xy - xy.mean(axis=0) + (10.0, 0.0)
    assert trajectory.duration_s == pytest.approx(19 * 0.4)
    for k, t in enumerate(times - times[0]):
        assert trajectory.state(t).xy_m == pytest.approx(tuple(shifted[k]), abs=1e-9)
    # straight walking: 0.5 m in x and -0.2 m in y every 10 frame units (0.4 s)
    assert trajectory.state(3.0).velocity_m_s == pytest.approx((1.25, -0.5), abs=1e-6)
    assert trajectory.state(100.0).speed_m_s == 0.0  # holds its last position
    default = make_trajectory(f"file:{path}")  # the longest track
    assert default.duration_s == pytest.approx(trajectory.duration_s)
    with pytest.raises(ValueError, match="no pedestrian 9"):
        make_trajectory(f"file:{path}#9")


def test_real_pedestrian_file(shared_data: Path) -> None:
    trajectory = make_trajectory(f"file:{shared_data / 'pedestrians' / 'biwi_eth.txt'}")
    speeds = [trajectory.state(t).speed_m_s for t in np.arange(0, trajectory.duration_s, 0.1)]
    assert trajectory.duration_s == pytest.approx(113 * 0.4)
    assert 0.1 < np.median(speeds) < 2.5  # people walk


def test_unknown_trajectory_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="unknown trajectory 'ovl'"):
        make_trajectory("ovl")
