"""Constant gyroscope bias estimated with the hinge axis (imucal.gyr_bias)."""

import numpy as np
import pytest
from conftest import axis_error_deg

from imucal import estimate_axis, estimate_position
from imucal.gyr_bias import MAX_PLAUSIBLE_RAD_S, estimate_gyr_bias
from imucal.simulate import simulate


def _axis(seed=2, motion="protocol", **realism):
    rec, truth = simulate(seed=seed, rate=100, duration=30, motion=motion, gyr_noise=0.01,
                          acc_noise=0.05, **realism)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    axis = estimate_axis(th.gyr, sh.gyr, rate=100, seed=1, restarts=10, time_offset=0,
                         acc1=th.acc, acc2=sh.acc)
    return rec, truth, axis


def _across(b, j):
    j = np.asarray(j) / np.linalg.norm(j)
    return np.asarray(b) - (np.asarray(b) @ j) * j


@pytest.mark.parametrize("seed, motion", [(2, "protocol"), (3, "gait")])
def test_bias_is_found_removed_and_covered(seed, motion):
    rec, truth, axis = _axis(seed, motion, gyr_bias=0.02)
    found = axis.gyr_bias
    assert found["applied"] and found["cost_ratio"] > 1.5
    for key, sensor, j in (("b1_rad_s", "thigh", "j1"), ("b2_rad_s", "shank", "j2")):
        true = _across(truth["gyr_bias"][sensor], truth[j])
        assert np.linalg.norm(np.array(found[key]) - true) < 0.015  # prior sigma 0.02
    err = axis_error_deg(axis.j1, axis.j2, truth["j1"], truth["j2"])
    # the plain eq. (1) fit is 0.45 deg (protocol, seed 2) / 0.79 deg (gait, seed 3) off
    assert max(err) < 0.15
    assert axis.uncertainty_components["gyr_bias"]["j1"] > 0
    assert all(e < 3 * axis.uncertainty_deg[k] for e, k in zip(err, ("j1", "j2"), strict=True))


def test_the_plain_fit_is_biased_and_the_joint_fit_is_not():
    rec, truth, _ = _axis(gyr_bias=0.02)
    g1, g2 = rec.sensor("thigh").gyr[::5], rec.sensor("shank").gyr[::5]
    j1, j2 = np.array(truth["j1"]), np.array(truth["j2"])
    tilt = np.array([0.0, 0.008, -0.006])  # start 0.6 deg away from the truth
    found = estimate_gyr_bias(g1, g2, (j1 + tilt) / np.linalg.norm(j1 + tilt), j2)
    assert found.significant and found.cost_ratio > 2.0
    # eq. (1) does not see the axes' signs
    for est, true in ((found.j1, j1), (found.j2, j2)):
        assert np.degrees(np.arccos(min(1.0, abs(est @ true)))) < 0.1
    assert all(f >= 1.0 for f in found.inflation)


def test_no_bias_is_not_applied():
    _, truth, axis = _axis()
    assert not axis.gyr_bias["applied"]
    assert axis.gyr_bias["cost_ratio"] == pytest.approx(1.0, abs=0.01)
    assert axis.uncertainty_components["gyr_bias"] == {"j1": 0.0, "j2": 0.0}


def test_soft_tissue_asks_for_an_implausible_bias_which_is_not_removed():
    _, _, axis = _axis(4, "gait", soft_tissue_deg=1, soft_tissue_mm=2)
    found = axis.gyr_bias
    assert found["cost_ratio"] > 1.5 and not found["applied"]
    assert max(np.linalg.norm(found["b1_rad_s"]), np.linalg.norm(found["b2_rad_s"])) \
        > MAX_PLAUSIBLE_RAD_S


@pytest.mark.parametrize("seed, realism, move", [
    (4, dict(soft_tissue_deg=1, soft_tissue_mm=2), (4.22, 1.31)),
    (2, dict(gyr_bias=0.1), (2.16, 1.22))])
