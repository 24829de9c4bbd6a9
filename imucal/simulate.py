"""Kinematic three-segment leg simulator (Seel, Schauer, Raisch 2012, Sec. III-A).

Thigh -- knee (hinge, 1 DOF) -- shank -- ankle (spheroidal, 3 DOF) -- foot. Each segment
carries one IMU at a random position and with a uniformly random orientation. All joint
angles and the hip position are analytic sums of sinusoids, so the sensor signals are
computed from exact poses by 5-point central differences (no integration, no drift).

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
and a constant position ``r_i`` in segment coordinates. See ``docs/simulator.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import InputError
from .recording import Recording, make_recording

MOTIONS = ("circling", "walking", "rigid-knee", "static")
SENSORS = ("thigh", "shank", "foot")

#: Gravity in the world frame (z up), m/s^2.
GRAVITY = np.array([0.0, 0.0, -9.81])
#: Step of the 5-point central differences, s.
FD_STEP = 1e-3
#: Gyroscope noise reference level, rad/s: the gyro noise std is max(RMS, this) / snr, so a
#: sensor at rest (RMS 0) still gets realistic noise (0.002 rad/s at snr=100).
GYR_NOISE_FLOOR_RMS = 0.2

CONVENTION = (
    "j1: knee hinge axis, unit vector in the thigh sensor frame; j2: the same physical axis "
    "(same direction, pointing to the lateral side) in the shank sensor frame, so "
    "j2.g2 - j1.g1 is the rate of the shank's rotation relative to the thigh about that "
    "axis (= minus the knee flexion rate). o1, o2: vector FROM the joint centre TO the "
    "sensor origin, in metres, in the first / second sensor's frame (ankle: shank / foot; "
    "knee: thigh / shank, with the knee centre on the hinge axis). Gyroscope: angular "
    "velocity of the sensor in its own frame, rad/s. Accelerometer: specific force "
    "R^T (p_ddot - g) in the sensor frame, m/s^2, with g = (0, 0, -9.81) in a z-up world "
    "(a sensor at rest reads +9.81 along up)."
)

_DEG = np.pi / 180.0

# Gait curves over one stride (phase 0 = heel strike), in degrees: mean, then (cos, sin)
# coefficients of harmonics 1, 2, ... (Fourier fit to textbook sagittal gait curves).
_GAIT = {
    "hip_flexion": (12.67, [(20.6, -4.14), (-2.64, -1.93), (-0.49, 0.52)]),
    "knee_flexion": (23.64, [(-4.67, -20.65), (-13.27, 8.44), (-1.43, 3.13), (0.22, 0.64)]),
    "dorsiflexion": (-1.1, [(-0.02, 3.66), (0.25, -9.63), (-0.88, 3.36), (1.43, -0.54)]),
}


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
class _Motion:
    hip_flexion: _Sines
    hip_abduction: _Sines
    hip_rotation: _Sines
    knee_flexion: _Sines
    dorsiflexion: _Sines
    inversion: _Sines
    foot_rotation: _Sines
    hip_offset: tuple[_Sines, _Sines, _Sines]  # oscillating part of the hip position, m
    hip_velocity: tuple[float, float, float]  # constant part of the hip velocity, m/s


@dataclass(frozen=True)
class _Geometry:
    l_thigh: float
    l_shank: float
    rot: dict  # sensor name -> (3, 3) sensor -> segment rotation
    pos: dict  # sensor name -> (3,) sensor origin in segment coordinates, m


# ----------------------------------------------------------------------------- public API


def simulate(
    *,
    seed: int | None = None,
    rate: float = 100.0,
    duration: float = 20.0,
    snr: float | None = 100.0,
    motion: str = "circling",
) -> tuple[Recording, dict]:
    """Simulate thigh, shank and foot IMUs on a leg with a knee hinge and a spheroidal ankle.

    Parameters
    ----------
    seed
        Seed of all randomness (sensor placement, motion details, noise). ``None`` draws a
        fresh seed; it is recorded in ``truth["settings"]["seed"]``. The placement depends
        only on the seed, the motion only on seed, motion and timing, and the noise stream is
        separate, so the same seed with ``snr=None`` gives the exact clean signals.
    rate, duration
        Sample rate in Hz and length in seconds (``round(rate * duration)`` samples).
    snr
        Amplitude signal-to-noise ratio: per sensor and per gyr/acc, white Gaussian noise of
        std ``RMS / snr`` per component, ``RMS = sqrt(mean |s|^2 / 3)`` (gyro RMS floored at
        :data:`GYR_NOISE_FLOOR_RMS`). ``None`` or ``inf``: no noise.
    motion
        One of :data:`MOTIONS`.

    Returns
    -------
    (Recording, dict)
        The recording (sensors ``thigh``, ``shank``, ``foot``; source ``"<simulated>"``) and
        the JSON-serialisable ground truth (see :data:`CONVENTION`).
    """
    rec, truth, _ = _simulate_with_internals(
        seed=seed, rate=rate, duration=duration, snr=snr, motion=motion
    )
    return rec, truth


# ----------------------------------------------------------------------------- internals


def _simulate_with_internals(*, seed, rate, duration, snr, motion):
    """:func:`simulate` plus internals for tests: clean signals, knee angle, sensor poses."""
    seed, rate, duration, snr, motion = _check_args(seed, rate, duration, snr, motion)
    n = int(round(rate * duration))
    if n < 2:
        raise InputError(f"simulate: rate * duration gives {n} sample(s); need at least 2")
    geo_ss, motion_ss, noise_ss = np.random.SeedSequence(seed).spawn(3)
    geo = _draw_geometry(np.random.default_rng(geo_ss))
    mot = _draw_motion(np.random.default_rng(motion_ss), motion)

    t = np.arange(n) / rate
    clean, rot_world, knee_angle = _signals(geo, mot, t)

    noise_rng = np.random.default_rng(noise_ss)
    data = {}
    for name in SENSORS:
        data[name] = {}
        for kind in ("gyr", "acc"):
            s = clean[name][kind]
            if snr is None:
                data[name][kind] = s.copy()
                continue
            rms = math.sqrt(float(np.mean(np.sum(s * s, axis=1))) / 3.0)
            if kind == "gyr":
                rms = max(rms, GYR_NOISE_FLOOR_RMS)
            data[name][kind] = s + noise_rng.standard_normal(s.shape) * (rms / snr)

    rec = make_recording(data, rate=rate, source="<simulated>")
    truth = _truth(geo, mot, seed, rate, duration, snr, motion)
    internals = {"clean": clean, "rot": rot_world, "knee_angle": knee_angle, "time": t}
    return rec, truth, internals


def _check_args(seed, rate, duration, snr, motion):
    if motion not in MOTIONS:
        raise InputError(f"simulate: unknown motion '{motion}'; use one of {', '.join(MOTIONS)}")
    if seed is None:
        seed = int(np.random.SeedSequence().entropy % (2**32))
    elif isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"simulate: seed must be a non-negative integer, got {seed!r}")
    seed = int(seed)
    for label, value in (("rate", rate), ("duration", duration)):
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise InputError(f"simulate: {label} '{value}' is not a number") from None
        if not math.isfinite(value) or value <= 0:
            raise InputError(f"simulate: {label} must be a positive number, got {value}")
    rate, duration = float(rate), float(duration)
    if snr is not None:
        try:
            snr = float(snr)
        except (TypeError, ValueError):
            raise InputError(f"simulate: snr '{snr}' is not a number") from None
        if math.isnan(snr) or snr <= 0:
            raise InputError(f"simulate: snr must be positive (or None for no noise), got {snr}")
        if math.isinf(snr):
            snr = None
    return seed, rate, duration, snr, motion


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
        )

    # walking
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
    )


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


def _signals(geo: _Geometry, mot: _Motion, t: np.ndarray):
    """Exact gyr/acc of every sensor by 5-point central differences of the analytic poses."""
    h = FD_STEP
    offsets = np.array([-2.0, -1.0, 0.0, 1.0, 2.0]) * h
    poses = _poses(geo, mot, t[None, :] + offsets[:, None])  # arrays of shape (5, N, ...)
    d1 = np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / (12.0 * h)
    d2 = np.array([-1.0, 16.0, -30.0, 16.0, -1.0]) / (12.0 * h * h)
    clean, rot_world = {}, {}
    for name in SENSORS:
        r_seg, origin = poses[name]
        s_rot, s_pos = geo.rot[name], geo.pos[name]
        # Angular velocity of the segment in segment coordinates: vee(R^T R_dot).
        r_dot = np.tensordot(d1, r_seg, axes=(0, 0))
        w = np.swapaxes(r_seg[2], -1, -2) @ r_dot
        omega_seg = 0.5 * np.stack(
            [w[:, 2, 1] - w[:, 1, 2], w[:, 0, 2] - w[:, 2, 0], w[:, 1, 0] - w[:, 0, 1]], axis=-1
        )
        # Sensor position in the world, its acceleration, and the specific force.
        p = origin + r_seg @ s_pos
        p_ddot = np.tensordot(d2, p, axes=(0, 0))
        f_world = p_ddot - GRAVITY
        f_seg = np.einsum("nji,nj->ni", r_seg[2], f_world)
        clean[name] = {"gyr": omega_seg @ s_rot, "acc": f_seg @ s_rot}
        rot_world[name] = r_seg[2] @ s_rot
    knee_angle = -mot.knee_flexion(t)
    return clean, rot_world, knee_angle


def _truth(geo: _Geometry, mot: _Motion, seed, rate, duration, snr, motion) -> dict:
    ex = np.array([1.0, 0.0, 0.0])
    s_t, s_s, s_f = (geo.rot[n] for n in SENSORS)
    p_t, p_s, p_f = (geo.pos[n] for n in SENSORS)
    knee_in_thigh = np.array([0.0, 0.0, -geo.l_thigh])
    ankle_in_shank = np.array([0.0, 0.0, -geo.l_shank])

    def vec(v: np.ndarray) -> list[float]:
        return [float(x) for x in v]

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
        "settings": {
            "seed": seed,
            "rate": rate,
            "duration": duration,
            "snr": snr,
            "motion": motion,
        },
        "model": {
            "thigh_length": float(geo.l_thigh),
            "shank_length": float(geo.l_shank),
            "sensor_position_in_segment": {n: vec(geo.pos[n]) for n in SENSORS},
            "sensor_to_segment_rotation": {n: [vec(row) for row in geo.rot[n]] for n in SENSORS},
            "hip_velocity": [float(v) for v in mot.hip_velocity],
            "gravity": vec(GRAVITY),
        },
    }
