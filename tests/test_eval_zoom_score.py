"""The zoom's scores: the target's true height in the frame at the head's true zoom, and the
losses while the zoom moved."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gazed.config import load_rig
from gazed.eval.zoom_score import ZoomScoring, zoom_scoring
from gazed.geometry.pose import CameraPose
from gazed.geometry.zoom import ZoomLens
from gazed.messages import GazeState, HeadPose, SimTruth

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
S = 1_000_000_000


def truth(
    k: int,
    zoom: float,
    pose: CameraPose,
    xy_m: tuple[float, float] = (0.0, 2.0),
    velocity_m_s: tuple[float, float] = (0.0, 0.0),
):
    pan, tilt = (float(a) for a in pose.gaze_angles(np.array([*xy_m, 0.2])))
    return SimTruth(
        t_capture_ns=k * S // 25,
        seq=k,
        target_xy_m=xy_m,
        target_velocity_m_s=velocity_m_s,
        target_height_m=0.4,
        head=HeadPose(pan_rad=pan, tilt_rad=tilt, zoom=zoom),
    )


def test_only_a_rig_whose_gaze_zooms_is_scored_for_it() -> None:
    assert zoom_scoring(load_rig(CONFIGS / "sim.toml")) is None
    scoring = zoom_scoring(load_rig(CONFIGS / "sim-zoom.toml"))
    assert scoring is not None and scoring.setpoint == 0.15


def test_the_height_is_the_targets_at_the_true_zoom_and_losses_while_zooming_count() -> None:
    rig = load_rig(CONFIGS / "sim-zoom.toml")
    scoring = zoom_scoring(rig)
    assert isinstance(scoring, ZoomScoring)
    pose, lens = CameraPose.from_rig(rig), ZoomLens.from_section(rig.camera)
    # the target 0.4 m tall, about 7.5 m away, on the optical axis, seen from 2.8 m above its
    # middle: f · 0.4 cos(depression) / distance
    distance_m = float(np.linalg.norm(np.array([0.0, 2.0, 0.2]) - pose.centre_m))
    metres_to_px = 0.4 * math.cos(math.asin(2.8 / distance_m)) / distance_m
    first = truth(0, 0.4, pose)
    expected = lens.focal_px(0.4) * metres_to_px / 480
    assert scoring.heights([first])[0] == pytest.approx(expected, rel=0.02)
    # a zoom the setpoint holds for 40 frames, then one 30 % too long for 10 more; a loss
    # while it zooms in between, and one with the zoom still
    held_zoom = lens.zoom_for_focal(0.15 * 480 / metres_to_px)
    long_zoom = lens.zoom_for_focal(1.3 * 0.15 * 480 / metres_to_px)
    frames = [truth(k, held_zoom, pose) for k in range(40)]
    frames += [truth(k, long_zoom, pose) for k in range(40, 50)]
    frames += [truth(k, long_zoom, pose) for k in range(50, 100)]
    states = [
        GazeState(t_capture_ns=41 * S // 25, state="lost", previous="pursuit"),
        GazeState(t_capture_ns=99 * S // 25, state="lost", previous="pursuit"),
        GazeState(t_capture_ns=60 * S // 25, state="saccade", previous="lost"),
    ]
    scores = scoring.score(frames, states, 0)
    assert scores["height_within_fraction"] == pytest.approx(0.4)
    assert scores["frames"] == 100
    assert scores["height_fraction"]["p5"] == pytest.approx(0.15, rel=0.01)
    assert scores["height_fraction"]["p95"] == pytest.approx(0.195, rel=0.01)
    assert (scores["losses"], scores["losses_while_zooming"]) == (2, 1)
    assert scores["loss_times_s"] == [[1.64, True, True], [3.96, False, True]]
    assert scoring.score(frames, states, None)["height_within_fraction"] == 0.0
    assert not math.isnan(scores["height_fraction"]["p50"])


def test_a_loss_counts_as_while_zooming_from_when_the_gaze_left_the_target() -> None:
    """`lost` comes seconds after the gaze left the target (it pursues something else first):
    the zoom is judged over the second before the gaze left, not before `lost`."""
    rig = load_rig(CONFIGS / "sim-zoom.toml")
    scoring = zoom_scoring(rig)
    assert scoring is not None
    pose = CameraPose.from_rig(rig)
    # the zoom steps at frame 40, the gaze leaves the target at frame 45, `lost` at frame 90
    frames = [truth(k, 0.3 if k < 40 else 0.4, pose) for k in range(100)]
    in_fovea = np.arange(100) < 45
    lost = [GazeState(t_capture_ns=90 * S // 25, state="lost", previous="pursuit")]
    scores = scoring.score(frames, lost, 0, in_fovea)
    assert (scores["losses"], scores["losses_while_zooming"]) == (1, 1)
    # the target still in the fovea when `lost` comes: judged before `lost`, the zoom still
    assert scoring.score(frames, lost, 0, np.ones(100, bool))["losses_while_zooming"] == 0
    assert scoring.score(frames, lost, 0)["losses_while_zooming"] == 0


def test_a_loss_while_zooming_of_a_target_that_stood_is_the_motion_detectors() -> None:
    """`lost` comes `lost_after_ms` (600 ms: 15 frames) after the last detection: a target that
    stood still for at least half of that gap is one a motion detector does not see whatever the
    lens does; one that walked through it, or stood for less, counts against the zoom."""
    rig = load_rig(CONFIGS / "sim-zoom.toml")
    scoring = zoom_scoring(rig)
    assert scoring is not None and scoring.lost_after_s == pytest.approx(0.6)
    pose = CameraPose.from_rig(rig)
    lost = [GazeState(t_capture_ns=90 * S // 25, state="lost", previous="pursuit")]

    def scored(standing_frames: int) -> dict:
        """The zoom moving throughout; the target standing for the gap's last frames."""
        frames = [
            truth(
                k,
                0.3 + 0.002 * k,
                pose,
                velocity_m_s=(0.0, 0.0 if k > 90 - standing_frames else 1.0),
            )
            for k in range(100)
        ]
        return scoring.score(frames, lost, 0)

    for standing_frames, stood in [(0, False), (6, False), (9, True), (40, True)]:
        scores = scored(standing_frames)
        assert scores["losses_while_zooming"] == 1
        assert scores["loss_times_s"] == [[3.6, True, stood]]
        assert scores["losses_while_zooming_walking"] == (0 if stood else 1)
