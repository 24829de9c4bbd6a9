"""How much to trust an estimate: uncertainty, identifiability, verdict (docs/quality.md).

Uncertainty. Near the least-squares solution the cost is quadratic with curvature
J^T J (Gauss-Newton). For independent residuals of equal variance the estimate's
covariance is sigma^2 (J^T J)^-1 (Olsson et al. 2020). Real residuals are neither
independent nor of equal variance: soft tissue wobbles for a tenth of a second and model
errors grow with the motion. So imucal uses the same curvature with a
heteroscedasticity- and autocorrelation-consistent "meat" (Newey and West 1987)::

    cov = (J^T J)^-1  S  (J^T J)^-1,   S = sum over lags l <= L of w_l sum_t u_t u_(t-l)^T

with the per-sample scores u_t = e_t J_t and Bartlett weights w_l = 1 - l / (L + 1). For
white noise this equals sigma^2 (J^T J)^-1 on average; for correlated residuals it grows
as it should.

Verdict. Every result carries one of three verdicts: ``good`` (no warning), ``use with
care`` (warnings, the estimate is still the best the data give) and ``not identifiable``
(the data cannot answer: the command line exits 1 unless ``--force``).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.signal import butter, filtfilt, freqz
from scipy.special import chdtri, fdtri

GOOD = "good"
CAREFUL = "use with care"
NOT_IDENTIFIABLE = "not identifiable"


class Verdict:
    """The verdict of a result with ``warnings`` and ``blocking`` lists (a mixin for the
    estimators' result classes)."""

    warnings: list[str]
    blocking: list[str]

    @property
    def verdict(self) -> str:
        """"good", "use with care" (warnings) or "not identifiable" (``blocking``)."""
        if self.blocking:
            return NOT_IDENTIFIABLE
        return CAREFUL if self.warnings else GOOD

    @property
    def identifiable(self) -> bool:
        """No blocking reason: the verdict is not "not identifiable"."""
        return not self.blocking

    @property
    def confident(self) -> bool:
        """True when no warning of either kind was raised."""
        return not (self.warnings or self.blocking)


def sensitivity_cutoffs(cutoff: float, default: float, top: float,
                        factors: tuple[float, float] = (0.5, 2.0)) -> tuple[float, float]:
    """The two cut-offs of the cut-off sensitivity refits of every estimator.

    Returns
    -------
    down, up : float
        Hz: ``cutoff`` times ``factors`` (down, up), or without a filter (``cutoff`` 0)
        ``default`` and ``default`` times the upper factor; ``up`` never above ``top``.

    Examples
    --------
    >>> from imucal.quality import sensitivity_cutoffs
    >>> sensitivity_cutoffs(6.0, 10.0, 40.0), sensitivity_cutoffs(0.0, 10.0, 15.0)
    ((3.0, 12.0), (10.0, 15.0))
    """
    down, up = factors
    base = cutoff if cutoff else default
    return (down * base, min(up * base, top)) if cutoff else (base, min(up * base, top))


def newey_west_lags(m: int) -> int:
    """Newey-West rule-of-thumb number of lags for ``m`` samples.

    Returns
    -------
    lags : int
        floor(4 (m / 100)^(2/9)), ``m`` taken as at least 1.

    Examples
    --------
    >>> from imucal.quality import newey_west_lags
    >>> newey_west_lags(100), newey_west_lags(1500)
    (4, 7)
    """
    return int(np.floor(4 * (max(m, 1) / 100) ** (2 / 9)))


def robust_covariance(e: np.ndarray, jac: np.ndarray, lags: int | None = None) -> np.ndarray:
    """Heteroscedasticity- and autocorrelation-consistent covariance of a least-squares
    estimate from residuals ``e`` (M,) and Jacobian ``jac`` (M, k) at the solution:
    (J^T J)^-1 S (J^T J)^-1, S with Bartlett weights over ``lags`` lags (None:
    :func:`newey_west_lags`) and the small-sample factor M / (M - k).

    Returns
    -------
    cov : ndarray
        (k, k) float64, in the squared units of the Jacobian's step coordinates (rad^2
        for the axis's tangent steps, m^2 for a joint centre). All infinite where J^T J is
        singular (condition number above 1e14) or ``e`` or ``jac`` is not finite.

    References
    ----------
    Newey, West (1987), "A simple, positive semi-definite, heteroskedasticity and
    autocorrelation consistent covariance matrix", Econometrica 55:703-708 (S);
    Olsson, Kok, Seel, Halvorsen (2020), "Robust plug-and-play joint axis estimation
    using inertial sensors", Sensors 20:3534 (the white-noise form sigma^2 (J^T J)^-1
    this reduces to).
    """
    m, k = jac.shape
    if not (np.isfinite(e).all() and np.isfinite(jac).all()):
        return np.full((k, k), np.inf)
    lags = newey_west_lags(m) if lags is None else int(lags)
    bread = jac.T @ jac
    u = jac * e[:, None]
    meat = u.T @ u
    for lag in range(1, min(lags, m - 1) + 1):
        g = u[lag:].T @ u[:-lag]
        meat += (1 - lag / (lags + 1)) * (g + g.T)
    # Small-sample correction, as in sigma^2 = sum e^2 / (m - k).
    meat *= m / max(m - k, 1)
    try:
        inv = np.linalg.inv(bread)
        if not np.isfinite(inv).all() or np.linalg.cond(bread) > 1e14:
            return np.full((k, k), np.inf)
    except np.linalg.LinAlgError:
        return np.full((k, k), np.inf)
    return inv @ meat @ inv


def singular_values(jac: np.ndarray) -> np.ndarray:
    """Singular values of the Jacobian ``jac`` (M, k) over sqrt(M).

    Returns
    -------
    sv : ndarray
        (min(M, k),) float64, largest first: the RMS sensitivity of the residual to a
        unit step along each principal direction (residual units per step unit). All 0
        when ``jac`` is not finite or the SVD fails.
    """
    m = max(jac.shape[0], 1)
    if not np.isfinite(jac).all():
        return np.zeros(min(jac.shape))
    try:
        return np.linalg.svd(jac, compute_uv=False) / np.sqrt(m)
    except np.linalg.LinAlgError:
        return np.zeros(min(jac.shape))


#: Contiguous time blocks of the delete-one-block jackknife (Kuensch 1989). Ten blocks of
#: a 55 s recording are 5.5 s each: longer than soft-tissue wobble and most of a
#: movement burst, so the blocks are close to independent, which random half-subsets of
#: interleaved samples are not.
JACKKNIFE_BLOCKS = 10


def block_masks(n: int, blocks: int = JACKKNIFE_BLOCKS) -> np.ndarray:
    """Sample weights of the delete-one-block jackknife over ``n`` time-ordered samples.

    Returns
    -------
    masks : ndarray
        (K, n) float64 of 0 and 1, K = max(2, min(``blocks``, n // 2)): row k leaves out
        the k-th of K contiguous, (nearly) equally long runs of samples.

    References
    ----------
    Kuensch (1989), "The jackknife and the bootstrap for general stationary
    observations", Annals of Statistics 17:1217-1241 (delete-one-block jackknife).

    Examples
    --------
    >>> from imucal.quality import block_masks
    >>> block_masks(6, blocks=3)
    array([[0., 0., 1., 1., 1., 1.],
           [1., 1., 0., 0., 1., 1.],
           [1., 1., 1., 1., 0., 0.]])
    """
    k = max(2, min(blocks, n // 2))
    which = np.minimum((np.arange(n) * k) // max(n, 1), k - 1)
    return (which[None, :] != np.arange(k)[:, None]).astype(np.float64)


def jackknife_sigma(deviation: np.ndarray) -> float:
    """1-sigma from the delete-one-block estimates' distances ``deviation`` (K,) to the
    estimate (deg, mm or s: the answer has the same unit).

    Distances to the full estimate rather than to the estimates' mean: slightly larger,
    never smaller.

    Returns
    -------
    sigma : float
        sqrt((K - 1) / K * sum d^2); infinite for K < 2 or a non-finite distance (a
        refit that failed).

    References
    ----------
    Kuensch (1989), "The jackknife and the bootstrap for general stationary
    observations", Annals of Statistics 17:1217-1241 (delete-one-block jackknife).

    Examples
    --------
    >>> from imucal.quality import jackknife_sigma
    >>> round(jackknife_sigma([0.3, -0.4, 0.0, 0.0]), 3)
    0.433
    """
    deviation = np.asarray(deviation, dtype=np.float64)
    k = deviation.size
    if k < 2 or not np.isfinite(deviation).all():
        return float("inf")
    return float(np.sqrt((k - 1) / k * np.sum(deviation**2)))


#: The model term's band, Hz: what soft tissue and a knee that is no perfect hinge leave
#: in eq. (1)'s residual follows the motion (strides, swings), below a few Hz; on
#: imucal's simulator with soft tissue the residual below 8 Hz tracked the axis error
#: more closely (relative to the excitation, see the estimators) than below 3 or 5 Hz.
SMOOTH_BAND_HZ = 8.0
#: The band never reaches above this fraction of the samples' own Nyquist frequency
#: (low rates, or a coarse subsampling step): the rest estimates the white noise.
SMOOTH_BAND_FRACTION = 0.5
#: Where even the quietest octave above the band is denser than the band itself by more
#: than white noise would be with this probability (the two densities' ratio is about
#: F-distributed, with twice their numbers of frequency bins as degrees of freedom), the
#: spectrum never falls to a white floor (soft tissue at 40 Hz: ringing and its aliases
#: fill every octave up to Nyquist) and nothing is taken off. White noise alone gives
#: ratios of 0.79-1.13 on 1200-3000 samples (simulated, 40 and 100 Hz; the bound there is
#: 1.33-1.57) and up to 1.4 on 500 (bound 1.49-1.68); soft tissue at 40 Hz up to 5.9.
FLOOR_FALSE_RATE = 1e-3
#: An octave's density is measured over windows this long, s, as the median of their mean
#: powers (scaled by a chi-square median to a mean): white noise fills every window alike,
#: soft tissue's ringing after each heel strike only some. At 40 Hz that ringing aliases
#: into every octave up to Nyquist, and the mean made the floor as dense as the band:
#: the model term read 0 under soft tissue, axes `good` at up to 16 sigma (an honesty
#: audit: 63 usable 40 Hz fits, 43 beyond 3 sigma, 35 `good`).
FLOOR_WINDOW_S = 0.25


def smooth_residual_rms(e: np.ndarray, rate: float) -> float:
    """RMS of the part of the residuals ``e`` (M,), samples ``rate`` Hz apart, that is not
    white noise: the part below ``SMOOTH_BAND_HZ`` less the white noise's share there.

    The residual is low-passed (Butterworth order 2, zero phase); the quietest octave
    above the band (band to 2 x band, 2 x to 4 x, ..., the last up to Nyquist), where a
    smooth model error hardly reaches, measures the white noise's density, and its share
    of the low band is taken off. Not simply the whole rest of the band: soft
    tissue rings at tens of Hz after each heel strike, far above the noise (simulated
    gait, 2 deg / 3 mm: 20 times the noise's density at 30-45 Hz). Before,
    ``var(e) - mean(diff(e)^2) / 2`` (a lag-1 autocovariance) stood for the smooth part:
    that ringing made it negative, so the stronger the soft tissue the smaller the term
    (simulated protocol, 2 deg / 3 mm: 0, with the axis 5.6 deg off at 11 sigma and
    "good"). At low rates no octave may be quiet (``FLOOR_FALSE_RATE``): at 40 Hz the
    ringing's aliases made the term 0 again, "good" at up to 16 sigma; an octave's
    density is therefore the median over short windows (:func:`_floor_power`), which the
    ringing's bursts after each heel strike leave at the noise.

    Returns
    -------
    smooth : float
        RMS of the smooth part, in the unit of ``e`` (rad/s for eq. (1)'s residual);
        0.0 for fewer than 20 samples, a non-finite residual, or where the white noise's
        share is at least the low band's power.
    """
    e = np.asarray(e, dtype=np.float64)
    nyquist = rate / 2
    band = min(SMOOTH_BAND_HZ, SMOOTH_BAND_FRACTION * nyquist)
    if e.size < 20 or not np.isfinite(e).all() or band <= 0:
        return 0.0
    low, gain = _zero_phase_lowpass(e, band / nyquist)
    # the white floor: the quietest octave above the band (model errors only add power)
    noise, below, under, edge, narrowest = np.inf, low, gain, band, nyquist
    while edge < 0.9 * nyquist:  # the last octave ends at Nyquist: the residual itself
        top = 2 * edge if 2 * edge < 0.9 * nyquist else nyquist
        above, over = (_zero_phase_lowpass(e, top / nyquist) if top < nyquist
                       else (e, np.ones_like(gain)))
        noise = min(noise, _floor_power(above - below, rate, top - edge)
                    / np.mean((over - under) ** 2))
        narrowest = min(narrowest, top - edge)
        below, under, edge = above, over, top
    bins = e.size / rate  # frequency bins per Hz
    bound = fdtri(2 * bins * narrowest, 2 * bins * band, 1 - FLOOR_FALSE_RATE)
    if noise > bound * np.mean(low * low) / np.mean(gain * gain):
        noise = 0.0  # no floor to measure: the model error reaches Nyquist
    smooth = np.mean(low * low) - noise * np.mean(gain * gain)
    return float(np.sqrt(max(smooth, 0.0)))


def _floor_power(part: np.ndarray, rate: float, width: float) -> float:
    """Mean power of ``part`` (one octave of a residual, samples ``rate`` Hz apart,
    ``width`` Hz wide) where it is stationary: the median of its power over
    ``FLOOR_WINDOW_S`` windows, over the median of a chi-square with the windows' 2 x
    width x length degrees of freedom (its mean: white noise reads the same either way).
    Fewer than 8 windows: the plain mean."""
    n = max(4, int(round(FLOOR_WINDOW_S * rate)))
    power = part * part
    if power.size < 8 * n:
        return float(np.mean(power))
    windows = power[: power.size // n * n].reshape(-1, n).mean(axis=1)
    dof = max(1.0, 2.0 * width * n / rate)
    return float(np.median(windows) / (chdtri(dof, 0.5) / dof))  # (the median's point)


def _zero_phase_lowpass(e: np.ndarray, fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """``e`` low-passed (Butterworth order 2, forward and backward) at ``fraction`` of the
    Nyquist frequency, and the filter's power gain on 1024 frequencies up to Nyquist."""
    b, a, gain = _lowpass_design(fraction)
    return filtfilt(b, a, e), gain


@functools.lru_cache(maxsize=64)
def _lowpass_design(fraction: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coefficients and power gain of :func:`_zero_phase_lowpass`'s filter: designing it
    costs more than filtering 1500 samples (0.4 against 0.17 ms), and one rate needs the
    same few every time."""
    b, a = butter(2, fraction)
    gain = np.abs(freqz(b, a, worN=1024)[1]) ** 2
    for shared in (b, a, gain):  # cached: every caller sees these very arrays
        shared.flags.writeable = False
    return b, a, gain


def total_sigma(curvature: float, blocks: float, cutoff_shift: float,
                model: float = 0.0) -> float:
    """The reported 1-sigma: the larger of the curvature's and the time blocks' (both
    measure the same sampling error; the blocks also see correlated and non-stationary
    errors the curvature misses), with the cut-off refits' largest shift added in
    quadrature: a reasonable processing choice (half or twice the cut-off) moves the
    answer by that much, so the data do not pin it down more closely. With half the
    shift, the two halves of the shared real recording's hip disagreed by 4.8 combined
    sigma; with all of it, every split of the real recording agrees within 3. ``model``
    is a bias bound from systematic residuals (see the estimators), added in quadrature:
    neither the curvature nor time blocks see an error that every block shares.

    Returns
    -------
    sigma : float
        sqrt(max(curvature, blocks)^2 + cutoff_shift^2 + model^2), in the inputs' unit
        (deg for an axis, mm for a joint centre).

    Examples
    --------
    >>> from imucal.quality import total_sigma
    >>> round(total_sigma(0.3, 0.4, 1.2), 3)  # deg: max(0.3, 0.4) and 1.2 in quadrature
    1.265
    """
    sampling = max(curvature, blocks)
    return float(np.sqrt(sampling**2 + cutoff_shift**2 + model**2))


#: How :func:`uncertainty_warning`'s warning begins.
UNCERTAIN_PREFIX = "the estimate is uncertain"
#: How the refusal of a recording without motion begins
#: (:func:`imucal.preprocess.stillness_warning`).
STILL_REASON = "the sensors barely rotate"


def is_still(blocking: list[str]) -> bool:
    """Whether an estimate's first blocking reason is a recording without motion.

    Returns
    -------
    bool
        ``blocking[0]`` begins with :data:`STILL_REASON` (a prefix such as "axis: " of a
        calibration's joint allowed).
    """
    if not blocking:
        return False
    first = blocking[0]
    return first.startswith(STILL_REASON) or first.partition(": ")[2].startswith(STILL_REASON)


def uncertainty_warning(total: dict, components: dict, unit: str) -> str:
    """The warning for a large reported 1-sigma, naming the component that dominates it.

    ``total`` is {name: 1-sigma} (the results' ``uncertainty_deg`` / ``uncertainty_mm``),
    ``components`` {kind: {name: value}} as in the results' ``uncertainty_components``,
    ``unit`` "deg" (axis) or "mm" (joint centre).

    Returns
    -------
    warning : str
        Begins with ``UNCERTAIN_PREFIX``; gives the largest 1-sigma and its vector, the
        dominating component's cause and every component's value in ``unit``.
    """
    name = max(total, key=total.get)
    parts = {kind: values[name] for kind, values in components.items()}
    main = max(parts, key=parts.get)
    why = {
        "curvature": "the data barely constrain it",
        "time_blocks": "fits on different stretches of the recording disagree",
        "cutoff_shift": "it moves with the low-pass cut-off of the refits",
        # the two estimators' model terms see a model error differently (unit: deg for
        # the axis, mm for a joint centre)
        "model": ("the residuals are systematic (soft tissue, a joint that is no hinge)"
                  if unit == "deg" else "a different weighting of the samples moves it "
                  "(soft tissue, a joint that is not the modelled one)"),
        "gyr_bias": ("it moves with the gyroscope biases the residual asks for (removed, "
                     "or too large to be a gyroscope's)" if unit == "deg" else
                     "it moves when gyroscope biases are fitted with it (an uncalibrated "
                     "gyroscope)"),
        "acc_error": "the motion cannot tell it from an accelerometer offset or scale "
                     "error (steady rotation: calibrate the accelerometers, or move more "
                     "variedly)",
        "time_offset": "it moves with the clock offset between the sensors (uncertain, "
                       "or mimicked by soft tissue)",
    }[main]
    extra = {"model": "model", "gyr_bias": "gyroscope bias", "acc_error": "accelerometer",
             "time_offset": "clock offset"}
    return (f"{UNCERTAIN_PREFIX}: 1-sigma {total[name]:.1f} {unit} for {name}, mostly "
            f"because {why} (curvature {parts['curvature']:.1f}, time blocks "
            f"{parts['time_blocks']:.1f}, cut-off shift {parts['cutoff_shift']:.1f}"
            + "".join(f", {label} {parts[kind]:.1f}" for kind, label in extra.items()
                      if kind in parts and (kind == "model" or parts[kind] > 0))
            + f" {unit})")


def cutoff_shifts(sensitivity: dict, names: tuple[str, str], unit: str) -> dict:
    """The larger of the two cut-off refits' shifts of each vector in ``names``.

    Returns
    -------
    shifts : dict
        {name: float}: the larger of ``sensitivity["<name>_shift_<unit>"]`` (``unit``
        "deg" or "mm").
    """
    return {k: max(sensitivity[f"{k}_shift_{unit}"]) for k in names}


def refresh_uncertainty(result, unit: str, limit: float) -> None:
    """``result``'s reported 1-sigma (``uncertainty_<unit>``) from its components after
    a part was added, and its "uncertain" warning to match: the fit's own warning gave
    the total without that part, and its numbers and main cause would contradict the
    reported 1-sigma. A warning is added where the new total first exceeds ``limit``."""
    components = result.uncertainty_components
    total = uncertainty_totals(components)
    setattr(result, f"uncertainty_{unit}", total)
    if max(total.values()) <= limit:
        return
    fresh = uncertainty_warning(total, components, unit)
    stale = [i for i, w in enumerate(result.warnings) if w.startswith(UNCERTAIN_PREFIX)]
    if stale:
        result.warnings[stale[0]] = fresh
    else:
        result.warnings.append(fresh)


def uncertainty_totals(components: dict) -> dict:
    """The reported 1-sigma of each vector from its uncertainty ``components``.

    :func:`total_sigma` of "curvature", "time_blocks", "cutoff_shift" and, where there is
    one, "model", with "gyr_bias" (the axis's widening by a removed gyroscope bias; a
    joint centre's move when gyroscope biases are fitted with it), "acc_error" (a joint
    centre's response to accelerometer offset and scale errors) and "time_offset" (the
    part due to the automatic clock offset's uncertainty,
    :func:`imucal.time_offset.fit_with_offset`) added in quadrature where present.

    Returns
    -------
    totals : dict
        {name: float} for every name of ``components["curvature"]`` (deg for j1, j2; mm
        for o1, o2).
    """
    model = components.get("model", {})
    extra = [components.get(kind, {}) for kind in ("gyr_bias", "acc_error", "time_offset")]
    return {k: float(np.linalg.norm([total_sigma(components["curvature"][k],
                                                 components["time_blocks"][k],
                                                 components["cutoff_shift"][k],
                                                 model.get(k, 0.0)),
                                     *(part.get(k, 0.0) for part in extra)]))
            for k in components["curvature"]}


def rms(values: np.ndarray) -> float:
    """RMS of ``values`` (ndarray).

    Returns
    -------
    rms : float
        sqrt(mean(values^2)) in the unit of ``values``; NaN when there are none (e.g. no
        restart settled).
    """
    return float(np.sqrt(np.mean(values**2))) if values.size else float("nan")
