"""Tests of the three-segment simulator: the stored truth satisfies the paper's constraints."""

import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import run_imucal

from imucal.errors import InputError
from imucal.simulate import MOTIONS, _expmap, _simulate_with_internals, simulate

MOVING = ("circling", "walking", "rigid-knee", "gait", "protocol")


def d5(x: np.ndarray, dt: float) -> np.ndarray:
    """5-point central difference along axis 0; aligned with ``x[2:-2]``."""
    return (x[:-4] - 8 * x[1:-3] + 8 * x[3:-1] - x[4:]) / (12 * dt)


def gamma(g: np.ndarray, gdot: np.ndarray, o: np.ndarray) -> np.ndarray:
    """Gamma_g(o) = g x (g x o) + gdot x o, per sample."""
    return np.cross(g, np.cross(g, o)) + np.cross(gdot, o)


def fine(motion: str, seed: int = 7, **kwargs):
    """High-rate, noise-free run for derivative-based checks (protocol: across the change
    from circling to walking)."""
    duration = 8.0 if motion == "protocol" else 2.0
    return _simulate_with_internals(seed=seed, rate=1000.0, duration=duration, snr=None,
                                    motion=motion, **kwargs)


def relative_rotation(internals) -> np.ndarray:
    """(N, 3, 3) matrices mapping thigh-sensor coordinates to shank-sensor coordinates."""
    r1, r2 = internals["rot"]["thigh"], internals["rot"]["shank"]
    return np.swapaxes(r2, -1, -2) @ r1


def test_recording_and_truth_format():
    rec, truth = simulate(seed=1, rate=50.0, duration=4.0)
    assert list(rec.sensors) == ["thigh", "shank", "foot"]
    assert rec.source == "<simulated>"
    assert rec.rate == 50.0 and rec.n_samples == 200
    for sd in rec.sensors.values():
        assert sd.gyr.shape == (200, 3) and sd.acc.shape == (200, 3)
    assert json.loads(json.dumps(truth)) == truth
    assert truth["knee"]["joint"] == "hinge" and truth["knee"]["sensors"] == ["thigh", "shank"]
    assert truth["ankle"]["joint"] == "spheroidal"
    assert truth["ankle"]["sensors"] == ["shank", "foot"]
    assert truth["j1"] == truth["knee"]["j1"] and truth["j2"] == truth["knee"]["j2"]
    assert truth["o1"] == truth["ankle"]["o1"] and truth["o2"] == truth["ankle"]["o2"]
    assert truth["settings"] == {
        "seed": 1,
        "rate": 50.0,
        "duration": 4.0,
        "snr": 100.0,
        "motion": "circling",
        "gyr_noise": None,
        "acc_noise": None,
        "soft_tissue_deg": 0.0,
        "soft_tissue_mm": 0.0,
        "clock_offset": {},
        "gyr_bias": None,
    }
    # The realism truth is there, and neutral, when no realism option is asked for.
    assert truth["clock_offset_s"] == {"thigh": 0.0, "shank": 0.0, "foot": 0.0}
    assert truth["time_offset_s"] == {"knee": 0.0, "ankle": 0.0}
    assert all(v == [0.0, 0.0, 0.0] for v in truth["gyr_bias"].values())
    assert truth["soft_tissue"]["sensors"] == {}
    assert len(truth["knee_flexion_deg"]) == 200
    for key in ("j1", "j2"):
        assert np.linalg.norm(truth[key]) == pytest.approx(1.0, abs=1e-12)
    # Offsets of realistic size: 4-40 cm from the joint centre.
    for joint in ("knee", "ankle"):
        for key in ("o1", "o2"):
            assert 0.04 < np.linalg.norm(truth[joint][key]) < 0.40
    assert "from the joint centre to the sensor" in truth["convention"].lower()


@pytest.mark.parametrize("motion", MOTIONS)
def test_hinge_constraint_holds_for_every_sample(motion):
    rec, truth = simulate(seed=3, snr=None, motion=motion)
    g1, g2 = rec.sensor("thigh").gyr, rec.sensor("shank").gyr
    j1, j2 = np.array(truth["j1"]), np.array(truth["j2"])
    e = np.linalg.norm(np.cross(g1, j1), axis=1) - np.linalg.norm(np.cross(g2, j2), axis=1)
    assert np.abs(e).max() < 1e-6
    if motion not in ("rigid-knee", "static"):  # the check has teeth: a wrong axis violates it
        wrong = j2 + 0.1 * np.cross(j2, [0.0, 0.0, 1.0])
        wrong /= np.linalg.norm(wrong)
        e = np.linalg.norm(np.cross(g1, j1), axis=1) - np.linalg.norm(np.cross(g2, wrong), axis=1)
        assert np.abs(e).max() > 1e-2


