"""Knee flexion over time (imucal.angles) and the simulator's shared mounting."""

from __future__ import annotations

import numpy as np
import pytest

from imucal.errors import InputError
from imucal.simulate import simulate


def test_mounting_seed_shares_the_mounting_and_nothing_else():
    cal, cal_truth = simulate(seed=1, mounting_seed=7, motion="protocol", duration=2.0)
    walk, walk_truth = simulate(seed=2, mounting_seed=7, motion="gait", duration=2.0)
    other, other_truth = simulate(seed=2, mounting_seed=8, motion="gait", duration=2.0)
    for key in ("j1", "j2", "o1", "o2"):
        assert walk_truth[key] == cal_truth[key]
        assert np.linalg.norm(np.subtract(other_truth[key], walk_truth[key])) > 0.05
    assert walk_truth["model"]["sensor_to_segment_rotation"] == (
        simulate(seed=7, duration=1.0)[1]["model"]["sensor_to_segment_rotation"])
    assert walk_truth["settings"]["mounting_seed"] == 7
    assert "mounting_seed" not in simulate(seed=2, duration=1.0)[1]["settings"]
    # the motion still follows seed: same seed and mounting -> same data
    again, _ = simulate(seed=2, mounting_seed=7, motion="gait", duration=2.0)
    assert np.array_equal(again.sensor("shank").gyr, walk.sensor("shank").gyr)
    assert not np.allclose(other.sensor("shank").gyr, walk.sensor("shank").gyr)


@pytest.mark.parametrize("bad", [-1, 1.5, "x", True])
def test_mounting_seed_must_be_a_non_negative_integer(bad):
    with pytest.raises(InputError, match="mounting_seed must be a non-negative integer"):
        simulate(seed=1, mounting_seed=bad, duration=1.0)