def test_an_implausible_bias_the_residual_asks_for_widens_the_axis_sigma(seed, realism, move):
    # not removed, and not counted either: a gait knee with biases of 0.1 rad/s read
    # 8.5 deg off at a 1-sigma of 1.43 deg (5.9 sigma; an independent audit), now 2.59
    _, truth, axis = _axis(seed, "gait", **realism)
    assert not axis.gyr_bias["applied"] and axis.gyr_bias["cost_ratio"] > 1.5
    part = axis.uncertainty_components["gyr_bias"]
    assert (part["j1"], part["j2"]) == pytest.approx(move, abs=0.05)
    assert axis.uncertainty_deg["j1"] >= part["j1"]
    assert sum("more than a warmed-up gyroscope's" in w for w in axis.warnings) == 1
    # the "uncertain" warning gives the total with that part (it gave the one before)
    (uncertain,) = [w for w in axis.warnings if w.startswith("the estimate is uncertain")]
    name = max(axis.uncertainty_deg, key=axis.uncertainty_deg.get)
    assert f"1-sigma {axis.uncertainty_deg[name]:.1f} deg for {name}" in uncertain
    err = axis_error_deg(axis.j1, axis.j2, truth["j1"], truth["j2"])
    assert err[0] / axis.uncertainty_deg["j1"] < (0.3 if seed == 4 else 3.3)