@pytest.mark.parametrize("motion", ["circling", "walking", "gait", "protocol"])
def test_axes_point_the_same_way_and_give_the_knee_rate(motion):
    rec, truth, internals = fine(motion)
    dt = 1.0 / rec.rate
    g1, g2 = rec.sensor("thigh").gyr, rec.sensor("shank").gyr
    j1, j2 = np.array(truth["j1"]), np.array(truth["j2"])
    theta_dot = g2 @ j2 - g1 @ j1
    # j2.g2 - j1.g1 is the rate of the shank's rotation about +j relative to the thigh.
    np.testing.assert_allclose(theta_dot[2:-2], d5(internals["knee_angle"], dt), atol=1e-6)
    # Relative angular velocity, in shank-sensor coordinates, is theta_dot * j2 (not -j2).
    r21 = relative_rotation(internals)
    rel = g2 - np.einsum("nij,nj->ni", r21, g1)
    np.testing.assert_allclose(rel, theta_dot[:, None] * j2[None, :], atol=1e-6)
    # ... and j1 is j2 carried into the thigh sensor frame.
    np.testing.assert_allclose(
        np.swapaxes(r21, -1, -2) @ j2, np.tile(j1, (len(r21), 1)), atol=1e-12
    )
    assert np.ptp(internals["knee_angle"]) > np.deg2rad(20)


def _position_residuals(rec, s1, s2, o1, o2):
    dt = 1.0 / rec.rate
    a1, a2 = rec.sensor(s1).acc[2:-2], rec.sensor(s2).acc[2:-2]
    g1, g2 = rec.sensor(s1).gyr, rec.sensor(s2).gyr
    c1 = a1 - gamma(g1[2:-2], d5(g1, dt), o1)
    c2 = a2 - gamma(g2[2:-2], d5(g2, dt), o2)
    return c1, c2


@pytest.mark.parametrize("motion", ["circling", "walking", "gait", "protocol"])
def test_spheroidal_constraint_with_exact_gyro_derivative(motion):
    rec, truth, internals = fine(motion)
    o1, o2 = np.array(truth["ankle"]["o1"]), np.array(truth["ankle"]["o2"])
    c1, c2 = _position_residuals(rec, "shank", "foot", o1, o2)
    n1, n2 = np.linalg.norm(c1, axis=1), np.linalg.norm(c2, axis=1)
    assert np.max(np.abs(n1 - n2) / n1) < 1e-4
    # Stronger: both are the same vector (the ankle centre's specific force), rotated.
    r_s, r_f = internals["rot"]["shank"][2:-2], internals["rot"]["foot"][2:-2]
    w1 = np.einsum("nij,nj->ni", r_s, c1)
    w2 = np.einsum("nij,nj->ni", r_f, c2)
    assert np.abs(w1 - w2).max() < 1e-4 * np.abs(w1).max()
    # The sign convention matters: the opposite vectors (sensor to joint) violate it.
    c1, c2 = _position_residuals(rec, "shank", "foot", -o1, -o2)
    bad = np.abs(np.linalg.norm(c1, axis=1) - np.linalg.norm(c2, axis=1))
    assert bad.max() > 0.1


@pytest.mark.parametrize("motion", ["circling", "walking", "gait", "protocol"])
def test_knee_centre_satisfies_position_constraint_along_the_axis(motion):
    rec, truth, _ = fine(motion)
    knee = truth["knee"]
    j1, j2 = np.array(knee["j1"]), np.array(knee["j2"])
    for lam in (0.0, 0.1, -0.07):
        o1 = np.array(knee["o1"]) + lam * j1
        o2 = np.array(knee["o2"]) + lam * j2
        c1, c2 = _position_residuals(rec, "thigh", "shank", o1, o2)
        n1, n2 = np.linalg.norm(c1, axis=1), np.linalg.norm(c2, axis=1)
        assert np.max(np.abs(n1 - n2) / n1) < 1e-4


def test_static_reads_gravity_only():
    rec, _, internals = _simulate_with_internals(
        seed=5, rate=100.0, duration=2.0, snr=None, motion="static"
    )
    for name, sd in rec.sensors.items():
        assert np.abs(sd.gyr).max() < 1e-9
        np.testing.assert_allclose(np.linalg.norm(sd.acc, axis=1), 9.81, atol=1e-6)
        up = internals["rot"][name][:, 2, :]  # world up in sensor coordinates
        np.testing.assert_allclose(sd.acc, 9.81 * up, atol=1e-6)


