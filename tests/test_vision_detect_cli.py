"""`gazed detect`: JSON lines, the annotated video, odometry from a CSV, clear errors; and the
detectors on real footage (../shared/data/video): they follow the walking people and stay
silent on the still background."""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from gazed.cli import main as gazed
from gazed.config import VisionSection
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.vision.pipeline import VisionPipeline
from gazed.vision.synthetic import SceneTruth, SyntheticScene, still_head

VIDEO = Path(__file__).resolve().parents[2] / "shared" / "data" / "video"
FPS = 25.0
CAMERA = CameraModel.from_fov(320, 240, math.radians(60))


def write_clip(path: Path, scene: SyntheticScene, count: int) -> list[SceneTruth]:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), FPS, (320, 240))
    assert writer.isOpened()
    truths = []
    for i in range(count):
        image, truth = scene.render(i / FPS, i)
        writer.write(image)
        truths.append(truth)
    writer.release()
    return truths


def panning_head(t: float):
    from gazed.messages import HeadPose

    rate = math.radians(25.0)
    return HeadPose(pan_rad=-0.2 + rate * t, tilt_rad=0.05, pan_rate_rad_s=rate)


@pytest.fixture(scope="module")
def walker_clip(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[SceneTruth]]:
    scene = SyntheticScene(
        CAMERA,
        HeadKinematics(),
        still_head(0.0, 0.0),
        lambda t: (-0.15 + 0.12 * t, 0.04 - 0.03 * t),
        seed=41,
        field_rad=0.8,
    )
    path = tmp_path_factory.mktemp("clips") / "walker.avi"
    return path, write_clip(path, scene, 40)