def test_the_joint_centre_bias_fit_has_the_right_jacobian():
    # the analytic Jacobian of eq. (3) in (o1, o2, b1, b2) against central differences,
    # gdot terms included
    import imucal.gyr_bias as gb

    rng = np.random.default_rng(0)
    data = tuple(rng.standard_normal((50, 3)) * s for s in (2.0, 5.0, 9.0, 2.0, 5.0, 9.0))
    x = rng.standard_normal(6) * 0.1
    found = {}

    def capture(rows, jacobian, p, tolerance):
        if p.size == 12:  # the fit with the biases (the second refits the centre alone)
            found["rows"], found["jacobian"] = rows, jacobian
        return p

    original = gb._levenberg_marquardt
    gb._levenberg_marquardt = capture
    try:
        gb.joint_centre_with_bias(data, x)
    finally:
        gb._levenberg_marquardt = original
    p = np.concatenate([x, rng.standard_normal(6) * 0.03])
    numeric = np.stack([(found["rows"](p + d) - found["rows"](p - d)) / 2e-6
                        for d in 1e-6 * np.eye(12)], axis=1)
    np.testing.assert_allclose(found["jacobian"](p), numeric, rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("seed", [5, 6])
def test_a_knee_centre_sliding_along_its_axis_is_not_taken_for_a_bias(seed):
    # no bias simulated: the hinge's point slid along the axis line in the bias refit and
    # that alone gave cost ratios of 2-10, so biases of 0.009 rad/s were "removed" and the
    # centre moved (seed 5: 5.4 -> 15.8 mm; an independent review)
    rec, _ = simulate(seed=seed, rate=100.0, duration=20.0, motion="gait", gyr_noise=0.01,
                      acc_noise=0.05, soft_tissue_deg=1.0, soft_tissue_mm=2.0)
    a, b = rec.sensor("thigh"), rec.sensor("shank")
    r = estimate_position(a.gyr, a.acc, b.gyr, b.acc, rate=100.0, seed=1, restarts=20,
                          joint="hinge", time_offset=0.0)
    assert not r.gyr_bias["applied"] and r.gyr_bias["cost_ratio"] < 1.5, r.gyr_bias


def test_a_fit_started_at_its_minimum_takes_one_jacobian():
    """A start at the minimum to rounding stops after its first step's model promises too
    little: it raised the damping ten times over, one Jacobian each (the right ankle's
    bias fit on the shared recording: 5 Jacobians)."""
    from imucal.gyr_bias import TOLERANCE, _levenberg_marquardt

    rng = np.random.default_rng(3)
    a = rng.normal(size=(200, 4))
    b = a @ np.array([1.0, -2.0, 0.5, 3.0]) + 0.1 * rng.normal(size=200)
    best = np.linalg.lstsq(a, b, rcond=None)[0]
    calls = []

    def jacobian(p):
        calls.append(p)
        return a
    out = _levenberg_marquardt(lambda p: a @ p - b, jacobian, best, TOLERANCE)
    np.testing.assert_allclose(out, best, atol=1e-12)
    assert len(calls) == 1
    calls.clear()
    out = _levenberg_marquardt(lambda p: a @ p - b, jacobian, best + 0.3, TOLERANCE)
    np.testing.assert_allclose(out, best, atol=1e-6)  # from elsewhere it still converges


@pytest.mark.parametrize("seed, rate, late, motion", [
    (0, 100, 0.045, "gait"), (12, 200, 0.02, "gait"), (0, 40, 0.02, "circling")])
def test_a_clock_offset_is_found_together_with_the_biases(seed, rate, late, motion):
    # at offset 0 the bias fit absorbed the misalignment (0.09-0.27 rad/s, implausible, not
    # removed), and the plain offset search settled where the unremoved bias put it:
    # 39.4 +- 0.16 ms for 45 ms (axis 1.2 deg off), 15.2 +- 0.25 ms for 20 ms (1.2 deg),
    # 15.0 +- 0.5 ms for 20 ms (1.3 deg); an honesty audit's 31 offsets off by 2-8 ms
    # at 0.2-1.7 ms 1-sigma all had a gyroscope bias
    rec, truth = simulate(seed=seed, rate=rate, duration=30 if motion == "gait" else 50,
                          motion=motion, gyr_noise=0.01, acc_noise=0.05,
                          clock_offset={"shank": late}, gyr_bias=0.02)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    axis = estimate_axis(th.gyr, sh.gyr, rate=rate, seed=1, acc1=th.acc, acc2=sh.acc)
    found = axis.time_offset
    assert found["applied"] and axis.gyr_bias["applied"]
    assert abs(found["time_offset_s"] - late) < max(0.001, 3 * found["sigma_s"])
    errors = axis_error_deg(axis.j1, axis.j2, truth["knee"]["j1"], truth["knee"]["j2"])
    assert max(errors) < 0.3, errors


def test_no_second_search_where_the_rates_ask_for_no_bias(monkeypatch):
    # the real recording's knees gain 1.00-1.04 from a bias: they pay no second search
    import imucal.axis as axis_module

    calls = []
    original = axis_module.offset_profile
    monkeypatch.setattr(axis_module, "offset_profile",
                        lambda *a, **k: calls.append(a[4:] or k) or original(*a, **k))
    rec, truth = simulate(seed=3, rate=100, duration=20, motion="gait", gyr_noise=0.01,
                          acc_noise=0.05, clock_offset={"shank": 0.02})
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    axis = estimate_axis(th.gyr, sh.gyr, rate=100, seed=1, restarts=20)
    assert axis.gyr_bias["cost_ratio"] < axis_module.BIAS_SEARCH_RATIO
    assert calls == [(False,)]


def test_a_large_bias_that_fakes_a_clock_offset_keeps_its_move_in_sync(monkeypatch):
    # gait with 0.1 rad/s biases, clocks in sync: the search applied +15.7 ms, where the
    # biases gain less and the axis moved 1.26 deg without them (8.55 deg off at a 1-sigma
    # of 1.70, an independent review); the move with the clocks in sync now counts too
    import imucal.axis as axis_module

    at_zero = []
    original = axis_module._estimate
    monkeypatch.setattr(axis_module, "_estimate", lambda *a, **k: (
        at_zero.append(1) if a[5].time_offset == 0 else None) or original(*a, **k))
    rec, truth = simulate(seed=2, rate=100, duration=30, motion="gait", gyr_noise=0.01,
                          acc_noise=0.05, gyr_bias=0.1)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    kw = dict(rate=100, seed=1, restarts=10, acc1=th.acc, acc2=sh.acc)
    auto = estimate_axis(th.gyr, sh.gyr, time_offset="auto", **kw)
    # two searches, each fitting the clocks in sync once with its bias-free refit; the
    # move in sync reuses the first search's (it fitted both again: 6)
    assert len(at_zero) == 2 * 2
    sync = estimate_axis(th.gyr, sh.gyr, time_offset=0, **kw)
    assert auto.time_offset["applied"]
    assert auto.time_offset["time_offset_s"] == pytest.approx(0.0157, abs=5e-4)
    for k in ("j1", "j2"):
        assert auto.uncertainty_components["gyr_bias"][k] == pytest.approx(
            sync.uncertainty_components["gyr_bias"][k], rel=1e-6)
    assert auto.uncertainty_deg["j1"] == pytest.approx(2.45, abs=0.02)
    (said,) = [w for w in auto.warnings if "more than a warmed-up gyroscope's" in w]
    assert "the axis would move by 2.2 deg with the clocks in sync, where they gain more" \
        in said