def test_rigid_knee_has_constant_relative_orientation():
    rec, _, internals = _simulate_with_internals(
        seed=11, rate=100.0, duration=10.0, snr=None, motion="rigid-knee"
    )
    g1, g2 = rec.sensor("thigh").gyr, rec.sensor("shank").gyr
    np.testing.assert_allclose(np.linalg.norm(g1, axis=1), np.linalg.norm(g2, axis=1), atol=1e-9)
    r21 = relative_rotation(internals)
    assert np.abs(r21 - r21[0]).max() < 1e-12
    np.testing.assert_allclose(np.einsum("ij,nj->ni", r21[0], g1), g2, atol=1e-9)
    assert np.ptp(internals["knee_angle"]) == 0.0


def test_deterministic_and_seed_dependent():
    a, ta = simulate(seed=42, duration=3.0)
    b, tb = simulate(seed=42, duration=3.0)
    c, tc = simulate(seed=43, duration=3.0)
    assert ta == tb and ta["j1"] != tc["j1"]
    for name in a.sensors:
        for kind in ("gyr", "acc"):
            x, y, z = (getattr(r.sensors[name], kind) for r in (a, b, c))
            assert np.array_equal(x, y)
            assert not np.allclose(x, z)


def test_seed_none_records_a_reproducible_seed():
    a, ta = simulate(seed=None, duration=2.0, motion="walking")
    seed = ta["settings"]["seed"]
    assert isinstance(seed, int)
    b, tb = simulate(seed=seed, duration=2.0, motion="walking")
    assert ta == tb
    assert np.array_equal(a.sensor("foot").acc, b.sensor("foot").acc)


def test_placement_depends_only_on_seed():
    _, t1 = simulate(seed=9, motion="circling", duration=1.0)
    _, t2 = simulate(seed=9, motion="walking", rate=200.0, duration=2.0, snr=None)
    for joint in ("knee", "ankle"):
        assert t1[joint] == t2[joint]


@pytest.mark.parametrize("snr", [100.0, 20.0])
def test_noise_level_matches_snr_definition(snr):
    clean, _ = simulate(seed=21, snr=None)
    noisy, _ = simulate(seed=21, snr=snr)
    for name in clean.sensors:
        for kind in ("gyr", "acc"):
            s = getattr(clean.sensors[name], kind)
            n = getattr(noisy.sensors[name], kind) - s
            rms = np.sqrt(np.mean(np.sum(s**2, axis=1)) / 3)
            ratio = n.std() / rms * snr
            assert 0.9 < ratio < 1.1, (name, kind, ratio)
            assert abs(n.mean()) < 4 * rms / snr / np.sqrt(n.size)


def test_static_gyro_noise_has_a_floor():
    rec, _ = simulate(seed=2, snr=100.0, motion="static")
    for sd in rec.sensors.values():
        assert 0.9 * 0.002 < sd.gyr.std() < 1.1 * 0.002
        acc_std = 9.81 / np.sqrt(3) / 100.0  # RMS per component of a 9.81 m/s^2 vector
        assert 0.9 * acc_std < (sd.acc - sd.acc.mean(axis=0)).std() < 1.1 * acc_std


def test_no_noise_for_none_and_inf():
    a, _ = simulate(seed=4, snr=None, duration=1.0)
    b, tb = simulate(seed=4, snr=float("inf"), duration=1.0)
    assert np.array_equal(a.sensor("shank").acc, b.sensor("shank").acc)
    assert tb["settings"]["snr"] is None


def test_motions_excite_the_joints():
    for motion in ("circling", "walking"):
        _, _, it = _simulate_with_internals(
            seed=8, rate=100.0, duration=20.0, snr=None, motion=motion
        )
        flex = -np.rad2deg(it["knee_angle"])
        assert flex.min() > -5 and flex.max() < 80 and np.ptp(flex) > 30


@pytest.mark.parametrize(
    "kwargs",
    [
        {"motion": "running"},
        {"rate": 0.0},
        {"rate": float("nan")},
        {"duration": -1.0},
        {"snr": 0.0},
        {"seed": -3},
        {"seed": 1.5},
        {"rate": 1.0, "duration": 1.0},
    ],
)
def test_bad_arguments(kwargs):
    with pytest.raises(InputError):
        simulate(**kwargs)


# ----------------------------------------------------------------------------- realism


