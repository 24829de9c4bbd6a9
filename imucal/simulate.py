"""Kinematic three-segment leg simulator (Seel, Schauer, Raisch 2012, Sec. III-A).

Thigh -- knee (hinge, 1 DOF) -- shank -- ankle (spheroidal, 3 DOF) -- foot. Each segment
carries one IMU at a random position and with a uniformly random orientation. All joint
angles and the hip position are analytic functions of time (sums of sinusoids, of a
smoothly varying stride phase, and smooth blends of both), so the sensor signals are
computed from exact poses by 5-point central differences (no integration, no drift) and are
the exact values at the sample instants.

Frames
------
World: ``x`` to the right (lateral for this right leg), ``y`` forward, ``z`` up; gravity
``(0, 0, -9.81)`` m/s^2. Segment frames at the neutral (standing) pose coincide with the
world frame: ``x`` lateral (= the knee hinge axis), ``y`` anterior, ``z`` along the segment
pointing proximally. Thigh origin = hip centre, shank origin = knee centre (thigh point
``(0, 0, -L_thigh)``), foot origin = ankle centre (shank point ``(0, 0, -L_shank)``).

* ``R_thigh = Rx(hip_flexion) @ Ry(-hip_abduction) @ Rz(hip_rotation)``
* ``R_shank = R_thigh @ Rx(-knee_flexion)``
* ``R_foot  = R_shank @ Rx(dorsiflexion) @ Ry(inversion) @ Rz(foot_rotation)``

Sensor ``i`` has a constant rotation ``S_i`` (sensor coordinates -> segment coordinates)
and a constant position ``r_i`` in segment coordinates; with a soft-tissue artefact the
sensor moves on its segment: ``Exp(dtheta_i(t)) S_i`` and ``r_i + dr_i(t)``. Realism options
(soft tissue, clock offsets, gyro bias, noise in physical units) are described in
``docs/simulator.md``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cache

import numpy as np

from .errors import InputError
from .recording import Recording, make_recording
from .restarts import resolve_seed
from .sensor_checks import SENSOR_RANGE
from .timing import check_rate

MOTIONS = ("circling", "walking", "rigid-knee", "static", "gait", "protocol")
SENSORS = ("thigh", "shank", "foot")

#: Gravity in the simulated world frame (z up), m/s^2. A local value, on purpose not the
#: standard 1 g (:data:`imucal.rest.GRAVITY_M_S2`, 9.80665) the estimators' checks use:
#: gravity differs by place (about 9.78-9.83 m/s^2), and no estimate may depend on the
#: two being equal (:data:`imucal.rest.LOCAL_GRAVITY_SPREAD_M_S2`).
GRAVITY = np.array([0.0, 0.0, -9.81])
#: Step of the 5-point central differences, s.
FD_STEP = 1e-3
#: Gyroscope noise reference level, rad/s: the gyro noise std is max(RMS, this) / snr, so a
#: sensor at rest (RMS 0) still gets realistic noise (0.002 rad/s at snr=100).
GYR_NOISE_FLOOR_RMS = 0.2
#: SNR used when neither ``snr`` nor a physical noise level is given.
DEFAULT_SNR = 100.0
#: ``protocol``: seconds of leg and foot circling before the change to walking (the paper).
PROTOCOL_CIRCLING_S = 5.0
#: ``protocol``: the change to walking is ``sigma(t) = (1 + tanh((t - centre) / width)) / 2``;
#: sigma(5 s) = 6e-4 and sigma(6.5 s) = 1 - 6e-4, i.e. 5 s circling, 1.5 s transition.
PROTOCOL_TRANSITION_CENTRE_S = 5.75
PROTOCOL_TRANSITION_WIDTH_S = 0.2
#: Soft tissue: relative weights of the stride- (or circling-) locked harmonics 1, 2, 3 and
#: of the damped wobble after each heel strike (directions and phases random per sensor);
#: the sum is then scaled so that its peak over the recording is the requested size.
SOFT_TISSUE_HARMONIC_SHARE = (0.4, 0.2, 0.1)
SOFT_TISSUE_HEEL_STRIKE_SHARE = 0.3
#: Heel-strike wobble: a Gaussian window of the time since heel strike, peak 1 at
#: ``centre`` = 50 ms, 1-sigma ``width`` 18 ms (2 % at the heel strike itself, 1 % at
#: 105 ms), oscillating at a per-sensor frequency in HEEL_STRIKE_WOBBLE_HZ (Hz). A smooth
#: window, not a causal step: a step's kink would put energy at every frequency (aliased
#: into the samples and beyond what 5-point differences resolve); this one lies below
#: ~35 Hz.
HEEL_STRIKE_CENTRE_S = 0.05
HEEL_STRIKE_WIDTH_S = 0.018
HEEL_STRIKE_WOBBLE_HZ = (10.0, 15.0)

CONVENTION = (
    "j1: knee hinge axis, unit vector in the thigh sensor frame; j2: the same physical axis "
    "(same direction, pointing to the lateral side) in the shank sensor frame, so "
    "j2.g2 - j1.g1 is the rate of the shank's rotation relative to the thigh about that "
    "axis (= minus the knee flexion rate). o1, o2: vector FROM the joint centre TO the "
    "sensor origin, in metres, in the first / second sensor's frame (ankle: shank / foot; "
    "knee: thigh / shank, with the knee centre on the hinge axis). Gyroscope: angular "
    "velocity of the sensor in its own frame, rad/s. Accelerometer: specific force "
    "R^T (p_ddot - g) in the sensor frame, m/s^2, with g = (0, 0, -9.81) in a z-up world "
    "(a sensor at rest reads +9.81 along up). Clock offset d_i of sensor i, s: its sample "
    "at time t shows the motion at true time t - d_i (positive: its clock is late, events "
    "appear later); time_offset_s of a joint = d_second - d_first, so the first sensor at "
    "t matches the second sensor at t + time_offset_s. Gyro bias: constant, added to the "
    "gyroscope, sensor frame, rad/s. With soft tissue the sensors move on their segments; "
    "j, o refer to the nominal (mean) mounting."
)

_DEG = np.pi / 180.0

# Gait curves over one stride (phase 0 = heel strike), in degrees: mean, then (cos, sin)
# coefficients of harmonics 1, 2, ... (Fourier fit to textbook sagittal gait curves).
# Used by the legacy `walking` motion only; `gait` uses the key points below.
_GAIT = {
    "hip_flexion": (12.67, [(20.6, -4.14), (-2.64, -1.93), (-0.49, 0.52)]),
    "knee_flexion": (23.64, [(-4.67, -20.65), (-13.27, 8.44), (-1.43, 3.13), (0.22, 0.64)]),
    "dorsiflexion": (-1.1, [(-0.02, 3.66), (0.25, -9.63), (-0.88, 3.36), (1.43, -0.54)]),
}

# `gait`: normative sagittal curves of level walking as (percent of stride from heel strike,
# degrees) key points, after the textbook curves (Winter; Perry): knee 5 deg at heel strike,
# ~19 deg loading response at 15 %, ~6 deg in late stance, ~63 deg peak in swing at 73 %;
# hip +25 deg at heel strike, ~-17 deg at 55 %, ~+27 deg in late swing; ankle -6 deg after
# heel strike, +10 deg dorsiflexion at 45 %, -15 deg plantarflexion just after toe-off.
# A periodic cubic spline through them is cut to GAIT_HARMONICS harmonics: smooth, within
# 0.6 deg of the key-point curve, energy at 1-6 x the stride frequency.
GAIT_HARMONICS = 6
_GAIT_KEYPOINTS = {
    "knee_flexion": [(0, 5), (5, 11), (10, 17), (15, 19), (20, 17), (30, 10), (40, 6),
                     (45, 7), (50, 12), (55, 21), (60, 36), (65, 52), (70, 61), (73, 63),
                     (77, 60), (80, 55), (85, 42), (90, 25), (95, 9)],
    "hip_flexion": [(0, 25), (10, 22), (20, 14), (30, 5), (40, -5), (50, -14), (55, -17),
                    (60, -12), (65, -2), (70, 9), (75, 18), (80, 24), (85, 27), (90, 27),
                    (95, 26)],
    "dorsiflexion": [(0, 0), (5, -5), (8, -6), (12, -3), (20, 2), (30, 6), (40, 9), (45, 10),
                     (50, 7), (55, -2), (60, -12), (63, -15), (67, -13), (72, -6), (80, 0),
                     (90, 2)],
}


@cache
def _gait_fourier(name: str) -> tuple[float, tuple[float, ...], tuple[float, ...]]:
    """Mean (rad), then amplitudes (rad) and phases of harmonics 1..GAIT_HARMONICS, such
    that the curve is ``mean + sum_k amp[k] sin(k psi + phase[k])`` (psi = 0: heel strike)."""
    from scipy.interpolate import CubicSpline

    pts = _GAIT_KEYPOINTS[name]
    x = np.array([p for p, _ in pts] + [100.0]) / 100.0
    y = np.array([v for _, v in pts] + [pts[0][1]], dtype=float)
    n = 1000
    grid = np.arange(n) / n
    spectrum = np.fft.rfft(CubicSpline(x, y, bc_type="periodic")(grid)) / n
    amp, ph = [], []
    for k in range(1, GAIT_HARMONICS + 1):
        # c_k e^{i k psi} + conj = 2|c_k| cos(k psi + arg c_k) = 2|c_k| sin(k psi + arg + pi/2)
        amp.append(2.0 * abs(spectrum[k]) * _DEG)
        ph.append(float(np.angle(spectrum[k])) + np.pi / 2)
    return float(spectrum[0].real) * _DEG, tuple(amp), tuple(ph)


@dataclass(frozen=True)
class _Sines:
    """``offset + sum_k amp[k] * sin(2 pi freq[k] t + phase[k])``, vectorised over ``t``."""

    offset: float = 0.0
    amp: tuple[float, ...] = ()
    freq: tuple[float, ...] = ()
    phase: tuple[float, ...] = ()

    def __call__(self, t: np.ndarray) -> np.ndarray:
        out = np.full(np.shape(t), float(self.offset))
        for a, f, p in zip(self.amp, self.freq, self.phase, strict=True):
            out = out + a * np.sin(2.0 * np.pi * f * t + p)
        return out


@dataclass(frozen=True)
class _Phase:
    """Stride phase ``psi(t) = p0 + 2 pi f0 t + mod(t)``, rad; heel strikes at psi = 2 pi k.

    ``mod`` carries the slow cadence variation: the stride frequency is
    ``f0 + mod'(t) / (2 pi)``, so stride durations vary from stride to stride.
    """

    p0: float
    f0: float
    mod: _Sines = _Sines()

    def __call__(self, t: np.ndarray) -> np.ndarray:
        return self.p0 + 2.0 * np.pi * self.f0 * np.asarray(t) + self.mod(t)


@dataclass(frozen=True)
class _PhaseCurve:
    """``offset(t) + scale(t) * sum_k amp[k] sin(harm[k] psi(t) + phase[k])``: a stride-locked
    pattern whose level and size drift slowly (stride-to-stride variation)."""

    psi: _Phase
    harm: tuple[int, ...]
    amp: tuple[float, ...]
    phase: tuple[float, ...]
    offset: _Sines = _Sines()
    scale: _Sines = _Sines(1.0)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        psi = self.psi(t)
        out = np.zeros(np.shape(t))
        for k, a, p in zip(self.harm, self.amp, self.phase, strict=True):
            out = out + a * np.sin(k * psi + p)
        return self.offset(t) + self.scale(t) * out


@dataclass(frozen=True)
class _Step:
    """Smooth switch ``sigma(t) = (1 + tanh((t - centre) / width)) / 2`` from 0 to 1."""

    centre: float
    width: float

    def __call__(self, t: np.ndarray) -> np.ndarray:
        return 0.5 * (1.0 + np.tanh((np.asarray(t) - self.centre) / self.width))


@dataclass(frozen=True)
class _Blend:
    """``(1 - sigma(t)) a(t) + sigma(t) b(t)``: one motion handing over to another."""

    sigma: _Step
    a: Callable
    b: Callable

    def __call__(self, t: np.ndarray) -> np.ndarray:
        s = self.sigma(t)
        return (1.0 - s) * self.a(t) + s * self.b(t)


@dataclass(frozen=True)
class _Progression:
    """Hip progression that starts from rest: velocity ``sigma(t) * velocity``. Only its
    acceleration ``velocity * sigma'(t)`` enters the signals (added analytically, because
    tens of metres of travel would spoil the finite differences' round-off)."""

    sigma: _Step
    velocity: tuple[float, float, float]

    def acc(self, t: np.ndarray) -> np.ndarray:
        w = self.sigma.width
        # far from the step the rate is 0 to double precision; cosh(x)^2 overflows beyond
        # |x| of about 355 (a 120 s protocol warned)
        x = np.clip((np.asarray(t) - self.sigma.centre) / w, -300.0, 300.0)
        rate = 0.5 / w / np.cosh(x) ** 2
        return rate[..., None] * np.asarray(self.velocity)


