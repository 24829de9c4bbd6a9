"""Hinge joint axis from two gyroscopes (Seel, Schauer, Raisch 2012, Sec. II-A, III-B/C).

For two segments joined by a hinge, the angular rates' projections into the joint plane
have the same length at every instant (eq. 1)::

    e(t) = |g1(t) x j1| - |g2(t) x j2| = 0

``j1`` is the unit axis in the first sensor's frame, ``j2`` the same physical axis in the
second sensor's frame. imucal minimises sum e^2 by Gauss-Newton with the gradient of
eq. (2), projected onto the tangent plane of each unit vector (no spherical-coordinate
poles), from many random starts on random data subsets at once.

Eq. (1) cannot see the signs of j1 and j2. Which of the pairs (j1, j2), (j1, -j2) points
the same physical way is decided from the data by three combined tests (joint-plane
angles, the integrated flexion's span, the joint centre's acceleration along the axis):
see :mod:`imucal.sign`; ``j2_sign`` pins it instead.

Assumptions: the joint is a hinge, the sensors sit rigidly on their segments, and the
joint angle changes during the recording (with a rigid joint every pair j1 = R j2 fits).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .errors import InputError, signed_ms
from .gauss_newton import every_row
from .gyr_bias import MAX_PLAUSIBLE_RAD_S as MAX_PLAUSIBLE_BIAS_RAD_S
from .gyr_bias import PRIOR_RAD_S, GyrBias, estimate_gyr_bias
from .multistart import (
    SENSITIVITY_ITERATIONS,
    SYMMETRIC,
    BatchedProblem,
    Multistart,
    Stages,
    multistart,
    one_blas_thread,
    safe_newton,
)
from .preprocess import (
    FILTER_ORDER,
    MAX_CUTOFF_FRACTION,
    Prepared,
    check_pair,
    default_cutoff,
    lowpass,
    only_the_stillness,
    prepare,
    stillness_warning,
    unit_doubts,
)
from .quality import (
    block_masks,
    cutoff_shifts,
    jackknife_sigma,
    refresh_uncertainty,
    rms,
    robust_covariance,
    sensitivity_cutoffs,
    singular_values,
    uncertainty_totals,
    uncertainty_warning,
)
from .rest import MAX_MISMATCH_DEG, gravity_check_near, gravity_warning
from .restarts import (
    MIN_AGREEING_FRACTION,
    competing_agreement,
    disagreement_warning,
    equal_minima,
    equal_minima_blocking,
    resolve_seed,
    settled,
    subset_mask,
)
from .result import EstimateResult, shared_fields
from .selection import MAX_SAMPLES
from .settings import MAX_ITERATIONS, OFFSET_SEARCH_S, SUBSET_FRACTION, AxisSettings
from .settings import resolve as resolve_settings
from .sign import (
    MAX_KNEE_SPAN_DEG,
    RANGE_BLOCK_S,
    decide_relative_sign,
    perpendicular,
)
from .time_offset import (
    DOUBT_WARNING,
    OFFSET_STEPS,
    adopt,
    check_given,
    delayed,
    fit_with_offset,
    given_search,
    profile_samples,
)
from .timing import check_rate
from .vectors import joint_plane_rate, tangent_basis, unit

#: Two axis estimates agree when both j1 and j2 are within this angle (sign-free), deg.
AGREEMENT_DEG = 2.0
#: The estimate is polished until its estimated distance to the minimum (tangent-plane
#: step x rho / (1 - rho), see :func:`imucal.gauss_newton.gauss_newton`) is below this,
#: rad (about 6e-4 deg).
STEP_TOLERANCE = 1e-5
#: The restarts (on their subsets and refined) stop at this estimated distance, rad
#: (about 0.06 deg).
RESTART_STEP_TOLERANCE = 1e-3
#: The coarse stage only has to find each restart's basin, rad (about 0.6 deg).
COARSE_STEP_TOLERANCE = 1e-2
#: Samples shared by all restarts in the coarse stage (each sees its subset of them).
COARSE_SAMPLES = 600
#: The coarse stage stops after this many steps; restarts still moving go on on their
#: subsets (a few restarts in flat valleys would otherwise run long on little data).
COARSE_ITERATIONS = 6
#: Stop when a step lowers the mean squared residual by less than this fraction.
COST_TOLERANCE = 1e-12
#: Largest tangent step per iteration, rad (norm over both axes).
MAX_STEP = 1.0
#: Below this many samples (after subsampling) the 4-parameter fit is meaningless.
MIN_SAMPLES = 20
#: Relative residual (against the angular-rate magnitude) above which restarts that
#: disagree mean "not a hinge": simulated hinges at SNR 30-300 stay below 0.03, simulated
#: spheroidal ankles fitted as a hinge lie above 0.15.
POOR_FIT_RESIDUAL = 0.1
#: Relative residual that alone earns a warning: real knees leave 0.35-0.45 (soft tissue,
#: a knee that is not a perfect hinge), so a lower threshold would flag every real knee
#: and separate nothing; what real data leave uncertain shows in the uncertainty.
MAX_RELATIVE_RESIDUAL = 0.5
#: Model-error bound per unit of (smooth residual / smallest singular value), as a
#: fraction of that turn (:func:`_model_term`): on imucal's simulator with soft tissue
#: (0.5 deg / 1 mm to 2 deg / 3 mm; protocol, gait, circling; 50-200 Hz; 240 fits, clocks
#: in sync) the axis error needed 0.07-0.20 (median) and 0.33 (95th percentile) of it to
#: lie within 3 sigma; 0.5 puts 98 % there (the rest are gait at 2 deg / 3 mm, whose
#: sigma of 2-6 deg already makes them "use with care"), and clean simulated knees get
#: 0.05-0.08 deg.
MODEL_FACTOR = 0.5
#: A fit whose bias fit gained at least this (:mod:`imucal.gyr_bias`) gets a second clock-
#: offset search with the biases refitted at every candidate (:func:`_with_auto_offset`):
#: the shared real recording's knees gain 1.00-1.04, simulated biases of 0.02 rad/s
#: 1.27-3.3 at the wrong offset (gait, shank 20-45 ms late).
BIAS_SEARCH_RATIO = 1.1
#: How the warning on a pinned relative sign the data contradict begins (imucal.angles
#: names it first when a calibration with it does not fit a recording).
PINNED_SIGN_WARNING = "the pinned j2 sign contradicts"
#: A 1-sigma axis uncertainty above this is not good enough for joint angles, deg: the
#: verdict is at best "use with care". With 5 deg, simulated soft tissue (2 deg / 3 mm,
#: 1-sigma 2.7-4.8 deg) was called "good" with errors up to 3.6 sigma; clean simulated
#: knees stay below 0.2 deg, so 2 deg separates them.
MAX_UNCERTAINTY_DEG = 2.0
#: A sign-free axis is never more than 90 deg from another: a 1-sigma this large says
#: nothing about where the axis is (a hip fitted as a hinge on the real recording: 217 deg,
#: "use with care" before).
MAX_INFORMATIVE_SIGMA_DEG = 90.0
#: Below this RMS flexion rate (j2.g2 - j1.g1 at the estimate) the joint did not bend,
#: deg/s: a rigid joint fits every pair j1 = R j2. Voluntary knee motion is 50-400 deg/s.
MIN_FLEXION_RATE_DEG_S = 5.0
#: A joint that bent at less than this RMS rate, deg/s, and at less than
#: ``MIN_FLEXION_SHARE`` of the rate its segments turned across the axis, did not bend
#: clearly more than the sensors wobble on the skin: a rigid knee swung with soft tissue
#: of 2-5 deg / 3-8 mm (simulated, seeds 1-8) bent at 9-48 deg/s about axes 40-87 deg
#: from the truth, and was "use with care" at a 1-sigma of 11-20 deg (3-5 sigma off).
#: Knee motion bends at 57-267 deg/s, 0.67-10 times its segments' rate across the axis
#: (circling lowest; 780 simulated runs at 40-100 Hz, 10-30 s, SNR 30, soft tissue up to
#: 5 deg / 8 mm: none refused).
MIN_BENT_FLEXION_RATE_DEG_S = 30.0
MIN_FLEXION_SHARE = 0.5
#: Below this smallest/largest singular value of the Jacobian one direction of (j1, j2)
#: is not determined (a rigid knee gives about 0.02, knee motion 0.1-0.9).
MIN_SINGULAR_RATIO = 0.04
#: The sign tests together must favour one hypothesis by at least this ratio of errors
#: for a pinned sign against them to get a warning.
MIN_SIGN_EVIDENCE = 1.5
#: Below this combined evidence the relative sign gets a warning that the data barely
#: decide it. Set on simulated knees (300 random gait, walking, protocol and circling
#: recordings, soft tissue up to 3 deg / 5 mm, clocks up to 50 ms apart): the 9 wrong
#: relative signs had 1.04-2.12, and an independent audit's two more 1.57 and 2.03 (axes
#: 164-166 deg off "use with care", no word of the sign, at 1.5); 58 of the 291 right ones
#: lay below 2.5, all under soft tissue; rigid sensors gave 55 and more.
SIGN_DECIDED_EVIDENCE = 2.5


@dataclass(kw_only=True, eq=False)
class AxisResult(EstimateResult):
    """Result of :func:`estimate_axis`: the fields of
    :class:`imucal.result.EstimateResult` and the axis' own.

    Attributes
    ----------
    j1, j2 : (3,) unit hinge axis in the first / second sensor's frame, pointing the same
        physical way (see ``sign_evidence``); overall sign: j1's largest component > 0,
        or as ``settings["sign_convention"]`` pins it.
    rms_residual : RMS of e(t) of eq. (1) over all used samples at the estimate, rad/s.
    relative_residual : ``rms_residual`` over the RMS angular-rate magnitude of both
        sensors, dimensionless (0 = perfect hinge).
    sign_evidence : how much better the data's relative sign explains the data than the
        opposite one: the product of the sign tests' evidence ratios for it over those
        against it (>= 1; below 2.5 the data barely decide; :mod:`imucal.sign`).
    sign_tests : each test's evidence, whether it favours the reported j2, and the
        numbers behind it for the reported and the flipped j2 (:mod:`imucal.sign`).
    singular_values : singular values of the Jacobian of eq. (1) over sqrt(samples),
        rad/s per rad (a joint that did not move leaves one near 0).
    uncertainty_deg : {"j1", "j2"} 1-sigma angle uncertainty, deg: the larger of the
        curvature's and the time blocks' with the cut-off shift, the model bound and
        (where present) the gyroscope bias's and the clock offset's parts added in
        quadrature (:func:`imucal.quality.uncertainty_totals`); its parts, in deg, are
        ``uncertainty_components``.
    excitation : RMS flexion rate j2.g2 - j1.g1 and RMS joint-plane rate |g_i x j_i| of
        each segment over the samples used, deg/s.
    sensitivity : cut-offs of two refits (halved and doubled; without a filter: 1 and 2
        times the default) and the angles the axes moved, deg.
    spread_deg : RMS angle between the agreeing restarts' subset results and the
        estimate, per axis, deg: how much the answer depends on the data (subset fits
        stuck in a local minimum left out, :func:`imucal.restarts.settled`).
    gyr1, gyr2 : the filtered, windowed, subsampled rates used (M, 3), rad/s (with a
        removed gyroscope bias, corrected).
    gyr_bias : the constant gyroscope biases fitted with eq. (1)
        (:class:`imucal.gyr_bias.GyrBias`): "applied", "b1_rad_s", "b2_rad_s" (across
        each axis, sensor frames), "cost_ratio", the prior and thresholds. When applied,
        the rates were corrected by them before the estimate reported here.
    gravity : the gravity check of the axes at rest (:func:`imucal.rest.gravity_check`):
        "periods" (each still period's angles of the axis to the vertical in both
        sensors, deg), "max_mismatch_deg", "consistent" (None without accelerometers or
        still periods), "max_allowed_deg".
    """

    j1: np.ndarray
    j2: np.ndarray
    sign_evidence: float
    sign_tests: dict
    uncertainty_deg: dict
    spread_deg: dict
    gyr1: np.ndarray
    gyr2: np.ndarray
    gyr_bias: dict = field(default_factory=dict)
    gravity: dict = field(default_factory=dict)


@one_blas_thread
def estimate_axis(
    gyr1: np.ndarray,
    gyr2: np.ndarray,
    *,
    rate: float,
    restarts: int = 100,
    seed: int | None = None,
    cutoff: float | None = None,
    subsample: int | None = None,
    subset: float = SUBSET_FRACTION,
    start: float | None = None,
    end: float | None = None,
    max_iterations: int = MAX_ITERATIONS,
    sign: str = "auto",
    j2_sign: str = "auto",
    acc1: np.ndarray | None = None,
    acc2: np.ndarray | None = None,
    select: bool = True,
    max_samples: int | None = MAX_SAMPLES,
    time_offset: float | str = "auto",
    offset_search: float = OFFSET_SEARCH_S,
    time_origin: float = 0.0,
    settings: AxisSettings | None = None,
) -> AxisResult:
    """Estimate the hinge axis seen by two gyroscopes.

    Parameters
    ----------
    gyr1, gyr2
        (N, 3) angular rates of the first (proximal) and second sensor, rad/s, each in
        its own frame, sampled together.
    rate
        Sample rate, Hz.
    restarts
        Number of random starts (axes uniform on the sphere), each on its own random
        ``subset`` of the samples.
    seed
        Seed of the random starts and subsets; None draws one (``settings["seed"]``).
    cutoff
        Zero-phase low-pass cut-off applied before the fit, Hz; None or 0: no filter.
        Eq. (1) holds sample by sample for raw rates, while a linear filter does not
        commute with the norms in it: on real recordings with impacts a low-pass moves
        the estimate by many degrees, so the default fits the raw rates. (The sign test
        always uses a low-passed copy, see :func:`imucal.sign.plane_test`.)
    subsample
        Use every k-th sample after filtering; None: all samples without a filter, else
        about 2.5 samples per cut-off period.
    subset
        Fraction of the samples each restart sees, in (0, 1]. The reported estimate is
        refined on all samples.
    start, end
        Window in seconds from the first sample; the filter runs on the whole signal
        first so the window edges have no filter transients.
    max_iterations
        Iteration limit per restart and stage (subset fit, refinement, polish).
    sign
        Overall sign convention: "auto" (j1's largest component positive) or "+x", "-x",
        "+y", "-y", "+z", "-z" (that component of j1 positive). j2 follows j1.
    j2_sign
        Relative sign: "auto" decides from the data which way j2 points relative to j1
        (:func:`imucal.sign.decide_relative_sign`); "+x" ... "-z" pins that component of
        j2 positive / negative instead (when you know how both sensors sit, e.g. both x
        axes lateral). The data's tests are reported either way, and a pin they clearly
        contradict gets a warning.
    acc1, acc2
        Optional (N, 3) specific force of the two sensors, m/s^2: adds the
        accelerometer test of the relative sign (the fit itself uses only the rates).
    time_offset
        The second sensor's clock lateness, s: "auto" estimates it from eq. (1) itself
        (:mod:`imucal.time_offset`) after a first fit and, where it is significant, fits
        again with the second sensor's signals read at t + offset; a number applies that
        offset; 0 assumes synchronised clocks.
    offset_search
        Search range of the automatic offset, +- s; at least one sample (else InputError).
    select, max_samples
        Informative-sample selection (:mod:`imucal.selection`): drop still stretches and
        thin to at most ``max_samples`` (None: no cap). ``select=False`` fits every sample.
    time_origin
        Time of the first sample given, s on the recording's clock: the gravity check's
        still periods (``gravity``, and its warning) are reported on that clock.
    settings
        All of the above (``restarts`` to ``time_origin``) as one
        :class:`imucal.settings.AxisSettings`, instead of keyword arguments (giving both,
        with keyword values other than the defaults, is an InputError).

    Returns
    -------
    AxisResult
        j1, j2 (unit, each in its sensor's frame), the quality report (uncertainty,
        identifiability, ``verdict``, ``warnings``) and every restart. An axis the data
        cannot identify is still returned, with ``blocking`` reasons.

    Raises
    ------
    InputError
        Invalid settings (before any data are used), arrays not (N, 3) of finite numbers
        or of different lengths, a sample rate outside 1-10000 Hz, a window outside the
        recording, or fewer than ``MIN_SAMPLES`` samples left to fit.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, Sec. II-A, III-B/C
    and IV (eq. 1 and 2, the restarts on data subsets).

    Examples
    --------
    >>> import imucal
    >>> rec = imucal.load_recording("sample_data/circling.h5")
    >>> r = imucal.estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr,
    ...                          rate=rec.rate, seed=1)
    >>> r.verdict, r.j1.round(2)
    ('good', array([-0.42, -0.35,  0.84]))
    """
    s = resolve_settings(
        AxisSettings, settings, restarts=restarts, seed=seed, cutoff=cutoff,
        subsample=subsample, subset=subset, start=start, end=end,
        max_iterations=max_iterations, sign=sign, j2_sign=j2_sign, select=select,
        max_samples=max_samples, time_offset=time_offset, offset_search=offset_search,
        time_origin=time_origin)
    g1, g2 = check_pair(gyr1, gyr2)
    rate = check_rate(rate)
    acc1, acc2 = _check_acc(g1, acc1, acc2)
    if s.time_offset == "auto":
        result = _with_auto_offset(g1, g2, acc1, acc2, rate, s)
        return only_the_stillness(refuse_doubted_sign(result))
    result = _estimate(g1, g2, acc1, acc2, rate, replace(s, seed=resolve_seed(s.seed)))
    search = given_search(s.offset_search, s.time_offset, rate)
    check_given(result, offset_profile(g1, g2, rate, search), rate, search, s.time_offset)
    return only_the_stillness(result)


def _estimate(g1, g2, acc1, acc2, rate, s: AxisSettings, bias_removed: bool = False
              ) -> AxisResult:
    """:func:`estimate_axis` with checked inputs, a given time offset and seed; once a
    gyroscope bias was removed (``bias_removed``), none is looked for again: rates that
    never change (a dead sensor, [0, 0, 2] rad/s throughout) kept finding a "bias" in
    what was left, recursing until Python gave up (exit 3)."""
    prepared = prepare((g1, acc1), (g2, acc2), rate, s, cutoff=s.cutoff or 0.0,
                       fit_signals=lambda sensors, c: _lowpassed_rates(sensors, rate, c),
                       min_samples=MIN_SAMPLES, what="axis")
    fit = _fit(prepared, s)
    bias = _gyr_bias(prepared, fit) if not bias_removed else None
    if bias is not None and bias.significant:
        return _with_gyr_bias(g1, g2, acc1, acc2, rate, s, bias)
    j1, j2, decision, applied = _signs(prepared, fit, s)
    quality = _quality(prepared, fit, np.concatenate([j1, j2]))
    gravity = _gravity(prepared, j1, j2, s.time_origin)
    warnings, blocking = _diagnose(prepared, quality, decision, gravity)
    warnings += _sign_warnings(decision, applied, s.j2_sign != "auto")
    result = _result(prepared, s, fit, j1, j2, decision, applied, quality, warnings, blocking)
    result.gravity = gravity
    if bias is not None:  # with a removed bias, _with_gyr_bias reports it
        result.gyr_bias = bias.report()
        if bias.implausible:
            _with_implausible_bias_move(result, g1, g2, acc1, acc2, rate, s, bias)
    return result


def _with_implausible_bias_move(result: AxisResult, g1, g2, acc1, acc2, rate,
                                s: AxisSettings, bias: GyrBias) -> None:
    """``result`` with the move to the axis fitted from rates without ``bias`` as its
    ``gyr_bias`` 1-sigma part, and a warning: the residual asks for biases larger than a
    warmed-up gyroscope's. Such a fit absorbs a smooth model error (soft tissue) as often
    as a gyroscope far from calibrated, so neither axis is taken for the other; the
    1-sigma spans both. Left out, a gait knee with 0.1 rad/s biases (cost ratio 1.86,
    fitted 0.07 rad/s) read 8.5 deg off at a 1-sigma of 1.15 deg (an independent audit)."""
    other = _estimate(g1 - bias.b1, g2 - bias.b2, acc1, acc2, rate, s, bias_removed=True)
    move = {"j1": float(_angle_deg(result.j1, other.j1)),
            "j2": float(_angle_deg(result.j2, other.j2))}
    result.uncertainty_components["gyr_bias"] = move
    refresh_uncertainty(result, "deg", MAX_UNCERTAINTY_DEG)
    _refuse_if_uninformative(result)
    result.warnings.append(_large_bias_warning(result.gyr_bias, max(move.values())))


#: How the warning on biases too large to remove begins after its numbers.
_LARGE_BIAS = "more than a warmed-up gyroscope's"


def _large_bias_warning(block: dict, move: float, where: str = "") -> str:
    """The warning on biases the residual asks for but no gyroscope has (``block``: the
    ``gyr_bias`` report; ``move``: deg, the largest move in the 1-sigma; ``where``: said
    of the move when it is not the fit's own)."""
    size = max(np.linalg.norm(block["b1_rad_s"]), np.linalg.norm(block["b2_rad_s"]))
    return (f"the residual is {block['cost_ratio']:.2f} x lower with gyroscope biases of "
            f"{size:.2f} rad/s, {_LARGE_BIAS} ({MAX_PLAUSIBLE_BIAS_RAD_S:g}): a model error "
            f"(soft tissue) or gyroscopes far from calibrated; not removed, the axis would "
            f"move by {move:.1f} deg{where} (in the 1-sigma). A still period at the start "
            "lets the biases be checked")


def _with_move_in_sync(result: AxisResult, in_sync) -> AxisResult:
    """``result`` (auto offset) whose 1-sigma holds a large bias's move
    (:func:`_with_implausible_bias_move`) and whose clock offset was applied, with the
    larger of that move and the one with the clocks in sync (``in_sync()``, the
    search's fit at 0): such
    biases fake an offset, at which they gain less and the axis moves less without them
    (gait, 0.1 rad/s per gyroscope, truly in sync: +15.7 ms applied, a move of 1.26 deg
    against 8.2 in sync; the axis 8.55 deg off at a 1-sigma of 1.70, an independent
    review)."""
    part = result.uncertainty_components.get("gyr_bias") or {}
    if (not result.time_offset.get("applied") or result.gyr_bias.get("applied")
            or not any(part.values())):
        return result
    zero = in_sync().uncertainty_components.get("gyr_bias") or {}
    wider = {k: max(v, float(zero.get(k, 0.0))) for k, v in part.items()}
    if wider == part:
        return result
    result.uncertainty_components["gyr_bias"] = wider
    refresh_uncertainty(result, "deg", MAX_UNCERTAINTY_DEG)
    said = _large_bias_warning(result.gyr_bias, max(wider.values()),
                               " with the clocks in sync, where they gain more")
    result.warnings = [said if _LARGE_BIAS in w else w for w in result.warnings]
    return _refuse_if_uninformative(result)


def _check_acc(g1, acc1, acc2):
    """The optional specific forces, checked like the rates (both or neither)."""
    if (acc1 is None) != (acc2 is None):
        raise InputError("give both acc1 and acc2, or neither")
    if acc1 is None:
        return None, None
    acc1, acc2 = check_pair(acc1, acc2, "acc")
    if acc1.shape != g1.shape:
        raise InputError(f"gyr and acc have different lengths ({g1.shape[0]}, "
                         f"{acc1.shape[0]})")
    return acc1, acc2


def adopt_offset(own: AxisResult, source: dict, found_by: str, gyr1, gyr2, *, acc1=None,
                 acc2=None, rate: float, **options) -> AxisResult:
    """The axis fitted again at the clock offset another "auto" search of the same two
    sensors applied (a knee's centre: :func:`imucal.calibration.calibrate` keeps one
    offset per joint, :func:`imucal.time_offset.choose`).

    Parameters
    ----------
    own
        This axis as estimated with ``time_offset="auto"`` (its own search).
    source
        The other search's ``time_offset`` block (docs/json.md), whose ``time_offset_s``
        (s) is applied.
    found_by
        Which estimate found it, for the block's ``found_by`` (e.g. "knee centre").
    gyr1, gyr2, acc1, acc2, rate, options
        As given to :func:`estimate_axis` for ``own`` (``time_offset`` is replaced).

    Returns
    -------
    AxisResult
        The fit at that offset; ``time_offset`` is ``source``'s block with ``found_by``,
        ``own`` (this axis's own search), ``disagreement_s`` (half of it joins
        ``sigma_s``, with a warning) and ``moved_from_own`` (deg); the other search's
        1-sigma and that move (capped at ``OFFSET_MODEL_CAP`` x the model term) are in
        the axes' 1-sigma (:func:`imucal.time_offset.adopt`).
    """
    result = estimate_axis(gyr1, gyr2, acc1=acc1, acc2=acc2, rate=rate,
                           **{**options, "time_offset": float(source["time_offset_s"])})
    g1, g2 = check_pair(gyr1, gyr2)
    search = float(own.time_offset["search_s"])
    adopt(result, own, offset_profile(g1, g2, check_rate(rate), search), rate, source,
          found_by, _offset_moved, "deg", MAX_UNCERTAINTY_DEG,
          lambda r: np.concatenate([r.j1, r.j2]))
    return _refuse_if_uninformative(result)


def _with_auto_offset(g1, g2, acc1, acc2, rate, s: AxisSettings) -> AxisResult:
    """The estimate with the clock offset found from eq. (1) itself
    (:func:`imucal.time_offset.fit_with_offset`).

    Where the rates may hold gyroscope biases (:func:`_biases_in_play`), the offset is
    searched a second time with the biases refitted at every candidate offset
    (:func:`offset_profile`), and that search's estimate is taken where its fit removed
    a plausible bias (:mod:`imucal.gyr_bias`): a bias fitted at the wrong offset absorbs
    part of the misalignment, comes out larger than a gyroscope's and is not removed,
    and the plain search then settles where the unremoved bias puts its minimum
    (simulated gait, shank 45 ms late, bias 0.02 rad/s per sensor: 39.4 +- 0.16 ms
    applied and the axis 1.2 deg off; searched with the biases, 44.9 +- 0.3 ms and
    0.09 deg)."""
    s = replace(s, seed=resolve_seed(s.seed))  # both fits must see the same restarts

    first: list[AxisResult] = []  # the first search's first fit: at 0

    def again(seconds):  # (the search's own fits: no check of their offset)
        fit = _estimate(g1, g2, acc1, acc2, rate, s.at_offset(seconds))
        if not first:
            first.append(fit)
        return fit

    def in_sync():
        # where an offset was applied, the search reported into another result than its
        # fit at 0: that fit is the clocks-in-sync one, unchanged (fitted once, not twice)
        return first[0]

    def search(biases: bool) -> AxisResult:
        return _refuse_if_uninformative(fit_with_offset(
            again, offset_profile(g1, g2, rate, s.offset_search, biases), rate,
            s.offset_search, _offset_moved, "deg", MAX_UNCERTAINTY_DEG,
            lambda r: np.concatenate([r.j1, r.j2]), unapplied=True))
    plain = _with_move_in_sync(search(False), in_sync)
    if not _biases_in_play(plain.gyr_bias):
        return plain
    joint = search(True)
    if not joint.gyr_bias.get("applied") or joint.blocking:
        return plain
    joint.time_offset["with_biases"] = True
    return joint


def _biases_in_play(bias: dict) -> bool:
    """Whether a fit's rates may hold gyroscope biases: it removed some, or its bias fit
    gained at least ``BIAS_SEARCH_RATIO`` (the shared real recording's knees:
    1.00-1.04)."""
    return bool(bias.get("applied")) or bias.get("cost_ratio", 1.0) >= BIAS_SEARCH_RATIO


def _lowpassed_rates(sensors, rate, cutoff) -> list[tuple]:
    """[(g1,), (g2,)]: both sensors' rates low-passed at ``cutoff`` (0: as they are) in
    one filter call (each channel on its own; a call's fixed cost is that of several)."""
    both = lowpass(np.concatenate([sensor[0] for sensor in sensors], axis=1), rate, cutoff)
    return [(g,) for g in np.split(both, len(sensors), axis=1)]


def _gyr_bias(p: Prepared, fit: Multistart) -> GyrBias:
    """Constant gyroscope biases across the axis, fitted with eq. (1) from the estimate
    (:mod:`imucal.gyr_bias`)."""
    return estimate_gyr_bias(*p.data, unit(fit.estimate[:3]), unit(fit.estimate[3:]))


def _with_gyr_bias(g1, g2, acc1, acc2, rate, s: AxisSettings, bias: GyrBias) -> AxisResult:
    """The estimate from rates corrected by ``bias``: a bias turns the axis by tenths of
    a degree, and everything after the fit (signs, uncertainty, the model bound) must
    see rates without it."""
    result = _estimate(g1 - bias.b1, g2 - bias.b2, acc1, acc2, rate, s, bias_removed=True)
    result.gyr_bias = bias.report()
    # the fit above takes the biases as known; with them estimated too, the axes are
    # known less well by the factor the joint fit's covariance gives
    c = result.uncertainty_components
    # no widening (f = 1) stays 0 where the curvature's sigma is infinite (no motion)
    c["gyr_bias"] = {k: float(np.sqrt(f**2 - 1) * max(c["curvature"][k], c["time_blocks"][k]))
                     if f > 1 else 0.0
                     for k, f in zip(("j1", "j2"), bias.inflation, strict=True)}
    result.uncertainty_deg = uncertainty_totals(c)
    return _refuse_if_uninformative(result)


def _gravity(p: Prepared, j1, j2, origin: float) -> dict:
    """The gravity check of the axes at rest (:func:`imucal.rest.gravity_check_near`: the
    window's still periods, else those near it), when accelerometers came with the rates;
    ``origin``: the first sample's time, s on the recording's clock."""
    if p.first[1] is None:
        return {"periods": [], "max_mismatch_deg": None, "consistent": None,
                "max_allowed_deg": MAX_MISMATCH_DEG, "scope": None}
    return gravity_check_near(p.first[0], p.first[1], p.second[0], p.second[1], j1, j2,
                              p.rate, window=p.window, origin=origin)


def _fit(p: Prepared, s: AxisSettings) -> Multistart:
    """The staged multistart of eq. (1) from axes uniform on the sphere (Sec. IV)."""
    rng = np.random.default_rng(s.seed)
    x0 = np.concatenate([_random_unit(rng, s.restarts), _random_unit(rng, s.restarts)],
                        axis=1)
    return multistart(HINGE, p.data, subset_mask(p.samples, s.restarts, s.subset, rng), x0,
                      s.max_iterations, rng)


def _signs(p: Prepared, fit: Multistart, s: AxisSettings):
    """(j1, j2, decision, applied): the estimate oriented by the sign tests or pins."""
    j1, j2 = unit(fit.estimate[:3]), unit(fit.estimate[3:])
    # The sign tests follow the rates sample by sample: they need the full rate and a
    # smooth signal, so they always see low-passed rates.
    decision = decide_relative_sign(p.first[0], p.second[0], j1, j2, p.rate, p.first[1],
                                    p.second[1], cutoff=_sign_cutoff(p), window=p.window)
    j1, j2, applied = _orient(j1, j2, decision.sign, s.sign, _sign_index(s.sign), s.j2_sign,
                              _sign_index(s.j2_sign))
    return j1, j2, decision, applied


def _sign_cutoff(p: Prepared) -> float:
    return p.cutoff or default_cutoff(p.rate)


def _quality(p: Prepared, fit: Multistart, x: np.ndarray) -> dict:
    """Residual, identifiability, uncertainty and restart agreement at the estimate ``x``
    (j1, j2)."""
    d1, d2 = p.data
    e, jac = _residual_and_jacobian(d1, d2, x)
    rms_e = float(np.sqrt(np.mean(e**2)))
    # Relative to the angular rates, so recordings of different intensity compare. Not
    # to the joint-plane rates |g x j| that eq. (1) compares: those vanish exactly when a
    # joint flexes cleanly about its axis, which would make the best data look worst.
    scale = float(np.sqrt(np.mean((np.sum(d1 * d1, axis=1) + np.sum(d2 * d2, axis=1)) / 2)))
    cov = robust_covariance(e, jac)
    sv = singular_values(jac)
    sensitivity = _cutoff_sensitivity(p, x)
    # a smooth residual is a model error every time block shares (soft tissue moving the
    # sensors in step with the gait cycle): a bias bound in proportion to it
    smooth = p.smooth_residual(e, lambda *moving: _residual_and_jacobian(*moving, x)[0])
    model = _model_term(smooth, sv)
    components = {
        "curvature": {"j1": float(np.degrees(np.sqrt(cov[0, 0] + cov[1, 1]))),
                      "j2": float(np.degrees(np.sqrt(cov[2, 2] + cov[3, 3])))},
        "time_blocks": _block_jackknife(d1, d2, x),
        "cutoff_shift": cutoff_shifts(sensitivity, ("j1", "j2"), "deg"),
        "model": {"j1": model, "j2": model},
        "gyr_bias": {"j1": 0.0, "j2": 0.0},
    }
    keep = settled(fit.batch.final_cost, fit.reached)
    return {
        "rms": rms_e,
        "smooth": smooth,
        "relative": rms_e / scale if scale > 0 else float("inf"),
        "singular_values": sv,
        "singular_ratio": float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0,
        "excitation": _excitation(d1, d2, x),
        "sensitivity": sensitivity,
        "components": components,
        "uncertainty": uncertainty_totals(components),
        "fraction": float(fit.reached.mean()),
        "agreement": competing_agreement(fit.refined.final_cost, fit.reached),
        "spread": {k: rms(_angle_deg(fit.batch.x[keep, sl], x[sl]))
                   for k, sl in (("j1", slice(0, 3)), ("j2", slice(3, 6)))},
        "minima": equal_minima(fit.refined.x, fit.refined.final_cost, fit.best, fit.reached,
                               _axis_distance),
    }


def _model_term(smooth: float, sv: np.ndarray) -> float:
    """The model-error bound of the axes, deg: ``MODEL_FACTOR`` times the smooth residual
    ``smooth`` (rad/s, :func:`imucal.quality.smooth_residual_rms`) over the
    Jacobian's smallest singular value ``sv[-1]`` (per sqrt(sample)), i.e. the largest
    turn of the axes a residual of that size could explain. Relative to the weakest
    direction, not to the rates' size: gait excites the axes less than circling, and the
    same smooth residual moved them several times as far there."""
    if sv.size == 0 or not sv[-1] > 0:
        return 0.0
    return float(MODEL_FACTOR * np.degrees(smooth / sv[-1]))


def _excitation(d1, d2, x) -> dict:
    """RMS flexion rate and joint-plane rates over the samples used, deg/s."""
    thetadot = d2 @ x[3:] - d1 @ x[:3]
    n1, n2 = joint_plane_rate(d1, x[:3]), joint_plane_rate(d2, x[3:])
    return {
        "flexion_rate_rms_deg_s": float(np.degrees(np.sqrt(np.mean(thetadot**2)))),
        "joint_plane_rate_rms_deg_s": [float(np.degrees(np.sqrt(np.mean(n1**2)))),
                                       float(np.degrees(np.sqrt(np.mean(n2**2))))],
    }


def _result(p: Prepared, s: AxisSettings, fit: Multistart, j1, j2, decision, applied,
            q: dict, warnings: list[str], blocking: list[str]) -> AxisResult:
    return AxisResult(
        **shared_fields(p, fit, q, unit="deg", settings=_settings_record(p, s, decision),
                        time_offset=s.time_offset, warnings=warnings, blocking=blocking),
        j1=j1,
        j2=j2,
        sign_evidence=decision.evidence,
        sign_tests={name: t.report(applied) for name, t in decision.tests.items()},
        uncertainty_deg=q["uncertainty"],
        spread_deg=q["spread"],
        gyr1=p.data[0],
        gyr2=p.data[1],
    )


def _settings_record(p: Prepared, s: AxisSettings, decision) -> dict:
    """Every setting used, for the result (``settings``)."""
    return {
        "restarts": s.restarts,
        "seed": s.seed,
        "cutoff_hz": p.cutoff,
        "filter": (f"Butterworth order {FILTER_ORDER} low-pass, zero phase" if p.cutoff
                   else None),
        "sign_test_cutoff_hz": _sign_cutoff(p),
        "sign_convention": s.sign,
        "j2_sign": s.j2_sign,
        "sign_tests": sorted(decision.tests),
        "time_offset": s.time_offset,
        "subsample": p.step,
        "select": s.select,
        "max_samples": s.max_samples if s.select else None,
        "subset_fraction": s.subset,
        "max_iterations": s.max_iterations,
        "step_tolerance_rad": STEP_TOLERANCE,
        "restart_step_tolerance_rad": RESTART_STEP_TOLERANCE,
        "coarse_samples": COARSE_SAMPLES,
        "coarse_iterations": COARSE_ITERATIONS,
        "cost_tolerance": COST_TOLERANCE,
        "agreement_deg": AGREEMENT_DEG,
        "initial_values": "j1, j2 uniform on the unit sphere",
    }


def _cutoff_sensitivity(p: Prepared, x: np.ndarray) -> dict:
    """Refit from the estimate ``x`` with the cut-off halved and doubled (no filter: the
    default cut-off and twice it); the shifts show how much the answer rests on the filter.
    """
    rate = p.rate
    pair = sensitivity_cutoffs(p.cutoff, default_cutoff(rate), MAX_CUTOFF_FRACTION * rate)
    both = np.concatenate([p.first[0], p.second[0]], axis=1)  # one filter call per cut-off
    data = [tuple(np.split(lowpass(both, rate, c)[p.window][::p.step][p.selection.index], 2,
                           axis=1)) for c in pair]
    y = HINGE.refit_each(data, x, SENSITIVITY_ITERATIONS)
    shifts = {"j1": [float(a) for a in _angle_deg(y[:, :3], x[:3])],
              "j2": [float(a) for a in _angle_deg(y[:, 3:], x[3:])]}
    return {"cutoffs_hz": list(pair), "j1_shift_deg": shifts["j1"],
            "j2_shift_deg": shifts["j2"],
            "max_shift_deg": max(shifts["j1"] + shifts["j2"])}


def offset_profile(g1, g2, rate, search, biases: bool = False):
    """``result -> refit(deltas)``: eq. (1) over candidate offsets, the axis refitted
    from ``result`` at each: (D, M) residuals and (D, 6) axes
    (:func:`imucal.time_offset.fit_with_offset`).

    The rates are low-passed at the fit's cut-off or, without one (the default), at
    :func:`imucal.preprocess.default_cutoff`: white noise above it dilutes the gain of
    the right alignment but not that of a soft-tissue lag, which lies in the band of the
    motion. Simulated, shank 20 ms late at 40 and 100 Hz: cost ratios 1.43-2.9
    unfiltered and 2.1-12 at 10 Hz on circling (5 fits), 1.7-8.4 and 2.7-47 on walking
    (3 fits); soft tissue without an offset: the shifts that gained 1.5-1.75 unfiltered
    gain 1.1-1.2. A gyroscope bias the fit removed is removed here too: left in, a shift
    of the low-passed rates mimics part of it (simulated circling, 0.02 rad/s: +24 ms
    applied at a cost ratio of 1.6). With ``biases``, constant biases across the axes
    are refitted with the axes at every candidate instead, from those ``result``
    removed or none (:func:`_refit_residuals`): a bias and an offset found together.

    Returns
    -------
    profile : callable
        ``result -> refit``, where ``refit(deltas)`` (D,) s gives the (D, M) residuals,
        rad/s, and the (D, 6) refitted axes.
    """
    def profile(first):
        cutoff = first.settings["cutoff_hz"] or default_cutoff(rate)
        removed = first.gyr_bias if first.gyr_bias.get("applied") else {}
        b = np.concatenate([removed.get("b1_rad_s", np.zeros(3)),
                            removed.get("b2_rad_s", np.zeros(3))])
        rates = np.concatenate([g1, g2], axis=1)
        both = lowpass(rates if biases else rates - b, rate, cutoff)
        index = profile_samples(first.sample_index, g1.shape[0], rate, search)
        d1, read2 = both[index, :3], delayed(both[:, 3:], rate)
        x = np.concatenate([first.j1, first.j2])
        start = b if biases else None
        # (every: a coarser look, one sample in so many, :func:`estimate_offset`)
        return lambda deltas, every=1: _refit_residuals(d1[::every],
                                                        read2(index[::every], deltas), x, start)
    return profile


def _offset_moved(result, a, b) -> dict:
    """{"j1", "j2"}: angles between two refitted axis pairs ``a``, ``b`` (6,), deg."""
    return {k: float(_angle_deg(a[sl], b[sl])) for k, sl in (("j1", slice(0, 3)),
                                                             ("j2", slice(3, 6)))}


def _refit_residuals(d1, d2, x, b=None) -> tuple[np.ndarray, np.ndarray]:
    """(D, M) residuals of eq. (1) and the (D, 6) axes after ``OFFSET_STEPS`` plain
    Gauss-Newton steps from ``x`` (6,), for each of D offset candidates at once (``d2``
    (D, M, 3)): the profile cost of each, without the solver's restart machinery.

    With ``b`` (6,) (rad/s, b1 and b2), constant gyroscope biases across the axes are
    refitted too, from ``b``, under :mod:`imucal.gyr_bias`'s prior (``PRIOR_RAD_S`` per
    component against the residual's own scale at the start)."""
    count = d2.shape[0]
    x = np.repeat(x[None, :], count, axis=0)
    d2t = np.ascontiguousarray(np.swapaxes(d2, 1, 2))
    if b is not None:
        b = np.repeat(np.asarray(b, dtype=float)[None, :], count, axis=0)
        e = _residuals_and_jacobian_rows(d1, d2t, x, b)[0]
        weight2 = np.mean(e * e, axis=1) / PRIOR_RAD_S**2
    for _ in range(OFFSET_STEPS):
        e, jac = _residuals_and_jacobian_rows(d1, d2t, x, b)
        jtj = jac @ np.swapaxes(jac, 1, 2)
        grad = jac @ e[..., None]
        if b is not None:  # the prior's rows, weight * (b . u, b . v) per sensor
            bases = tangent_basis(x.reshape(-1, 3))  # (2D, 3, 2): u, v of j1, j2, ...
            across = (b.reshape(-1, 1, 3) @ bases).reshape(count, 4)
            jtj[:, 4:, 4:] += weight2[:, None, None] * np.eye(4)
            grad[:, 4:, 0] += weight2[:, None] * across
        # a touch of damping: a sensor that never turns leaves J^T J singular (the step
        # is then 0, not an error)
        damp = 1e-9 * np.trace(jtj, axis1=1, axis2=2)[:, None, None] + 1e-30
        step = -np.linalg.solve(jtj + damp * np.eye(jtj.shape[-1]), grad)[..., 0]
        if b is not None:  # the bias step in the bases it was computed in
            b = b + (bases @ step[:, 4:].reshape(-1, 2, 1)).reshape(count, 6)
        x = _retract(x, step[:, :4])
    return _residuals_and_jacobian_rows(d1, d2t, x, b)[0], x


def _diagnose(p: Prepared, q: dict, decision, gravity: dict) -> tuple[list[str], list[str]]:
    """(warnings, blocking) of an axis estimate; thresholds and their reasons in
    docs/quality.md."""
    doubts = unit_doubts(p.data)
    blocking = _blocking(p, q, decision, doubts)
    relative, sigma = q["relative"], max(q["uncertainty"].values())
    warnings = list(doubts)
    warned = gravity_warning(gravity)
    if warned and not blocking:
        # an axis the still periods show is no one line is not the joint's: on the real
        # recording's first 55 s the fit found the segments' long axes (gravity along
        # both sensors' x while standing), 60-90 deg from any knee axis, at a 1-sigma of
        # 19-40 deg; `calibrate` refused those knees already (angles.own_check_failure)
        blocking = [warned]
    elif warned:
        warnings.append(warned)
    if not blocking:
        warnings += disagreement_warning(
            q["agreement"], "; the joint may have moved too little or not as a hinge")
    if MAX_RELATIVE_RESIDUAL < relative < np.inf:  # inf: no motion, refused for that
        warnings.append(
            f"the hinge model fits poorly (residual {relative:.0%} of the signal; real knees "
            "leave 35-45 %): the joint may not be a hinge, or the sensors moved on the skin"
        )
    if sigma > MAX_UNCERTAINTY_DEG:
        warnings.append(uncertainty_warning(q["uncertainty"], q["components"], "deg"))
    return warnings, blocking


def _blocking(p: Prepared, q: dict, decision, doubts: list[str]) -> list[str]:
    """The first reason, if any, why the data cannot identify the axis: the rules of
    :data:`_BLOCKING_RULES` in order, each ``(p, q, decision, doubts) -> [reason] or []``."""
    for rule in _BLOCKING_RULES:
        reason = rule(p, q, decision, doubts)
        if reason:
            return reason
    return []


def _still(p: Prepared, q, decision, doubts) -> list[str]:
    return stillness_warning(*p.data)


def _barely_bent(p, q: dict, decision, doubts) -> list[str]:
    flex = q["excitation"]["flexion_rate_rms_deg_s"]
    if flex >= MIN_FLEXION_RATE_DEG_S:
        return []
    return [f"the joint barely bent (RMS flexion rate {flex:.1f} deg/s, below "
            f"{MIN_FLEXION_RATE_DEG_S:g}): the axis is not identifiable from this "
            "recording; record the joint flexing and extending"]


def _bent_on_the_skin(p, q: dict, decision, doubts) -> list[str]:
    flex = q["excitation"]["flexion_rate_rms_deg_s"]
    across = max(q["excitation"]["joint_plane_rate_rms_deg_s"])
    if not (flex < MIN_BENT_FLEXION_RATE_DEG_S and flex < MIN_FLEXION_SHARE * across):
        return []
    return [f"the joint barely bent while its segments turned (RMS flexion rate "
            f"{flex:.1f} deg/s, {flex / across:.2f} of the {across:.0f} deg/s they turned "
            f"across the axis; below {MIN_BENT_FLEXION_RATE_DEG_S:g} deg/s and "
            f"{MIN_FLEXION_SHARE:g}): what bent may be the sensors moving on the skin, so "
            "the axis is not identifiable from this recording; record the joint "
            "flexing and extending"]


def _undetermined(p, q: dict, decision, doubts) -> list[str]:
    ratio = q["singular_ratio"]
    if ratio >= MIN_SINGULAR_RATIO:
        return []
    return [f"the data leave one direction of the axes undetermined (singular ratio "
            f"{ratio:.3f}, below {MIN_SINGULAR_RATIO:g}): the axis is not identifiable "
            "from this recording; record more varied motion"]


def _no_hinge(p, q: dict, decision, doubts) -> list[str]:
    fraction, relative = q["fraction"], q["relative"]
    if not (fraction < MIN_AGREEING_FRACTION and relative > POOR_FIT_RESIDUAL):
        return []
    return [f"restarts disagree ({fraction:.0%} reached the lowest cost) and the hinge "
            f"model fits poorly (residual {relative:.0%} of the signal): the joint does not "
            "move like a hinge (a spheroidal joint such as the ankle?), so no axis is "
            "identifiable"]


def _no_line(p, q: dict, decision, doubts) -> list[str]:
    return _uninformative(q["uncertainty"])


def _another_answer(p, q: dict, decision, doubts) -> list[str]:
    # an equally good answer outside the reported 1-sigma: the sigma cannot cover it
    return equal_minima_blocking(q["minima"], max(q["uncertainty"].values()),
                                 2 * AGREEMENT_DEG, "deg", "different axes", "axis")


def _beyond_a_knee(p, q, decision, doubts: list[str]) -> list[str]:
    span = min(decision.tests["range"].detail["span_deg"])
    # rates in the wrong units scale the span, too: then the unit warning is the finding
    if doubts or span <= MAX_KNEE_SPAN_DEG:
        return []
    return [f"the angle about this axis, integrated from j2.g2 - j1.g1, spans {span:.0f} "
            f"deg within {RANGE_BLOCK_S:g} s (more than the {MAX_KNEE_SPAN_DEG:g} deg a "
            "joint can flex) with either relative sign: the segments do not move as a "
            "hinge here (soft tissue, impacts, or a joint that is not a hinge)"]


#: Why the data may not identify the axis, in the order they are asked (the first that
#: answers is the reason): no motion, too little flexion, flexion that may be the skin's,
#: a direction the data leave open, no hinge at all, a 1-sigma that says nothing, another
#: answer as good, an angle no knee reaches.
_BLOCKING_RULES = (_still, _barely_bent, _bent_on_the_skin, _undetermined, _no_hinge,
                   _no_line, _another_answer, _beyond_a_knee)


def _uninformative(uncertainty: dict) -> list[str]:
    """The reason, if any, why a 1-sigma ({"j1", "j2"}, deg) says nothing about the axis."""
    sigma = max(uncertainty.values())
    if not sigma >= MAX_INFORMATIVE_SIGMA_DEG:
        return []
    return [f"the axis's 1-sigma is {sigma:.0f} deg (at least {MAX_INFORMATIVE_SIGMA_DEG:g}, "
            "the most a sign-free axis can be off): the data do not locate the axis"]


#: How the reason :func:`refuse_doubted_sign` gives begins.
DOUBTED_SIGN = "the relative sign of j1 and j2 is barely decided"


def refuse_doubted_sign(result: AxisResult, advice: str = ", or use imucal calibrate (the "
                        "knee centre checks the offset)") -> AxisResult:
    """``result`` refused (or, re-asked, no longer) where its relative sign is barely
    decided (``sign_evidence`` below :data:`SIGN_DECIDED_EVIDENCE`, not pinned) and its
    clock offset is in doubt too: applied from the rates alone where a smooth residual can
    fake one (:data:`imucal.time_offset.DOUBT_WARNING`), or searched to an end of the
    range. Together they turned j2 over in 4 of 14 usable simulated soft-tissue walks (an
    honesty audit: 171-177 deg off at a 1-sigma of 5-13 deg, "use with care"; a spurious
    +69 to +115 ms applied in three); no result of evidence 2.5 or more had the wrong
    sign. ``calibrate`` asks again once the knee centre has confirmed or replaced the
    offset (``advice`` then names no calibrate). Only with ``time_offset="auto"``: a
    given offset is no doubted one.

    Returns
    -------
    AxisResult
        ``result``, with the reason among its ``blocking`` or withdrawn from them.
    """
    result.blocking[:] = [b for b in result.blocking if not b.startswith(DOUBTED_SIGN)]
    offset = result.time_offset if isinstance(result.time_offset, dict) else {}
    doubted = any(w.startswith(DOUBT_WARNING) for w in result.warnings)
    if (result.blocking or offset.get("mode") != "auto"
            or result.settings.get("j2_sign", "auto") != "auto"
            or not result.sign_evidence < SIGN_DECIDED_EVIDENCE
            or not (doubted or offset.get("at_edge"))):
        return result
    why = (f"applied from the rates alone ({signed_ms(offset['time_offset_s'], 1)} ms), "
           "which soft tissue can fake" if doubted else
           f"searched to the end of its range ({signed_ms(offset['estimated_s'], 1)} ms)")
    result.blocking.append(
        f"{DOUBTED_SIGN} (evidence {result.sign_evidence:.2f}, below "
        f"{SIGN_DECIDED_EVIDENCE:g}) and the clock offset is in doubt, {why}: together they "
        "turned j2 over (171-177 deg off at a 1-sigma of 5-13 deg) in 4 of 14 simulated "
        "walks with soft tissue; pin the relative sign (--j2-sign) or give the clock offset "
        f"(--time-offset){advice}")
    return result


def _refuse_if_uninformative(result: AxisResult) -> AxisResult:
    """``result`` refused where a part added after the diagnosis (a removed gyroscope
    bias, the clock offset) took its 1-sigma to ``MAX_INFORMATIVE_SIGMA_DEG``."""
    if not result.blocking:
        result.blocking.extend(_uninformative(result.uncertainty_deg))
    return result


def _block_jackknife(d1, d2, x) -> dict:
    """{"j1", "j2"}: delete-one-block jackknife 1-sigma, deg; every refit starts at the
    estimate ``x`` and leaves out one contiguous time block of the samples used."""
    masks = block_masks(d1.shape[0])
    y = HINGE.refit((d1, d2), masks, np.repeat(x[None, :], masks.shape[0], axis=0),
                    MAX_ITERATIONS)
    return {"j1": jackknife_sigma(_angle_deg(y[:, :3], x[:3])),
            "j2": jackknife_sigma(_angle_deg(y[:, 3:], x[3:]))}


def _sign_index(sign: str) -> int | None:
    """Index of the component a (checked) sign convention pins; None for "auto"."""
    return None if sign == "auto" else "xyz".index(sign[1])


def _pin(v: np.ndarray, k: int | None, convention: str) -> float:
    """+1 or -1: the factor that makes ``v`` follow ``convention`` (component ``k``
    positive for "+k", negative for "-k"; "auto": the largest component positive)."""
    if k is None:
        k = int(np.argmax(np.abs(v)))
        convention = "+"
    positive = 1.0 if v[k] >= 0 else -1.0
    return positive if convention[0] == "+" else -positive


def _orient(j1, j2, data_sign, sign, flip_axis, j2_sign, pin_j2):
    """(j1, j2, applied): the overall sign from ``sign``, the relative sign from the data
    (``data_sign`` for j2) or from the user's ``j2_sign`` pin; ``applied`` is the factor
    finally applied to the solver's j2, in the sign tests' terms."""
    f1 = _pin(j1, flip_axis, sign)
    f2 = f1 * data_sign if pin_j2 is None else _pin(j2, pin_j2, j2_sign)
    # flipping both axes keeps their relative sign: f1 * f2 is what the tests' terms
    # (j1 as the solver returned it) call the sign applied to j2
    return f1 * j1, f2 * j2, f1 * f2


def _sign_warnings(decision, applied: float, pinned: bool) -> list[str]:
    """Warnings about the relative sign of j1 and j2 (see :mod:`imucal.sign`)."""
    evidence = decision.evidence
    if pinned:
        if applied != decision.sign and evidence >= MIN_SIGN_EVIDENCE:
            return [f"{PINNED_SIGN_WARNING} the data's sign tests (evidence "
                    f"{evidence:.2f} for the other sign); check how the sensors sit"]
        return []
    if evidence < SIGN_DECIDED_EVIDENCE:
        return [f"the data barely decide whether j1 and j2 point the same way (evidence "
                f"ratio {evidence:.2f}, below {SIGN_DECIDED_EVIDENCE:g}: on simulated knees "
                "with soft tissue such ratios were wrong about 1 time in 7, the axis then off "
                "by 160 deg or more); check the relative sign by another means, or pin it "
                "with j2_sign (--j2-sign)"]
    if decision.contradicting:
        return [f"the sign tests disagree ({', '.join(decision.contradicting)} favours the "
                f"other relative sign); the combined evidence is {evidence:.2f}"]
    return []


def joint_plane_projection(g: np.ndarray, j: np.ndarray) -> np.ndarray:
    """The rates ``g`` (N, 3) projected into the plane normal to the unit axis ``j`` (3,),
    both in one sensor's frame (eq. 6).

    Returns
    -------
    (N, 2) float64
        Coordinates of each projection in the orthonormal basis (u, j x u) of the plane,
        u = :func:`imucal.sign.perpendicular` of ``j``; units of ``g`` (rad/s).

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, Sec. III-C, eq. 6.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.axis import joint_plane_projection
    >>> joint_plane_projection(np.array([[1.0, 2.0, 3.0]]), np.array([0.0, 0.0, 1.0]))
    array([[1., 2.]])
    """
    u = perpendicular(j)
    return np.stack([g @ u, g @ np.cross(j, u)], axis=1)


#: Smallest |g x j|^2 / |g|^2 used, per precision: a little above the relative rounding
#: error of |g|^2 - (g.j)^2 (|g x j| >= 1e-3 |g| in single, 1e-7 |g| in double precision).
NORM_FLOOR = {np.dtype(np.float32): 1e-6, np.dtype(np.float64): 1e-14}

#: Samples per block in the hinge problem's sums: bounds its work arrays to
#: restarts x CHUNK (about 10 MB per array kind at 100 restarts), whatever the length.
CHUNK = 4096


class _HingeProblem(BatchedProblem):
    """Residual (1) and its Gauss-Newton normal equations for many restarts at once.

    With ``|g x j|^2 = |g|^2 - (g.j)^2`` every restart's residual needs only the matrix
    product ``J G^T`` (restarts x samples), and the normal equations are sums of
    per-sample outer products weighted per restart: one more matrix product with a fixed
    table of products ``g g^T``. Data subsets are 0/1 weights, so every restart sees the
    same arrays. All element-wise work happens in preallocated arrays, in blocks of
    ``CHUNK`` samples: fresh large temporaries cost more (page faults) than the
    arithmetic itself.
    """

    def __init__(self, g1: np.ndarray, g2: np.ndarray, mask: np.ndarray | None,
                 dtype=np.float64, newton: bool = False):
        """``mask`` (R, N): 1 where restart r uses sample n; None: all samples for all.
        ``newton``: :meth:`normal` returns the exact Hessian where it is positive definite
        (see there); ``dtype``: precision of the element-wise work."""
        n = g1.shape[0]
        self.n = n
        self.dtype = dtype
        self.newton = newton
        g1, g2 = g1.astype(dtype), g2.astype(dtype)
        if mask is not None:
            mask = mask.astype(dtype, copy=False)
        self.g1, self.g2 = g1, g2
        self.g1t, self.g2t = np.ascontiguousarray(g1.T), np.ascontiguousarray(g2.T)
        self.gg1, self.gg2 = np.sum(g1 * g1, axis=1), np.sum(g2 * g2, axis=1)
        rel = NORM_FLOOR[np.dtype(dtype)]
        # (floor of |g x j|^2, |g|^2) per sample; the floor is relative to |g|^2, with an
        # absolute minimum so that g = 0 gives no 0 / 0.
        self.floor1 = ((rel * self.gg1 + 1e-24).astype(dtype), self.gg1)
        self.floor2 = ((rel * self.gg2 + 1e-24).astype(dtype), self.gg2)
        self.mask = mask
        self.count = float(n) if mask is None else mask.sum(axis=1, dtype=np.float64)
        # Tables of g g^T products (upper triangles) and g1 g2^T: the normal equations'
        # blocks are weighted sums of them, one matrix product each. A product's cost
        # grows with the restarts x samples operand, hardly with the table's width.
        up = np.triu_indices(3)
        self.tables = [
            np.ascontiguousarray((g1[:, :, None] * g1[:, None, :])[:, up[0], up[1]]),
            np.ascontiguousarray((g2[:, :, None] * g2[:, None, :])[:, up[0], up[1]]),
            np.ascontiguousarray((g1[:, :, None] * g2[:, None, :]).reshape(n, 9)),
        ]
        self.blocks = [slice(k, min(k + CHUNK, n)) for k in range(0, n, CHUNK)]
        self._work = None

    def _buffers(self, r: int):
        width = self.blocks[0].stop - self.blocks[0].start
        if self._work is None or self._work.shape[1] < r:
            self._work = np.empty((6, max(r, 1), width), dtype=self.dtype)
        return [w[:r] for w in self._work]

    def _block(self, x, rows, sl, buf):
        """Residual pieces of samples ``sl`` for restarts ``rows`` (views into ``buf``):
        g.j and |g x j| of both sensors, e = n1 - n2 (times the 0/1 weights when subset),
        and the weights (None: all samples)."""
        width = sl.stop - sl.start
        d1, d2, n1, n2, e = (a[:, :width] for a in buf[:5])
        x = x.astype(self.dtype, copy=False)
        np.matmul(x[:, :3], self.g1t[:, sl], out=d1)  # g1.j1, every restart and sample
        np.matmul(x[:, 3:], self.g2t[:, sl], out=d2)
        for d, nrm, floor in ((d1, n1, self.floor1), (d2, n2, self.floor2)):
            np.multiply(d, d, out=nrm)
            np.subtract(floor[1][sl], nrm, out=nrm)
            # |g x j|^2 = |g|^2 - (g.j)^2 cancels when g is nearly parallel to j, and
            # the derivatives divide by |g x j| (the Hessian by its cube): below the
            # rounding floor of the precision in use the value is noise, and letting it
            # reach 0 overflowed single precision on real impacts (issue 10).
            np.maximum(nrm, floor[0][sl], out=nrm)
            np.sqrt(nrm, out=nrm)
        np.subtract(n1, n2, out=e)
        w = None
        if self.mask is not None:
            if every_row(rows, self.mask.shape[0]):
                w = self.mask[:, sl]
            else:  # some stopped, trials, or a block of them; (np.take of the column
                # slice copied all of it first: 16 of 29 s for 4000 restarts of 10 000)
                w = self.mask[rows, sl]
            # w is 0 or 1, so weighting e once weights e^2 and every product with e
            np.multiply(e, w, out=e)
        return d1, d2, n1, n2, e, w

    def _count(self, rows):
        return self.count if self.mask is None else self.count[rows]

    def cost(self, x, rows):
        """(r,) mean squared residual over each restart's samples."""
        buf = self._buffers(x.shape[0])
        total = np.zeros(x.shape[0])
        for sl in self.blocks:
            *_, e, _ = self._block(x, rows, sl, buf)
            total += np.einsum("ij,ij->i", e, e)
        return total / self._count(rows)

    def _sums(self, x, rows):
        """Per restart, the weighted sums of the tables the normal equations need:
        ``a[k]`` sum c^2 g g^T and ``p[k]`` sum (e / n) g g^T of sensor k (upper
        triangles), ``q[k]`` sum c^2 (e / n) g g^T (with ``newton``), ``cross`` sum
        c1 c2 g1 g2^T (9), and the sum of e^2; c = (g.j) / n, n = |g x j|."""
        r = x.shape[0]
        buf = self._buffers(r)
        a, p, q = (np.zeros((2, r, 6)) for _ in range(3))
        cross, total = np.zeros((r, 9)), np.zeros(r)
        for sl in self.blocks:
            d1, d2, n1, n2, e, w = self._block(x, rows, sl, buf)
            tmp = buf[5][:, :sl.stop - sl.start]
            for k, (d, nrm) in enumerate(((d1, n1), (d2, n2))):
                table = self.tables[k][sl]
                # the weights enter once, through 1/n (w^2 = w): then c, c^2, e/n, c1 c2
                # are all weighted
                inv = np.divide(1.0 if w is None else w, nrm, out=nrm)
                np.multiply(d, inv, out=d)  # c
                np.multiply(d, d, out=tmp)  # c^2
                a[k] += tmp @ table
                np.multiply(inv, e, out=inv)  # e / n
                p[k] += inv @ table
                if self.newton:
                    np.multiply(tmp, inv, out=tmp)
                    q[k] += tmp @ table
            np.multiply(d1, d2, out=tmp)
            cross += tmp @ self.tables[2][sl]
            total += np.einsum("ij,ij->i", e, e)
        return a, p, q, cross, total

    def normal(self, x, rows):
        """Cost (r,), J^T J (r, 4, 4) and J^T e (r, 4) in tangent-plane coordinates.

        With ``newton`` the first matrix is the cost's exact Hessian J^T J + sum e H_e
        wherever that is safely positive definite. Gauss-Newton alone converges only
        linearly when the residuals stay large (real knees: about 0.4 of the rates), each
        step 0.2-0.9 times the last; Newton steps converge quadratically near a minimum.
        The Hessian of |g x j| on the sphere, in the tangent basis B, is
        -(|g|^2 / n^3) B^T g g^T B + ((g.j)^2 / n) I with n = |g x j|.

        d|g x j| / dj = -(g.j) g / n (eq. 2); e = n1 - n2, so the Jacobian row is
        (-c1 g1^T B1, c2 g2^T B2) with c = (g.j) / n. Every sum is a table sum
        (:meth:`_sums`): J^T e's sum (e / n)(g.j) g is (sum (e / n) g g^T) j, the Hessian's
        sum e (g.j)^2 / n is j^T (sum (e / n) g g^T) j, and its sum e |g|^2 / n^3 g g^T is
        sum (e / n)(1 + c^2) g g^T, as |g|^2 = n^2 + (g.j)^2.
        """
        r = x.shape[0]
        a, p, q, cross, total = self._sums(x, rows)
        j = x.reshape(r, 2, 3).transpose(1, 0, 2)  # (2, r, 3)
        pm = p[:, :, SYMMETRIC]  # (2, r, 3, 3)
        pj = (pm @ j[..., None])[..., 0]  # (2, r, 3): sum (e/n)(g.j) g
        # J^T J in ambient coordinates (r, 6, 6), then in the tangent bases (r, 6, 4)
        m = np.empty((2, r, 6, 6)) if self.newton else np.empty((1, r, 6, 6))
        m[0, :, :3, :3] = a[0][:, SYMMETRIC]
        m[0, :, 3:, 3:] = a[1][:, SYMMETRIC]
        m[0, :, :3, 3:] = -cross.reshape(r, 3, 3)
        m[0, :, 3:, :3] = np.swapaxes(m[0, :, :3, 3:], 1, 2)
        basis = np.zeros((r, 6, 4))
        both = tangent_basis(x.reshape(2 * r, 3))  # rows j1, j2, j1, j2, ...
        basis[:, :3, :2], basis[:, 3:, 2:] = both[0::2], both[1::2]
        bt = np.swapaxes(basis, 1, 2)
        grad = np.concatenate([-pj[0], pj[1]], axis=1)
        jte = (bt @ grad[..., None])[..., 0]
        cost = total / self._count(rows)
        if self.newton:
            # e = n1 - n2: the second sensor's curvature enters with the opposite sign;
            # sum e |g|^2 / n^3 g g^T = sum (e/n)(1 + c^2) g g^T
            m[1] = m[0]
            m[1, :, :3, :3] -= pm[0] + q[0][:, SYMMETRIC]
            m[1, :, 3:, 3:] += pm[1] + q[1][:, SYMMETRIC]
        both = bt @ m @ basis  # (1 or 2, r, 4, 4)
        jtj = both[0]
        if not self.newton:
            return cost, jtj, jte
        hess = both[1]
        shift = np.sum(pj * j, axis=2)  # sum e (g.j)^2 / n, per sensor
        idx = np.arange(2)
        hess[:, idx, idx] += shift[0][:, None]
        hess[:, idx + 2, idx + 2] -= shift[1][:, None]
        return cost, safe_newton(jtj, hess), jte


def _residual_and_jacobian(g1: np.ndarray, g2: np.ndarray, x: np.ndarray):
    """e (N,) and J (N, 4) of one state ``x`` (6,) on all samples (for quality)."""
    e, jac = _residuals_and_jacobian_rows(g1, g2.T[None], x[None])
    return e[0], jac[0].T


def _residuals_and_jacobian_rows(g1: np.ndarray, g2t: np.ndarray, x: np.ndarray,
                                 b: np.ndarray | None = None):
    """e (D, N) and J (D, 4, N) of eq. (1) for D states ``x`` (D, 6), each with its own
    second sensor's rates, component-major ``g2t`` (D, 3, N), and the first sensor's
    ``g1`` (N, 3): every product over samples is then one matrix product (a few times
    faster than small matrices per sample).

    With biases ``b`` (D, 6) (rad/s, b1 and b2; only their parts across the axes count)
    the rates are ``g - b`` and J (D, 8, N) also has the derivatives by each bias's
    components along the axis's tangent basis (u, v) (:func:`imucal.vectors.tangent_basis`)."""
    d = x.shape[0]
    j = x.reshape(-1, 3)  # rows j1, j2, j1, j2, ...
    basis = np.concatenate([j[:, :, None], tangent_basis(j)], axis=2)  # columns j, u, v
    # (D, 3, N): g.j, g.u, g.v of every sample
    p1 = (basis[0::2].transpose(0, 2, 1).reshape(3 * d, 3) @ g1.T).reshape(d, 3, -1)
    p2 = basis[1::2].transpose(0, 2, 1) @ g2t
    if b is None:
        n1 = np.sqrt(np.maximum(np.sum(g1 * g1, axis=1) - p1[:, 0] ** 2, 0.0))
        n2 = np.sqrt(np.maximum(np.sum(g2t * g2t, axis=1) - p2[:, 0] ** 2, 0.0))
    else:
        # (g - b).(j, u, v); |(g - b) x j| is the length of its (u, v) part
        shift = (b.reshape(-1, 1, 3) @ basis).reshape(d, 2, 3)
        p1 = p1 - shift[:, 0, :, None]
        p2 = p2 - shift[:, 1, :, None]
        n1 = np.sqrt(p1[:, 1] ** 2 + p1[:, 2] ** 2)
        n2 = np.sqrt(p2[:, 1] ** 2 + p2[:, 2] ** 2)
    r1 = 1.0 / np.maximum(n1, 1e-12)[:, None]
    r2 = 1.0 / np.maximum(n2, 1e-12)[:, None]
    jac = np.empty((d, 4 if b is None else 8, p1.shape[2]))
    jac[:, :2] = -p1[:, :1] * p1[:, 1:] * r1
    jac[:, 2:4] = p2[:, :1] * p2[:, 1:] * r2
    if b is not None:  # d|h x j| / d(b . u) = -(h . u) / |h x j|
        jac[:, 4:6] = -p1[:, 1:] * r1
        jac[:, 6:] = p2[:, 1:] * r2
    return n1 - n2, jac


def _retract(x: np.ndarray, step: np.ndarray) -> np.ndarray:
    r = x.shape[0]
    j = x.reshape(2 * r, 3)  # rows j1, j2, j1, j2, ...
    basis = tangent_basis(j)
    moved = j + (basis @ step.reshape(2 * r, 2, 1))[..., 0]
    moved /= np.sqrt(np.sum(moved * moved, axis=1, keepdims=True))
    return moved.reshape(r, 6)


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Sign-free angle between unit vectors, deg (axes have no sign in eq. 1)."""
    c = np.clip(np.abs(np.sum(a * b, axis=-1)), 0.0, 1.0)
    return np.degrees(np.arccos(c))


def _axis_distance(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Larger of the sign-free angles between the j1 parts and the j2 parts, deg."""
    return np.maximum(_angle_deg(x[..., :3], y[..., :3]), _angle_deg(x[..., 3:], y[..., 3:]))


def _random_unit(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _hinge_problem(data, mask, dtype, newton) -> _HingeProblem:
    return _HingeProblem(data[0], data[1], mask, dtype, newton)


#: Eq. (1) in the staged multistart (:mod:`imucal.multistart`). In single precision the
#: restarts resolve the axis to about 1e-5 rad, far below ``RESTART_STEP_TOLERANCE``.
HINGE = Stages(
    problem=_hinge_problem, retract=_retract, distance=_axis_distance,
    agreement=AGREEMENT_DEG, step_tolerance=STEP_TOLERANCE,
    restart_step_tolerance=RESTART_STEP_TOLERANCE,
    coarse_step_tolerance=COARSE_STEP_TOLERANCE, coarse_samples=COARSE_SAMPLES,
    coarse_iterations=COARSE_ITERATIONS, cost_tolerance=COST_TOLERANCE, max_step=MAX_STEP,
    contraction=True,
)