def _strides(truth) -> np.ndarray:
    """Stride durations, s, from the true heel strikes."""
    return np.diff(truth["heel_strikes_s"])


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_gait_angles_and_stride_rate_are_those_of_walking(seed):
    rec, truth, it = _simulate_with_internals(seed=seed, rate=100.0, duration=30.0, snr=None,
                                              motion="gait")
    t, mot = it["time"], it["motion"]
    flex = np.array(truth["knee_flexion_deg"])
    np.testing.assert_allclose(flex, -np.degrees(it["knee_angle"]), atol=1e-6)
    # Knee about 5-65 deg in every stride, never hyperextended.
    hs = np.array(truth["heel_strikes_s"])
    for a, b in zip(hs[:-1], hs[1:], strict=True):
        stride = flex[(t >= a) & (t < b)]
        assert 0.0 < stride.min() < 10.0 and 55.0 < stride.max() < 72.0
    # 0.8-1.1 strides/s, from the heel strikes and, independently, the knee's spectrum.
    strides = _strides(truth)
    assert 0.8 < 1.0 / strides.max() and 1.0 / strides.min() < 1.1
    spectrum = np.abs(np.fft.rfft(flex - flex.mean()))
    freqs = np.fft.rfftfreq(len(flex), 1.0 / rec.rate)
    f_peak = freqs[np.argmax(spectrum * (freqs < 1.5))]
    assert abs(f_peak - 1.0 / strides.mean()) < 0.05
    # Stride-to-stride variation: stride times and peak flexion differ (CV 0.5-5 %).
    assert 0.005 < strides.std() / strides.mean() < 0.05
    peaks = [flex[(t >= a) & (t < b)].max() for a, b in zip(hs[:-1], hs[1:], strict=True)]
    assert np.std(peaks) > 0.3
    # Hip about +-25 deg, ankle mostly sagittal (+-15 deg), the rest a few degrees.
    deg = {k: np.degrees(getattr(mot, k)(t)) for k in (
        "hip_flexion", "hip_abduction", "hip_rotation", "dorsiflexion", "inversion",
        "foot_rotation")}
    assert -25 < deg["hip_flexion"].min() < -10 and 20 < deg["hip_flexion"].max() < 35
    assert -22 < deg["dorsiflexion"].min() < -10 and 5 < deg["dorsiflexion"].max() < 15
    for k in ("hip_abduction", "hip_rotation"):
        assert 1.5 < np.abs(deg[k]).max() < 8
    for k in ("inversion", "foot_rotation"):
        assert 1.0 < np.abs(deg[k]).max() < 6
    # Energy in the stride harmonics up to ~6 Hz: > 99.9 % of the shank rate's power.
    g = rec.sensor("shank").gyr
    power = np.sum(np.abs(np.fft.rfft(g - g.mean(axis=0), axis=0)) ** 2, axis=1)
    assert power[freqs <= 7.0].sum() / power.sum() > 0.999
    assert power[(freqs > 1.6) & (freqs < 4.5)].sum() / power.sum() > 0.2


def test_protocol_circles_then_walks():
    seed = 5
    _, truth, it = _simulate_with_internals(seed=seed, rate=100.0, duration=30.0, snr=None,
                                            motion="protocol")
    _, _, circ = _simulate_with_internals(seed=seed, rate=100.0, duration=5.0, snr=None,
                                          motion="circling")
    t = it["time"]
    share = it["motion"].walking_share(t)
    assert share[t <= 5.0].max() < 1e-3 and share[t >= 6.5].min() > 1 - 1e-3
    # The first 5 s are this seed's `circling` (up to the 0.06 % tail of the hand-over) ...
    flex = np.array(truth["knee_flexion_deg"])
    n = len(circ["time"])
    np.testing.assert_allclose(flex[:n], -np.degrees(circ["knee_angle"]), atol=0.05)
    assert truth["model"]["motion"]["circling_s"] == 5.0
    # ... then walking: heel strikes only after the change, at 0.8-1.1 strides/s, with the
    # knee reaching swing flexion.
    hs = np.array(truth["heel_strikes_s"])
    assert hs.min() > 5.5 and len(hs) > 18
    assert 0.8 < 1.0 / _strides(truth).max() and 1.0 / _strides(truth).min() < 1.1
    assert flex[t > 7].max() > 55 and flex[t > 7].min() < 10


@pytest.mark.parametrize("motion", ["gait", "protocol"])
def test_axis_estimate_on_noise_free_gait_matches_truth(motion):
    from imucal import estimate_axis

    worst = 0.0
    for seed in (1, 2, 3):
        rec, truth = simulate(seed=seed, rate=100.0, duration=30.0, snr=None, motion=motion)
        r = estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rec.rate,
                          restarts=20, seed=1)
        s = 1.0 if np.dot(r.j1, truth["j1"]) >= 0 else -1.0  # the overall sign is free
        for est, true in ((r.j1, truth["j1"]), (r.j2, truth["j2"])):
            worst = max(worst, np.degrees(np.arccos(np.clip(s * np.dot(est, true), -1, 1))))
    assert worst < 0.05


