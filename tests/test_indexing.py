"""Strided slices and lax.pad for a Layout's indices (batchveh/model/indexing.py) against plain
fancy indexing: the same values for every index pattern, JAX and numpy alike."""

import jax.numpy as jnp
import numpy as np
import pytest

from batchveh.model.indexing import place, runs, take


def test_runs_split_indices_into_evenly_spaced_slices():
    assert runs([3, 5, 7, 9]) == [slice(3, 10, 2)]
    assert runs([7, 9, 11, 13, 6, 8, 10, 12]) == [slice(7, 14, 2), slice(6, 13, 2)]
    assert runs([4]) == [slice(4, 5, 1)]
    assert runs([3, 1]) == [slice(3, 4, 1), slice(1, 2, 1)]  # decreasing: one index per slice
    assert runs([0, 1, 2, 5, 8]) == [slice(0, 3, 1), slice(5, 9, 3)]


@pytest.mark.parametrize("idx", [[3, 5, 7, 9], [7, 9, 1, 3], [2], [0, 1, 2, 5, 8], [8, 2, 5]])
@pytest.mark.parametrize("axis", [-1, -2, -3])
def test_take_equals_fancy_indexing(idx, axis):
    x = np.random.default_rng(0).normal(size=(5, 10, 10, 10)).astype(np.float32)
    want = x[(Ellipsis, np.array(idx)) + (slice(None),) * (-axis - 1)]
    np.testing.assert_array_equal(np.asarray(take(jnp.asarray(x), np.array(idx), axis)), want)
    got = take(x, np.array(idx), axis)
    np.testing.assert_array_equal(got, want)
    assert not np.shares_memory(got, x)  # numpy: a copy, never a view of MuJoCo's buffers


@pytest.mark.parametrize("idx", [[3, 5, 7, 9], [2, 4, 6, 8], [1, 2, 3, 4], [9, 7, 5, 3], [0, 3, 4, 9]])
def test_place_equals_assignment(idx):
    v = np.random.default_rng(1).normal(size=(5, 4, 6)).astype(np.float32)
    want = np.zeros((5, 10, 6), np.float32)
    want[:, idx, :] = v
    np.testing.assert_array_equal(np.asarray(place(jnp.asarray(v), np.array(idx), 10)), want)
    np.testing.assert_array_equal(place(v, np.array(idx), 10), want)
