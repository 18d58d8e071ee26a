"""Seeded textures are made once in a process and shared read-only: a scene or a renderer built
again from the same seed gets the very same texture, and the generator it drew from is left
where making it would have left it, so everything drawn after is unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from gazed.sim.renderer import _ground_texture, ground_texture
from gazed.vision import synthetic


def test_a_texture_made_again_is_the_same_one_and_leaves_the_generator_as_making_it_would() -> None:
    first, again, made = (np.random.default_rng(41) for _ in range(3))
    shared = synthetic.texture(40, 30, first, (1.0, 2.0, 4.0))
    assert synthetic.texture(40, 30, again, (1.0, 2.0, 4.0)) is shared
    fresh = synthetic._texture(40, 30, made, (1.0, 2.0, 4.0))
    np.testing.assert_array_equal(shared, fresh)
    after = [rng.standard_normal(4) for rng in (first, again, made)]
    np.testing.assert_array_equal(after[0], after[2])
    np.testing.assert_array_equal(after[1], after[2])
    other = synthetic.texture(40, 30, np.random.default_rng(42), (1.0, 2.0, 4.0))
    assert not np.array_equal(other, shared)  # another seed, another texture
    with pytest.raises(ValueError, match="read-only"):
        shared[0, 0] = 0


def test_a_ground_texture_is_shared_read_only() -> None:
    yard = ground_texture(7, 64)
    assert ground_texture(7, 64) is yard
    np.testing.assert_array_equal(yard, _ground_texture(7, 64))
    with pytest.raises(ValueError, match="read-only"):
        yard[0, 0] = 0