def test_clock_offset_shifts_exactly_that_sensor():
    kw = {"seed": 6, "duration": 6.0, "snr": None, "motion": "gait"}
    ref, _ = simulate(rate=100.0, **kw)
    late, truth = simulate(rate=100.0, clock_offset={"shank": 0.02}, **kw)
    assert truth["clock_offset_s"] == {"thigh": 0.0, "shank": 0.02, "foot": 0.0}
    assert truth["time_offset_s"] == {"knee": 0.02, "ankle": -0.02}
    assert truth["settings"]["clock_offset"] == {"shank": 0.02}
    for name in ("thigh", "foot"):  # the other sensors are untouched
        assert np.array_equal(late.sensor(name).gyr, ref.sensor(name).gyr)
        assert np.array_equal(late.sensor(name).acc, ref.sensor(name).acc)
    # A late clock shows the motion later: shifting back by 2 samples restores it.
    for kind in ("gyr", "acc"):
        a, b = getattr(late.sensor("shank"), kind), getattr(ref.sensor("shank"), kind)
        np.testing.assert_allclose(a[2:], b[:-2], atol=1e-9 * np.abs(b).max())
        assert np.abs(a - b).max() > 0.05 * np.abs(b).max()
    # A fractional offset is exact too: 13 ms at 100 Hz is sample 10 n - 13 at 1 kHz.
    frac, _ = simulate(rate=100.0, clock_offset={"shank": 0.013}, **kw)
    dense, _ = simulate(rate=1000.0, **kw)
    np.testing.assert_allclose(frac.sensor("shank").gyr[2:],
                               dense.sensor("shank").gyr[np.arange(2, 600) * 10 - 13],
                               atol=1e-9)
    # The hinge constraint holds for the first sensor at t and the second at t + offset.
    j1, j2 = np.array(truth["j1"]), np.array(truth["j2"])
    g1, g2 = late.sensor("thigh").gyr, late.sensor("shank").gyr

    def residual(shift):
        e = (np.linalg.norm(np.cross(g1[: len(g1) - shift], j1), axis=1)
             - np.linalg.norm(np.cross(g2[shift:], j2), axis=1))
        return np.abs(e).max()

    assert residual(2) < 1e-6 and residual(0) > 0.05


def test_gyro_bias_is_a_constant_in_the_sensor_frame():
    kw = {"seed": 8, "duration": 3.0, "snr": None, "motion": "gait"}
    ref, _ = simulate(**kw)
    biased, truth = simulate(gyr_bias=0.02, **kw)
    dirs = []
    for name in ("thigh", "shank", "foot"):
        b = np.array(truth["gyr_bias"][name])
        assert np.linalg.norm(b) == pytest.approx(0.02, rel=1e-12)
        diff = biased.sensor(name).gyr - ref.sensor(name).gyr
        np.testing.assert_allclose(diff, np.tile(b, (len(diff), 1)), atol=1e-15)
        assert np.array_equal(biased.sensor(name).acc, ref.sensor(name).acc)
        dirs.append(b / 0.02)
    assert abs(np.dot(dirs[0], dirs[1])) < 0.999  # random directions, not one shared
    # Given per sensor: a vector exactly, a magnitude in the seed's direction, others none.
    _, t2 = simulate(gyr_bias={"shank": 0.01, "foot": (0.0, 0.0, -0.03)}, **kw)
    assert t2["gyr_bias"]["thigh"] == [0.0, 0.0, 0.0]
    assert t2["gyr_bias"]["foot"] == [0.0, 0.0, -0.03]
    np.testing.assert_allclose(t2["gyr_bias"]["shank"], 0.5 * np.array(truth["gyr_bias"]["shank"]))
    assert t2["settings"]["gyr_bias"] == {"shank": 0.01, "foot": [0.0, 0.0, -0.03]}


