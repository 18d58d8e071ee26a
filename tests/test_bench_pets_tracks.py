"""The offline PETS bench's truth-free figure: ids born and how long each is held."""

from __future__ import annotations

import pytest
from bench.pets_tracks import id_lifetimes


def rows(tracks_by_frame: list[list[int]]) -> list[dict]:
    return [{"frame": f, "tracks": dict.fromkeys(ids)} for f, ids in enumerate(tracks_by_frame)]


def test_one_id_held_throughout_is_one_long_life():
    figure = id_lifetimes(rows([[3]] * 70), rate_hz=7.0)
    assert figure["ids"] == 1
    assert figure["median_life_s"] == pytest.approx(10.0)
    assert figure["ids_per_min"] == pytest.approx(6.0)


def test_a_person_split_into_restarts_gives_more_ids_and_shorter_lives():
    held = id_lifetimes(rows([[0, 1]] * 70), rate_hz=7.0)
    restarted = id_lifetimes(rows([[0, 10 + f // 14] for f in range(70)]), rate_hz=7.0)
    assert restarted["ids"] == held["ids"] + 4
    assert restarted["median_life_s"] < held["median_life_s"]
    assert restarted["mean_life_s"] < held["mean_life_s"]


def test_no_tracks_no_ids():
    assert id_lifetimes(rows([[]] * 5), rate_hz=7.0)["ids"] == 0
    assert id_lifetimes([], rate_hz=7.0)["ids_per_min"] == 0.0