@dataclass(frozen=True)
class _Motion:
    hip_flexion: Callable
    hip_abduction: Callable
    hip_rotation: Callable
    knee_flexion: Callable
    dorsiflexion: Callable
    inversion: Callable
    foot_rotation: Callable
    hip_offset: tuple  # three callables: oscillating part of the hip position, m
    hip_velocity: tuple[float, float, float]  # constant part of the hip velocity, m/s
    # What drives the soft-tissue artefact: the stride phase and its nominal frequency
    # (walking), the circling frequency (circling), and the walking share sigma(t) in
    # [0, 1] (None: 1 if there is a stride phase, else 0).
    stride_phase: _Phase | None = None
    cycle_freq: float = 0.0
    walking_share: _Step | None = None
    progression: _Progression | None = None
    info: dict = field(default_factory=dict)  # motion parameters for the truth's model


@dataclass(frozen=True)
class _Geometry:
    l_thigh: float
    l_shank: float
    rot: dict  # sensor name -> (3, 3) sensor -> segment rotation
    pos: dict  # sensor name -> (3,) sensor origin in segment coordinates, m


@dataclass(frozen=True)
class _Wobble:
    """Unit-amplitude soft-tissue pattern of one sensor, for rotation or translation:
    directions (unit vectors, segment frame) and phases of the locked harmonics, and the
    heel-strike wobble's direction, frequency (Hz) and phase."""

    dirs: np.ndarray  # (3, 3): one unit vector per harmonic
    phases: np.ndarray  # (3,)
    hs_dir: np.ndarray  # (3,)
    hs_freq: float
    hs_phase: float


# ----------------------------------------------------------------------------- public API


#: Peak memory of a simulation per sample, bytes (measured: 2.2 kB per sample between
#: 5 and 20 min at 100 Hz, gait): 1 h at 10 kHz would need about 80 GB.
BYTES_PER_SAMPLE = 2500
#: A simulation may take at most this share of the machine's memory.
MAX_MEMORY_SHARE = 0.5