def test_accelerometer_bias_is_a_constant_in_the_sensor_frame():
    kw = {"seed": 8, "duration": 3.0, "snr": None, "motion": "gait"}
    ref, ref_truth = simulate(**kw)
    biased, truth = simulate(acc_bias=0.05, gyr_bias=0.02, **kw)
    gyr_only, _ = simulate(gyr_bias=0.02, **kw)
    for name in ("thigh", "shank", "foot"):
        b = np.array(truth["acc_bias"][name])
        assert np.linalg.norm(b) == pytest.approx(0.05, rel=1e-12)
        diff = biased.sensor(name).acc - ref.sensor(name).acc
        np.testing.assert_allclose(diff, np.tile(b, (len(diff), 1)), atol=1e-12)
        # its own random stream: the gyroscope biases do not change with it
        assert np.array_equal(biased.sensor(name).gyr, gyr_only.sensor(name).gyr)
        assert np.dot(b / 0.05, np.array(truth["gyr_bias"][name]) / 0.02) < 0.999
    assert truth["settings"]["acc_bias"] == 0.05
    # without it the truth keeps its earlier keys
    assert "acc_bias" not in ref_truth and "acc_bias" not in ref_truth["settings"]
    _, t2 = simulate(acc_bias={"foot": (0.0, 0.1, 0.0)}, **kw)
    assert t2["acc_bias"]["foot"] == [0.0, 0.1, 0.0] and t2["acc_bias"]["thigh"] == [0.0] * 3
    with pytest.raises(InputError, match="acc_bias of shank must be a non-negative"):
        simulate(acc_bias={"shank": -1.0}, **kw)


def test_physical_noise_has_the_requested_std():
    kw = {"seed": 9, "duration": 30.0, "motion": "protocol"}
    ref, _ = simulate(snr=None, **kw)
    noisy, truth = simulate(gyr_noise=0.01, acc_noise=0.05, **kw)
    assert truth["settings"]["snr"] is None
    for name in ("thigh", "shank", "foot"):
        assert truth["noise_std"][name] == {"gyr": 0.01, "acc": 0.05}
        for kind, std in (("gyr", 0.01), ("acc", 0.05)):
            n = getattr(noisy.sensor(name), kind) - getattr(ref.sensor(name), kind)
            assert n.std(axis=0) == pytest.approx([std] * 3, rel=0.05)
            assert np.abs(n.mean(axis=0)).max() < 4 * std / np.sqrt(len(n))
            # white: neighbouring samples uncorrelated
            assert abs(np.mean(n[1:] * n[:-1])) / std**2 < 0.05
    # One alone leaves the other signal clean; snr and physical units do not mix.
    only, t2 = simulate(gyr_noise=0.01, **kw)
    assert np.array_equal(only.sensor("foot").acc, ref.sensor("foot").acc)
    assert t2["noise_std"]["foot"]["acc"] == 0.0
    with pytest.raises(InputError, match="not both"):
        simulate(snr=50.0, gyr_noise=0.01, **kw)


def test_soft_tissue_moves_the_sensors_and_keeps_the_hinge():
    seed, kw = 4, {"rate": 200.0, "duration": 12.0, "snr": None, "motion": "protocol"}
    rigid, _, it0 = _simulate_with_internals(seed=seed, **kw)
    rec, truth, it = _simulate_with_internals(seed=seed, soft_tissue_deg=2.0,
                                              soft_tissue_mm=3.0, **kw)
    # Off means off: no option and zeros give identical data.
    same, _ = simulate(seed=seed, soft_tissue_deg=0.0, soft_tissue_mm=0.0, **kw)
    assert np.array_equal(same.sensor("shank").acc, rigid.sensor("shank").acc)
    st = truth["soft_tissue"]
    assert st["rotation_deg"] == 2.0 and st["translation_mm"] == 3.0
    for name in ("thigh", "shank", "foot"):
        s = st["sensors"][name]  # the requested size is the peak over the recording
        assert s["rotation_peak_deg"] == pytest.approx(2.0, rel=2e-3)
        assert s["translation_peak_mm"] == pytest.approx(3.0, rel=2e-3)
        assert 0.3 < s["rotation_rms_deg"] / 2.0 < 0.9
        # The rates change by the artefact's size: 2 deg wobbling at 10-15 Hz is up to
        # 2 pi 15 Hz * 0.035 rad = 3.3 rad/s; its turn of a 6 rad/s rate is 0.2 rad/s.
        d = rec.sensor(name).gyr - rigid.sensor(name).gyr
        assert 0.05 < np.abs(d).max() < 3.3
    # The joint stays an exact hinge: strip each sensor's wobble and the segments' relative
    # rotation is Rx(-knee_flexion), exactly as without soft tissue.
    rot = {}
    for name in ("thigh", "shank"):
        s_rot = np.array(truth["model"]["sensor_to_segment_rotation"][name])
        wob = _expmap(it["soft_tissue"][name]["dtheta"])
        rot[name] = it["rot"][name] @ s_rot.T @ np.swapaxes(wob, -1, -2)  # segment -> world
    rel = np.swapaxes(rot["thigh"], -1, -2) @ rot["shank"]
    k = it["knee_angle"]
    assert np.abs(rel[:, 0, 0] - 1).max() < 1e-12
    np.testing.assert_allclose(rel[:, 1, 1], np.cos(k), atol=1e-12)
    np.testing.assert_allclose(rel[:, 2, 1], np.sin(k), atol=1e-12)
    assert np.array_equal(it["knee_angle"], it0["knee_angle"])
    # The wobble after heel strike: the artefact's fast part (its second difference, which
    # weighs 10-15 Hz ~100 times more than the stride harmonics) sits in the 0-130 ms after
    # the heel strikes; the circling before has none.
    t = it["time"][1:-1]
    dth = it["soft_tissue"]["shank"]["dtheta"]
    fast = np.sum((dth[2:] - 2 * dth[1:-1] + dth[:-2]) ** 2, axis=1)
    hs = np.array(truth["heel_strikes_s"])
    since = t[:, None] - hs[None, :]
    near = np.any((since > -0.01) & (since < 0.13), axis=1)
    assert fast[near].sum() / fast.sum() > 0.9


