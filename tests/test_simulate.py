"""Tests of the three-segment simulator: the stored truth satisfies the paper's constraints."""

import json

import numpy as np
import pytest

from imucal.errors import InputError
from imucal.simulate import MOTIONS, _simulate_with_internals, simulate

MOVING = ("circling", "walking", "rigid-knee", "gait", "protocol")


def d5(x: np.ndarray, dt: float) -> np.ndarray:
    """5-point central difference along axis 0; aligned with ``x[2:-2]``."""
    return (x[:-4] - 8 * x[1:-3] + 8 * x[3:-1] - x[4:]) / (12 * dt)


def gamma(g: np.ndarray, gdot: np.ndarray, o: np.ndarray) -> np.ndarray:
    """Gamma_g(o) = g x (g x o) + gdot x o, per sample."""
    return np.cross(g, np.cross(g, o)) + np.cross(gdot, o)


def fine(motion: str, seed: int = 7):
    """High-rate, noise-free run for derivative-based checks."""
    return _simulate_with_internals(seed=seed, rate=1000.0, duration=2.0, snr=None, motion=motion)


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
    if motion in ("circling", "walking"):  # the check has teeth: a wrong axis violates it
        wrong = j2 + 0.1 * np.cross(j2, [0.0, 0.0, 1.0])
        wrong /= np.linalg.norm(wrong)
        e = np.linalg.norm(np.cross(g1, j1), axis=1) - np.linalg.norm(np.cross(g2, wrong), axis=1)
        assert np.abs(e).max() > 1e-2


@pytest.mark.parametrize("motion", ["circling", "walking"])
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


@pytest.mark.parametrize("motion", ["circling", "walking"])
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


@pytest.mark.parametrize("motion", ["circling", "walking"])
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