@pytest.fixture(scope="module")
def panning_clip(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The head pans at 25°/s over an empty scene; and its odometry as a CSV."""
    scene = SyntheticScene(CAMERA, HeadKinematics(), panning_head, None, seed=42, field_rad=0.8)
    folder = tmp_path_factory.mktemp("panning")
    truths = write_clip(folder / "pan.avi", scene, 30)
    lines = ["t_s,pan_deg,tilt_deg"]
    for k in range(0, 130):  # 100 Hz odometry over the clip
        pose = panning_head(k / 100.0)
        lines.append(f"{k / 100.0},{math.degrees(pose.pan_rad)},{math.degrees(pose.tilt_rad)}")
    (folder / "odometry.csv").write_text("\n".join(lines) + "\n")
    assert len(truths) == 30
    return folder / "pan.avi", folder / "odometry.csv"


def json_lines(capsys: pytest.CaptureFixture[str]) -> list[dict]:
    return [json.loads(line) for line in capsys.readouterr().out.splitlines()]


def test_json_lines_follow_the_target(walker_clip, capsys, tmp_path: Path) -> None:
    path, truths = walker_clip
    annotated = tmp_path / "out.mp4"
    code = gazed(
        ["detect", str(path), "--detector", "pyramid", "--json", "--annotate", str(annotated)]
    )
    assert code == 0
    records = json_lines(capsys)
    assert [r["frame"] for r in records] == list(range(40))
    assert set(records[0]) == {
        "frame",
        "t_s",
        "found",
        "u",
        "v",
        "du",
        "dv",
        "area",
        "ms",
        "movers",
    }
    assert records[10]["t_s"] == pytest.approx(10 / FPS)
    found = [r for r in records if r["found"]]
    assert len(found) >= 35
    for r in found:  # the target's own mover first, with its box
        own = r["movers"][0]
        assert (own["u"], own["v"]) == (r["u"], r["v"]) and len(own["box"]) == 4
    assert all(r["movers"] == [] for r in records if not r["found"])
    assert all(r["ms"] >= 0 for r in records)
    assert records[0]["found"] is False and records[0]["u"] is None
    errors = [
        math.hypot(r["u"] - truths[r["frame"]].u_px, r["v"] - truths[r["frame"]].v_px)
        for r in found
    ]
    assert np.median(errors) <= 2.5  # MJPG compression on top of the synthetic noise
    speeds = [math.hypot(r["du"], r["dv"]) for r in found[5:]]
    true_speed = math.hypot(truths[20].du_px_s, truths[20].dv_px_s)
    assert np.median(speeds) == pytest.approx(true_speed, rel=0.15)
    video = cv2.VideoCapture(str(annotated))
    frames = 0
    while video.read()[0]:
        frames += 1
    assert frames == 40
    assert int(video.get(cv2.CAP_PROP_FRAME_WIDTH)) == 320


def test_summary_without_json(walker_clip, capsys) -> None:
    path, _ = walker_clip
    assert gazed(["detect", str(path), "--detector", "flow"]) == 0
    out = capsys.readouterr().out
    assert "40 frames at 25 fps (320x240), detector flow" in out
    assert "found in" in out and "median" in out


@pytest.mark.parametrize("detector", ["flow", "pyramid"])
def test_odometry_csv_compensates_the_panning_head(panning_clip, capsys, detector: str) -> None:
    video, csv_path = panning_clip
    assert gazed(["detect", str(video), "--detector", detector, "--json"]) == 0
    without = sum(r["found"] for r in json_lines(capsys))
    assert (
        gazed(["detect", str(video), "--detector", detector, "--json", "--odometry", str(csv_path)])
        == 0
    )
    with_odometry = sum(r["found"] for r in json_lines(capsys))
    assert without >= 20  # the panning background looks like motion
    assert with_odometry == 0


def test_bad_inputs_exit_2_with_a_message(walker_clip, tmp_path: Path, capsys) -> None:
    path, _ = walker_clip
    assert gazed(["detect", str(tmp_path / "none.mp4")]) == 2
    assert "cannot read video" in capsys.readouterr().err
    bad_csv = tmp_path / "bad.csv"
    bad_csv.write_text("t_s,pan_deg,tilt_deg\n0,1,2\n0.1,one,2\n")
    assert gazed(["detect", str(path), "--odometry", str(bad_csv)]) == 2
    assert "bad.csv:3: expected three numbers" in capsys.readouterr().err
    backwards = tmp_path / "backwards.csv"
    backwards.write_text("0.2,1,2\n0.1,1,2\n")
    assert gazed(["detect", str(path), "--odometry", str(backwards)]) == 2
    assert "t_s must increase" in capsys.readouterr().err
    rig = tmp_path / "rig.toml"
    rig.write_text('[rig]\nname = "r"\n[camera]\nwidth_px = 640\nheight_px = 480\n')
    assert gazed(["detect", str(path), "--rig", str(rig)]) == 2
    assert "the video is 320x240, the rig's camera is 640x480" in capsys.readouterr().err


# --- real footage -------------------------------------------------------------------------


# the detectors run on the clip's first 20 s, in which several people cross; the empty scene is
# the median of the whole clip
DETECTED_FRAMES = 200


@pytest.fixture(scope="module")
def footage() -> list[np.ndarray]:
    clip = VIDEO / "vtest_480x360.avi"
    if not clip.is_file():
        pytest.skip(f"{clip} is absent (the shared data sits beside the repository only in CI)")
    capture = cv2.VideoCapture(str(clip))
    frames = []
    while len(frames) < 400:
        ok, image = capture.read()
        if not ok:
            break
        frames.append(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY))
    capture.release()
    assert len(frames) == 400
    return frames


@pytest.fixture(scope="module")
def still_background(footage: list[np.ndarray]) -> np.ndarray:
    """The scene without people: the median of frames spread over the clip."""
    return np.median(np.stack(footage[::10]), axis=0).astype(np.uint8)


def moving_people(frame: np.ndarray, background: np.ndarray) -> np.ndarray:
    """Where the frame differs from the empty scene (people), grown by 12 px."""
    difference = cv2.absdiff(
        cv2.GaussianBlur(frame, (5, 5), 0), cv2.GaussianBlur(background, (5, 5), 0)
    )
    mask = cv2.morphologyEx(
        (difference > 30).astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)
    )
    return cv2.dilate(mask, np.ones((25, 25), np.uint8)) > 0


@pytest.fixture(scope="module")
def people(footage: list[np.ndarray], still_background: np.ndarray) -> Callable[[int], np.ndarray]:
    """Frame i -> its `moving_people` mask, worked out once for all the detectors."""
    return functools.cache(lambda i: moving_people(footage[i], still_background))


@pytest.fixture(scope="module")
def noisy_still_frames(still_background: np.ndarray) -> list[np.ndarray]:
    """The empty scene with fresh sensor noise in each of 100 frames (seeded), the same
    frames for every detector (read-only)."""
    rng = np.random.default_rng(7)
    frames = []
    for _ in range(100):
        noise = rng.normal(0.0, 2.0, still_background.shape)
        frame = np.clip(still_background + noise, 0, 255).astype(np.uint8)
        frame.flags.writeable = False
        frames.append(frame)
    return frames


@pytest.mark.parametrize(
    ("detector", "min_found"), [("flow", 0.5), ("pyramid", 0.9), ("background", 0.9)]
)
def test_real_footage_detections_are_on_the_walking_people(
    footage: list[np.ndarray],
    people: Callable[[int], np.ndarray],
    detector: str,
    min_found: float,
) -> None:
    camera = CameraModel.from_fov(480, 360, math.radians(60))
    pipeline = VisionPipeline(camera, HeadKinematics(), VisionSection(), detector)
    found = on_people = 0
    frames = footage[:DETECTED_FRAMES]
    for i, frame in enumerate(frames):
        out = pipeline.process(frame, round(i / 10.0 * 1e9), None).output
        if i < 15 or not out.found:  # the background model learns first
            continue
        found += 1
        u = min(max(round(out.u_px), 0), 479)
        v = min(max(round(out.v_px), 0), 359)
        on_people += bool(people(i)[v, u])
    assert found >= min_found * (len(frames) - 15)
    assert on_people >= 0.9 * found


@pytest.mark.parametrize("detector", ["flow", "pyramid", "background"])
def test_real_still_background_fires_nothing(
    noisy_still_frames: list[np.ndarray], detector: str
) -> None:
    camera = CameraModel.from_fov(480, 360, math.radians(60))
    pipeline = VisionPipeline(camera, HeadKinematics(), VisionSection(), detector)
    fired = 0
    for i, frame in enumerate(noisy_still_frames):
        result = pipeline.process(frame, round(i / 10.0 * 1e9), None)
        fired += result.output.found + bool(result.candidates)
    assert fired <= 1