def test_static_has_no_soft_tissue_motion():
    rec, truth = simulate(seed=2, snr=None, motion="static", soft_tissue_deg=2.0,
                          soft_tissue_mm=3.0, duration=2.0)
    assert np.abs(rec.sensor("thigh").gyr).max() < 1e-9
    assert truth["soft_tissue"]["sensors"]["thigh"]["rotation_peak_deg"] == 0.0


def test_realism_is_deterministic_and_placement_unchanged():
    kw = {"seed": 12, "duration": 4.0, "motion": "gait", "gyr_noise": 0.01, "acc_noise": 0.05,
          "soft_tissue_deg": 1.0, "soft_tissue_mm": 2.0, "clock_offset": {"foot": -0.01},
          "gyr_bias": 0.02}
    a, ta = simulate(**kw)
    b, tb = simulate(**kw)
    _, plain = simulate(seed=12, duration=4.0, motion="circling")
    assert ta == tb and json.loads(json.dumps(ta)) == ta
    for joint in ("knee", "ankle"):
        assert ta[joint] == plain[joint]
    for name in a.sensors:
        assert np.array_equal(a.sensor(name).gyr, b.sensor(name).gyr)


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"gyr_noise": -0.1}, "gyr_noise"),
        ({"acc_noise": "lots"}, "acc_noise"),
        ({"soft_tissue_deg": float("nan")}, "soft_tissue_deg"),
        ({"soft_tissue_mm": -1}, "soft_tissue_mm"),
        ({"clock_offset": {"knee": 0.1}}, "unknown sensor"),
        ({"clock_offset": {"shank": float("inf")}}, "clock_offset"),
        ({"clock_offset": {"shank": 25.0}}, "duration"),
        ({"clock_offset": 0.02}, "clock_offset"),
        ({"gyr_bias": -0.01}, "gyr_bias"),
        ({"gyr_bias": {"shank": (1.0, 2.0)}}, "3-vector"),
        ({"gyr_bias": {"hip": 0.1}}, "unknown sensor"),
        ({"snr": "high"}, "snr"),
        ({"snr": 30.0, "acc_noise": 0.1}, "not both"),
    ],
)
def test_realism_option_errors_are_one_clear_line(kwargs, words):
    with pytest.raises(InputError) as err:
        simulate(seed=1, duration=2.0, **kwargs)
    message = str(err.value)
    assert "\n" not in message and message.startswith("simulate: ") and words in message


def test_command_line_realism_options(tmp_path):
    out = tmp_path / "walk.h5"
    args = [sys.executable, "-m", "imucal", "simulate", str(out), "--seed", "3", "--motion",
            "protocol", "--rate", "40", "--duration", "8", "--gyr-noise", "0.01",
            "--acc-noise", "0.05", "--soft-tissue-deg", "1", "--soft-tissue-mm", "2",
            "--clock-offset", "shank=0.02", "--gyr-bias", "foot=0.01,0,0", "--quiet"]
    assert subprocess.run(args, capture_output=True, timeout=120).returncode == 0
    truth = json.loads(out.with_name("walk.truth.json").read_text())
    assert truth["settings"] == {
        "seed": 3, "rate": 40.0, "duration": 8.0, "snr": None, "motion": "protocol",
        "gyr_noise": 0.01, "acc_noise": 0.05, "soft_tissue_deg": 1.0, "soft_tissue_mm": 2.0,
        "clock_offset": {"shank": 0.02}, "gyr_bias": {"foot": [0.01, 0.0, 0.0]},
    }
    assert truth["time_offset_s"]["knee"] == 0.02
    for bad, words in ((["--clock-offset", "knee=1"], "--clock-offset"),
                       (["--gyr-bias", "shank=1,2"], "--gyr-bias"),
                       (["--snr", "30", "--gyr-noise", "0.01"], "not both"),
                       (["--soft-tissue-mm", "-2"], "soft_tissue_mm")):
        run = run_imucal(*args[3:5], *bad, text=True)
        assert run.returncode == 2, bad
        lines = run.stderr.strip().splitlines()
        assert len(lines) == 1 and words in lines[0], run.stderr


