"""Hinge axis estimation against simulated recordings with known truth."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import axis_error_deg, simulated

from imucal import InputError, estimate_axis
from imucal.sign import plane_test


@pytest.mark.parametrize("rate", [100.0, 40.0])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_knee_axis_meets_paper_targets(seed, rate):
    rec, truth = simulated(seed, rate)
    r = estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rec.rate, seed=seed)
    e1, e2 = axis_error_deg(r.j1, r.j2, truth["j1"], truth["j2"])
    assert e1 < 0.5 and e2 < 0.5, (e1, e2)
    assert r.convergence_fraction >= 0.95
    assert np.median(r.iterations) <= 10
    assert np.isfinite(r.batch.x).all() and np.isfinite(r.refined.x).all()
    assert r.warnings == []
    assert np.allclose(np.linalg.norm(r.j1), 1) and np.allclose(np.linalg.norm(r.j2), 1)


def test_relative_sign_matches_truth_over_many_cases():
    wrong = []
    for seed in range(20, 40):
        rec, truth = simulated(seed, 100.0, 100.0, "circling", 10.0)
        r = estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rec.rate,
                          seed=0, restarts=10)
        e1, e2 = axis_error_deg(r.j1, r.j2, truth["j1"], truth["j2"])
        if max(e1, e2) > 2:
            wrong.append((seed, e1, e2))
    assert wrong == []


def test_sign_test_rejects_flipped_axis():
    rec, truth = simulated(4)
    g1, g2 = rec.sensor("thigh").gyr, rec.sensor("shank").gyr
    j1, j2 = np.array(truth["j1"]), np.array(truth["j2"])
    test = plane_test(g1, g2, j1, j2, rec.rate)
    assert test.sign == 1.0 and test.evidence > 5
    test = plane_test(g1, g2, j1, -j2, rec.rate)
    assert test.sign == -1.0 and test.evidence > 5


def test_spheroidal_ankle_gives_no_confident_axis():
    rec, _ = simulated(1)
    r = estimate_axis(rec.sensor("shank").gyr, rec.sensor("foot").gyr, rate=rec.rate, seed=1)
    assert not r.confident
    assert r.convergence_fraction < 0.8 or r.relative_residual > 0.25
    assert np.isfinite(r.batch.x).all()


def test_rigid_knee_gives_no_confident_axis():
    rec, _ = simulated(1, motion="rigid-knee")
    r = estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rec.rate, seed=1)
    assert not r.confident


@pytest.mark.parametrize(("motion", "seed", "refused"),
                         [("rigid-knee", 7, True), ("rigid-knee", 8, True),
                          ("gait", 1, False), ("circling", 4, False)])
def test_a_rigid_knee_that_wobbles_on_the_skin_is_refused(motion, seed, refused):
    # soft tissue (2 deg / 3 mm) makes a rigid knee "bend" at about 9-22 deg/s while the
    # leg swings at 70-100 deg/s: the fit latched onto the wobble, 46-87 deg from the
    # truth, and said "use with care" at a 1-sigma of 11-18 deg (4-5 sigma off); real
    # knee motion with the same soft tissue stays answered
    from imucal.simulate import simulate

    rec, truth = simulate(seed=seed, motion=motion, rate=100.0, duration=20.0,
                          soft_tissue_deg=2, soft_tissue_mm=3, gyr_noise=0.01,
                          acc_noise=0.05)
    r = estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rec.rate,
                      seed=1)
    flex = r.excitation["flexion_rate_rms_deg_s"]
    if refused:
        assert r.verdict == "not identifiable" and flex < 30.0
        assert r.blocking[0].startswith("the joint barely bent while its segments turned")
    else:
        assert not any("barely bent" in b for b in r.blocking) and flex > 60.0
        assert max(axis_error_deg(r.j1, r.j2, truth["j1"], truth["j2"])) < 10.0


def test_same_seed_same_answer_and_seed_recorded():
    rec, _ = simulated(5)
    g1, g2 = rec.sensor("thigh").gyr, rec.sensor("shank").gyr
    a = estimate_axis(g1, g2, rate=rec.rate, seed=9, restarts=20)
    b = estimate_axis(g1, g2, rate=rec.rate, seed=9, restarts=20)
    assert np.array_equal(a.j1, b.j1) and np.array_equal(a.batch.path, b.batch.path)
    c = estimate_axis(g1, g2, rate=rec.rate, restarts=5)
    d = estimate_axis(g1, g2, rate=rec.rate, restarts=5, seed=c.settings["seed"])
    assert np.array_equal(c.batch.path, d.batch.path)


def test_window_selects_samples():
    rec, truth = simulated(6)
    r = estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rec.rate,
                      seed=1, start=5.0, end=15.0, subsample=1)
    assert r.window == (5.0, 15.0)
    assert r.samples_used == 1000
    assert max(axis_error_deg(r.j1, r.j2, truth["j1"], truth["j2"])) < 0.5


@pytest.mark.parametrize(
    ("kwargs", "phrase"),
    [
        ({"rate": 0.0}, "sample rate"),
        ({"rate": 100.0, "start": 30.0}, "outside the recording"),
        ({"rate": 100.0, "start": 5.0, "end": 4.0}, "after its start"),
        ({"rate": 100.0, "end": 0.05}, "samples left"),
        ({"rate": 100.0, "restarts": 0}, "restarts"),
    ],
)
def test_bad_arguments_raise_input_error(kwargs, phrase):
    rec, _ = simulated(1)
    with pytest.raises(InputError, match=phrase):
        estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, **kwargs)


def test_mismatched_arrays_raise_input_error():
    with pytest.raises(InputError, match="different lengths"):
        estimate_axis(np.ones((100, 3)), np.ones((99, 3)), rate=100)
    with pytest.raises(InputError, match=r"expected \(N, 3\)"):
        estimate_axis(np.ones((100, 2)), np.ones((100, 2)), rate=100)


def test_lowest_cost_wins_even_when_most_restarts_end_elsewhere():
    # Simulated walking: most restarts end in a local minimum ~10 deg off the truth.
    rec, truth = simulated(2, 100.0, 100.0, "walking")
    r = estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rec.rate, seed=1)
    assert max(axis_error_deg(r.j1, r.j2, truth["j1"], truth["j2"])) < 0.5
    assert r.refined.final_cost[r.reached].max() <= r.refined.final_cost.min() * 1.001
    # The other minimum fits clearly worse, so it is no reason to doubt the estimate.
    rms = np.sqrt(r.refined.final_cost)
    assert r.convergence_fraction < 0.5 and rms[~r.reached].min() > 1.25 * rms.min()
    assert r.competing_agreement == 1.0 and r.warnings == []


def test_static_recording_is_flagged():
    rec, _ = simulated(1, motion="static")
    r = estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rec.rate, seed=1)
    assert any("barely rotate" in w for w in r.blocking)
    # and nothing beside it: a poor fit, an uncertain estimate or a clock offset read
    # first sent a user checking the synchronisation (a new-user trial)
    assert r.warnings == []
    assert r.verdict == "not identifiable"
    assert np.isfinite(r.batch.x).all() and 1.0 <= r.sign_evidence < 1.5


def test_a_sensor_that_does_not_turn_is_named():
    # "RMS rate 123.9 and 0.0 deg/s, below 5" left the dead one to be guessed
    rec, _ = simulated(1)
    gyr = rec.sensor("thigh").gyr
    r = estimate_axis(gyr, np.zeros_like(gyr), rate=rec.rate, seed=1, restarts=4)
    assert any(w.startswith("the sensors barely rotate (the second sensor: RMS rate 0.0 "
                            "deg/s, the first ") for w in r.blocking), r.blocking


def test_rigid_knee_has_a_small_singular_ratio():
    rigid, _ = simulated(1, motion="rigid-knee")
    moving, _ = simulated(1)
    ratios = [
        estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rec.rate,
                      seed=1, restarts=10).singular_ratio
        for rec in (rigid, moving)
    ]
    assert ratios[0] < 0.05 < 0.2 < ratios[1]


@pytest.mark.parametrize(("evidence", "warned"), [(1.2, True), (1.57, True), (2.03, True),
                                                  (2.6, False), (40.0, False)])
def test_a_relative_sign_on_evidence_below_2_5_gets_a_warning(evidence, warned):
    # two weak tests (plane 1.06, acc 1.48) combined to 1.57 and read as decided: a gait
    # knee under soft tissue came out 164 deg off, "use with care", no word of its sign
    # (an independent audit); of 300 simulated knees the wrong signs had 1.04-2.12
    from imucal.axis import _sign_warnings
    from imucal.sign import SignDecision

    decision = SignDecision(sign=1.0, evidence=evidence, tests={}, contradicting=[])
    said = _sign_warnings(decision, 1.0, pinned=False)
    assert bool(said) is warned
    if warned:
        assert said[0].startswith("the data barely decide whether j1 and j2 point the same "
                                  f"way (evidence ratio {evidence:.2f}, below 2.5")


def test_a_still_sensor_keeps_the_doubt_about_the_others_units():
    # a still thigh beside a shank whose deg/s were read as rad/s: the stillness reason
    # stands alone, but the units doubt is a reason too and was dropped with the rest
    rec, _ = simulated(4, motion="gait", duration=20.0)
    sh = rec.sensor("shank")
    rng = np.random.default_rng(0)
    g1 = rng.normal(0, 0.002, sh.gyr.shape)
    r = estimate_axis(g1, sh.gyr * 57.2958, rate=rec.rate, seed=1, restarts=10,
                      time_offset=0)
    assert r.blocking[0].startswith("the sensors barely rotate (the first sensor")
    assert len(r.warnings) == 1
    assert r.warnings[0].startswith("the second sensor's angular rate exceeds 370 rad/s")
    assert r.warnings[0].endswith("the gyroscope data look like deg/s read as rad/s")


def test_a_barely_decided_sign_with_a_doubted_clock_offset_is_refused():
    # simulated gait with soft tissue: the axis applied +69 ms the clocks did not have,
    # from the rates alone, and its barely decided relative sign turned j2 over, 175 deg
    # off at a 1-sigma of 5 deg, "use with care" (an honesty audit); calibrate's knee
    # centre leaves that offset unapplied, and its axis is right
    import imucal
    from imucal.simulate import simulate

    rec, truth = simulate(seed=3044, motion="gait", rate=120.0, duration=8.0,
                          gyr_noise=0.005, acc_noise=0.02, soft_tissue_deg=3.0,
                          soft_tissue_mm=4.0, gyr_bias=0.05, acc_bias=0.05)
    thigh, shank = rec.sensor("thigh"), rec.sensor("shank")
    result = imucal.estimate_axis(thigh.gyr, shank.gyr, acc1=thigh.acc, acc2=shank.acc,
                                  rate=rec.rate, seed=1)
    assert result.sign_evidence < 2.5 and result.time_offset["applied"]
    assert result.blocking and result.blocking[0].startswith(
        "the relative sign of j1 and j2 is barely decided (evidence 1.37")
    assert result.blocking[0].endswith("or use imucal calibrate (the knee centre checks "
                                       "the offset)")
    pinned = imucal.estimate_axis(thigh.gyr, shank.gyr, acc1=thigh.acc, acc2=shank.acc,
                                  rate=rec.rate, seed=1, j2_sign="-x")
    assert not pinned.blocking
    # a given offset is no doubted one (calibrate --time-offset 0 was told to give one, a
    # review)
    from imucal.axis import refuse_doubted_sign

    result.time_offset["mode"] = "given"
    assert not refuse_doubted_sign(result).blocking
    knee = imucal.calibrate(rec, joints=["knee=hinge:thigh,shank"], seed=1).joints["knee"]
    assert knee.verdict == "use with care"
    assert max(axis_error_deg(knee.j1, knee.j2, truth["knee"]["j1"], truth["knee"]["j2"])) < 6.0
