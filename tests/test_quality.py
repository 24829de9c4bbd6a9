"""The quality report: honest uncertainties, identifiability, signs, sample selection.

Everything is checked against simulated recordings with known truth.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import axis_error_deg, simulated
from test_cli import imucal

from imucal import estimate_axis, estimate_position
from imucal.quality import smooth_residual_rms
from imucal.recording import make_recording
from imucal.simulate import simulate
from imucal.writers import save_recording


def _random_cases(n: int):
    """n simulated recordings, SNR log-uniform in [30, 300], rate in [40, 200] Hz."""
    rng = np.random.default_rng(2026)
    for i in range(n):
        snr = float(np.exp(rng.uniform(np.log(30), np.log(300))))
        rate = float(rng.choice([40, 50, 60, 100, 120, 150, 200]))
        rec, truth = simulate(seed=500 + i, rate=rate, duration=10, snr=snr)
        yield rec, truth, snr, rate


@pytest.fixture(scope="module")
def random_batch():
    """Axis and position estimates with their true errors on 60 random cases."""
    rows = []
    for rec, truth, _snr, rate in _random_cases(60):
        th, sh, ft = rec.sensor("thigh"), rec.sensor("shank"), rec.sensor("foot")
        a = estimate_axis(th.gyr, sh.gyr, rate=rate, seed=1, restarts=20)
        # exact accelerometers, so no accelerometer error part (its own test below)
        p = estimate_position(sh.gyr, sh.acc, ft.gyr, ft.acc, rate=rate, seed=1, restarts=20,
                              acc_error=0.0)
        knee, ankle = truth["knee"], truth["ankle"]
        rows.append({
            "axis_err": axis_error_deg(a.j1, a.j2, knee["j1"], knee["j2"]),
            "axis_sigma": (a.uncertainty_deg["j1"], a.uncertainty_deg["j2"]),
            "same_way": np.sign(a.j1 @ knee["j1"]) == np.sign(a.j2 @ knee["j2"]),
            "pos_err": (1000 * np.linalg.norm(p.o1 - ankle["o1"]),
                        1000 * np.linalg.norm(p.o2 - ankle["o2"])),
            "pos_sigma": (p.uncertainty_mm["o1"], p.uncertainty_mm["o2"]),
            "verdicts": (a.verdict, p.verdict),
        })
    return rows


def test_axis_uncertainty_is_honest(random_batch):
    err = np.array([r["axis_err"] for r in random_batch])
    sigma = np.array([r["axis_sigma"] for r in random_batch])
    within = np.all(err < 3 * sigma, axis=1)
    assert within.mean() >= 0.95, within.mean()
    # ... and not uselessly wide: the median error is a sizeable part of sigma
    assert np.median(err / sigma) > 0.3


def test_position_uncertainty_is_honest(random_batch):
    err = np.array([r["pos_err"] for r in random_batch])
    sigma = np.array([r["pos_sigma"] for r in random_batch])
    within = np.all(err < 3 * sigma, axis=1)
    assert within.mean() >= 0.95, within.mean()
    assert np.median(err / sigma) > 0.3


def test_relative_sign_is_right_in_every_case(random_batch):
    assert all(r["same_way"] for r in random_batch)
    assert all(max(r["axis_err"]) < 2 for r in random_batch)


def test_good_recordings_raise_no_warning(random_batch):
    verdicts = [v for r in random_batch for v in r["verdicts"]]
    assert verdicts.count("good") >= 0.95 * len(verdicts), verdicts


def test_sampling_uncertainty_shrinks_as_the_recording_grows():
    sampling, shift = [], []
    for duration in (8, 30):
        rec, _ = simulate(seed=3, rate=100, duration=duration, snr=50)
        th, sh, ft = rec.sensor("thigh"), rec.sensor("shank"), rec.sensor("foot")
        a = estimate_axis(th.gyr, sh.gyr, rate=100, seed=1, restarts=10)
        p = estimate_position(sh.gyr, sh.acc, ft.gyr, ft.acc, rate=100, seed=1, restarts=10)
        row, moved = [], []
        for r, names in ((a, ("j1", "j2")), (p, ("o1", "o2"))):
            c = r.uncertainty_components
            row += [max(c["curvature"][k], c["time_blocks"][k]) for k in names]
            moved += [c["cutoff_shift"][k] for k in names]
        sampling.append(row)
        shift.append(moved)
    short, long = np.array(sampling)
    # the sampling error goes about as 1/sqrt(number of samples): 3000 against 800
    assert np.all(long < 0.75 * short), (short, long)
    # the filter's bias does not average out: the reported total keeps it
    assert np.array(shift)[1, 2] > 0.5 * np.array(shift)[0, 2]


@pytest.mark.parametrize(
    ("motion", "pair", "phrase"),
    [
        ("rigid-knee", "thigh,shank", "barely bent"),
        ("static", "thigh,shank", "barely rotate"),
        ("circling", "shank,foot", "does not move like a hinge"),
    ],
)
def test_axis_refuses_what_the_data_cannot_identify(tmp_path, motion, pair, phrase):
    rec = tmp_path / f"{motion}.h5"
    assert imucal("simulate", rec, "--seed", 1, "--motion", motion).returncode == 0
    run = imucal("axis", rec, "--sensors", pair, "--seed", 1, "--out", tmp_path / "a.json")
    assert run.returncode == 1
    err = run.stderr.decode()
    assert phrase in err and "--force" in err and "Traceback" not in err
    assert run.stdout == b"" and not (tmp_path / "a.json").exists()

    forced = imucal("axis", rec, "--sensors", pair, "--seed", 1, "--force")
    assert forced.returncode == 0
    quality = json.loads(forced.stdout)["quality"]
    assert quality["verdict"] == "not identifiable"
    assert any(phrase in w for w in quality["warnings"])


def test_position_refuses_a_rigid_joint(tmp_path):
    rec = tmp_path / "rigid.h5"
    assert imucal("simulate", rec, "--seed", 1, "--motion", "rigid-knee").returncode == 0
    run = imucal("position", rec, "--sensors", "thigh,shank", "--seed", 1)
    assert run.returncode == 1 and b"barely moved" in run.stderr and run.stdout == b""


def test_rigid_joint_identifiability_numbers():
    rec, _ = simulated(1, motion="rigid-knee")
    r = estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rec.rate,
                      seed=1, restarts=10)
    assert r.excitation["flexion_rate_rms_deg_s"] < 5 and r.verdict == "not identifiable"
    good, _ = simulated(1)
    g = estimate_axis(good.sensor("thigh").gyr, good.sensor("shank").gyr, rate=good.rate,
                      seed=1, restarts=10)
    assert g.excitation["flexion_rate_rms_deg_s"] > 50 and g.verdict == "good"
    assert g.sensitivity["max_shift_deg"] < 0.5


def test_line_ambiguity_is_a_warning_with_the_reason():
    rec, _ = simulated(1)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    r = estimate_position(th.gyr, th.acc, sh.gyr, sh.acc, rate=rec.rate, seed=1, restarts=10)
    assert r.verdict == "use with care"
    assert any("only known along a line" in w for w in r.warnings)


@pytest.mark.parametrize("sign", ["+x", "-x", "+y", "-z"])
def test_sign_convention_pins_j1_and_keeps_j2_aligned(sign):
    rec, truth = simulated(2)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    r = estimate_axis(th.gyr, sh.gyr, rate=rec.rate, seed=1, restarts=10, sign=sign)
    k = "xyz".index(sign[1])
    assert (r.j1[k] > 0) == (sign[0] == "+")
    assert max(axis_error_deg(r.j1, r.j2, truth["j1"], truth["j2"])) < 0.5


def test_bad_sign_convention_is_a_usage_error(tmp_path):
    run = imucal("axis", "sample_data/circling.h5", "--sign", "x+")
    assert run.returncode == 2 and b"sign must be" in run.stderr


def _with_still_stretch(seed: int, still_s: float):
    """A simulated recording with ``still_s`` seconds of standing still in the middle."""
    rec, truth = simulated(seed)
    n_still = int(still_s * rec.rate)
    half = rec.n_samples // 2
    sensors = {}
    for name, s in rec.sensors.items():
        still_acc = np.tile(s.acc[half], (n_still, 1))
        sensors[name] = {
            "gyr": np.concatenate([s.gyr[:half], np.zeros((n_still, 3)), s.gyr[half:]]),
            "acc": np.concatenate([s.acc[:half], still_acc, s.acc[half:]]),
        }
    return make_recording(sensors, rate=rec.rate, source="still.h5"), truth, half / rec.rate


def test_selection_drops_still_stretches_and_reports_the_ranges():
    rec, truth, t_still = _with_still_stretch(1, 30.0)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    r = estimate_axis(th.gyr, sh.gyr, rate=rec.rate, seed=1, restarts=10)
    assert r.time_ranges.shape == (2, 2)
    assert abs(r.time_ranges[0, 1] - t_still) < 0.3
    assert abs(r.time_ranges[1, 0] - (t_still + 30)) < 0.3
    # the 0.2 s energy window reaches 0.1 s into the still stretch on each side
    assert r.samples_used <= 2000 + 20 and r.verdict == "good"
    assert max(axis_error_deg(r.j1, r.j2, truth["j1"], truth["j2"])) < 0.5
    everything = estimate_axis(th.gyr, sh.gyr, rate=rec.rate, seed=1, restarts=10,
                               select=False)
    assert everything.samples_used == rec.n_samples and len(everything.time_ranges) == 1


def test_selection_thins_to_max_samples_and_the_window_wins():
    rec, _ = simulated(1)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    r = estimate_axis(th.gyr, sh.gyr, rate=rec.rate, seed=1, restarts=10, max_samples=500,
                      start=5.0, end=15.0)
    assert r.samples_used <= 500
    assert r.time_ranges.min() >= 5.0 - 1e-9 and r.time_ranges.max() <= 15.0 + 1e-9


def test_cli_reports_time_ranges_and_the_verdict(tmp_path):
    rec, _, _ = _with_still_stretch(1, 20.0)
    path = tmp_path / "still.h5"
    save_recording(rec, path)
    run = imucal("axis", path, "--seed", 1, "--restarts", 10)
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert len(doc["input"]["time_ranges_s"]) == 2
    q = doc["quality"]
    assert q["verdict"] == "good" and q["warnings"] == []
    assert q["j1_uncertainty_deg"] > 0 and q["j1_spread_deg"] >= 0
    assert q["identifiability"]["condition_number"] >= 1
    assert b"verdict: good" in run.stderr


def test_repaired_input_is_never_good(tmp_path):
    lines = (Path(__file__).resolve().parents[1] / "sample_data" /
             "circling_40hz.csv").read_text().splitlines()
    row = lines[100].split(",")
    lines[100] = ",".join([row[0]] + ["nan"] * (len(row) - 1))
    path = tmp_path / "gap.csv"
    path.write_text("\n".join(lines) + "\n")
    run = imucal("axis", path, "--seed", 1, "--restarts", 10)
    assert run.returncode == 0, run.stderr
    quality = json.loads(run.stdout)["quality"]
    assert quality["verdict"] == "use with care"
    assert any(w.startswith("input: ") and "interpolation" in w for w in quality["warnings"])


def test_simulate_refuses_an_unknown_format_before_simulating(tmp_path):
    run = imucal("simulate", tmp_path / "x.txt", "--duration", 3600)
    assert run.returncode == 2 and b"unknown output format" in run.stderr


def test_spheroidal_ankles_fitted_as_a_hinge_are_never_good():
    verdicts = []
    for seed in range(1, 7):
        for duration, rate, snr in ((20, 100, 100), (10, 50, 30)):
            rec, _ = simulate(seed=seed, rate=rate, duration=duration, snr=snr)
            sh, ft = rec.sensor("shank"), rec.sensor("foot")
            r = estimate_axis(sh.gyr, ft.gyr, rate=rate, seed=1)
            assert r.relative_residual > 0.1, (seed, duration)
            verdicts.append(r.verdict)
    assert "good" not in verdicts
    # measured: 11 of 12 refused; the other one, where the restarts agree, warns
    assert verdicts.count("not identifiable") >= 10, verdicts


def test_smooth_residual_is_the_slow_part_not_white_noise_or_ringing():
    rng = np.random.default_rng(3)
    t = np.arange(4000) / 100.0
    noise = 0.05 * rng.standard_normal(t.size)
    # ringing at 35 Hz after "heel strikes" once a second, ten times the noise's power
    ringing = 0.3 * np.sin(2 * np.pi * 35 * t) * np.exp(-((t % 1.0) / 0.05))
    slow = 0.04 * np.sqrt(2) * np.sin(2 * np.pi * 1.1 * t)  # RMS 0.04
    assert smooth_residual_rms(noise, 100.0) < 0.006
    assert smooth_residual_rms(noise + ringing, 100.0) < 0.008
    assert 0.035 < smooth_residual_rms(noise + ringing + slow, 100.0) < 0.045


@pytest.mark.parametrize(("motion", "seed", "deg", "mm"),
                         [("protocol", 19, 2.0, 3.0), ("gait", 9, 0.5, 1.0),
                          ("gait", 13, 1.0, 2.0)])
def test_soft_tissue_axis_error_is_covered_or_not_called_good(motion, seed, deg, mm):
    # an independent review found these "good" at 11, 6.3 and 6.0 sigma: the model term
    # had been 0 (protocol: the lag-1 estimate went negative) or a third of what gait needs
    # (gait seed 21 at 1 deg / 2 mm is still 4.2 sigma and "good": method.md)
    rec, truth = simulate(seed=seed, motion=motion, rate=100.0, duration=20.0,
                          gyr_noise=0.01, acc_noise=0.05, soft_tissue_deg=deg,
                          soft_tissue_mm=mm)
    a, b = rec.sensor("thigh"), rec.sensor("shank")
    r = estimate_axis(a.gyr, b.gyr, rate=100.0, seed=1, acc1=a.acc, acc2=b.acc,
                      time_offset=0.0)
    errors = axis_error_deg(r.j1, r.j2, truth["j1"], truth["j2"])
    ratio = max(e / r.uncertainty_deg[k] for e, k in zip(errors, ("j1", "j2"), strict=True))
    assert ratio < 3.0, (errors, r.uncertainty_deg, r.verdict)
    assert r.uncertainty_components["model"]["j1"] > 0.5


@pytest.mark.parametrize(("motion", "seed"), [("gait", 528), ("protocol", 505)])
def test_soft_tissue_at_40_hz_keeps_its_model_term(motion, seed):
    # At 40 Hz the ringing's aliases fill every octave above the model band, so the
    # "white floor" was the residual itself and the model term 0: "good" at 16 and 5.5
    # sigma (an independent review; seed 505 at 1 deg / 2 mm from a held-out sweep)
    rec, truth = simulate(seed=seed, motion=motion, rate=40.0, duration=30.0,
                          gyr_noise=0.01, acc_noise=0.05, soft_tissue_deg=1.0,
                          soft_tissue_mm=2.0)
    a, b = rec.sensor("thigh"), rec.sensor("shank")
    r = estimate_axis(a.gyr, b.gyr, rate=40.0, seed=1, restarts=30, acc1=a.acc, acc2=b.acc,
                      time_offset=0.0)
    errors = axis_error_deg(r.j1, r.j2, truth["j1"], truth["j2"])
    ratio = max(e / r.uncertainty_deg[k] for e, k in zip(errors, ("j1", "j2"), strict=True))
    assert ratio < 3.0, (errors, r.uncertainty_deg, r.verdict)
    assert r.uncertainty_components["model"]["j1"] > 0.5


@pytest.mark.parametrize(("seed", "deg", "mm"), [(15, 1.0, 2.0), (19, 2.0, 3.0), (6, 0.5, 1.0)])
def test_soft_tissue_joint_centre_error_is_covered_or_not_called_good(seed, deg, mm):
    # circling ankles with soft tissue were "good" at 4.7, 3.9 and 3.0 sigma (o1 off by
    # 9.4, 27.7 and 3.9 mm): every time block shares the error, and the joint centre had
    # no model term
    rec, truth = simulate(seed=seed, motion="circling", rate=100.0, duration=20.0,
                          gyr_noise=0.01, acc_noise=0.05, soft_tissue_deg=deg,
                          soft_tissue_mm=mm)
    a, b = rec.sensor("shank"), rec.sensor("foot")
    r = estimate_position(a.gyr, a.acc, b.gyr, b.acc, rate=100.0, seed=1, time_offset=0.0)
    error = {k: 1000 * np.linalg.norm(getattr(r, k) - truth["ankle"][k]) for k in ("o1", "o2")}
    ratio = max(error[k] / r.uncertainty_mm[k] for k in error)
    assert ratio < 3.0 or r.verdict != "good", (error, r.uncertainty_mm, r.verdict)
    assert r.uncertainty_components["model"]["o1"] > 0.5 * error["o1"] / 3


def test_clean_joint_centre_gets_a_small_model_term_and_keeps_its_verdict():
    rec, _ = simulated(seed=3)
    a, b = rec.sensor("shank"), rec.sensor("foot")
    r = estimate_position(a.gyr, a.acc, b.gyr, b.acc, rate=rec.rate, seed=1, time_offset=0.0,
                          acc_error=0.0)  # the simulator's accelerometers are exact
    model = r.uncertainty_components["model"]
    assert r.verdict == "good"
    assert 0.0 < max(model.values()) < 1.5  # mm; the curvature's 1-sigma is about 0.5-1
    # the term enters the reported 1-sigma in quadrature
    c = r.uncertainty_components
    for k in ("o1", "o2"):
        expected = np.sqrt(max(c["curvature"][k], c["time_blocks"][k])**2
                           + c["cutoff_shift"][k]**2 + model[k]**2 + c["gyr_bias"][k]**2
                           + c["acc_error"][k]**2)
        assert r.uncertainty_mm[k] == pytest.approx(expected)


@pytest.mark.parametrize("seed", [5, 7])
def test_accelerometer_offsets_are_in_the_joint_centre_sigma(seed):
    # Under steady circling an accelerometer offset b looks like a move of the centre by
    # about b / w^2. With 0.05 m/s^2 per sensor, simulated knee centres (seeds 1-8) came
    # out 2-35 mm off at a 1-sigma of 1-8 mm, 6 of 8 beyond 3 sigma, before the
    # accelerometer part joined it.
    from imucal.position import closest_point_on_axis

    rec, truth = simulate(seed=seed, duration=20.0, acc_bias=0.05)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")
    knee = truth["knee"]
    want = closest_point_on_axis(np.concatenate([knee["o1"], knee["o2"]]),
                                 np.concatenate([knee["j1"], knee["j2"]]))

    def fit(**kw):
        r = estimate_position(th.gyr, th.acc, sh.gyr, sh.acc, rate=rec.rate, seed=seed,
                              joint="hinge", **kw)
        return r, 1000 * np.linalg.norm(r.o1 - want[:3])

    r, error = fit()
    assert error > 20.0  # the offsets did move the thigh's side of the centre (30-35 mm)
    assert error < 3 * r.uncertainty_mm["o1"] and r.verdict != "good"
    part = r.uncertainty_components["acc_error"]["o1"]
    assert part > error / 3 and part == max(c["o1"] for c in r.uncertainty_components.values())
    assert "accelerometer offset" in " ".join(r.warnings)
    assert r.settings["acc_error_m_s2"] == 0.05
    # told the accelerometers are exact, the same fit is confidently wrong
    exact, error_exact = fit(acc_error=0.0)
    assert error_exact > 3 * exact.uncertainty_mm["o1"]
    assert exact.uncertainty_components["acc_error"] == {"o1": 0.0, "o2": 0.0}


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("rate", [20.0, 35.0, 36.0, 40.0, 100.0, 1000.0])
def test_smooth_residual_at_any_rate_is_finite(rate):
    # at 35 Hz the octave above 8 Hz ended between 0.9 and 1 x Nyquist, and the next one
    # compared the residual with itself: 0 / 0 (the real recording's crash sweep)
    e = np.random.default_rng(1).standard_normal(500)
    assert 0.0 <= smooth_residual_rms(e, rate) < 0.3


def test_model_term_of_a_long_thinned_recording_is_judged_on_every_moving_sample():
    # 180 s of gait thins the fit's samples to every third: there the residual's smooth
    # part aliased into its noise, the term was 0 and the axis 1.5 deg off was "good" at
    # 18 sigma; the first 60 s (not thinned) gave 1.5 deg of model term
    rec, truth = simulate(seed=2, motion="gait", rate=100.0, duration=180.0, gyr_noise=0.01,
                          acc_noise=0.05, soft_tissue_deg=1.0, soft_tissue_mm=2.0)
    a, b = rec.sensor("thigh"), rec.sensor("shank")
    runs = [estimate_axis(a.gyr, b.gyr, rate=100.0, seed=1, restarts=10, time_offset=0.0,
                          end=end) for end in (None, 60.0)]
    whole, first = (r.uncertainty_components["model"]["j1"] for r in runs)
    assert runs[0].sample_index.size <= 3000 < 180 * 100 * 0.5  # thinned
    assert whole > 1.0 and abs(whole - first) < 0.3 * first
    errors = axis_error_deg(runs[0].j1, runs[0].j2, truth["j1"], truth["j2"])
    assert max(e / runs[0].uncertainty_deg[k]
               for e, k in zip(errors, ("j1", "j2"), strict=True)) < 3.0


@pytest.mark.parametrize("bias", [0.05, 0.1])
def test_a_joint_centre_from_biased_gyroscopes_is_covered(bias):
    # eq. (3) sees a gyroscope bias through g x (g x o), and the joint centre had no part
    # for it: simulated circling, seed 19, came out "good" 3.6 sigma off at 0.05 and 0.1
    # rad/s. The centre's move when biases are fitted with it is now part of the 1-sigma
    rec, truth = simulate(seed=19, motion="circling", duration=20.0, gyr_noise=0.01,
                          acc_noise=0.05, gyr_bias=bias)
    a, b = rec.sensor("shank"), rec.sensor("foot")
    r = estimate_position(a.gyr, a.acc, b.gyr, b.acc, rate=rec.rate, restarts=30, seed=1)
    worst = max(1000 * np.linalg.norm(np.subtract(getattr(r, k), truth["ankle"][k]))
                / r.uncertainty_mm[k] for k in ("o1", "o2"))
    assert worst < 2.0, worst
    if bias == 0.05:  # a bias eq. (3) asks for, and a gyroscope can have: removed
        assert r.gyr_bias["applied"] and r.gyr_bias["cost_ratio"] > 1.5
        assert max(1000 * np.linalg.norm(np.subtract(getattr(r, k), truth["ankle"][k]))
                   for k in ("o1", "o2")) < 2.0  # mm; 9.5 mm before it was removed
    else:  # 0.1 rad/s is more than a warmed-up gyroscope has: a 1-sigma part instead
        assert not r.gyr_bias["applied"]
        assert max(r.uncertainty_components["gyr_bias"].values()) > 2.0  # mm


def test_an_axis_whose_1_sigma_reaches_90_deg_is_not_identifiable(monkeypatch):
    # a sign-free axis is never more than 90 deg off: a hip fitted as a hinge on the real
    # recording reported 1-sigma 217 deg at "use with care" (an independent review)
    import imucal.axis as axis_module

    rec, _ = simulated(2, duration=8.0)
    a, b = rec.sensor("thigh"), rec.sensor("shank")
    plain = estimate_axis(a.gyr, b.gyr, rate=rec.rate, restarts=8, seed=1, time_offset=0.0)
    assert plain.verdict == "good"
    original = axis_module._quality

    def widened(*args, **kwargs):
        q = original(*args, **kwargs)
        q["uncertainty"] = {"j1": 120.0, "j2": 95.0}
        return q

    monkeypatch.setattr(axis_module, "_quality", widened)
    r = estimate_axis(a.gyr, b.gyr, rate=rec.rate, restarts=8, seed=1, time_offset=0.0)
    assert r.verdict == "not identifiable"
    assert r.blocking[0].startswith("the axis's 1-sigma is 120 deg")


def test_a_1_sigma_widened_past_90_deg_by_the_clock_offset_is_refused(monkeypatch):
    # the 90 deg rule was judged before the offset's part was added: a fit at 89.9 deg
    # with an applied 20 ms offset reported 90.01 deg at "use with care" (a review)
    import imucal.axis as axis_module
    from imucal.quality import uncertainty_totals

    rec, _ = simulate(seed=2, motion="circling", duration=20.0, gyr_noise=0.01,
                      acc_noise=0.05, clock_offset={"shank": 0.02})
    a, b = rec.sensor("thigh"), rec.sensor("shank")
    original = axis_module._quality

    def widened(*args, **kwargs):
        q = original(*args, **kwargs)
        q["components"]["model"] = {"j1": 89.9, "j2": 89.9}
        q["uncertainty"] = uncertainty_totals(q["components"])
        return q

    monkeypatch.setattr(axis_module, "_quality", widened)
    r = estimate_axis(a.gyr, b.gyr, rate=rec.rate, seed=1, restarts=20, acc1=a.acc, acc2=b.acc)
    assert r.time_offset["applied"] and max(r.uncertainty_deg.values()) >= 90.0
    assert r.verdict == "not identifiable" and r.blocking[0].startswith("the axis's 1-sigma")


def test_the_model_term_sees_soft_tissue_at_40_hz():
    # gait at 40 Hz with soft tissue: heel-strike ringing aliased into every octave up to
    # Nyquist made the noise floor as dense as the band, the term 0 and the axis "good" at
    # 7.9 sigma (1.03 deg off at 0.13); clean data keep their term near 0

    def axis(soft_deg, soft_mm):
        rec, truth = simulate(seed=18, rate=40.0, duration=30.0, motion="gait",
                              gyr_noise=0.01, acc_noise=0.05, soft_tissue_deg=soft_deg,
                              soft_tissue_mm=soft_mm)
        th, sh = rec.sensor("thigh"), rec.sensor("shank")
        a = estimate_axis(th.gyr, sh.gyr, rate=40.0, seed=1, time_offset=0)
        return a, axis_error_deg(a.j1, a.j2, truth["knee"]["j1"], truth["knee"]["j2"])

    soft, errors = axis(0.5, 1.0)
    assert soft.uncertainty_components["model"]["j1"] > 0.8
    assert errors[0] > 0.5 and errors[0] < 3 * soft.uncertainty_deg["j1"]
    clean, _ = axis(0.0, 0.0)
    assert clean.uncertainty_components["model"]["j1"] < 0.05