def test_a_rate_outside_the_imus_range_is_refused_before_simulating():
    # 1e9 Hz for 0.1 s used to simulate 1e8 samples (minutes, then a memory error) before
    # the recording's own check ("<simulated>: sample rate ...") refused the rate
    with pytest.raises(InputError, match="^simulate: sample rate 1e\\+09 Hz is above 10000 "
                       "Hz, outside the 1 to 10000 Hz of body-worn IMUs; check its "
                       "units$"):
        simulate(rate=1e9, duration=0.1)
    assert simulate(seed=1, rate=10_000.0, duration=0.01)[0].rate == 10_000.0


def test_a_simulation_that_cannot_fit_in_memory_is_refused_up_front():
    # 10 h at 10 kHz: the kernel killed such a run at 24 GB without a word (exit 137)
    from imucal.errors import InputError
    from imucal.simulate import simulate

    with pytest.raises(InputError, match="simulate: 360000000 samples .* would need about "
                                         "838 GiB, more than half this machine's"):
        simulate(seed=1, rate=10000.0, duration=36000.0)


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_a_long_protocol_simulates_without_overflow_warnings():
    # the hip progression's 1 / cosh^2 overflowed far from its start (a 120 s protocol
    # printed "overflow encountered in square"; an independent review)
    rec, _ = simulate(seed=500, motion="protocol", duration=120.0, rate=40.0)
    assert all(np.isfinite(s.acc).all() for s in rec.sensors.values())


def test_the_shipped_sample_data_are_what_make_sample_data_makes():
    # circling.h5 and its truth came from an older simulator: data 4e-10 m/s^2 off and a
    # truth without the keys docs/simulator.md lists (a docs review)
    from pathlib import Path

    from imucal import load_recording

    sample = Path(__file__).resolve().parents[1] / "sample_data"
    for name, kwargs in (("circling", dict(seed=7, rate=100, duration=20, snr=100)),
                         ("walking", dict(seed=8, mounting_seed=7, rate=100, duration=30,
                                          motion="gait", gyr_noise=0.01, acc_noise=0.05,
                                          gyr_bias=0.02))):
        rec, truth = simulate(**kwargs)
        shipped = load_recording(sample / f"{name}.h5")
        for sensor in ("thigh", "shank", "foot"):
            for kind in ("gyr", "acc"):
                # not bit-equal: another CPU's vector kernels round the simulator's
                # products differently (on an AVX-512 machine the rates by 3e-14 rad/s,
                # the specific forces, second differences of positions, by 1.2e-10 m/s^2)
                np.testing.assert_allclose(getattr(shipped.sensor(sensor), kind),
                                           getattr(rec.sensor(sensor), kind), rtol=0,
                                           atol=1e-12 if kind == "gyr" else 1e-9)
        written = json.loads((sample / f"{name}.truth.json").read_text())
        assert set(written) == set(truth) and written["settings"] == truth["settings"]


@pytest.mark.parametrize("kwargs, phrase", [
    ({"gyr_bias": 1e300}, "gyr_bias of thigh 1e+300 rad/s is beyond a body-worn sensor's range"),
    ({"acc_bias": [0.0, 5e3, 0.0]}, "acc_bias of thigh 5000 m/s^2 is beyond"),
    ({"acc_noise": 1e300}, "acc_noise 1e+300 m/s^2 is beyond"),
    ({"soft_tissue_mm": 1e9}, "soft_tissue_mm 1e+09 mm is beyond"),
    ({"soft_tissue_deg": 1e6}, "soft_tissue_deg 1e+06 deg is beyond"),
    ({"snr": 1e-300}, "snr 1e-300 is below 0.01"),
])
def test_settings_no_sensor_could_record_are_refused(kwargs, phrase):
    # each wrote a file that every estimator then refused, or that meant nothing (a fuzz
    # review)
    with pytest.raises(InputError) as info:
        simulate(seed=1, duration=2.0, **kwargs)
    assert phrase in str(info.value)
