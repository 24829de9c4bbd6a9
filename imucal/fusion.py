"""The flexion angle of a hinge from both sensors (Seel, Raisch, Schauer 2014, Sensors
14:6891): the numerics :mod:`imucal.angles` applies.

* **gyro angle**: ``theta_g(t) = integral of (j2.g2 - j1.g1) dt``, the rotation of the second
  segment relative to the first about the axis (rad), a cubic running integral
  (:func:`integrate`). Exact up to a constant, but a gyro bias makes it drift linearly
  (0.02 rad/s is 69 deg per minute).
* **acc angle**: the joint centre's acceleration seen from either sensor,
  ``c_i = a_i - Gamma_gi(o_i)`` with ``Gamma_g(o) = g x (g x o) + gdot x o``, is one
  physical vector; projected into each joint plane (orthogonal to ``j_i``), the angle
  between the projections is the same rotation plus a constant set by the in-plane
  reference directions (:func:`plane_basis`). It is noisy but does not drift.
* **fusion** (offline, the whole recording): the offset ``d(t) = theta_a(t) - theta_g(t)``
  is a constant plus the slow drift of the integrated bias plus noise. A local-linear
  Gaussian-kernel regression of ``d`` (zero-phase, weighted by the in-plane acceleration
  squared, exact for a drift that is linear within the kernel, also at the recording's
  ends) gives ``d_hat``; the angle is ``theta_g + d_hat``. Everything is a few
  convolutions (``scipy.ndimage.gaussian_filter1d``), no loop over samples.

Units: rad/s, m/s^2, m in; rad out (sensor frames throughout).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from .errors import InputError, NotIdentifiableError
from .preprocess import derivative, lowpass
from .settings import as_real
from .vectors import gamma_rows

#: Half-width (1-sigma of the Gaussian kernel) of the fusion, s. The kernel removes the
#: acc angle's noise and its stride-locked errors (soft tissue, an imperfect o: a stride
#: lasts about 1 s, and a 3 s kernel passes < 1e-15 of 1 Hz) while following any gyro
#: bias that changes over tens of seconds; a bias that is constant is followed exactly.
SMOOTHING_S = 3.0
#: The kernel's half-width a calibration may carry, s: below a few samples there is no
#: fusion, and far beyond a recording's length the kernel only costs time and memory
#: (1e9 s asked for terabytes).
SMOOTHING_RANGE_S = (0.01, 600.0)


def check_smoothing(smoothing_s) -> float:
    """``smoothing_s`` (the fusion kernel's half-width, s) checked.

    Returns
    -------
    float
        ``smoothing_s`` as a float, s, within :data:`SMOOTHING_RANGE_S`.

    Raises
    ------
    InputError
        ``smoothing_s`` is not a real number (a bool, a text) or lies outside
        :data:`SMOOTHING_RANGE_S` (NaN and Inf included).

    Examples
    --------
    >>> from imucal.fusion import check_smoothing
    >>> check_smoothing(3)
    3.0
    """
    low, high = SMOOTHING_RANGE_S
    value = as_real(smoothing_s)
    if value is None and not isinstance(smoothing_s, float | np.floating):
        raise InputError(f"smoothing_s must be a number of seconds, got {smoothing_s!r}")
    if value is None:  # nan, inf
        value = float(smoothing_s)
    if not low <= value <= high:
        raise InputError(f"smoothing_s must be from {low:g} to {high:g} s, got {value:g}")
    return value


#: Ridge of the local-linear fit's slope, as a fraction of the kernel's sigma: a drift
#: that is linear within the kernel is still followed to within 4 % of its slope.
RIDGE = 0.2
#: The offset is fitted where the kernel holds at least this share of the usable weight
#: it typically holds; across longer stretches without usable acceleration (standing
#: with the axis along gravity, free fall) it is interpolated between their ends.
MIN_KERNEL_SHARE = 0.1
#: Low-pass before the acc angle (4th-order zero-phase Butterworth, Hz): gdot is a
#: derivative of the gyro and amplifies its noise; human motion lies below it.
ACC_ANGLE_CUTOFF_HZ = 12.0
#: The acc angle is not used where the in-plane part of c_i is below this in either
#: sensor (m/s^2): its direction is then mostly noise (free fall, an axis along gravity).
MIN_INPLANE_ACC = 2.0


# ----------------------------------------------------------------------------- signals


def plane_basis(j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """In-plane reference directions of the joint plane orthogonal to the unit axis ``j``
    (3,) in a sensor's frame. Fixed by ``j`` alone, so the acc angle's constant is fixed
    by the calibration (the zero convention then replaces it).

    Returns
    -------
    x : (3,) float64
        The sensor axis least aligned with ``j``, made orthogonal to ``j`` and unit
        length; same frame as ``j``.
    y : (3,) float64
        ``j x x`` (unit length when ``j`` is).

    Examples
    --------
    >>> from imucal.fusion import plane_basis
    >>> x, y = plane_basis([0.0, 0.0, 1.0])
    >>> x.tolist(), y.tolist()
    ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    """
    j = np.asarray(j, dtype=float)
    e = np.zeros(3)
    e[int(np.argmin(np.abs(j)))] = 1.0
    x = e - (e @ j) * j
    x /= np.linalg.norm(x)
    return x, np.cross(j, x)


def joint_centre_acc(g: np.ndarray, a: np.ndarray, o: np.ndarray, rate: float) -> np.ndarray:
    """The joint centre's specific force seen from one sensor, ``c = a - Gamma_g(o)`` with
    ``Gamma_g(o) = g x (g x o) + gdot x o``.

    Parameters
    ----------
    g, a
        (N, 3) angular rate (rad/s) and specific force (m/s^2) in the sensor's frame.
    o
        (3,) vector from the joint centre to the sensor's origin, sensor frame, m.
    rate
        Sample rate, Hz (``gdot`` is an 8th-order central difference of ``g``,
        :func:`imucal.preprocess.derivative`; no filtering here).

    Returns
    -------
    c : (N, 3) float64
        m/s^2, in the sensor's frame.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, Sec. II-B (eq. 3,
    the definition of Gamma_g).
    """
    return a - gamma_rows(g, derivative(g, rate)) @ np.asarray(o, dtype=float)


def integrate(x: np.ndarray, rate: float) -> np.ndarray:
    """The running integral of samples ``x`` (N,) of a smooth signal, from 0 at the first
    sample: each step by the cubic through the four samples around it,
    ``(13 (x_k + x_k+1) - (x_k-1 + x_k+2)) / 24 / rate``, the two end steps by the
    parabola through the three samples at that end (the trapezoid when there are two).

    The trapezoid throughout shrinks a component of frequency f by ``u cot(u)``, u = pi f
    / rate: 2 % at 1.6 Hz sampled at 20 Hz, enough to leave simulated walks at 20-30 Hz
    with 67-89 % of their flexion samples within 3 sigma (1.5 % compression, 0.45 deg RMS
    at 20 Hz); the cubic step loses 0.1 % there (97-100 % within 3 sigma, 0.09-0.20 deg
    RMS over 10 mountings). At 100 Hz both are within 0.1 % for the motion of a leg;
    impacts put energy near the Nyquist frequency, where the two differ more (the real
    recording's vigorous part: fused angles up to 2.6 deg apart, within its 1-sigma).

    Parameters
    ----------
    x : (N,) samples, N >= 0.
    rate : sample rate, Hz.

    Returns
    -------
    (N,) float64
        The integral, in ``x``'s unit times s (rad from rad/s).

    Raises
    ------
    InputError
        ``x`` is not one-dimensional.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.fusion import integrate
    >>> t = np.arange(201) / 20.0                       # s, 20 Hz
    >>> theta = integrate(2 * np.pi * np.cos(2 * np.pi * t), 20.0)   # rad
    >>> round(float(np.max(np.abs(theta - np.sin(2 * np.pi * t)))), 4)
    0.0002
    """
    x = np.asarray(x, float)
    if x.ndim != 1:
        raise InputError(f"integrate takes one signal (N,), got shape {x.shape}")
    if x.shape[0] == 0:
        return np.zeros(0)
    step = 0.5 * (x[1:] + x[:-1])
    if x.shape[0] >= 3:
        step[0] = (5.0 * x[0] + 8.0 * x[1] - x[2]) / 12.0
        step[-1] = (5.0 * x[-1] + 8.0 * x[-2] - x[-3]) / 12.0
    if x.shape[0] >= 4:
        step[1:-1] = (13.0 * (x[1:-2] + x[2:-1]) - (x[:-3] + x[3:])) / 24.0
    return np.concatenate([[0.0], np.cumsum(step)]) / rate


@dataclass(frozen=True)
class HingeSignals:
    """Per-sample ingredients of the flexion angle of one hinge (all (N,) arrays).

    rate : j2.g2 - j1.g1, rad/s. theta_gyro : its integral from 0, rad.
    theta_acc : the acc angle, rad, wrapped to (-pi, pi]. inplane : the smaller of the two
    in-plane magnitudes of c_i, m/s^2. weight : fusion weight (inplane^2, 0 where unusable).
    across1, across2 : (N, 2) each sensor's rate across the axis in its joint-plane
    coordinates (``g_i . x_i``, ``g_i . y_i``, :func:`plane_basis`), rad/s: turned by the
    fused angle into one frame they give the relative rotation across the axis
    (:func:`across_axis_wobble`), which a rigid hinge with the right axes makes zero.
    """

    rate: np.ndarray
    theta_gyro: np.ndarray
    theta_acc: np.ndarray
    inplane: np.ndarray
    weight: np.ndarray
    across1: np.ndarray
    across2: np.ndarray


def hinge_signals(g1, a1, g2, a2, *, rate: float, j1, j2, o1, o2) -> HingeSignals:
    """The gyro and acc angles of a hinge (module docstring).

    Parameters
    ----------
    g1, a1, g2, a2
        (N, 3) angular rates (rad/s) and specific forces (m/s^2) of the first (thigh)
        and second (shank) sensor, each in its own frame, on one time grid.
    rate
        Sample rate, Hz. Before the acc angle, gyr and acc are low-passed at
        min(:data:`ACC_ANGLE_CUTOFF_HZ`, 0.4 ``rate``) (4th-order zero-phase).
    j1, j2
        The hinge axis in each sensor's frame, pointing the same physical way
        (normalised here).
    o1, o2
        (3,) vectors from the joint centre to each sensor's origin, own frame, m.

    Returns
    -------
    HingeSignals
        (N,) arrays: ``rate`` (j2.g2 - j1.g1, rad/s), ``theta_gyro`` (its running
        integral from 0, :func:`integrate`, rad), ``theta_acc`` (rad, wrapped), ``inplane`` (m/s^2),
        ``weight`` ((m/s^2)^2, 0 below :data:`MIN_INPLANE_ACC`), and (N, 2) ``across1``,
        ``across2`` (rad/s); see :class:`HingeSignals`.

    References
    ----------
    Seel, Raisch, Schauer (2014), "IMU-based joint angle measurement for gait analysis",
    Sensors 14:6891 (the gyroscope angle and the accelerometer angle); Seel, Schauer,
    Raisch (2012), IEEE CCA, eq. 3 (``Gamma_g``).
    """
    j1, j2 = (np.asarray(v, float) / np.linalg.norm(v) for v in (j1, j2))
    w = j2 @ np.asarray(g2, float).T - j1 @ np.asarray(g1, float).T
    theta_g = integrate(w, rate)
    cut = min(ACC_ANGLE_CUTOFF_HZ, 0.4 * rate)
    angles, mags, across = [], [], []
    for g, a, j, o in ((g1, a1, j1, o1), (g2, a2, j2, o2)):
        gf, af = lowpass(np.asarray(g, float), rate, cut, 4), lowpass(np.asarray(a, float),
                                                                       rate, cut, 4)
        c = joint_centre_acc(gf, af, np.asarray(o, float), rate)
        x, y = plane_basis(j)
        cx, cy = c @ x, c @ y
        angles.append(np.arctan2(cy, cx))
        mags.append(np.hypot(cx, cy))
        across.append(np.asarray(g, float) @ np.stack([x, y], axis=1))
    # c2 = Rot(j, phi)^T c1 in aligned plane coordinates: phi = angle(c1) - angle(c2).
    theta_a = np.angle(np.exp(1j * (angles[0] - angles[1])))
    inplane = np.minimum(mags[0], mags[1])
    weight = np.where(inplane >= MIN_INPLANE_ACC, inplane**2, 0.0)
    return HingeSignals(w, theta_g, theta_a, inplane, weight, across[0], across[1])


# ----------------------------------------------------------------------------- fusion


@dataclass(frozen=True)
class Fusion:
    """Result of :func:`fuse` (rad, (N,) arrays): ``theta`` the fused angle, ``offset`` the
    smoothed acc-minus-gyro offset, ``residual`` the acc angle's deviation from ``theta``
    (NaN where unused), ``sigma`` the 1-sigma of ``theta`` (module docstring and
    docs/angles.md), ``disagreement`` the weighted RMS of ``residual`` (rad) and
    ``correlation_samples`` the residual's correlation length used for ``sigma``."""

    theta: np.ndarray
    offset: np.ndarray
    residual: np.ndarray
    sigma: np.ndarray
    disagreement: float
    correlation_samples: float


def _smooth(x: np.ndarray, sigma: float) -> np.ndarray:
    return gaussian_filter1d(x, sigma, mode="constant", cval=0.0, truncate=4.0)


def fuse(sig: HingeSignals, rate: float, smoothing_s: float = SMOOTHING_S) -> Fusion:
    """Gyro angle plus a zero-phase local-linear estimate of the acc-minus-gyro offset.

    Parameters
    ----------
    sig
        The hinge's signals (:func:`hinge_signals`).
    rate
        Sample rate, Hz.
    smoothing_s
        1-sigma half-width of the Gaussian kernel, s (:data:`SMOOTHING_S`; not checked
        here, :func:`check_smoothing`).

    Returns
    -------
    Fusion
        ``theta`` (N,) fused angle, rad (``theta_gyro + offset``, the sign of j2.g2 -
        j1.g1, its zero the acc angle's arbitrary constant); ``offset`` (N,) rad;
        ``residual`` (N,) rad, NaN where the acc angle is unused; ``sigma`` (N,) 1-sigma
        of ``theta``, rad; ``disagreement`` weighted RMS of ``residual``, rad;
        ``correlation_samples`` the residual's correlation length, samples (>= 1).

    Raises
    ------
    NotIdentifiableError
        the joint centre's acceleration never lies in the joint plane: no accelerometer
        angle corrects the gyro drift.

    References
    ----------
    Seel, Raisch, Schauer (2014), "IMU-based joint angle measurement for gait analysis",
    Sensors 14:6891 (fusing the drift-free acc angle with the gyro angle; the paper's
    complementary filter is replaced here by an offline kernel regression).
    """
    n = sig.theta_gyro.shape[0]
    w = sig.weight
    if not np.any(w > 0):
        raise NotIdentifiableError(
            "the joint centre's acceleration never lies in the joint plane (in-plane part "
            f"below {MIN_INPLANE_ACC:g} m/s^2 throughout): no accelerometer angle to correct "
            "the gyro drift")
    s = smoothing_s * rate  # kernel sigma in samples
    raw = np.angle(np.exp(1j * (sig.theta_acc - sig.theta_gyro)))
    # The offset drifts through +-pi with a bias: unwrap a smoothed circular mean, then
    # put every sample within pi of it.
    # Unwrapped over the usable samples only: between them the smoothed mean is noise.
    zc = _smooth(w * np.exp(1j * raw).real, s) + 1j * _smooth(w * np.exp(1j * raw).imag, s)
    use = np.flatnonzero(w > 0)
    coarse = np.interp(np.arange(n), use, np.unwrap(np.angle(zc[use])))
    d = coarse + np.angle(np.exp(1j * (raw - coarse)))
    offset, var_unit, ridge_bias = _local_linear(d, w, s)
    residual = np.where(w > 0, d - offset, np.nan)
    r0 = np.nan_to_num(residual)
    # The local mean square, shrunk towards the recording's where the kernel holds few
    # usable samples (a fit to a handful of samples leaves a residual that is too small).
    mass = _smooth(w, s)
    prior = MIN_KERNEL_SHARE * np.median(mass[w > 0])
    overall = float(np.sum(w * r0**2) / np.sum(w))
    local_ms = (_smooth(w * r0**2, s) + prior * overall) / (mass + prior)
    tau = _correlation_samples(r0, w)
    sigma_offset = np.sqrt(np.maximum(local_ms, 0.0) * var_unit * tau)
    # What the offset cannot correct: the gyro angle's own error within the kernel (soft
    # tissue turning a sensor on its segment, about the axis as across it). Only the turning
    # across the axis is seen: the relative rotation across it, less its slow part (which
    # the fusion would absorb), local RMS per component; as much is assumed about the axis.
    theta = sig.theta_gyro + offset
    sigma_shape = across_axis_wobble(sig.across1, sig.across2, theta, rate, s)
    sigma = np.sqrt(sigma_offset**2 + sigma_shape**2 + ridge_bias**2)
    disagreement = math.sqrt(float(np.sum(w * r0**2) / np.sum(w)))
    return Fusion(theta, offset, residual, sigma, disagreement, tau)


def across_axis_wobble(across1: np.ndarray, across2: np.ndarray, theta: np.ndarray,
                       rate: float, s: float) -> np.ndarray:
    """The 1-sigma, rad, of the gyro angle's error that the fusion cannot correct, per
    sample: soft tissue turning the sensors on their segments (and a joint that is no
    hinge) within the kernel.

    The shank's rate across the axis (``across2``, its joint-plane coordinates) turned by
    the fused angle ``theta`` into the thigh's plane, minus the thigh's (``across1``), is
    the relative rotation rate across the axis: zero for a rigid hinge with the right axes.
    Its running integral (2 components), less its local-linear part (what the fusion would
    absorb, kernel sigma ``s`` samples), gives the local RMS of the turning across the axis
    per component. The turning *about* the axis, which the flexion carries, is not seen by
    any sensor (the acc angle turns with the gyro angle); it is assumed as large as one
    component across (tissue turning in any direction alike).

    Replaces the integral of ``|g1 x j1| - |g2 x j2|`` (a difference of magnitudes: one
    component at most, and changing sign with the rates' direction), which under simulated
    soft tissue (1 deg / 2 mm, 2 deg / 3 mm; 30 s protocol calibration, 60 s gait, clocks
    given in sync, 25 mountings) left 5 and 6 runs with fewer than 95 % of the samples
    within 3 sigma (56 % at worst) and 86-87 % within 2 sigma on average; now 1 and 2 runs
    (78 % at worst: tissue turning mostly about the axis, which nothing sees), 93-94 %
    within 2 sigma, rigid sensors' bands unchanged (docs/angles.md, "Uncertainty band").

    Parameters
    ----------
    across1, across2 : (N, 2) rates across the axis, rad/s (:class:`HingeSignals`).
    theta : (N,) fused angle, rad (the raw one: its zero is the plane bases').
    rate : Hz. s : kernel sigma, samples.

    Returns
    -------
    (N,) float64, rad.
    """
    c, sn = np.cos(theta), np.sin(theta)
    rel = np.stack([c * across2[:, 0] - sn * across2[:, 1] - across1[:, 0],
                    sn * across2[:, 0] + c * across2[:, 1] - across1[:, 1]], axis=1)
    ones = np.ones(theta.shape[0])
    ms = np.zeros(theta.shape[0])
    for k in range(2):  # the two components across the axis (not samples)
        turned = integrate(rel[:, k], rate)
        ms += (turned - _local_linear(turned, ones, s)[0]) ** 2
    return np.sqrt(0.5 * _smooth(ms, s) / _smooth(ones, s))


def _local_linear(d: np.ndarray, w: np.ndarray,
                  s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Local-linear regression of ``d`` with weights ``w * K`` (Gaussian K, sigma ``s``
    samples) at every sample, the sum of squared equivalent weights (the variance of
    the estimate per unit variance of independent samples) and the size of the bias the
    slope's ridge (:data:`RIDGE`) leaves where the kernel is one-sided (the recording's
    ends, a stretch without usable samples): a linear drift of slope b moves the
    estimate by b * ridge * S0 * S1 / det, where S0, S1 are the kernel's weight and its
    first moment about the sample (0 mid-recording). Where the kernel holds less than
    :data:`MIN_KERNEL_SHARE` of its typical usable weight, the estimate is interpolated
    between the neighbouring fits and its variance grows with the squared distance to
    them, in kernel sigmas."""
    n = d.shape[0]
    t = np.arange(n, dtype=float) - n / 2
    k2 = s / math.sqrt(2.0)
    k2_scale = 1.0 / (2.0 * math.sqrt(math.pi) * s)  # sum of K^2 for the normalised K

    def mom(x, sq=False):
        return _smooth(x, k2) * k2_scale if sq else _smooth(x, s)

    wk = [mom(w * t**p) for p in range(3)]
    wd = [mom(w * d * t**p) for p in range(2)]
    s0 = wk[0]
    s1 = wk[1] - t * wk[0]
    s2 = wk[2] - 2 * t * wk[1] + t**2 * wk[0]
    # A small ridge on the slope (as if the usable samples' times spread by RIDGE_S more):
    # where they bunch up on one side of the kernel (a long stretch without usable
    # acceleration) the slope is poorly determined, and extrapolating it would run away.
    s2 = s2 + (RIDGE * s) ** 2 * s0
    b0 = wd[0]
    b1 = wd[1] - t * wd[0]
    det = s0 * s2 - s1**2
    # Only where the kernel holds a fair share of usable weight: an estimate from a few
    # samples at the kernel's far end would extrapolate their slope across the gap.
    typical = np.median(s0[w > 0]) if np.any(w > 0) else 0.0
    ok = (s0 > MIN_KERNEL_SHARE * typical) & (det > 1e-9 * np.maximum(s0 * s2, 1e-300))
    if not ok.any():
        ok = s0 >= s0.max()
    est = np.full(n, np.nan)
    est[ok] = (s2[ok] * b0[ok] - s1[ok] * b1[ok]) / det[ok]
    # the fitted (ridged) slope stands for the drift's: a gyroscope bias of 1.5 deg/s
    # across the axis left the angle 0.5 deg off at the ends of short walks, at a 1-sigma
    # of 0.1 deg (an independent audit)
    bias = np.full(n, np.nan)
    slope = (s0[ok] * b1[ok] - s1[ok] * b0[ok]) / det[ok]
    bias[ok] = np.abs(slope * (RIDGE * s) ** 2 * s0[ok] * s1[ok] / det[ok])
    w2 = w**2
    q = [mom(w2 * t**p, sq=True) for p in range(3)]
    q0 = q[0]
    q1 = q[1] - t * q[0]
    q2 = q[2] - 2 * t * q[1] + t**2 * q[0]
    var = np.full(n, np.nan)
    var[ok] = (s2[ok] ** 2 * q0[ok] - 2 * s2[ok] * s1[ok] * q1[ok] + s1[ok] ** 2 * q2[ok]) / (
        det[ok] ** 2)
    if not ok.all():
        # no usable sample under the kernel: carry the neighbours' estimate over, and let
        # its variance grow with the distance to them (a drift is then extrapolated)
        idx = np.arange(n)
        good = np.flatnonzero(ok)
        est[~ok] = np.interp(idx[~ok], good, est[ok])
        bias[~ok] = np.interp(idx[~ok], good, bias[ok])
        pos = np.clip(np.searchsorted(good, idx[~ok]), 1, good.size - 1)
        gap = np.minimum(np.abs(idx[~ok] - good[pos - 1]), np.abs(good[pos] - idx[~ok]))
        var[~ok] = np.interp(idx[~ok], good, var[ok]) * (1.0 + (gap / s) ** 2)
    return est, var, bias


def _correlation_samples(r: np.ndarray, w: np.ndarray) -> float:
    """Correlation length of the weighted residual, samples (>= 1): twice the sum of its
    autocorrelation up to the first zero crossing, minus one (white noise: 1)."""
    x = np.sqrt(w) * r
    n = x.shape[0]
    if not np.any(x):
        return 1.0
    f = np.fft.rfft(x, 2 * n)
    ac = np.fft.irfft(f * np.conj(f))[:n]
    ac = ac / ac[0]
    neg = np.flatnonzero(ac <= 0)
    stop = int(neg[0]) if neg.size else n
    return max(1.0, 2.0 * float(np.sum(ac[:stop])) - 1.0)
