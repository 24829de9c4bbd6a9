"""The restart bookkeeping shared by both estimators."""

from __future__ import annotations

import numpy as np
import pytest

from imucal import InputError
from imucal.restarts import best_restart, resolve_seed, subset_mask


def _dist(x, y):
    return np.linalg.norm(x - y, axis=-1)


def test_best_restart_is_the_lowest_cost_not_the_most_popular():
    finals = np.array([[0.0], [0.0], [0.0], [5.0], [5.001], [np.nan]])
    costs = np.array([2.0, 2.0, 2.0, 1.0, 1.0000001, np.nan])
    best, reached = best_restart(finals, costs, _dist, tolerance=0.01)
    assert best == 3
    assert reached.tolist() == [False, False, False, True, True, False]


def test_best_restart_needs_one_finite_result():
    with pytest.raises(InputError, match="finite"):
        best_restart(np.full((2, 1), np.nan), np.full(2, np.nan), _dist, 1.0)


def test_subset_fraction_must_be_in_0_1():
    with pytest.raises(InputError):
        subset_mask(100, 7, 0.0, np.random.default_rng(0))


def test_seed_is_drawn_when_missing_and_kept_when_given():
    assert resolve_seed(42) == 42
    assert 0 <= resolve_seed(None) < 2**32
    with pytest.raises(InputError):
        resolve_seed(-1)


def test_subset_mask_rows_are_random_halves():
    mask = subset_mask(2000, 50, 0.5, np.random.default_rng(0))
    assert mask.shape == (50, 2000) and set(np.unique(mask)) == {0.0, 1.0}
    share = mask.mean(axis=1)
    assert np.all(np.abs(share - 0.5) < 0.06)  # 0.011 standard deviation per row
    assert not np.array_equal(mask[0], mask[1])
    assert subset_mask(2000, 50, 1.0, np.random.default_rng(0)) is None
    tiny = subset_mask(2, 200, 0.01, np.random.default_rng(0))
    assert np.all(tiny.sum(axis=1) >= 1)
