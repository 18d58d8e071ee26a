"""The background model's learning frames: a person passing through them is left out of what
the model learns, and the scene's own motion (foliage) is learnt as it is."""

from __future__ import annotations

import numpy as np
import pytest
from test_vision_ghosts import LEARNING, frame, lefts, model
from test_vision_shadows import BODY

from gazed.vision.scene_learning import without_passers_by
from gazed.vision.silhouettes import SCENE_BATCH_FRAMES, channel_threshold

SIZE = (60, 80)
BLOCK = (12, 6)  # a passer-by's height and width, pixels
SWAY = (slice(5, 20), slice(55, 75))  # a patch of foliage, its leaves moving in every frame


def scene(n: int, seed: int = 7) -> np.ndarray:
    """Frame n of a textured still scene with sensor noise and a patch of foliage whose leaves
    sway a few pixels from frame to frame, grey."""
    rng = np.random.default_rng(seed)
    image = rng.uniform(60.0, 180.0, SIZE)
    noise = np.random.default_rng(100 + n).normal(0.0, 1.5, SIZE)
    image[SWAY] = np.roll(image[SWAY], round(3 * np.sin(1.3 * n)), axis=1)
    return np.clip(image + noise, 0, 255).astype(np.uint8)


def with_block(image: np.ndarray, left: int) -> np.ndarray:
    out = image.copy()
    h, w = BLOCK
    out[30 : 30 + h, left : left + w] = 20
    return out


def test_a_passer_by_is_shown_as_the_scene_and_the_foliage_kept() -> None:
    """A block crossing the frames (over each pixel in a few of them) is shown as the scene,
    each of its pixels a sample another frame took of it (not the median, one value repeated);
    the swaying patch and every other pixel are the frame's own."""
    plain = [scene(n) for n in range(10)]
    frames = [with_block(image, 4 + 3 * n) for n, image in enumerate(plain)]
    cleaned = without_passers_by(frames, threshold=16.0, var_min=4.0, min_area=20)
    still = np.random.default_rng(7).uniform(60.0, 180.0, SIZE)
    for n, (image, out) in enumerate(zip(frames, cleaned, strict=True)):
        block = (slice(30, 30 + BLOCK[0]), slice(4 + 3 * n, 4 + 3 * n + BLOCK[1]))
        assert np.abs(out[block] - still[block]).max() < 8.0, n  # the scene, within the noise
        # every shown pixel is the same pixel of a frame whose block lies clear of it
        for column in range(4 + 3 * n, 4 + 3 * n + BLOCK[1]):
            clear = [m for m in range(10) if not 0 <= column - 4 - 3 * m < BLOCK[1]]
            samples = np.stack([plain[m][30 : 30 + BLOCK[0], column] for m in clear])
            assert (samples == out[30 : 30 + BLOCK[0], column]).any(axis=0).all(), (n, column)
        rest = np.ones(SIZE, bool)
        rest[30 - 3 : 30 + BLOCK[0] + 3, 4 + 3 * n - 3 : 4 + 3 * n + BLOCK[1] + 3] = False
        assert np.array_equal(out[rest], image[rest]), n
        assert np.array_equal(out[SWAY], image[SWAY]), n


def test_a_passer_by_smaller_than_a_blob_is_kept() -> None:
    plain = [scene(n) for n in range(10)]
    frames = [with_block(image, 4 + 3 * n) for n, image in enumerate(plain)]
    small = BLOCK[0] * BLOCK[1] + 1
    assert all(
        np.array_equal(a, b)
        for a, b in zip(frames, without_passers_by(frames, 16.0, 4.0, small), strict=True)
    )


def test_colour_frames_are_judged_over_their_channels() -> None:
    """A block 11 grey levels off the scene in each of three channels: within the threshold on
    any one channel (over the floor's variance), beyond it summed over the three, as MOG2
    judges a colour pixel."""
    threshold, var_min, shift = channel_threshold(16.0, 3), 6.0, 11.0
    assert shift**2 / var_min < threshold < 3 * shift**2 / var_min
    frames = []
    for n in range(10):
        image = np.repeat(scene(n).astype(float)[..., None], 3, axis=2)
        image[30 : 30 + BLOCK[0], 4 + 3 * n : 4 + 3 * n + BLOCK[1]] += shift
        frames.append(np.clip(image, 0, 255).astype(np.uint8))
    cleaned = without_passers_by(frames, threshold, var_min, min_area=20)
    for n, (image, out) in enumerate(zip(frames, cleaned, strict=True)):
        block = (slice(30, 30 + BLOCK[0]), slice(4 + 3 * n, 4 + 3 * n + BLOCK[1]))
        assert (out[block] != image[block]).any(axis=2).mean() >= 0.7, n  # most of it


def test_too_few_frames_to_tell_the_scene_are_learnt_as_they_are() -> None:
    frames = [with_block(scene(n), 4 + 3 * n) for n in range(2)]
    assert without_passers_by(frames, 16.0, 4.0, 20) is frames


@pytest.mark.parametrize("grey", [False, True], ids=["colour", "grey"])
def test_a_walker_on_the_path_another_took_while_the_model_learnt_is_seen(grey: bool) -> None:
    """One walker crosses the scene while the model learns it; then another in the same
    clothes walks the same path: they are seen, whole, in every frame (a model that learnt the
    first walker's colours along the path as the scene does not see the second there)."""
    silhouettes = model(ghosts=True)
    for n in range(LEARNING + 20):
        left = 40.0 + 4.0 * (n if n < LEARNING else n - LEARNING)
        foreground = silhouettes.segment(frame(n, left, grey))
        if foreground is None:
            continue
        assert lefts(foreground.found) == pytest.approx([left], abs=3.0), n
        widths = [body.width * 2 for _, bodies in foreground.found for body in bodies]
        assert widths[0] >= BODY[0], n


def test_frames_that_change_format_while_learning_start_the_learning_over() -> None:
    """Grey frames, then colour ones before the learning is done: the model starts over on the
    colour frames and reports after its learning frames of them."""
    silhouettes = model(ghosts=True)
    for n in range(LEARNING // 2):
        assert silhouettes.segment(frame(n, None, grey=True)) is None
    reported = [silhouettes.segment(frame(n, None)) is not None for n in range(LEARNING + 1)]
    assert reported == [False] * LEARNING + [True]


def test_long_learning_is_held_in_runs() -> None:
    """However many learning frames the rig asks for, at most `SCENE_BATCH_FRAMES` are held at
    once; a walker on a path taken during any of the runs is seen."""
    learning = 2 * SCENE_BATCH_FRAMES + 3
    silhouettes = model(ghosts=True)
    silhouettes.learning_frames = learning
    for n in range(learning + 10):
        left = 40.0 + 4.0 * ((n - SCENE_BATCH_FRAMES) if n < learning else n - learning)
        foreground = silhouettes.segment(frame(n, left if left >= 40.0 else None))
        assert len(silhouettes._learning) < SCENE_BATCH_FRAMES
        if foreground is not None:
            assert lefts(foreground.found) == pytest.approx([left], abs=3.0), n
