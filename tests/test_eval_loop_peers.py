"""`gazed eval loop`: the peers' control laws are runnable one at a time and in --compare."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from gazed.config import load_rig
from gazed.eval.loop import COMPARED, loop_arguments
from gazed.eval.private_rig import private_rig

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("control", ["pid", "move-wait-move"])
def test_a_peer_law_runs_in_a_private_rig(tmp_path: Path, control: str) -> None:
    path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 1, control)
    assert load_rig(path).gaze.control == control
    parser = argparse.ArgumentParser()
    loop_arguments(parser)
    args = parser.parse_args(["--rig", "x.toml", "--scenario", "oval", "--control", control])
    assert args.control == control


def test_compare_runs_the_estimation_modes_and_the_peers_on_one_seed() -> None:
    assert [filter_mode for filter_mode, _ in COMPARED[:3]] == ["imm", "image-cv", "none"]
    assert [control for _, control in COMPARED] == [None, None, None, "pid", "move-wait-move"]
