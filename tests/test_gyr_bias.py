"""Constant gyroscope bias estimated with the hinge axis (imucal.gyr_bias)."""

import numpy as np
import pytest

from imucal import estimate_axis
from imucal.gyr_bias import MAX_PLAUSIBLE_RAD_S, estimate_gyr_bias
from imucal.simulate import simulate


def _fit(**realism):
    rec, truth = simulate(seed=2, rate=100, duration=30, motion="protocol", gyr_noise=0.01,
                          acc_noise=0.05, **realism)
    g1, g2 = rec.sensor("thigh").gyr, rec.sensor("shank").gyr
    axis = estimate_axis(g1, g2, rate=100, seed=1, restarts=10, time_offset=0)
    return truth, axis, estimate_gyr_bias(axis.gyr1, axis.gyr2, axis.j1, axis.j2)


def _across(b, j):
    j = np.asarray(j) / np.linalg.norm(j)
    return np.asarray(b) - (np.asarray(b) @ j) * j


def _deg(a, b):
    return np.degrees(np.arccos(min(1.0, abs(a @ b) / np.linalg.norm(a) / np.linalg.norm(b))))


def test_bias_found_and_axis_corrected():
    truth, axis, found = _fit(gyr_bias=0.02)
    assert found.significant and found.cost_ratio > 2.0
    for b, sensor, j in ((found.b1, "thigh", "j1"), (found.b2, "shank", "j2")):
        assert np.linalg.norm(b - _across(truth["gyr_bias"][sensor], truth[j])) < 0.005
    # the plain fit is off by about half a degree; the joint fit lands next to the truth
    assert _deg(axis.j1, np.array(truth["j1"])) > 0.3
    assert _deg(found.j1, np.array(truth["j1"])) < 0.05
    assert _deg(found.j2, np.array(truth["j2"])) < 0.05


def test_no_bias_is_not_applied():
    _, _, found = _fit()
    assert found.cost_ratio == pytest.approx(1.0, abs=0.01)
    assert not found.significant and not found.implausible


def test_soft_tissue_asks_for_an_implausible_bias():
    rec, _ = simulate(seed=4, rate=100, duration=30, motion="gait", gyr_noise=0.01,
                      acc_noise=0.05, soft_tissue_deg=1, soft_tissue_mm=2)
    g1, g2 = rec.sensor("thigh").gyr, rec.sensor("shank").gyr
    axis = estimate_axis(g1, g2, rate=100, seed=1, restarts=10, time_offset=0)
    found = estimate_gyr_bias(axis.gyr1, axis.gyr2, axis.j1, axis.j2)
    assert found.cost_ratio > 1.5 and found.size > MAX_PLAUSIBLE_RAD_S
    assert found.implausible and not found.significant