def _check_memory(n: int) -> None:
    """Refuse up front a simulation that would not fit in memory (the kernel killed one of
    36 million samples at 24 GB, without a word)."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):  # not a POSIX system: no guard
        return
    need = n * BYTES_PER_SAMPLE
    if need > MAX_MEMORY_SHARE * total:
        raise InputError(f"simulate: {n} samples (rate x duration) would need about "
                         f"{need / 2**30:.0f} GiB, more than half this machine's "
                         f"{total / 2**30:.0f} GiB; simulate a shorter or slower recording")


def simulate(
    *,
    seed: int | None = None,
    rate: float = 100.0,
    duration: float = 20.0,
    snr: float | None | str = "auto",
    motion: str = "circling",
    gyr_noise: float | None = None,
    acc_noise: float | None = None,
    soft_tissue_deg: float = 0.0,
    soft_tissue_mm: float = 0.0,
    clock_offset: Mapping[str, float] | None = None,
    gyr_bias: float | Mapping[str, float | tuple[float, float, float]] | None = None,
    mounting_seed: int | None = None,
    acc_bias: float | Mapping[str, float | tuple[float, float, float]] | None = None,
) -> tuple[Recording, dict]:
    """Simulate thigh, shank and foot IMUs on a leg with a knee hinge and a spheroidal ankle.

    Parameters
    ----------
    seed
        Seed of all randomness (sensor placement, motion details, noise, soft tissue, bias
        directions). ``None`` draws a fresh seed; it is recorded in
        ``truth["settings"]["seed"]``. The placement depends only on the seed, the motion
        only on seed, motion and timing, and each kind of randomness has its own stream, so
        the same seed with ``snr=None`` gives the exact clean signals.
    rate, duration
        Sample rate in Hz and length in seconds (``round(rate * duration)`` samples).
    snr
        Amplitude signal-to-noise ratio: per sensor and per gyr/acc, white Gaussian noise of
        std ``RMS / snr`` per component, ``RMS = sqrt(mean |s|^2 / 3)`` (gyro RMS floored at
        :data:`GYR_NOISE_FLOOR_RMS`). ``None`` or ``inf``: no noise. ``"auto"`` (default):
        :data:`DEFAULT_SNR`, or no SNR noise when ``gyr_noise`` or ``acc_noise`` is given.
    motion
        One of :data:`MOTIONS`: ``circling``, ``walking`` (legacy gait-like), ``rigid-knee``,
        ``static``, ``gait`` (realistic walking with stride-to-stride variation),
        ``protocol`` (5 s of leg and foot circling, then ``gait``).
    gyr_noise, acc_noise
        White Gaussian noise in physical units instead of ``snr``: standard deviation per
        component and sample, gyroscope rad/s, accelerometer m/s^2, the same for every
        sensor. Not together with a numeric ``snr``; one alone leaves the other signal clean.
    soft_tissue_deg, soft_tissue_mm
        Soft-tissue artefact: every sensor moves on its segment by a rotation ``dtheta(t)``
        (segment frame) whose size ``|dtheta|`` peaks at ``soft_tissue_deg`` degrees over
        the recording, and a displacement ``dr(t)`` peaking at ``soft_tissue_mm``
        millimetres; mostly locked to the stride (harmonics 1-3) plus a damped 10-15 Hz
        wobble after each heel strike; while circling, locked to the circling frequency.
        The joints stay exact; ``static`` has none. 0: rigid.
    clock_offset
        Per-sensor clock offset, s, e.g. ``{"shank": 0.02}`` (others 0): sensor ``i``'s
        sample at time ``t`` shows the motion at true time ``t - d_i``, so a positive offset
        (a late clock) makes events appear later in that sensor. ``|d_i| < duration``.
    gyr_bias
        Constant gyroscope bias, rad/s, sensor frame: a number gives every sensor a bias of
        that magnitude in a random direction (seeded), a 3-vector gives every sensor that
        vector; a mapping gives some sensors a magnitude (random direction) or a 3-vector,
        e.g. ``{"shank": (0.01, 0, -0.02)}``.
    mounting_seed
        Seed of the mounting alone (segment lengths, sensor positions and orientations):
        recordings with different ``seed`` (motion, noise, ...) but one ``mounting_seed``
        show the same sensors strapped on the same leg, e.g. a calibration trial and a
        walking trial of one session; another ``mounting_seed`` is a re-strapped (or
        another) leg. ``None`` (default): the mounting follows ``seed`` as before. The
        mounting with ``mounting_seed=m`` equals the one of ``seed=m``.
    acc_bias
        Constant accelerometer bias (offset), m/s^2, sensor frame, given like ``gyr_bias``
        (its own random directions). Factory-calibrated MEMS accelerometers keep about
        0.02-0.1 m/s^2. Recorded in the truth only when given.

    Returns
    -------
    recording : Recording
        Sensors ``thigh``, ``shank``, ``foot`` (gyr rad/s, acc m/s^2, (N, 3) float64 in each
        sensor's frame, N = ``round(rate * duration)``), ``rate`` Hz; source
        ``"<simulated>"``.
    truth : dict
        The JSON-serialisable ground truth (see :data:`CONVENTION` and docs/simulator.md):
        ``knee`` and ``ankle`` (``j1``, ``j2`` unit axes, ``o1``, ``o2`` in m, sensor
        frames), ``knee_flexion_deg``, ``clock_offset_s``, ``gyr_bias``, ``noise_std``,
        ``settings`` (the seed drawn, too), ...

    Raises
    ------
    InputError
        An unknown ``motion``, a rate, duration, ``snr``, noise level, soft-tissue size,
        clock offset, bias or seed that is not a usable number, fewer than 2 samples, or
        more samples than half this machine's memory holds.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, Sec. III-A (the
    three-segment model with randomly placed sensors; the motions here are imucal's own).

    Examples
    --------
    >>> from imucal.simulate import simulate
    >>> rec, truth = simulate(seed=1, duration=5.0)
    >>> list(rec.sensors), rec.n_samples, rec.rate
    (['thigh', 'shank', 'foot'], 500, 100.0)
    >>> [round(x, 3) for x in truth["knee"]["j1"]]     # thigh sensor frame
    [0.458, -0.854, 0.248]
    """
    rec, truth, _ = _simulate_with_internals(
        seed=seed, rate=rate, duration=duration, snr=snr, motion=motion, gyr_noise=gyr_noise,
        acc_noise=acc_noise, soft_tissue_deg=soft_tissue_deg, soft_tissue_mm=soft_tissue_mm,
        clock_offset=clock_offset, gyr_bias=gyr_bias, mounting_seed=mounting_seed,
        acc_bias=acc_bias,
    )
    return rec, truth


# ----------------------------------------------------------------------------- internals


def _simulate_with_internals(*, seed, rate, duration, snr="auto", motion="circling",
                             gyr_noise=None, acc_noise=None, soft_tissue_deg=0.0,
                             soft_tissue_mm=0.0, clock_offset=None, gyr_bias=None,
                             mounting_seed=None, acc_bias=None):
    """:func:`simulate` plus internals for tests: clean signals, knee angle, sensor poses."""
    seed, rate, duration, snr, motion = _check_args(seed, rate, duration, snr, motion,
                                                    gyr_noise, acc_noise)
    gyr_noise = _check_level("gyr_noise", gyr_noise, "rad/s", SENSOR_RANGE["gyr"])
    acc_noise = _check_level("acc_noise", acc_noise, "m/s^2", SENSOR_RANGE["acc"])
    soft_tissue_deg = _check_level("soft_tissue_deg", soft_tissue_deg, "deg",
                                   MAX_SOFT_TISSUE["deg"]) or 0.0
    soft_tissue_mm = _check_level("soft_tissue_mm", soft_tissue_mm, "mm",
                                  MAX_SOFT_TISSUE["mm"]) or 0.0
    clock = _check_clock_offset(clock_offset, duration)
    n = int(round(rate * duration))
    if n < 2:
        raise InputError(f"simulate: rate * duration gives {n} sample(s); need at least 2")
    _check_memory(n)
    # Streams 0-2 as before (placement, motion, noise), so existing seeds keep their data;
    # soft tissue and bias directions get streams of their own.
    geo_ss, motion_ss, noise_ss, tissue_ss, bias_ss = np.random.SeedSequence(seed).spawn(5)
    if mounting_seed is not None:
        mounting_seed = _check_seed(mounting_seed, "mounting_seed")
        # the placement stream of seed=mounting_seed: "mounting m" is "the mounting of seed m"
        geo_ss = np.random.SeedSequence(mounting_seed).spawn(5)[0]
    geo = _draw_geometry(np.random.default_rng(geo_ss))
    mot = _draw_motion(np.random.default_rng(motion_ss), motion)
    bias = _sensor_bias("gyr_bias", gyr_bias, np.random.default_rng(bias_ss), "rad/s")
    # a sixth stream (spawn(6)[:5] equals spawn(5)), so the other streams keep their data
    acc_ss = np.random.SeedSequence(seed).spawn(6)[5]
    acc_bias_vec = _sensor_bias("acc_bias", acc_bias, np.random.default_rng(acc_ss), "m/s^2")
    wobble = None
    if soft_tissue_deg > 0 or soft_tissue_mm > 0:
        wobble = _scale_soft_tissue(_draw_soft_tissue(np.random.default_rng(tissue_ss)), mot,
                                    duration, clock, soft_tissue_deg * _DEG,
                                    soft_tissue_mm * 1e-3)

    t = np.arange(n) / rate
    clean, rot_world, knee_angle, tissue = _signals(geo, mot, t, clock=clock, wobble=wobble)

    noise_rng = np.random.default_rng(noise_ss)
    data, noise_std = {}, {}
    for name in SENSORS:
        data[name], noise_std[name] = {}, {}
        for kind in ("gyr", "acc"):
            s = clean[name][kind]
            if snr is not None:
                rms = math.sqrt(float(np.mean(np.sum(s * s, axis=1))) / 3.0)
                if kind == "gyr":
                    rms = max(rms, GYR_NOISE_FLOOR_RMS)
                sigma = rms / snr
            else:
                sigma = (gyr_noise if kind == "gyr" else acc_noise) or 0.0
            noise_std[name][kind] = sigma
            if sigma == 0.0:
                out = s.copy()
            else:
                out = s + noise_rng.standard_normal(s.shape) * sigma
            if kind == "gyr" and name in bias:
                out = out + bias[name]
            if kind == "acc" and name in acc_bias_vec:
                out = out + acc_bias_vec[name]
            data[name][kind] = out

    rec = make_recording(data, rate=rate, source="<simulated>")
    settings = {
        "seed": seed,
        "rate": rate,
        "duration": duration,
        "snr": snr,
        "motion": motion,
        "gyr_noise": gyr_noise,
        "acc_noise": acc_noise,
        "soft_tissue_deg": soft_tissue_deg,
        "soft_tissue_mm": soft_tissue_mm,
        "clock_offset": {k: clock[k] for k in SENSORS if clock.get(k, 0.0) != 0.0},
        "gyr_bias": _bias_setting(gyr_bias),
    }
    if mounting_seed is not None:  # only when given, so earlier truth files keep their bytes
        settings["mounting_seed"] = mounting_seed
    if acc_bias is not None:  # likewise
        settings["acc_bias"] = _bias_setting(acc_bias)
    truth = _truth(geo, mot, settings)
    truth.update(_realism_truth(mot, t, clock, bias, noise_std, tissue, knee_angle,
                                soft_tissue_deg, soft_tissue_mm))
    if acc_bias is not None:
        truth["acc_bias"] = {n: _vec(acc_bias_vec.get(n, np.zeros(3))) for n in SENSORS}
    internals = {"clean": clean, "rot": rot_world, "knee_angle": knee_angle, "time": t,
                 "soft_tissue": tissue, "motion": mot}
    return rec, truth, internals


def _one_line(value) -> str:
    return " ".join(repr(value).split())[:80]


def _number(label: str, value) -> float:
    if isinstance(value, bool):
        raise InputError(f"simulate: {label} {value!r} is not a number")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InputError(f"simulate: {label} {_one_line(value)} is not a number") from None


def _check_args(seed, rate, duration, snr, motion, gyr_noise=None, acc_noise=None):
    if motion not in MOTIONS:
        raise InputError(f"simulate: unknown motion '{motion}'; use one of {', '.join(MOTIONS)}")
    # a fresh seed drawn as the estimators draw theirs (one rule for both)
    seed = _check_seed(resolve_seed(None) if seed is None else seed, "seed")
    try:
        # the recordings' own check, before anything is simulated: 1e9 Hz would fill the
        # memory first
        rate = check_rate(rate)
    except InputError as err:
        raise InputError(f"simulate: {err}") from None
    try:
        duration = float(duration)
    except (TypeError, ValueError):
        raise InputError(f"simulate: duration '{duration}' is not a number") from None
    if not math.isfinite(duration) or duration <= 0:
        raise InputError(f"simulate: duration must be a positive number, got {duration}")
    physical = gyr_noise is not None or acc_noise is not None
    if isinstance(snr, str):
        if snr != "auto":
            raise InputError(f"simulate: snr must be a number, None or 'auto', got '{snr}'")
        snr = None if physical else DEFAULT_SNR
    elif snr is not None:
        try:
            snr = float(snr)
        except (TypeError, ValueError):
            raise InputError(f"simulate: snr '{snr}' is not a number") from None
        if math.isnan(snr) or snr <= 0:
            raise InputError(f"simulate: snr must be positive (or None for no noise), got {snr}")
        if snr < MIN_SNR:  # (1e-300: noise beyond any sensor's range, a file none reads)
            raise InputError(f"simulate: snr {snr:g} is below {MIN_SNR:g}: the noise would "
                             f"be more than {1 / MIN_SNR:g} x the signal")
        if math.isinf(snr):
            snr = None
        elif physical:
            raise InputError("simulate: give either snr or gyr_noise/acc_noise (physical "
                             f"units), not both (snr={snr:g})")
    return seed, rate, duration, snr, motion


def _check_seed(seed, label: str) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"simulate: {label} must be a non-negative integer, got {seed!r}")
    return int(seed)


#: The lowest signal-to-noise ratio the simulator accepts.
MIN_SNR = 0.01
#: The most soft tissue the simulator moves a sensor on its segment (the amplitudes'
#: scale): beyond, the "sensor" no longer follows its segment at all.
MAX_SOFT_TISSUE = {"deg": 45.0, "mm": 100.0}


def _check_level(label: str, value, unit: str, high: float = math.inf) -> float | None:
    """A non-negative finite amount in ``unit``, at most ``high``, or None."""
    if value is None:
        return None
    x = _number(label, value)
    if not math.isfinite(x) or x < 0:
        raise InputError(f"simulate: {label} must be a non-negative number of {unit}, got {x:g}")
    if x > high:  # (1e300 wrote a file that every estimator refused)
        raise InputError(f"simulate: {label} {x:g} {unit} is beyond what a body-worn sensor "
                         f"reads or soft tissue moves (at most {high:g} {unit})")
    return x


def _check_clock_offset(clock_offset, duration: float) -> dict[str, float]:
    if clock_offset is None:
        return {}
    if not isinstance(clock_offset, Mapping):
        raise InputError("simulate: clock_offset must map sensor names to seconds, e.g. "
                         f"{{'shank': 0.02}}, got {_one_line(clock_offset)}")
    out = {}
    for name, value in clock_offset.items():
        if name not in SENSORS:
            raise InputError(f"simulate: clock_offset for unknown sensor '{name}'; sensors "
                             f"are {', '.join(SENSORS)}")
        d = _number(f"clock_offset of {name}", value)
        if not math.isfinite(d) or abs(d) >= duration:
            raise InputError(f"simulate: clock_offset of {name} must be finite and shorter "
                             f"than the duration ({duration:g} s), got {d:g} s")
        out[name] = d
    return out


def _sensor_bias(label: str, value, rng: np.random.Generator, unit: str
                 ) -> dict[str, np.ndarray]:
    """Bias vector per sensor (sensor frame, ``unit``) from the option ``label``
    (``gyr_bias`` or ``acc_bias``); sensors without bias are left out."""
    # One random direction per sensor, always drawn in sensor order, so a sensor's direction
    # does not depend on which other sensors get a bias.
    dirs = {}
    for name in SENSORS:
        v = rng.standard_normal(3)
        dirs[name] = v / np.linalg.norm(v)
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        value = dict.fromkeys(SENSORS, value)
    out = {}
    for name, given in value.items():
        if name not in SENSORS:
            raise InputError(f"simulate: {label} for unknown sensor '{name}'; sensors are "
                             f"{', '.join(SENSORS)}")
        if np.ndim(given) == 0:
            mag = _number(f"{label} of {name}", given)
            if not math.isfinite(mag) or mag < 0:
                raise InputError(f"simulate: {label} of {name} must be a non-negative "
                                 f"magnitude in {unit} or a 3-vector, got {mag:g}")
            vec = mag * dirs[name]
        else:
            try:
                vec = np.asarray(given, dtype=float)
            except (TypeError, ValueError):
                raise InputError(f"simulate: {label} of {name} {_one_line(given)} is not "
                                 f"a number or 3-vector ({unit})") from None
            if vec.shape != (3,) or not np.all(np.isfinite(vec)):
                raise InputError(f"simulate: {label} of {name} must be a magnitude or a "
                                 f"finite 3-vector ({unit}), got {_one_line(given)}")
        limit = SENSOR_RANGE[label.removesuffix("_bias")]
        size = mag if np.ndim(given) == 0 else float(np.abs(vec).max())
        if not size <= limit:  # (1e300 wrote a file that every estimator refused)
            raise InputError(f"simulate: {label} of {name} {size:g} {unit} is beyond a "
                             f"body-worn sensor's range ({limit:g} {unit})")
        if np.any(vec != 0.0):
            out[name] = vec
    return out


def _bias_setting(gyr_bias):
    """The bias option as given (already validated), JSON-ready."""

    def plain(v):
        return float(v) if np.ndim(v) == 0 else [float(x) for x in v]

    if gyr_bias is None:
        return None
    if isinstance(gyr_bias, Mapping):
        return {k: plain(v) for k, v in gyr_bias.items()}
    return plain(gyr_bias)  # one magnitude, or one vector, for every sensor


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    """Uniformly distributed rotation matrix (normalised Gaussian quaternion)."""
    q = rng.standard_normal(4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _draw_geometry(rng: np.random.Generator) -> _Geometry:
    l_thigh = rng.uniform(0.40, 0.45)
    l_shank = rng.uniform(0.40, 0.45)
    pos = {}
    # Thigh / shank: on the surface, 5-35 cm above the distal joint, 4-10 cm off the axis.
    for name, length in (("thigh", l_thigh), ("shank", l_shank)):
        d = rng.uniform(0.05, 0.35)
        r = rng.uniform(0.04, 0.10)
        phi = rng.uniform(0.0, 2.0 * np.pi)
        pos[name] = np.array([r * np.cos(phi), r * np.sin(phi), -length + d])
    # Foot: on the dorsum, in front of and around the ankle (about 5-15 cm away).
    pos["foot"] = np.array(
        [rng.uniform(-0.04, 0.04), rng.uniform(0.05, 0.12), rng.uniform(-0.06, 0.02)]
    )
    rot = {name: _random_rotation(rng) for name in SENSORS}
    return _Geometry(l_thigh=l_thigh, l_shank=l_shank, rot=rot, pos=pos)


def _draw_motion(rng: np.random.Generator, motion: str) -> _Motion:
    u = rng.uniform
    deg = _DEG

    def phase() -> float:
        return u(0.0, 2.0 * np.pi)

    zero = _Sines()
    if motion == "static":
        # A random, relaxed standing posture; nothing moves.
        return _Motion(
            hip_flexion=_Sines(u(-5, 10) * deg),
            hip_abduction=_Sines(u(-5, 5) * deg),
            hip_rotation=_Sines(u(-5, 5) * deg),
            knee_flexion=_Sines(u(0, 15) * deg),
            dorsiflexion=_Sines(u(-10, 10) * deg),
            inversion=_Sines(u(-5, 5) * deg),
            foot_rotation=_Sines(u(-5, 5) * deg),
            hip_offset=(zero, zero, zero),
            hip_velocity=(0.0, 0.0, 0.0),
        )

    if motion == "gait":
        return _draw_gait(rng)

    if motion == "protocol":
        # The paper's experiment: circling first (the same draws as `circling` with this
        # seed), then walking; angles and hip position hand over smoothly.
        circ = _draw_motion(rng, "circling")
        gait = _draw_gait(rng)
        sigma = _Step(PROTOCOL_TRANSITION_CENTRE_S, PROTOCOL_TRANSITION_WIDTH_S)
        names = ("hip_flexion", "hip_abduction", "hip_rotation", "knee_flexion",
                 "dorsiflexion", "inversion", "foot_rotation")
        angles = {k: _Blend(sigma, getattr(circ, k), getattr(gait, k)) for k in names}
        hip = tuple(_Blend(sigma, a, b) for a, b in zip(circ.hip_offset, gait.hip_offset,
                                                        strict=True))
        info = {"circling_frequency_hz": circ.cycle_freq, **gait.info,
                "circling_s": PROTOCOL_CIRCLING_S,
                "transition_centre_s": PROTOCOL_TRANSITION_CENTRE_S,
                "transition_width_s": PROTOCOL_TRANSITION_WIDTH_S}
        return _Motion(**angles, hip_offset=hip, hip_velocity=(0.0, 0.0, 0.0),
                       stride_phase=gait.stride_phase, cycle_freq=circ.cycle_freq,
                       walking_share=sigma, progression=_Progression(sigma, gait.hip_velocity),
                       info=info)

    if motion in ("circling", "rigid-knee"):
        # Standing on the other leg, circling thigh and foot (the paper's calibration motion).
        fc, pc = u(0.5, 0.8), phase()
        hip_flexion = _Sines(u(15, 30) * deg, (u(20, 30) * deg,), (fc,), (pc,))
        hip_abduction = _Sines(u(5, 15) * deg, (u(20, 30) * deg,), (fc,), (pc + np.pi / 2,))
        hip_rotation = _Sines(0.0, (u(5, 10) * deg,), (u(0.3, 0.6),), (phase(),))
        knee_mid, knee_amp = u(42, 48) * deg, u(20, 25) * deg
        knee_small = u(3, 5) * deg
        knee_flexion = _Sines(
            knee_mid, (knee_amp, knee_small), (u(0.6, 1.0), u(0.2, 0.4)), (phase(), phase())
        )
        fa, pa = u(0.6, 1.0), phase()
        dorsiflexion = _Sines(u(-10, 0) * deg, (u(15, 25) * deg,), (fa,), (pa,))
        inversion = _Sines(0.0, (u(15, 25) * deg,), (fa,), (pa + np.pi / 2,))
        foot_rotation = _Sines(0.0, (u(8, 12) * deg,), (u(0.4, 0.8),), (phase(),))
        hip_offset = tuple(
            _Sines(0.0, (u(0.01, 0.03),), (u(0.2, 0.6),), (phase(),)) for _ in range(3)
        )
        if motion == "rigid-knee":
            knee_flexion = _Sines(knee_mid)
        return _Motion(
            hip_flexion,
            hip_abduction,
            hip_rotation,
            knee_flexion,
            dorsiflexion,
            inversion,
            foot_rotation,
            hip_offset,
            (0.0, 0.0, 0.0),
            cycle_freq=fc,
            info={"circling_frequency_hz": fc},
        )

    # walking (legacy: a strictly periodic gait-like pattern, kept for existing seeds)
    f, p0 = u(0.85, 1.1), phase()

    def gait(name: str) -> _Sines:
        mean, harmonics = _GAIT[name]
        scale = u(0.85, 1.15)
        amp, freq, ph = [], [], []
        for k, (a, b) in enumerate(harmonics, start=1):
            # a cos(k psi) + b sin(k psi) = c sin(k psi + atan2(a, b)), psi = 2 pi f t + p0
            amp.append(scale * math.hypot(a, b) * deg)
            freq.append(k * f)
            ph.append(k * p0 + math.atan2(a, b))
        return _Sines(mean * deg, tuple(amp), tuple(freq), tuple(ph))

    def small(amp_deg: float) -> _Sines:
        return _Sines(0.0, (u(0.7, 1.3) * amp_deg * deg,), (f,), (p0 + phase(),))

    stride = u(1.2, 1.5)  # m per stride
    hip_offset = (
        _Sines(0.0, (u(0.015, 0.025),), (f,), (p0 + np.pi / 2,)),  # lateral sway
        _Sines(0.0, (u(0.01, 0.03),), (2 * f,), (2 * p0 + phase(),)),  # speed fluctuation
        _Sines(0.0, (u(0.015, 0.03),), (2 * f,), (2 * p0 + np.pi / 2,)),  # vertical bounce
    )
    return _Motion(
        hip_flexion=gait("hip_flexion"),
        hip_abduction=small(5.0),
        hip_rotation=small(5.0),
        knee_flexion=gait("knee_flexion"),
        dorsiflexion=gait("dorsiflexion"),
        inversion=small(3.0),
        foot_rotation=small(3.0),
        hip_offset=hip_offset,
        hip_velocity=(0.0, stride * f, 0.0),
        stride_phase=_Phase(p0, f),
        info={"stride_frequency_hz": f, "stride_length_m": stride},
    )


def _draw_gait(rng: np.random.Generator) -> _Motion:
    """Level walking with stride-to-stride variation (see docs/simulator.md, `gait`)."""
    u = rng.uniform
    deg = _DEG

    def phase() -> float:
        return u(0.0, 2.0 * np.pi)

    # Cadence: nominal stride frequency f0 with two slow modulations of 1-2 % each (stride
    # times vary by a few percent, as in healthy walking), so strides are not all alike.
    f0 = u(0.85, 1.05)
    mods = [(u(0.01, 0.02), u(lo, hi), phase()) for lo, hi in ((0.04, 0.12), (0.15, 0.35))]
    # f(t) = f0 (1 + sum a sin(2 pi nu t + ph)) integrates to psi's mod term below.
    psi = _Phase(u(0.0, 2.0 * np.pi), f0, _Sines(
        0.0, tuple(f0 * a / nu for a, nu, _ in mods), tuple(nu for _, nu, _ in mods),
        tuple(ph - np.pi / 2 for _, _, ph in mods)))

    def drift(level: float, wander: float) -> _Sines:
        # Slowly wandering level: ``level + wander sin(...)`` at 0.05-0.2 Hz.
        return _Sines(level, (wander,), (u(0.05, 0.2),), (phase(),))

    def size(lo: float, hi: float) -> _Sines:
        # Stride-to-stride size: a scale in [lo, hi] varying by 2-5 % and 1-3 %.
        return _Sines(u(lo, hi), (u(0.02, 0.05), u(0.01, 0.03)), (u(0.1, 0.3), u(0.3, 0.6)),
                      (phase(), phase()))

    def sagittal(name: str, lo: float, hi: float, shift_deg: tuple[float, float],
                 wander_deg: float) -> _PhaseCurve:
        mean, amp, ph = _gait_fourier(name)
        return _PhaseCurve(psi, tuple(range(1, GAIT_HARMONICS + 1)), amp, ph,
                           drift(mean + u(*shift_deg) * deg, wander_deg * deg), size(lo, hi))

    def small(first: tuple[float, float], second: tuple[float, float]) -> _PhaseCurve:
        # A few degrees at the stride frequency and its second harmonic, random shape.
        return _PhaseCurve(psi, (1, 2), (u(*first) * deg, u(*second) * deg),
                           (phase(), phase()), drift(u(-1.0, 1.0) * deg, 0.5 * deg),
                           size(0.95, 1.05))

    knee_flexion = sagittal("knee_flexion", 0.93, 1.03, (-0.5, 1.5), 0.7)
    hip_flexion = sagittal("hip_flexion", 0.9, 1.1, (-3.0, 3.0), 1.0)
    dorsiflexion = sagittal("dorsiflexion", 0.85, 1.1, (-2.0, 2.0), 1.0)
    hip_abduction = small((2.0, 4.0), (0.5, 1.5))
    hip_rotation = small((2.0, 5.0), (0.5, 1.5))
    inversion = small((1.5, 3.0), (0.5, 1.5))
    foot_rotation = small((1.5, 3.0), (0.5, 1.0))
    stride = u(1.2, 1.5)  # m per stride; speed = stride * f(t)
    # Forward position = stride * psi / (2 pi): the cadence modulation moves the hip too.
    cadence = _Sines(0.0, tuple(stride / (2 * np.pi) * a for a in psi.mod.amp), psi.mod.freq,
                     psi.mod.phase)
    hip_offset = (
        _PhaseCurve(psi, (1,), (u(0.015, 0.025),), (phase(),)),  # lateral sway
        _Sum((cadence, _PhaseCurve(psi, (2,), (u(0.01, 0.03),), (phase(),)))),  # speed
        _PhaseCurve(psi, (2,), (u(0.015, 0.03),), (phase(),)),  # vertical bounce
    )
    return _Motion(
        hip_flexion=hip_flexion,
        hip_abduction=hip_abduction,
        hip_rotation=hip_rotation,
        knee_flexion=knee_flexion,
        dorsiflexion=dorsiflexion,
        inversion=inversion,
        foot_rotation=foot_rotation,
        hip_offset=hip_offset,
        hip_velocity=(0.0, stride * f0, 0.0),
        stride_phase=psi,
        info={"stride_frequency_hz": f0, "stride_length_m": stride},
    )


@dataclass(frozen=True)
class _Sum:
    """Sum of callables of ``t``."""

    parts: tuple

    def __call__(self, t: np.ndarray) -> np.ndarray:
        return sum(p(t) for p in self.parts)


def _draw_soft_tissue(rng: np.random.Generator) -> dict:
    """Unit-amplitude soft-tissue patterns: sensor -> (rotation _Wobble, translation _Wobble).
    Drawn for every sensor in a fixed order, so the pattern depends only on the seed."""

    def unit(n: int) -> np.ndarray:
        v = rng.standard_normal((n, 3))
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    def one() -> _Wobble:
        k = len(SOFT_TISSUE_HARMONIC_SHARE)
        return _Wobble(dirs=unit(k), phases=rng.uniform(0, 2 * np.pi, k), hs_dir=unit(1)[0],
                       hs_freq=rng.uniform(*HEEL_STRIKE_WOBBLE_HZ),
                       hs_phase=rng.uniform(0, 2 * np.pi))

    return {name: (one(), one()) for name in SENSORS}


def _scale_soft_tissue(patterns: dict, mot: _Motion, duration: float, clock: dict,
                       rot_peak: float, trans_peak: float) -> dict:
    """Scale each sensor's unit patterns so that ``|dtheta|`` and ``|dr|`` peak at exactly
    ``rot_peak`` (rad) and ``trans_peak`` (m) over the recording (on a 1 kHz grid of the
    sensor's own times, so the scale does not depend on the sample rate)."""
    out = {}
    for name in SENSORS:
        grid = np.arange(0.0, duration, 1e-3) - clock.get(name, 0.0)
        pair = []
        for pattern, peak in zip(patterns[name], (rot_peak, trans_peak), strict=True):
            top = float(np.linalg.norm(_wobble_vector(pattern, mot, grid), axis=1).max())
            # A motion without stride or circling (static) has no artefact: scale 0.
            pair.append((pattern, peak / top if top > 0 else 0.0))
        out[name] = tuple(pair)
    return out


def _heel_strike_envelope(s: np.ndarray) -> np.ndarray:
    """Gaussian window ``exp(-(s - centre)^2 / (2 width^2))`` of the time ``s`` since heel
    strike (:data:`HEEL_STRIKE_CENTRE_S`, :data:`HEEL_STRIKE_WIDTH_S`)."""
    return np.exp(-0.5 * ((s - HEEL_STRIKE_CENTRE_S) / HEEL_STRIKE_WIDTH_S) ** 2)


def _wobble_vector(w: _Wobble, mot: _Motion, t: np.ndarray) -> np.ndarray:
    """Soft-tissue pattern (before scaling) at times ``t`` (any shape), shape ``t.shape + (3,)``:
    stride-locked harmonics plus heel-strike wobble while walking, circling-locked harmonics
    while circling, blended by the walking share; zero for a motion without either."""
    out = np.zeros(np.shape(t) + (3,))
    share = SOFT_TISSUE_HARMONIC_SHARE
    if mot.stride_phase is not None:
        psi = mot.stride_phase(t)
        walk = np.zeros_like(out)
        for k, (a, d, p) in enumerate(zip(share, w.dirs, w.phases, strict=True), start=1):
            walk += (a * np.sin(k * psi + p))[..., None] * d
        # Time since the nearest heel strike (psi = 2 pi k), from the phase, wrapped half a
        # stride away where the window is < 1e-100, so the wrap is seamless.
        since = (np.mod(psi + np.pi, 2.0 * np.pi) - np.pi) / (2.0 * np.pi * mot.stride_phase.f0)
        hs = SOFT_TISSUE_HEEL_STRIKE_SHARE * _heel_strike_envelope(since) * np.sin(
            2.0 * np.pi * w.hs_freq * since + w.hs_phase)
        walk += hs[..., None] * w.hs_dir
        weight = np.ones(np.shape(t)) if mot.walking_share is None else mot.walking_share(t)
        out += weight[..., None] * walk
    else:
        weight = np.zeros(np.shape(t))
    if mot.cycle_freq > 0:
        circ = np.zeros_like(out)
        for k, (a, d, p) in enumerate(zip(share, w.dirs, w.phases, strict=True), start=1):
            circ += (a * np.sin(2.0 * np.pi * k * mot.cycle_freq * t + p))[..., None] * d
        out += (1.0 - weight)[..., None] * circ
    return out


def _expmap(v: np.ndarray) -> np.ndarray:
    """Rotation matrices ``Exp(v)`` of rotation vectors ``v`` (..., 3), rad (Rodrigues)."""
    angle = np.linalg.norm(v, axis=-1)
    small = angle < 1e-8
    safe = np.where(small, 1.0, angle)
    k = np.zeros(v.shape + (3,))
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    k[..., 0, 1], k[..., 0, 2], k[..., 1, 2] = -z, y, -x
    k[..., 1, 0], k[..., 2, 0], k[..., 2, 1] = z, -y, x
    # sin(a)/a and (1 - cos a)/a^2, with their series near 0 (no division by ~0)
    s = np.where(small, 1.0 - angle**2 / 6.0, np.sin(safe) / safe)
    c = np.where(small, 0.5 - angle**2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    return np.eye(3) + s[..., None, None] * k + c[..., None, None] * (k @ k)


def _rot(axis: int, angle: np.ndarray) -> np.ndarray:
    """Elementary rotation matrices about world/body axis 0, 1 or 2; shape (..., 3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(angle) + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out[..., axis, axis] = 1.0
    out[..., i, i] = c
    out[..., j, j] = c
    out[..., i, j] = -s
    out[..., j, i] = s
    return out


def _poses(geo: _Geometry, mot: _Motion, t: np.ndarray):
    """Segment orientations and origins (oscillating part of the hip only) at times ``t``."""
    r_thigh = (
        _rot(0, mot.hip_flexion(t)) @ _rot(1, -mot.hip_abduction(t)) @ _rot(2, mot.hip_rotation(t))
    )
    r_shank = r_thigh @ _rot(0, -mot.knee_flexion(t))
    r_foot = (
        r_shank
        @ _rot(0, mot.dorsiflexion(t))
        @ _rot(1, mot.inversion(t))
        @ _rot(2, mot.foot_rotation(t))
    )
    hip = np.stack([s(t) for s in mot.hip_offset], axis=-1)
    knee = hip - geo.l_thigh * r_thigh[..., :, 2]
    ankle = knee - geo.l_shank * r_shank[..., :, 2]
    return {"thigh": (r_thigh, hip), "shank": (r_shank, knee), "foot": (r_foot, ankle)}


def _vee(w: np.ndarray) -> np.ndarray:
    """Axial vector of the antisymmetric part of (N, 3, 3) matrices."""
    return 0.5 * np.stack(
        [w[:, 2, 1] - w[:, 1, 2], w[:, 0, 2] - w[:, 2, 0], w[:, 1, 0] - w[:, 0, 1]], axis=-1
    )


def _signals(geo: _Geometry, mot: _Motion, t: np.ndarray, clock=None, wobble=None):
    """Exact gyr/acc of every sensor by 5-point central differences of the analytic poses.

    ``clock``: sensor -> clock offset d (s); that sensor is evaluated at true times
    ``t - d``. ``wobble``: None, or sensor -> ((rotation pattern, scale rad),
    (translation pattern, scale m)), see :func:`_scale_soft_tissue`.
    Returns clean signals, sensor-to-world rotations, the knee angle at ``t`` and the
    soft-tissue motion per sensor (``dtheta`` rad, ``dr`` m, segment frame, at the sensor's
    own evaluation times).
    """
    clock = clock or {}
    # The heel-strike wobble reaches ~35 Hz, where 1 ms steps leave ~3e-6 relative error;
    # a quarter of the step brings it to ~1e-8 (round-off stays below 1e-7 m/s^2).
    h = FD_STEP if wobble is None else FD_STEP / 4
    offsets = np.array([-2.0, -1.0, 0.0, 1.0, 2.0]) * h
    d1 = np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / (12.0 * h)
    d2 = np.array([-1.0, 16.0, -30.0, 16.0, -1.0]) / (12.0 * h * h)
    clean, rot_world, tissue = {}, {}, {}
    # Sensors sharing a clock share one evaluation of the poses.
    for d in dict.fromkeys(clock.get(n, 0.0) for n in SENSORS):
        tt = t - d if d else t
        stencil = tt[None, :] + offsets[:, None]
        poses = _poses(geo, mot, stencil)  # arrays of shape (5, N, ...)
        for name in SENSORS:
            if clock.get(name, 0.0) != d:
                continue
            r_seg, origin = poses[name]
            s_rot, s_pos = geo.rot[name], geo.pos[name]
            if wobble is None:
                # Angular velocity of the segment in segment coordinates: vee(R^T R_dot).
                r_dot = np.tensordot(d1, r_seg, axes=(0, 0))
                omega_seg = _vee(np.swapaxes(r_seg[2], -1, -2) @ r_dot)
                # Sensor position in the world, its acceleration, and the specific force.
                p = origin + r_seg @ s_pos
                p_ddot = np.tensordot(d2, p, axes=(0, 0))
                if mot.progression is not None:
                    p_ddot = p_ddot + mot.progression.acc(tt)
                f_world = p_ddot - GRAVITY
                f_seg = np.einsum("nji,nj->ni", r_seg[2], f_world)
                clean[name] = {"gyr": omega_seg @ s_rot, "acc": f_seg @ s_rot}
                rot_world[name] = r_seg[2] @ s_rot
                continue
            # Soft tissue: the sensor turns by Exp(dtheta) and shifts by dr on its segment.
            (w_rot, rot_amp), (w_trans, trans_amp) = wobble[name]
            dtheta = rot_amp * _wobble_vector(w_rot, mot, stencil)
            dr = trans_amp * _wobble_vector(w_trans, mot, stencil)
            r_sensor = r_seg @ _expmap(dtheta) @ s_rot  # sensor -> world, (5, N, 3, 3)
            r_dot = np.tensordot(d1, r_sensor, axes=(0, 0))
            gyr = _vee(np.swapaxes(r_sensor[2], -1, -2) @ r_dot)
            p = origin + np.einsum("snij,snj->sni", r_seg, s_pos + dr)
            p_ddot = np.tensordot(d2, p, axes=(0, 0))
            if mot.progression is not None:
                p_ddot = p_ddot + mot.progression.acc(tt)
            f_world = p_ddot - GRAVITY
            clean[name] = {"gyr": gyr, "acc": np.einsum("nji,nj->ni", r_sensor[2], f_world)}
            rot_world[name] = r_sensor[2]
            tissue[name] = {"dtheta": dtheta[2], "dr": dr[2]}
    knee_angle = -mot.knee_flexion(t)
    return clean, rot_world, knee_angle, tissue


def _vec(v) -> list[float]:
    return [float(x) for x in v]


def _truth(geo: _Geometry, mot: _Motion, settings: dict) -> dict:
    ex = np.array([1.0, 0.0, 0.0])
    s_t, s_s, s_f = (geo.rot[n] for n in SENSORS)
    p_t, p_s, p_f = (geo.pos[n] for n in SENSORS)
    knee_in_thigh = np.array([0.0, 0.0, -geo.l_thigh])
    ankle_in_shank = np.array([0.0, 0.0, -geo.l_shank])
    vec = _vec

    knee = {
        "joint": "hinge",
        "sensors": ["thigh", "shank"],
        "j1": vec(s_t.T @ ex),
        "j2": vec(s_s.T @ ex),
        "o1": vec(s_t.T @ (p_t - knee_in_thigh)),
        "o2": vec(s_s.T @ p_s),
    }
    ankle = {
        "joint": "spheroidal",
        "sensors": ["shank", "foot"],
        "o1": vec(s_s.T @ (p_s - ankle_in_shank)),
        "o2": vec(s_f.T @ p_f),
    }
    return {
        "convention": CONVENTION,
        "knee": knee,
        "ankle": ankle,
        "j1": knee["j1"],
        "j2": knee["j2"],
        "o1": ankle["o1"],
        "o2": ankle["o2"],
        "settings": settings,
        "model": {
            "thigh_length": float(geo.l_thigh),
            "shank_length": float(geo.l_shank),
            "sensor_position_in_segment": {n: vec(geo.pos[n]) for n in SENSORS},
            "sensor_to_segment_rotation": {n: [vec(row) for row in geo.rot[n]] for n in SENSORS},
            "hip_velocity": [float(v) for v in mot.hip_velocity],
            "gravity": vec(GRAVITY),
            "motion": {k: float(v) for k, v in mot.info.items()},
        },
    }


def _heel_strikes(mot: _Motion, t: np.ndarray) -> list[float]:
    """True times (s) in the recording at which the stride phase passes 2 pi k while
    walking (walking share > 0.5)."""
    if mot.stride_phase is None or len(t) < 2:
        return []
    # Dense grid, then Newton steps on psi(t) = 2 pi k (psi is smooth and increasing).
    grid = np.linspace(t[0], t[-1], max(4 * len(t), 1000))
    cycles = np.floor(mot.stride_phase(grid) / (2.0 * np.pi))
    out = []
    for i in np.nonzero(np.diff(cycles) > 0)[0]:
        target, x = 2.0 * np.pi * cycles[i + 1], grid[i]
        for _ in range(5):
            h = 1e-6
            slope = (mot.stride_phase(x + h) - mot.stride_phase(x - h)) / (2 * h)
            x = x - (mot.stride_phase(x) - target) / slope
        if mot.walking_share is None or mot.walking_share(x) > 0.5:
            out.append(round(float(x), 9))
    return out


def _realism_truth(mot, t, clock, bias, noise_std, tissue, knee_angle, rot_deg, trans_mm):
    """True values of the realism options, and the knee flexion over time."""
    d = {n: float(clock.get(n, 0.0)) for n in SENSORS}
    out = {
        "clock_offset_s": d,
        "time_offset_s": {"knee": d["shank"] - d["thigh"], "ankle": d["foot"] - d["shank"]},
        "gyr_bias": {n: _vec(bias.get(n, np.zeros(3))) for n in SENSORS},
        "noise_std": {n: {k: float(v) for k, v in noise_std[n].items()} for n in SENSORS},
        "soft_tissue": {
            "rotation_deg": rot_deg,
            "translation_mm": trans_mm,
            "sensors": {
                n: {
                    "rotation_peak_deg": float(np.degrees(np.linalg.norm(x["dtheta"], axis=1)
                                                          .max())),
                    "rotation_rms_deg": float(np.degrees(np.sqrt(np.mean(np.sum(
                        x["dtheta"] ** 2, axis=1))))),
                    "translation_peak_mm": float(1e3 * np.linalg.norm(x["dr"], axis=1).max()),
                    "translation_rms_mm": float(1e3 * np.sqrt(np.mean(np.sum(x["dr"] ** 2,
                                                                             axis=1)))),
                }
                for n, x in tissue.items()
            },
        },
        "heel_strikes_s": _heel_strikes(mot, t),
        # Knee flexion at the true sample times n / rate, deg (1e-6 deg is plenty).
        "knee_flexion_deg": [round(float(x), 6) for x in np.degrees(-knee_angle)],
    }
    return out


# ----------------------------------------------------------------------------- command line


def parse_clock_offsets(items: list[str] | None, option: str = "--clock-offset") -> dict:
    """``["shank=0.02", ...]`` -> ``{"shank": 0.02}`` (seconds); one-line errors.

    Returns
    -------
    dict[str, float]
        Sensor (``thigh``, ``shank``, ``foot``) -> clock offset, s; ``{}`` for None or
        ``[]``.

    Raises
    ------
    InputError
        an item is not ``SENSOR=SECONDS`` with a number of seconds, names an unknown
        sensor, or names one a second time (``option`` names the option).

    Examples
    --------
    >>> from imucal.simulate import parse_clock_offsets
    >>> parse_clock_offsets(["shank=0.02", "foot=-0.01"])
    {'shank': 0.02, 'foot': -0.01}
    """
    out = {}
    usage = f"use SENSOR=SECONDS with SENSOR one of {', '.join(SENSORS)}, e.g. shank=0.02"
    for item, name, value in _sensor_items(items or [], option, usage):
        try:
            out[name] = float(value)
        except ValueError:
            raise InputError(f"{option} '{item}': '{value}' is not a number of seconds") from None
    return out


def _sensor_items(items: list[str], option: str, usage: str):
    """(item, sensor, value) of each ``SENSOR=VALUE`` item; one-line errors for another
    form, an unknown sensor (``usage`` says the form) or a sensor given twice."""
    seen = set()
    for item in items:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or name not in SENSORS:
            raise InputError(f"{option} '{item}': {usage}")
        if name in seen:
            raise InputError(f"{option}: {name} given twice")
        seen.add(name)
        yield item, name, value


def parse_sensor_bias(items: list[str] | None, option: str = "--gyr-bias", unit: str = "rad/s"):
    """``--gyr-bias`` (rad/s) or ``--acc-bias`` (m/s^2, with ``option``, ``unit``):
    ``["0.02"]`` -> 0.02 (every sensor, random directions); ``["shank=0.02",
    "foot=0.01,0,0"]`` -> ``{"shank": 0.02, "foot": (0.01, 0.0, 0.0)}``.

    Returns
    -------
    None, float or dict
        None for no items; a magnitude (``unit``) for one bare number; else sensor ->
        magnitude (float) or components (tuple of 3 floats), ``unit``, sensor frame.

    Raises
    ------
    InputError
        an item is neither one magnitude nor ``SENSOR=`` one magnitude or three components,
        names an unknown sensor, or names one a second time.

    Examples
    --------
    >>> from imucal.simulate import parse_sensor_bias
    >>> parse_sensor_bias(["0.02"]), parse_sensor_bias(["foot=0.01,0,0"])
    (0.02, {'foot': (0.01, 0.0, 0.0)})
    """
    if not items:
        return None
    if len(items) == 1 and "=" not in items[0]:
        try:
            return float(items[0])
        except ValueError:
            raise InputError(f"{option} '{items[0]}': use {unit.upper()}, SENSOR="
                             f"{unit.upper()} or SENSOR=X,Y,Z ({unit})") from None
    out = {}
    usage = (f"use SENSOR={unit.upper()} or SENSOR=X,Y,Z with SENSOR one of "
             f"{', '.join(SENSORS)} (a bare magnitude only alone)")
    for item, name, value in _sensor_items(items, option, usage):
        try:
            parts = [float(x) for x in value.split(",")]
        except ValueError:
            raise InputError(f"{option} '{item}': '{value}' is not a number or X,Y,Z in "
                             f"{unit}") from None
        if len(parts) not in (1, 3):
            raise InputError(f"{option} '{item}': give one magnitude or three components "
                             f"X,Y,Z ({unit})")
        out[name] = parts[0] if len(parts) == 1 else tuple(parts)
    return out
