"""Movers: every separate mover a detector segments in a frame.

- the width model splits silhouettes that stand side by side, and only those;
- background subtraction on a synthetic street: three separated walkers and two adjacent ones
  are five movers with their boxes, ground contact points and velocities; differently coloured
  ones look different, the same one alike from frame to frame;
- flow and pyramid: the target's own mover comes first, with the target's point and velocity;
- the stage puts the movers on the Detection; `--annotate` draws every mover's box;
- a digital head's wide camera: its movers land in the view where the rendered view shows them;
- on the PETS footage (where present): the movers against the annotated people, and the PETS
  rig's detections carrying its wide camera's walkers.
"""

from __future__ import annotations

import csv
import functools
import math
from collections import defaultdict
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import REPO, write_rig
from vision_scene import CAMERA_BODY, T0_NS, captured, odometry, scene

from gazed.config import VisionSection, load_rig
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import Detection, HeadPose
from gazed.vision.annotate import MAGENTA, annotate
from gazed.vision.appearance import BINS
from gazed.vision.detector import DetectorOutput
from gazed.vision.digital_view import DigitalView
from gazed.vision.frames import CapturedFrame
from gazed.vision.movers import Blob, MoverRegion, split_blob
from gazed.vision.pipeline import VisionPipeline
from gazed.vision.silhouettes import SilhouetteModel
from gazed.vision.stage import VisionStage
from gazed.vision.wide_movers import WideMovers, target_first

RATE_HZ = 25.0
KINEMATICS = HeadKinematics("pan-tilt")


def person(mask: np.ndarray, u: float, top: int, width: int, height: int) -> None:
    """A walker's silhouette: an upright ellipse of `width` x `height` from row `top`."""
    centre = (round(u), round(top + height / 2))
    cv2.ellipse(mask, centre, (width // 2, height // 2), 0, 0, 360, 1, -1)


def blob_of(mask: np.ndarray) -> Blob:
    ys, xs = np.nonzero(mask)
    y0, x0 = ys.min(), xs.min()
    return Blob(int(x0), int(y0), mask[y0 : ys.max() + 1, x0 : xs.max() + 1].astype(bool))


def test_the_width_model_splits_walkers_side_by_side_and_nothing_else() -> None:
    mask = np.zeros((80, 120), np.uint8)
    for u in (20, 36, 52):  # three touching walkers, 16 wide and 44 tall
        person(mask, u, 10, 16, 44)
    parts = split_blob(blob_of(mask))
    assert len(parts) == 3
    assert [round(p.x + p.width / 2) for p in parts] == pytest.approx([20, 36, 52], abs=2)
    assert all(p.height >= 42 for p in parts)
    one = np.zeros((80, 120), np.uint8)
    person(one, 40, 10, 22, 44)  # a wide walker (mid-stride): still one
    assert len(split_blob(blob_of(one))) == 1
    wide = np.zeros((80, 120), np.uint8)
    wide[20:40, 10:90] = 1  # one wide thing with no valley (a car, a bench): one
    assert len(split_blob(blob_of(wide))) == 1
    arm = np.zeros((80, 120), np.uint8)
    person(arm, 30, 10, 16, 44)
    arm[30:34, 38:50] = 1  # an outstretched arm is no second body
    assert len(split_blob(blob_of(arm))) == 1


# the street: (colour BGR, u at t=0, v of the feet, u velocity px/s, v velocity px/s)
WALKERS = [
    ((40, 40, 220), 40.0, 100.0, 40.0, 0.0),  # red
    ((220, 60, 40), 150.0, 110.0, -30.0, 0.0),  # blue
    ((20, 150, 20), 270.0, 90.0, 0.0, 20.0),  # green
    ((40, 220, 230), 120.0, 200.0, 25.0, 0.0),  # yellow, beside ...
    ((230, 220, 40), 138.0, 200.0, 25.0, 0.0),  # ... cyan, 2 px apart: one blob
]
SIZE = (16, 44)  # a walker's width and height (px)
ENTER = 100  # walkers appear once the background is learnt


@functools.cache
def street_background() -> tuple[np.ndarray, list[np.ndarray]]:
    """The street's texture (BGR) and sensor noise for a cycle of frames (float)."""
    rng = np.random.default_rng(5)
    texture = cv2.GaussianBlur(rng.integers(60, 200, (240, 320, 3), dtype=np.uint8), (0, 0), 2)
    noise = [rng.normal(0.0, 1.5, texture.shape) for _ in range(7)]
    return texture, noise


@functools.cache
def street(n: int) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """Frame n (BGR, 320x240) and every walker's ground contact point. The walkers' clothes
    have a texture (brightness only) that moves with them."""
    texture, noise = street_background()
    frame = np.clip(texture + noise[n % len(noise)], 0, 255)
    feet = []
    if n < ENTER:
        return frame.astype(np.uint8), feet
    t = (n - ENTER) / RATE_HZ
    w, h = SIZE
    for k, (colour, u0, v0, du, dv) in enumerate(WALKERS):
        u, v = u0 + du * t, v0 + dv * t
        mask = np.zeros((240, 320), np.uint8)
        top, left = round(v) - h + 1, round(u) - w // 2
        person(mask, round(u), top, w, h)
        texture = np.random.default_rng(k).uniform(0.6, 1.3, (h + 2, w + 2))
        shade = np.ones((240, 320))
        shade[top : top + h + 2, left : left + w + 2] = texture
        inside = mask > 0
        frame[inside] = np.clip(np.array(colour) * shade[inside][:, None], 0, 255)
        feet.append((u, v))
    return frame.astype(np.uint8), feet


@pytest.fixture(scope="module")
def street_run() -> list[tuple[DetectorOutput, list[tuple[float, float]]]]:
    camera = CameraModel.from_fov(320, 240, math.radians(60))
    pipeline = VisionPipeline(camera, KINEMATICS, VisionSection(), "background")
    results = []
    for n in range(ENTER + 12):
        frame, feet = street(n)
        gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        out = pipeline.process(
            gray, round(n / RATE_HZ * 1e9), None, colour=frame, with_candidates=False
        ).output
        results.append((out, feet))
    return results


def nearest(movers: tuple[MoverRegion, ...], u: float, v: float) -> MoverRegion:
    return min(movers, key=lambda m: math.hypot(m.u_px - u, m.v_px - v))


def test_background_reports_every_walker_adjacent_ones_apart(street_run) -> None:
    for out, feet in street_run[-4:]:
        assert out.found and len(out.movers) == len(WALKERS)
        for u, v in feet:
            mover = nearest(out.movers, u, v)
            assert math.hypot(mover.u_px - u, mover.v_px - v) <= 3.0  # half resolution
            x, y, w, h = mover.box
            assert abs(x + w / 2 - u) <= 2.0 and abs(w - SIZE[0]) <= 4.0  # half resolution
            assert abs(y + h - 1 - v) <= 3.0 and abs(h - SIZE[1]) <= 4.0
        # the target's own first: a walker of the largest blob (the adjacent pair's)
        x, y, w, h = out.movers[0].box
        wx, wy, ww, wh = out.window
        assert wx <= x and x + w <= wx + ww and wy <= y and y + h <= wy + wh
        assert out.movers[0].u_px == pytest.approx(out.u_px, abs=SIZE[0] / 2)


def test_the_adjacent_walkers_are_one_blob_split_in_two() -> None:
    model = SilhouetteModel(
        level=1, history_frames=200, threshold=16.0, min_area_px=200, learning_frames=10
    )
    for n in range(ENTER + 2):
        frame, _ = street(n)
        foreground = model.segment(cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY))
    assert foreground is not None
    assert sorted(len(parts) for _, parts in foreground.found) == [1, 1, 1, 2]


def test_each_walker_has_its_own_velocity(street_run) -> None:
    out, feet = street_run[-1]
    for (_, _, _, du, dv), (u, v) in zip(WALKERS, feet, strict=True):
        mover = nearest(out.movers, u, v)
        assert math.hypot(mover.du_px_s - du, mover.dv_px_s - dv) <= 5.0


def test_differently_coloured_walkers_look_different(street_run) -> None:
    (late, late_feet), (early, early_feet) = street_run[-1], street_run[-4]
    looks = [np.array(nearest(late.movers, u, v).appearance) for u, v in late_feet]
    before = [np.array(nearest(early.movers, u, v).appearance) for u, v in early_feet]
    assert all(len(a) == BINS for a in looks + before)
    for i, a in enumerate(looks):
        assert np.abs(a - before[i]).sum() < 0.3  # the same walker a few frames apart
        for j in range(i + 1, len(looks)):
            assert np.abs(a - looks[j]).sum() > 1.0  # another colour


def test_annotate_draws_every_movers_box_and_index(street_run) -> None:
    out, _ = street_run[-1]
    frame, _ = street(len(street_run) - 1)
    image = annotate(frame, out, None, "")
    drawn = np.all(image == MAGENTA, axis=2)
    for mover in out.movers:
        x, y, w, _ = (round(c) for c in mover.box)
        top_edge = drawn[y, x : x + w]
        assert top_edge.mean() > 0.8
        inside = (slice(y + 2, y + 11), slice(x + 2, x + 9))
        assert np.any(image[inside] != frame[inside])  # its index
    assert not np.all(annotate(frame, DetectorOutput.nothing(), None, "") == MAGENTA, axis=2).any()


@pytest.mark.parametrize("detector", ["flow", "pyramid"])
def test_the_targets_own_mover_comes_first(detector: str) -> None:
    from gazed.vision.synthetic import SyntheticScene, still_head

    camera = CameraModel.from_fov(320, 240, math.radians(60))
    scene = SyntheticScene(
        camera, KINEMATICS, still_head(), lambda t: (-0.1 + 0.25 * t, 0.0), seed=7
    )
    pipeline = VisionPipeline(camera, KINEMATICS, VisionSection(), detector)
    found = 0
    for image, truth in scene.frames(RATE_HZ, 20):
        gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        out = pipeline.process(
            gray, round(truth.t_s * 1e9), truth.head, with_candidates=False
        ).output
        if not out.found:
            assert out.movers == ()
            continue
        found += 1
        own = out.movers[0]
        assert (own.u_px, own.v_px, own.du_px_s, own.dv_px_s) == (
            out.u_px,
            out.v_px,
            out.du_px_s,
            out.dv_px_s,
        )
        x, y, w, h = own.box
        assert x - 2 <= out.u_px <= x + w + 2 and y - 2 <= out.v_px <= y + h + 2
        assert len(own.appearance) == BINS
    assert found >= 10


def test_the_stage_puts_the_movers_on_the_detection(tmp_path: Path) -> None:
    stage = VisionStage(load_rig(write_rig(tmp_path, CAMERA_BODY)))
    synthetic = scene()
    for k in range(100):
        stage.add_odometry(odometry(k / 100.0), T0_NS + 10**9)
    found = 0
    for i in range(12):
        frame = captured(*synthetic.render(i / RATE_HZ, i), i)
        grey = cv2.cvtColor(frame.pixels, cv2.COLOR_BGR2GRAY)  # as the sim rig sends them
        frame = CapturedFrame(grey, "gray8", frame.t_capture_ns, frame.seq, frame.stamps)
        detection = stage.process(frame).detection
        assert detection is not None
        if not detection.found:
            assert detection.movers == ()
            continue
        found += 1
        own = detection.movers[0]
        assert (own.u_px, own.v_px) == (detection.u_px, detection.v_px)
        assert own.box_width_px > 0 and own.box_height_px > 0 and own.area_px > 0
        assert len(own.appearance) == BINS
        assert Detection.model_validate_json(detection.to_json()).movers == detection.movers
    assert found >= 6


def test_target_first_puts_the_mover_holding_the_target_first() -> None:
    def mover(u: float, box: tuple[float, float, float, float]) -> MoverRegion:
        return MoverRegion(u, 50.0, 0.0, 0.0, box, 100.0, 0.5)

    a, b = mover(10.0, (0, 30, 20, 40)), mover(60.0, (50, 30, 20, 40))
    assert target_first((58.0, 40.0), (a, b)) == (b, a)
    assert target_first((120.0, 40.0), (a, b)) == (a, b)  # in no wide box: nothing added
    assert target_first(None, (a, b)) == (a, b)


def test_a_digital_heads_movers_come_from_its_wide_camera() -> None:
    """Walkers segmented in the still wide frames land in the view where the view rendered from
    the same frame shows them, and their wide velocity becomes the view's."""
    wide_camera = CameraModel.from_intrinsics(
        320, 240, 260.0, 260.0, 158.0, 121.0, (-0.12, 0.0, 0.0, 0.0, 0.0)
    )
    view_camera = CameraModel.from_fov(200, 150, math.radians(40))
    view = DigitalView(wide_camera, view_camera, KINEMATICS)
    movers = WideMovers(view, VisionSection(), "centroid")
    pose = HeadPose(pan_rad=math.radians(4.0), tilt_rad=math.radians(-3.0))
    mapped, seen = [], []
    for n in range(ENTER + 10):
        frame, _ = street(n)
        movers.observe(CapturedFrame(frame, "bgr8", round(n / RATE_HZ * 1e9), n))
        if n < ENTER + 6:
            continue
        in_view = movers.in_view(n, pose)
        assert in_view is not None
        rendered = view.render(frame, pose.pan_rad, pose.tilt_rad)
        b, g, r = (rendered[..., c].astype(float) for c in range(3))
        blue = (b > 2 * g) & (b > 2 * r) & (b > 60)  # the blue walker, as the view shows it
        ys, xs = np.nonzero(blue)
        assert len(xs) > 100
        mapped.append(nearest(in_view, xs.mean(), ys.mean()))
        seen.append((xs.mean(), ys.mean()))
    for mover, (u, v) in zip(mapped, seen, strict=True):
        assert math.hypot(mover.u_px - u, mover.v_px - v) <= 1.5
        assert len(mover.appearance) == BINS
    view_du = (seen[-1][0] - seen[0][0]) * RATE_HZ / (len(seen) - 1)
    assert mapped[-1].du_px_s == pytest.approx(view_du, rel=0.15)
    assert movers.in_view(10**6, pose) is None  # a frame never segmented


PETS_TRUTH = Path("footage/pets09-s2l1/truth_frames_0000-0399.csv")
PETS_VIDEO = Path("video/vtest_480x360.avi")
SCORED = range(60, 160, 10)  # frames scored (the background model learns before)
RIG_SCORED = range(40, 90, 10)


def test_movers_on_the_pets_footage_against_the_annotated_people(shared_data: Path) -> None:
    """Background subtraction with the default settings on the still PETS camera: a person is
    recalled when a mover's ground contact point is within half their box of their feet. The
    figure is printed; the bound only guards against a collapse."""
    people = defaultdict(list)
    with (shared_data / PETS_TRUTH).open() as rows:
        for row in csv.DictReader(rows):
            people[int(row["frame"])].append({k: float(v) for k, v in row.items()})
    capture = cv2.VideoCapture(str(shared_data / PETS_VIDEO))
    camera = CameraModel.from_fov(480, 360, math.radians(60))
    pipeline = VisionPipeline(camera, KINEMATICS, VisionSection(), "background")
    recalled = annotated = reported = 0
    for n in range(SCORED[-1] + 1):
        ok, frame = capture.read()
        assert ok
        gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        out = pipeline.process(
            gray, round(n / 7.0 * 1e9), None, colour=frame, with_candidates=False
        ).output  # 7 Hz
        if n not in SCORED:
            continue
        reported += len(out.movers)
        taken: set[int] = set()
        for p in people[n]:
            annotated += 1
            misses = [
                (
                    math.hypot(
                        (m.u_px - p["foot_u_px"]) / p["box_w_px"],
                        (m.v_px - p["foot_v_px"]) / p["box_h_px"],
                    ),
                    i,
                )
                for i, m in enumerate(out.movers)
                if i not in taken
            ]
            close = [(d, i) for d, i in misses if d < 0.5]
            if close:
                recalled += 1
                taken.add(min(close)[1])
    capture.release()
    recall = recalled / annotated
    frames = f"{SCORED.start}-{SCORED.stop - 1}"
    print(f"PETS frames {frames}: {annotated} people, {recall:.2f} recalled, {reported} movers")
    assert annotated >= 50
    assert recall >= 0.4


def test_the_pets_rigs_detections_carry_the_walkers_of_its_wide_camera(shared_data: Path) -> None:
    """configs/pets.toml's vision stage, its digital head still at park: each Detection lists
    the walkers its wide camera segments, mapped into the view, most of the annotated people."""
    rig = load_rig(REPO / "configs" / "pets.toml")
    wide_camera = CameraModel.from_intrinsics(
        rig.wide.width_px,
        rig.wide.height_px,
        rig.wide.fx_px,
        rig.wide.fy_px,
        rig.wide.cx_px,
        rig.wide.cy_px,
        tuple(rig.wide.distortion),
    )
    view = DigitalView(wide_camera, CameraModel.from_section(rig.camera), KINEMATICS)
    stage = VisionStage(rig)
    stage.wide_movers = WideMovers(view, rig.vision, "centroid")
    people = defaultdict(int)
    with (shared_data / PETS_TRUTH).open() as rows:
        for row in csv.DictReader(rows):
            people[int(row["frame"])] += 1
    capture = cv2.VideoCapture(str(shared_data / PETS_VIDEO))
    park = HeadPose(pan_rad=0.0, tilt_rad=0.0)
    counts, coloured = [], 0
    for n in range(RIG_SCORED[-1] + 1):
        ok, wide = capture.read()
        assert ok
        t_ns = T0_NS + round(n / 7.0 * 1e9)
        stage.wide_movers.observe(CapturedFrame(wide, "bgr8", t_ns, n))
        rendered = view.render(wide, 0.0, 0.0)
        output = stage.process(CapturedFrame(rendered, "bgr8", t_ns, n, head=park))
        detection = output.detection
        assert detection is not None
        if n in RIG_SCORED:
            described = [m for m in detection.movers if m.appearance]
            assert all(len(m.appearance) == BINS for m in described)
            coloured += len(described)
            counts.append(len(detection.movers) / people[n])
    capture.release()
    print(f"PETS rig: movers per annotated person {np.mean(counts):.2f}")
    assert np.mean(counts) >= 0.5
    assert coloured > 0  # dark or grey clothes have no reliable hue, and no descriptor
