"""Joint position from two IMUs (Seel, Schauer, Raisch 2012, Sec. II-B, III-B).

For two segments joined at a point, the joint centre has one acceleration; seen from
either sensor it is ``a_i - Gamma_i(o_i)``, the same vector in two frames, so (eq. 3)::

    e(t) = |a1(t) - Gamma_g1(o1)| - |a2(t) - Gamma_g2(o2)| = 0
    Gamma_g(o) = g x (g x o) + gdot x o

``o1``, ``o2`` (metres) are the vectors FROM the joint centre TO each sensor's origin, in
that sensor's frame (the paper's convention; some later papers use the opposite sign).
``a`` is specific force (gravity included): gravity is one vector for both sensors, so
eq. (3) holds with it. imucal minimises sum e^2 by Gauss-Newton with the Jacobian of
eq. (4) from many random starts on random data subsets at once.

On a hinge every point of the axis fits, so the estimate is only known along a line
``o1 + lambda j1``, ``o2 + lambda j2``. With ``joint="hinge"`` imucal reports the point of
that line closest to both sensors, ``lambda = -(o1.j1 + o2.j2) / 2`` (Seel, Raisch,
Schauer 2014), with the axis from the same recording.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np

from .axis import AxisResult, estimate_axis
from .errors import InputError
from .gauss_newton import every_row
from .gyr_bias import joint_centre_with_bias
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
    JOINT_FILTER_ORDER,
    MAX_CUTOFF_FRACTION,
    Prepared,
    check_pair,
    default_joint_cutoff,
    derivative,
    lowpass,
    only_the_stillness,
    prepare,
    rms_rate_deg_s,
    spectral_cutoff,
    stillness_warning,
    unit_doubts,
)
from .quality import (
    block_masks,
    cutoff_shifts,
    jackknife_sigma,
    rms,
    robust_covariance,
    sensitivity_cutoffs,
    singular_values,
    uncertainty_totals,
    uncertainty_warning,
)
from .rest import GRAVITY_M_S2, LOCAL_GRAVITY_SPREAD_M_S2, norm_at_rest
from .restarts import (
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
from .sensor_checks import ACC_UNITS
from .settings import (
    ACC_ERROR_M_S2,
    MAX_ITERATIONS,
    OFFSET_SEARCH_S,
    SUBSET_FRACTION,
    PositionSettings,
)
from .settings import resolve as resolve_settings
from .time_offset import (
    OFFSET_STEPS,
    adopt,
    check_given,
    delayed,
    fit_with_offset,
    given_search,
    profile_samples,
)
from .timing import check_rate
from .vectors import gamma_rows, unit

#: Two estimates agree when both o1 and o2 are within this distance, m.
AGREEMENT_M = 0.01
#: Initial offsets are uniform in [-INIT_BOX_M, INIT_BOX_M]^3 per sensor, m: a sensor
#: strapped to a thigh, shank or foot sits well within half a metre of the joint.
INIT_BOX_M = 0.5
#: The estimate is polished (double precision) until the step is below this, m (0.01 mm).
STEP_TOLERANCE = 1e-5
#: The restarts (single precision, on their subsets and refined) stop at this step, m:
#: a hundredth of ``AGREEMENT_M``, and below the spreads and sigmas reported (mm).
RESTART_STEP_TOLERANCE = 1e-4
#: The coarse stage only has to find each restart's basin, m.
COARSE_STEP_TOLERANCE = 1e-3
#: Samples shared by all restarts in the coarse stage, and its step limit (see
#: :mod:`imucal.multistart`).
COARSE_SAMPLES = 150
COARSE_ITERATIONS = 6
COST_TOLERANCE = 1e-9
#: The cut-off sensitivity refits use the cut-off times these factors.
SENSITIVITY_FACTORS = (0.75, 1.5)
#: Largest step per iteration, m.
MAX_STEP = 0.5
MIN_SAMPLES = 30
MAX_RELATIVE_RESIDUAL = 0.25
#: A singular value of the Jacobian at the estimate below this fraction of the largest is
#: a direction of (o1, o2) the data barely determine (simulated: a point that slides along
#: a hinge line gives 0.015-0.02, a rigid joint three values of 0.004-0.02, full 3-D
#: ankle motion none below 0.06).
MIN_SINGULAR_RATIO = 0.04
#: A 1-sigma position uncertainty above this is not good enough for kinematics, mm.
MAX_UNCERTAINTY_MM = 10.0
#: A sensor strapped to a thigh, shank or foot is never this far from the joint, m.
MAX_PLAUSIBLE_OFFSET_M = 1.0
#: A joint position's 1-sigma from which the data do not locate the joint at all, mm:
#: its 2-sigma spans ``MAX_PLAUSIBLE_OFFSET_M`` (:func:`_refuse_if_uninformative`).
MAX_INFORMATIVE_SIGMA_MM = 500.0
#: The rates' derivative (``Gamma``'s dw/dt, per second: the sample rate's) is tried
#: scaled by these factors, the estimate refitted at each (:func:`_rate_doubt`).
RATE_SCALES = (0.1, 0.25, 0.5, 2.0, 4.0, 10.0)
#: A scale that lowers eq. (3)'s mean squared residual this many times asks whether the
#: sample rate is right (a warning). Simulated ankles and knee centres (circling, gait,
#: protocol, walking; 40-1000 Hz; soft tissue up to 3 deg / 5 mm; 408 estimates of two
#: sweeps) at their true rate: gain at most 0.84 (the rate as given fits best); the shared
#: real recording's ankles and knees over many windows: at most 1.64 (impacts). A rate
#: 2 x off gained 3-1300 x; 10 x too high 1.4-8.8 x (the low-pass, set in Hz, is off too).
#: At a rate 2 x off a circling ankle was `good` tens of mm off; a file's rate attribute
#: or ``--rate`` is the only clock a file without time stamps has (a fuzz review).
RATE_DOUBT_GAIN = 2.0
#: The joint centre's model term is this many times the move of the refit on eq. (3)'s
#: squared-norm weighting (:func:`_refits`). Set on imucal's simulator (ankles, 20 s at
#: 100 Hz, soft tissue 0.5 deg / 1 mm to 2 deg / 3 mm, circling and protocol seeds 1-70,
#: gait 1-30): 27 of 510 fits were `good` beyond 3 sigma without it, none with it; on
#: seeds 71-150 (480 fits) 24 without it and 7 with it (up to 3.8 sigma; 4 once the
#: gyroscope-bias part joined the 1-sigma). A factor of 6
#: would cover those too but take `good` from 10 of 77 clean protocol ankles.
#: docs/method.md has the numbers.
MODEL_MOVE_FACTOR = 3.0
#: A sensor reading further from 1 g at rest than this many 1-sigmas of ``acc_error``
#: along gravity gets a warning (:func:`_acc_at_rest_warnings`).
ACC_REST_SIGMAS = 3.0


@dataclass(kw_only=True, eq=False)
class PositionResult(EstimateResult):
    """Result of :func:`estimate_position`: the fields of
    :class:`imucal.result.EstimateResult` and the position's own.

    Attributes
    ----------
    o1, o2 : (3,) vector from the joint centre to the first / second sensor's origin, in
        that sensor's frame, m.
    joint : "spheroidal" or "hinge".
    rms_residual : RMS of e(t) of eq. (3) at the estimate, m/s^2.
    relative_residual : ``rms_residual`` over the RMS of |a_i - Gamma_i(o_i)|.
    singular_ratio : as in :class:`imucal.result.EstimateResult`; for a hinge, of the
        directions across the axis.
    singular_values : singular values of that Jacobian over sqrt(samples), 1/s^2.
    uncertainty_mm : {"o1", "o2"} 1-sigma, mm (for a hinge: across the axis line): the
        larger of the curvature's and the time blocks' with the cut-off shift, the model
        term, the gyroscope-bias part and (with the automatic clock offset) the offset's
        part added in quadrature
        (:func:`imucal.quality.uncertainty_totals`); its parts, in mm, are
        ``uncertainty_components``.
    excitation : RMS angular rate of each sensor, deg/s, and the Jacobian's singular
        values over sqrt(samples), 1/s^2.
    sensitivity : cut-offs of two refits (times 0.75 and 1.5) and the shifts, mm.
    equal_minima : as in :class:`imucal.result.EstimateResult`, distance in mm
        ("max_distance_mm").
    convergence_fraction : as in :class:`imucal.result.EstimateResult`, within
        ``AGREEMENT_M`` (for a hinge: after moving each restart to its closest point on
        the axis).
    spread_mm : RMS distance of the agreeing restarts' subset results from the estimate
        per vector, mm: how much the answer depends on the data (subset fits stuck in a
        local minimum left out, :func:`imucal.restarts.settled`).
    axis : for ``joint="hinge"`` with an estimated axis, its :class:`AxisResult`.
    line : for ``joint="hinge"``, the (j1, j2) used, else None.
    weak_direction : for a spheroidal joint, the direction of (o1, o2) the data determine
        least (the curvature covariance's largest eigenvector): "o1", "o2" (unit vectors,
        sensor frames; moving the estimate along them together costs least), "along_mm"
        (1-sigma along it), "across_mm" (the 1-sigma of everything else; both the
        curvature's, scaled to the reported total) and "line" (True when the data leave
        the point only known along a line, the singular ratio below
        ``MIN_SINGULAR_RATIO``: walking alone does that to an
        ankle). None for a hinge (its line is ``line``).
    gyr_bias : the constant gyroscope biases fitted with eq. (3) from the estimate
        (:class:`imucal.gyr_bias.CentreBias`): "applied" (True when the estimate is the
        fit to the rates corrected by them), "b1_rad_s", "b2_rad_s", "cost_ratio" and the
        rule's constants; empty where the refit could not be made.
    """

    o1: np.ndarray
    o2: np.ndarray
    joint: str
    uncertainty_mm: dict
    spread_mm: dict
    axis: AxisResult | None = None
    line: np.ndarray | None = None
    weak_direction: dict | None = None
    gyr_bias: dict = field(default_factory=dict)


@one_blas_thread
def estimate_position(
    gyr1: np.ndarray,
    acc1: np.ndarray,
    gyr2: np.ndarray,
    acc2: np.ndarray,
    *,
    rate: float,
    restarts: int = 100,
    seed: int | None = None,
    joint: str = "spheroidal",
    axis: AxisResult | tuple[np.ndarray, np.ndarray] | None = None,
    cutoff: float | None = None,
    subsample: int | None = None,
    subset: float = SUBSET_FRACTION,
    start: float | None = None,
    end: float | None = None,
    max_iterations: int = MAX_ITERATIONS,
    select: bool = True,
    max_samples: int | None = MAX_SAMPLES,
    sign: str = "auto",
    j2_sign: str = "auto",
    time_offset: float | str = "auto",
    offset_search: float = OFFSET_SEARCH_S,
    time_origin: float = 0.0,
    acc_error: float = ACC_ERROR_M_S2,
    settings: PositionSettings | None = None,
) -> PositionResult:
    """Estimate the joint centre seen by two IMUs.

    Parameters
    ----------
    gyr1, acc1, gyr2, acc2
        (N, 3) angular rate (rad/s) and specific force (m/s^2) of the first (proximal)
        and second sensor, each in its own frame, sampled together.
    rate
        Sample rate, Hz.
    cutoff
        Zero-phase low-pass cut-off for gyroscope and accelerometer, Hz; None:
        from the recording's spectrum, :func:`imucal.preprocess.spectral_cutoff` (three
        times the frequency below which 99 % of the rates' power lies, 4 to 12 Hz, at
        most 0.4 x rate); 0: no filter. The filter is fourth order, run forward and
        backward, so flat over the motion's band: eq. (3) is quadratic in the rates, and
        attenuating the motion's band biases the centre. ``gdot`` is an 8th-order
        central difference of the filtered gyroscope signal
        (:func:`imucal.preprocess.derivative`), so some low-pass is needed against the
        noise the difference amplifies.
    subsample
        Use every k-th sample after filtering; None: about 2.5 samples per cut-off period.
    restarts, seed, subset, start, end, max_iterations, select, max_samples
        As in :func:`imucal.estimate_axis`. Initial offsets are uniform in the box
        [-0.5, 0.5]^3 m per sensor.
    joint
        "spheroidal" (3 rotational DOF, e.g. the ankle) or "hinge" (e.g. the knee): for a
        hinge the point of the axis closest to both sensors is reported.
    axis
        For ``joint="hinge"``: the axis, as an :class:`AxisResult` or ``(j1, j2)``
        pointing the same physical way; None estimates it from ``gyr1``, ``gyr2`` (and
        the accelerometers, for the relative sign) with :func:`imucal.estimate_axis`'s
        defaults (the same axis ``imucal axis`` reports).
    sign, j2_sign
        For ``joint="hinge"`` with an estimated axis: the sign conventions passed to
        :func:`imucal.estimate_axis`. The point closest to both sensors depends on
        j1 and j2 pointing the same physical way, so pinning ``j2_sign`` (with ``sign``)
        pins the line the point is taken on.
    time_offset, offset_search
        The second sensor's clock lateness, s, as in :func:`imucal.estimate_axis`, found
        here from eq. (3) (for a hinge, the axis is fitted with the same offset).
    time_origin
        Time of the first sample given, s on the recording's clock, for the still
        periods a hinge's estimated axis reports (:func:`imucal.estimate_axis`).
    acc_error
        1-sigma of each accelerometer's error at 1 g, m/s^2 (default 0.05): an offset of
        this size per axis and a scale error of ``acc_error`` / 1 g per axis. Neither is
        fitted: the motion must tell them from a move of the centre, and where it cannot
        (steady circling: an offset b looks like a move of about b / w^2) the 1-sigma
        carries them (``uncertainty_components["acc_error"]``). 0: calibrated sensors.
    settings
        All of the above but ``axis`` as one :class:`imucal.settings.PositionSettings`,
        instead of keyword arguments (giving both, with keyword values other than the
        defaults, is an InputError).

    Returns
    -------
    PositionResult
        o1, o2 (m, each in its sensor's frame; for a hinge the point of the axis closest
        to both sensors), the quality report (uncertainty, identifiability, ``verdict``,
        ``warnings``) and every restart. A position the data cannot identify is still
        returned, with ``blocking`` reasons.

    Raises
    ------
    InputError
        Invalid settings (before any data are used), arrays not (N, 3) of finite numbers
        or of different lengths, a sample rate outside 1-10000 Hz, a window outside the
        recording, or fewer than ``MIN_SAMPLES`` samples left to fit.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, Sec. II-B, III-B
    (eq. 3 and 4); Seel, Raisch, Schauer (2014), "IMU-based joint angle measurement for
    gait analysis", Sensors 14 (the point of a hinge axis closest to both sensors).

    Examples
    --------
    >>> import imucal
    >>> rec = imucal.load_recording("sample_data/circling.h5")
    >>> shank, foot = rec.sensor("shank"), rec.sensor("foot")
    >>> r = imucal.estimate_position(shank.gyr, shank.acc, foot.gyr, foot.acc,
    ...                              rate=rec.rate, seed=1)
    >>> r.verdict, round(r.uncertainty_components["acc_error"]["o1"])  # circling: mm
    ('use with care', 13)
    >>> r = imucal.estimate_position(shank.gyr, shank.acc, foot.gyr, foot.acc,
    ...                              rate=rec.rate, seed=1, acc_error=0.0)  # exact sensors
    >>> r.verdict, (1000 * r.o1).round()  # mm
    ('good', array([101.,  40.,  17.]))
    """
    s = resolve_settings(
        PositionSettings, settings, restarts=restarts, seed=seed, joint=joint, cutoff=cutoff,
        subsample=subsample, subset=subset, start=start, end=end,
        max_iterations=max_iterations, select=select, max_samples=max_samples, sign=sign,
        j2_sign=j2_sign, time_offset=time_offset, offset_search=offset_search,
        time_origin=time_origin, acc_error=acc_error)
    axis = _check_axis(axis, s.joint)
    g1, g2 = check_pair(gyr1, gyr2)
    a1, a2 = check_pair(acc1, acc2, "acc")
    if g1.shape != a1.shape:
        raise InputError(f"gyr and acc have different lengths ({g1.shape[0]}, {a1.shape[0]})")
    rate = check_rate(rate)
    if s.time_offset == "auto":
        return only_the_stillness(_refuse_if_uninformative(
            _with_auto_offset(g1, a1, g2, a2, rate, axis, s)))
    result = _estimate(g1, a1, g2, a2, rate, axis, replace(s, seed=resolve_seed(s.seed)))
    search = given_search(s.offset_search, s.time_offset, rate)
    check_given(result, offset_profile((g1, a1, g2, a2), rate, search), rate, search,
                s.time_offset)
    return only_the_stillness(_refuse_if_uninformative(result))


def _refuse_if_uninformative(result: PositionResult) -> PositionResult:
    """``result`` refused where its 1-sigma, with every part added after the diagnosis
    (the clock offset's), reaches :data:`MAX_INFORMATIVE_SIGMA_MM`: its 2-sigma then spans
    the whole metre a sensor can sit from a joint (:data:`MAX_PLAUSIBLE_OFFSET_M`), as
    the axis is refused at a 1-sigma of 90 deg. An ankle whose foot's clock ran 0.25 s
    late (beyond the search) was `use with care` 437 mm off at a 1-sigma of 545 mm (an
    independent audit)."""
    sigma = max(result.uncertainty_mm.values())
    if not result.blocking and sigma >= MAX_INFORMATIVE_SIGMA_MM:
        result.blocking.append(
            f"the joint position's 1-sigma is {sigma:.0f} mm (at least "
            f"{MAX_INFORMATIVE_SIGMA_MM:g}: its 2-sigma spans the whole "
            f"{1000 * MAX_PLAUSIBLE_OFFSET_M:g} mm a sensor can sit from a joint): the data "
            "do not locate the joint")
    return result


def _estimate(g1, a1, g2, a2, rate, axis, s: PositionSettings, bias_removed: bool = False
              ) -> PositionResult:
    """:func:`estimate_position` with checked inputs, a given time offset and seed; where
    constant gyroscope biases lower eq. (3)'s residual as much as the axis asks
    (:attr:`imucal.gyr_bias.CentreBias.significant`), the estimate from rates corrected by
    them (once: ``bias_removed``)."""
    prepared = prepare(
        (g1, a1), (g2, a2), rate, s,
        cutoff=(lambda w1, w2: spectral_cutoff((w1, w2), rate)) if s.cutoff is None
        else float(s.cutoff),
        fit_signals=lambda sensors, c: _filtered_sensors(sensors, rate, c),
        min_samples=MIN_SAMPLES, what="joint position")
    axis_result, line = _axis_line(prepared, s, axis)
    fit = _fit(prepared, s, line)
    bias = joint_centre_with_bias(prepared.data, fit.estimate)
    if bias is not None and bias.significant and not bias_removed:
        # on simulated circling and protocol with 0.05 rad/s per gyroscope, the corrected
        # ankle is 0.9-1.0 mm off (median) against 2.3-3.0 mm for the plain fit
        result = _estimate(g1 - bias.b1, a1, g2 - bias.b2, a2, rate, axis, s, True)
        result.gyr_bias = bias.report(applied=True)
        return result
    quality = _quality(prepared, s, fit, line, bias)
    warnings, blocking = _diagnose(prepared, s, fit.estimate, quality, line)
    warnings += _acc_at_rest_warnings(((g1, a1), (g2, a2)), rate, s.acc_error)
    if axis_result is not None:
        blocking.extend(f"axis: {w}" for w in axis_result.blocking)
        warnings.extend(f"axis: {w}" for w in axis_result.warnings)
    result = _result(prepared, s, fit, quality, axis_result, line, warnings, blocking)
    if bias is not None and not bias_removed:  # with a removed bias, the caller reports it
        result.gyr_bias = bias.report(applied=False)
    return result


def adopt_offset(own: PositionResult | None, source: dict, found_by: str, gyr1, acc1, gyr2,
                 acc2, *, rate: float, versus: dict | None = None,
                 **options) -> PositionResult:
    """The joint position fitted again at the clock offset another "auto" search of the
    same two sensors applied (a knee's axis: :func:`imucal.calibration.calibrate` keeps
    one offset per joint, :func:`imucal.time_offset.choose`).

    Parameters
    ----------
    own
        This position as estimated with ``time_offset="auto"`` (its own search), or None
        where ``source`` is its own search, made on another axis.
    source
        The other search's ``time_offset`` block (docs/json.md), whose ``time_offset_s``
        (s) is applied.
    found_by
        Which estimate found it, for the block's ``found_by`` (e.g. "axis").
    versus
        Without ``own``: the other estimate's own search (its ``time_offset`` block),
        whose disagreement joins the offset's 1-sigma (the axis carries the warning).
    gyr1, acc1, gyr2, acc2, rate, options
        As given to :func:`estimate_position` for ``own`` (``time_offset`` is replaced).

    Returns
    -------
    PositionResult
        The fit at that offset; ``time_offset`` is ``source``'s block with ``found_by``
        and, with ``own``, ``own`` (this position's own search) and ``disagreement_s``
        (half of it joins ``sigma_s``, with a warning); the offset's 1-sigma is in the
        centre's (:func:`imucal.time_offset.adopt`; no move from its own choice, as for
        an applied offset in "auto").
    """
    result = estimate_position(gyr1, acc1, gyr2, acc2, rate=rate,
                               **{**options, "time_offset": float(source["time_offset_s"])})
    g1, g2 = check_pair(gyr1, gyr2)
    a1, a2 = check_pair(acc1, acc2, "acc")
    search = float(source["search_s"])
    return _refuse_if_uninformative(adopt(
        result, own, offset_profile((g1, a1, g2, a2), check_rate(rate), search), rate,
        source, found_by, _offset_moved, "mm", MAX_UNCERTAINTY_MM, versus=versus,
        warn=False))


def _with_auto_offset(g1, a1, g2, a2, rate, axis, s: PositionSettings) -> PositionResult:
    """The estimate with the clock offset found from eq. (3) itself
    (:func:`imucal.time_offset.fit_with_offset`)."""
    s = replace(s, seed=resolve_seed(s.seed))  # both fits must see the same restarts

    def again(seconds):  # (the search's own fits: no check of their offset)
        return _estimate(g1, a1, g2, a2, rate, axis, s.at_offset(seconds))
    # No offset's choice in the 1-sigma (``state``), unlike the axis: 20 ms move a joint
    # centre by hundreds of mm, so a choice capped at 3 x the model term would always add
    # all of that to every clean fit with a real offset (simulated, 20 ms late: 8 of 10
    # `good` before, 5 with it), and soft tissue has never had an offset applied to a
    # joint centre (docs/accuracy.md: 0 of 80 fits).
    return fit_with_offset(again, offset_profile((g1, a1, g2, a2), rate, s.offset_search), rate,
                           s.offset_search, _offset_moved, "mm", MAX_UNCERTAINTY_MM)


def _check_axis(axis, joint: str):
    """``axis`` as given (None or an :class:`AxisResult`) or as two finite non-zero
    3-vectors (float arrays), else InputError: a usage error before any work (a wrong
    shape failed deep inside numpy, a zero axis as "no restart produced a finite
    result", a third vector was ignored)."""
    if axis is None:
        return None
    if joint != "hinge":
        raise InputError(f"an axis is given only for joint='hinge' (got joint='{joint}')")
    if isinstance(axis, AxisResult):
        return axis
    try:
        j = np.asarray(axis)
        if j.dtype.kind == "c":
            raise TypeError
        j = j.astype(np.float64)
    except (ValueError, TypeError):
        j = None
    if j is None or j.shape != (2, 3):
        raise InputError("axis must be an AxisResult or two real 3-vectors (j1, j2), in the "
                         "first and second sensor's frames")
    size = np.abs(j).max(axis=1)
    if not (np.isfinite(j).all() and (size > 0).all()):
        raise InputError(f"axis must be two finite non-zero 3-vectors, got {j.tolist()}")
    j /= size[:, None]  # (1e200 overflowed the norm: a zero axis, silently)
    return j[0], j[1]


def _axis_line(p: Prepared, s: PositionSettings, axis):
    """(axis result or None, the hinge line (j1, j2) or None) for ``s.joint``."""
    if s.joint != "hinge":
        return None, None
    axis_result = None
    if axis is None:
        axis_result = estimate_axis(
            p.first[0], p.second[0], rate=p.rate, restarts=s.restarts, seed=s.seed,
            subset=s.subset, start=s.start, end=s.end, max_iterations=s.max_iterations,
            select=s.select, max_samples=s.max_samples, acc1=p.first[1], acc2=p.second[1],
            sign=s.sign, j2_sign=s.j2_sign, time_origin=s.time_origin,
            time_offset=0.0,  # the second sensor is already aligned
        )
        axis = (axis_result.j1, axis_result.j2)
    elif isinstance(axis, AxisResult):
        axis_result = axis
        axis = (axis.j1, axis.j2)
    return axis_result, np.concatenate([unit(axis[0]), unit(axis[1])])


def _fit(p: Prepared, s: PositionSettings, line) -> Multistart:
    """The staged multistart of eq. (3) from offsets uniform in the box (Sec. IV)."""
    rng = np.random.default_rng(s.seed)
    x0 = rng.uniform(-INIT_BOX_M, INIT_BOX_M, size=(s.restarts, 6))
    mask = subset_mask(p.samples, s.restarts, s.subset, rng)
    # On a hinge every point of the line has the same cost, so comparing the projected
    # points with the lowest-cost one is fair.
    stages = SPHEROIDAL if line is None else replace(
        SPHEROIDAL, project=partial(closest_point_on_axis, line=line))
    return multistart(stages, p.data, mask, x0, s.max_iterations, rng)


def _quality(p: Prepared, s: PositionSettings, fit: Multistart, line, bias) -> dict:
    """Residual, identifiability, uncertainty and restart agreement at the estimate;
    ``bias``: the centre refitted with gyroscope biases (or None)."""
    x = fit.estimate
    full = _SpheroidalProblem(*p.data, None)
    e, jac = full.linearise(x[None, :])
    e, jac = e[0], jac[0]
    r1 = full.joint_acceleration_norm(0, x[:3])
    r2 = full.joint_acceleration_norm(1, x[3:])
    rms_e = float(np.sqrt(np.mean(e**2)))
    # Relative to the joint-centre accelerations the residual compares.
    scale = float(np.sqrt(np.mean((r1**2 + r2**2) / 2)))
    # On a hinge the direction along the axis is invisible by construction; what is
    # identifiable is the point across it.
    free = np.eye(6) if line is None else _across(line)
    sv = singular_values(jac @ free)
    inner = robust_covariance(e, jac @ free)
    # a singular J^T J (a sensor that never moved) leaves no finite covariance: infinite
    cov = free @ inner @ free.T if np.isfinite(inner).all() else np.full((6, 6), np.inf)
    sensitivity = _cutoff_sensitivity(p, x, line)
    blocks, model = _refits(p.data, x, line, r1 + r2, s.max_iterations)
    components = {
        "curvature": {"o1": float(1000 * np.sqrt(np.trace(cov[:3, :3]))),
                      "o2": float(1000 * np.sqrt(np.trace(cov[3:, 3:])))},
        "time_blocks": blocks,
        "cutoff_shift": cutoff_shifts(sensitivity, ("o1", "o2"), "mm"),
        "model": model,
        "gyr_bias": _bias_move(bias, x, line),
        "acc_error": _acc_error_move(full, x, jac, free, s.acc_error),
    }
    subset_finals = fit.batch.x if line is None else closest_point_on_axis(fit.batch.x, line)
    keep = settled(fit.batch.final_cost, fit.reached)
    count, apart, ratio = equal_minima(fit.finals, fit.refined.final_cost, fit.best,
                                       fit.reached, _position_distance)
    smooth = p.smooth_residual(
        e, lambda *moving: _SpheroidalProblem(*moving, None).linearise(x[None, :])[0][0])
    return {
        "rms": rms_e,
        "smooth": smooth,
        "relative": rms_e / scale if scale > 0 else float("inf"),
        "singular_values": sv,
        "singular_ratio": float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0,
        "excitation": {"rate_rms_deg_s": [rms_rate_deg_s(p.data[0]),
                                          rms_rate_deg_s(p.data[3])],
                       "singular_values_1_s2": sv},
        "sensitivity": sensitivity,
        "components": components,
        "uncertainty": uncertainty_totals(components),
        "fraction": float(fit.reached.mean()),
        "agreement": competing_agreement(fit.refined.final_cost, fit.reached),
        "spread": {k: rms(np.linalg.norm(subset_finals[keep, sl] - x[sl], axis=1) * 1000)
                   for k, sl in (("o1", slice(0, 3)), ("o2", slice(3, 6)))},
        "minima": (count, 1000 * apart, ratio),  # distance in mm
        "weak_direction": (_weak_direction(cov, float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0,
                                           components) if line is None else None),
    }


def _weak_direction(cov: np.ndarray, singular_ratio: float, components: dict) -> dict | None:
    """The least determined direction of (o1, o2) from the (6, 6) curvature covariance
    (m^2), its 1-sigma scaled as the reported total is to the curvature's."""
    if not np.isfinite(cov).all():
        return None
    curvature = np.hypot(*components["curvature"].values())
    total = np.hypot(*uncertainty_totals(components).values())
    # the time blocks and cut-off refits widen the reported sigma beyond the curvature's;
    # the direction they leave weakest is the curvature's
    scale = total / curvature if curvature > 0 else 1.0
    values, vectors = np.linalg.eigh(cov * scale**2)
    v = vectors[:, -1]
    halves = [v[:3], v[3:]]
    norms = [float(np.linalg.norm(h)) for h in halves]
    # the eigenvector's overall sign is arbitrary: make o1's largest component positive
    flip = 1.0 if halves[0][np.argmax(np.abs(halves[0]))] >= 0 else -1.0
    return {
        "o1": (flip * halves[0] / norms[0]).tolist() if norms[0] > 1e-9 else None,
        "o2": (flip * halves[1] / norms[1]).tolist() if norms[1] > 1e-9 else None,
        "along_mm": float(1000 * np.sqrt(max(values[-1], 0.0))),
        "across_mm": float(1000 * np.sqrt(max(values[:-1].sum(), 0.0))),
        "line": bool(singular_ratio < MIN_SINGULAR_RATIO),
    }


def _diagnose(p: Prepared, s: PositionSettings, x: np.ndarray, q: dict,
              line) -> tuple[list[str], list[str]]:
    """(warnings, blocking) of a joint position; thresholds and their reasons in
    docs/quality.md."""
    sv = q["singular_values"]
    # Each singular value far below the largest is a direction of (o1, o2) the data
    # barely see: one is the line of a hinge or of planar motion; three (the point's
    # every coordinate) mean the joint did not move at all.
    weak = int(np.sum(sv < MIN_SINGULAR_RATIO * sv[0])) if sv[0] > 0 else sv.size
    blocking = _blocking(p, x, q, weak)
    warnings: list[str] = []
    if not blocking and weak and line is None:
        d = q["weak_direction"] or {}
        along = (f" (1-sigma {d['along_mm']:.0f} mm along o1 direction "
                 f"{_vector_text(d['o1'])}, {d['across_mm']:.0f} mm across: "
                 "quality.weak_direction)" if d.get("o1") else "")
        warnings.append(
            "motion stays in one plane (or the joint is a hinge): the joint position is only "
            f"known along a line{along}; use --joint hinge for a hinge"
            if weak == 1 else
            f"motion stays close to one axis: {weak} directions of the joint position are "
            "barely determined"
        )
    elif not blocking and weak:
        warnings.append(f"{weak} directions of the point across the hinge axis are barely "
                        "determined")
    if not blocking:
        # an equally good answer outside the reported 1-sigma: the sigma cannot cover it
        blocking = equal_minima_blocking(q["minima"], max(q["uncertainty"].values()),
                                         2000 * AGREEMENT_M, "mm", "joint positions",
                                         "joint centre")
    warnings += disagreement_warning(q["agreement"])
    if q["relative"] > MAX_RELATIVE_RESIDUAL:
        warnings.append(
            f"the {s.joint} joint model fits poorly (residual {q['relative']:.0%} of the "
            "signal)"
        )
    if max(q["uncertainty"].values()) > MAX_UNCERTAINTY_MM:
        warnings.append(uncertainty_warning(q["uncertainty"], q["components"], "mm"))
    if not blocking:
        warnings += _rate_doubt(p, x)
    return warnings, blocking


def _vector_text(v) -> str:
    return "[" + ", ".join(f"{c:+.2f}" for c in v) + "]"


def _blocking(p: Prepared, x: np.ndarray, q: dict, weak: int) -> list[str]:
    """The first reason, if any, why the data cannot identify the joint position (the
    equal minima come after the warnings about weak directions, :func:`_diagnose`)."""
    g1, _, a1, g2, _, a2 = p.data
    # both scales enter eq. (3): wrong units give a confident-looking wrong point
    blocking = stillness_warning(g1, g2) or unit_doubts((g1, g2), (a1, a2))
    if blocking:
        return blocking
    if weak >= 3:
        return [f"the joint barely moved ({weak} of {q['singular_values'].size} directions of "
                "the joint position are undetermined): the joint position is not "
                "identifiable from this recording; record the joint moving in all directions"]
    far = max(np.linalg.norm(x[:3]), np.linalg.norm(x[3:]))
    if far > MAX_PLAUSIBLE_OFFSET_M:
        return [f"the estimate puts the joint {far:.2f} m from a sensor, implausible on a "
                "limb: the data do not determine the joint position"]
    return []


def _rate_doubt(p: Prepared, x: np.ndarray) -> list[str]:
    """The warning, if any, that the sample rate may be wrong: eq. (3) refitted from ``x``
    with the rates' derivative scaled by each of :data:`RATE_SCALES` (a rate ``s`` times
    the one given would scale it so) fits :data:`RATE_DOUBT_GAIN` times better than as
    given. Eq. (1) does not see the rate; eq. (3) does, through dw/dt. A warning, not a
    refusal, and not without a low-pass: a noisy dw/dt (no filter at 500-1000 Hz, gains of
    2.1-3.4; the real recording's impacts, 1.5-1.6 with the filter and 2.5 without) also
    fits better scaled down, and the advice to change a right rate would spoil every
    estimate (a review)."""
    if not p.cutoff:
        return []
    g1, d1, a1, g2, d2, a2 = p.data
    scales = np.array((1.0, *RATE_SCALES))
    n = scales.size

    def each(arr, scaled=False):  # (D, M, 3): one per scale
        return (scales[:, None, None] * arr if scaled else np.broadcast_to(arr, (n, *arr.shape)))

    e, _ = _refit_offsets([each(g1), each(d1, True), each(a1)],
                          [each(g2), each(d2, True), each(a2)], x)
    given, *costs = np.mean(np.square(e), axis=1)
    k = int(np.argmin(costs))
    if not (np.isfinite(given) and costs[k] > 0 and given >= RATE_DOUBT_GAIN * costs[k]):
        return []
    scale = RATE_SCALES[k]
    return [f"the joint-centre constraint fits {given / costs[k]:.1f} x better with the "
            f"angular accelerations scaled by {scale:g}: is the sample rate of {p.rate:g} Hz "
            f"right? The data fit as if recorded at {scale * p.rate:g} Hz (check a file's "
            "rate attribute or --rate); with the rate right, the angular accelerations are "
            "mostly noise or the joint model fits poorly"]


def _result(p: Prepared, s: PositionSettings, fit: Multistart, q: dict, axis_result, line,
            warnings: list[str], blocking: list[str]) -> PositionResult:
    x = fit.estimate
    # distances in q["minima"] are in mm already
    return PositionResult(
        **shared_fields(p, fit, q, unit="mm", settings=_settings_record(p, s),
                        time_offset=s.time_offset, warnings=warnings, blocking=blocking),
        o1=x[:3].copy(),
        o2=x[3:].copy(),
        joint=s.joint,
        uncertainty_mm=q["uncertainty"],
        spread_mm=q["spread"],
        axis=axis_result,
        line=line,
        weak_direction=q["weak_direction"],
    )


def _settings_record(p: Prepared, s: PositionSettings) -> dict:
    """Every setting used, for the result (``settings``)."""
    hinge = s.joint == "hinge"
    return {
        "restarts": s.restarts,
        "seed": s.seed,
        "joint": s.joint,
        "cutoff_hz": p.cutoff,
        "filter": (f"Butterworth order {JOINT_FILTER_ORDER} low-pass, zero phase"
                   if p.cutoff else None),
        "sensitivity": "refits with the cut-off x 0.75 and x 1.5",
        "gdot": "central difference of the filtered gyroscope signal",
        "subsample": p.step,
        "select": s.select,
        "max_samples": s.max_samples if s.select else None,
        "subset_fraction": s.subset,
        "max_iterations": s.max_iterations,
        "axis_sign_convention": s.sign if hinge else None,
        "j2_sign": s.j2_sign if hinge else None,
        "time_offset": s.time_offset,
        "acc_error_m_s2": s.acc_error,
        "step_tolerance_m": STEP_TOLERANCE,
        "restart_step_tolerance_m": RESTART_STEP_TOLERANCE,
        "coarse_samples": COARSE_SAMPLES,
        "coarse_iterations": COARSE_ITERATIONS,
        "cost_tolerance": COST_TOLERANCE,
        "agreement_mm": AGREEMENT_M * 1000,
        "initial_values": f"o1, o2 uniform in [-{INIT_BOX_M}, {INIT_BOX_M}]^3 m",
    }


def _across(line: np.ndarray) -> np.ndarray:
    """(6, 5) orthonormal basis of the directions of (o1, o2) across the hinge line."""
    along = line / np.linalg.norm(line)
    return np.linalg.svd(np.eye(6) - np.outer(along, along))[0][:, :5]


def _cutoff_sensitivity(p: Prepared, x: np.ndarray, line) -> dict:
    """Refit from the estimate ``x`` with the cut-off times 0.75 and 1.5 (no filter: the
    default cut-off and 1.5 times it); shifts in mm."""
    # With the flat joint filter, half the cut-off (6 Hz) would cut the stride's own
    # harmonics: the refits move it by a quarter down and a half up instead.
    rate = p.rate
    pair = sensitivity_cutoffs(p.cutoff, default_joint_cutoff(rate), MAX_CUTOFF_FRACTION * rate,
                               factors=SENSITIVITY_FACTORS)
    data = [tuple(arr[p.window][::p.step][p.selection.index]
                  for sensor in _filtered_sensors((p.first, p.second), rate, c)
                  for arr in sensor) for c in pair]
    y = SPHEROIDAL.refit_each(data, x, SENSITIVITY_ITERATIONS)
    if line is not None:
        y = closest_point_on_axis(y, line)
    shifts = {k: [float(d) for d in 1000 * np.linalg.norm(y[:, sl] - x[sl], axis=1)]
              for k, sl in (("o1", slice(0, 3)), ("o2", slice(3, 6)))}
    return {"cutoffs_hz": list(pair), "o1_shift_mm": shifts["o1"],
            "o2_shift_mm": shifts["o2"], "max_shift_mm": max(shifts["o1"] + shifts["o2"])}


def closest_point_on_axis(x: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Move each (o1, o2) row of ``x`` along the hinge axis to the point closest to both sensors.

    ``x`` (..., 6) holds o1, o2 (joint point to each sensor's origin, m, sensor frames);
    ``line`` (6,) is (j1, j2), unit and pointing the same physical way. Moving the joint
    point along the axis changes o_i to o_i + lambda j_i (the point moves by -lambda); the
    sum of squared distances to both sensor origins, |o1|^2 + |o2|^2, is smallest at
    lambda = -(o1.j1 + o2.j2) / 2.

    Returns
    -------
    (..., 6) ndarray
        ``x`` + lambda ``line`` per row, m.

    References
    ----------
    Seel, Raisch, Schauer (2014), "IMU-based joint angle measurement for gait analysis",
    Sensors 14:6891 (the point of the axis closest to both sensors).

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.position import closest_point_on_axis
    >>> x = np.array([0.0, 0.0, 0.1, 0.0, 0.0, -0.3])  # o1, o2 on the z axis, m
    >>> closest_point_on_axis(x, np.array([0.0, 0.0, 1.0, 0.0, 0.0, 1.0]))
    array([ 0. ,  0. ,  0.2,  0. ,  0. , -0.2])
    """
    j1, j2 = line[:3], line[3:]
    lam = -(x[..., :3] @ j1 + x[..., 3:] @ j2) / 2
    return x + lam[..., None] * line


class _SpheroidalProblem(BatchedProblem):
    """Residual (3) and the normal equations of eq. (4) for many restarts at once.

    ``Gamma_g(o) = (g g^T - |g|^2 I + [gdot]x) o`` is linear in ``o``: each sample's 3x3
    matrix is built once, and every restart's ``a - Gamma(o)`` is one matrix product
    (restarts x 3 samples). So is the Jacobian's ``Gamma^T (a - Gamma o)``, from the fixed
    ``Gamma^T a`` and ``Gamma^T Gamma``. Data subsets are 0/1 weights, so no per-restart
    copies.
    """

    def __init__(self, g1, gdot1, a1, g2, gdot2, a2, mask, dtype=np.float64,
                 newton: bool = False):
        """``mask`` (R, N): 1 where restart r uses sample n; None: all samples for all.
        ``dtype``: precision of the element-wise work; ``newton``: :meth:`normal` returns
        the exact Hessian where it is safely positive definite."""
        self.dtype = dtype
        self.newton = newton
        self.mask = None if mask is None else mask.astype(dtype, copy=False)
        self.n = g1.shape[0]
        self.count = float(self.n) if mask is None else mask.sum(axis=1, dtype=np.float64)
        # Component-major layouts (3, N), so every sum over x, y, z adds three
        # contiguous rows instead of reducing a short inner axis. Per sensor: a^T, the
        # flattened Gamma and Gamma^T Gamma (row i holds component i's coefficient of
        # every output component and sample), Gamma^T a, and the upper triangles of
        # Gamma^T Gamma per sample (N, 6).
        up = np.triu_indices(3)
        self.sensors = []
        for g, gdot, a in ((g1, gdot1, a1), (g2, gdot2, a2)):
            gam = self._gamma(g, gdot)
            gtg = np.einsum("kin,kjn->ijn", gam, gam)
            self.sensors.append((
                np.ascontiguousarray(a.T, dtype=dtype),
                np.ascontiguousarray(gam.transpose(1, 0, 2).reshape(3, -1), dtype=dtype),
                np.ascontiguousarray(gtg.transpose(1, 0, 2).reshape(3, -1), dtype=dtype),
                np.ascontiguousarray(np.einsum("kin,kn->in", gam, a.T), dtype=dtype),
                np.ascontiguousarray(gtg[up[0], up[1]].T, dtype=dtype),
            ))
        self._work = None

    @staticmethod
    def _gamma(g, gdot):
        """(3, 3, N) array G with (Gamma_n o)_k = sum_i G[k, i, n] o_i
        (:func:`imucal.vectors.gamma_rows`)."""
        return gamma_rows(g, gdot).transpose(1, 2, 0)

    def _r(self, k, o, out=None):
        """a - Gamma(o) for sensor k and offsets o (r, 3): (r, 3, N)."""
        at, flat = self.sensors[k][:2]
        # (r, 3) @ (3, 3N): row r holds (Gamma_n o_r)_k for every component k, sample n
        prod = np.matmul(o.astype(self.dtype, copy=False), flat,
                         out=None if out is None else out.reshape(o.shape[0], -1))
        prod = prod.reshape(o.shape[0], 3, self.n)
        return np.subtract(at, prod, out=prod)

    @staticmethod
    def _norm(r, out=None):
        """|r| over the component axis of (r, 3, N), (r, N)."""
        out = np.multiply(r[:, 0], r[:, 0], out=out)
        out += r[:, 1] * r[:, 1]
        out += r[:, 2] * r[:, 2]
        return np.sqrt(out, out=out)

    def _weights(self, rows):
        if self.mask is None:
            return None
        return self.mask if every_row(rows, self.mask.shape[0]) else self.mask[rows]

    def _count(self, rows):
        return self.count if self.mask is None else self.count[rows]

    def joint_acceleration_norm(self, k: int, o: np.ndarray) -> np.ndarray:
        """|a_k - Gamma(o)| per sample for one offset ``o`` (3,), m/s^2."""
        return self._norm(self._r(k, o[None, :]))[0]

    def residual(self, x):
        """e (r, N) for states ``x`` (r, 6)."""
        return self._norm(self._r(0, x[:, :3])) - self._norm(self._r(1, x[:, 3:]))

    def cost(self, x, rows):
        e = self.residual(x)
        we = e if self.mask is None else e * self._weights(rows)
        return np.einsum("ij,ij->i", we, e, dtype=np.float64) / self._count(rows)

    def _buffers(self, r: int):
        """Work arrays for ``r`` restarts, reused across iterations: fresh large
        temporaries cost more (page faults) than the arithmetic on them. The first is
        the stacked left operand of :meth:`normal`'s one batched product."""
        if self._work is None or self._work[0].shape[0] < r:
            self._work = (np.empty((r, 13, self.n), self.dtype),
                          np.empty((r, 3, self.n), self.dtype),
                          np.empty((2, r, self.n), self.dtype))
        return self._work[0][:r], self._work[1][:r], self._work[2][:, :r]

    def _linearise(self, x, rows=None):
        """(stack, norms): ``stack`` (r, 13, N) holds the Jacobian of eq. (4) in rows 0-5
        (times the subset weights when ``rows`` is given) and e in row 6 (not weighted),
        rows 7-12 are work space; ``norms`` (2, r, N) the weighted 1 / |r_k|."""
        r = x.shape[0]
        stack, res, norms = self._buffers(r)
        w = None if rows is None else self._weights(rows)
        for k in (0, 1):
            _, _, mflat, b, _ = self.sensors[k]
            o = x[:, 3 * k:3 * k + 3].astype(self.dtype, copy=False)
            nr = self._norm(self._r(k, o, out=res), out=norms[k])
            stack[:, 6] = nr if k == 0 else stack[:, 6] - nr
            # d|a - Gamma o| / do = -Gamma^T (a - Gamma o) / |r| = (Gamma^T Gamma o -
            # Gamma^T a) / |r|  (eq. 4); e = |r1| - |r2|, so sensor 2's enters negated
            out = stack[:, 3 * k:3 * k + 3]
            np.matmul(o, mflat, out=res.reshape(r, -1))
            if k == 0:
                np.subtract(res, b, out=out)
            else:
                np.subtract(b, res, out=out)
            np.maximum(nr, 1e-12, out=nr)
            np.divide(1.0 if w is None else w, nr, out=nr)
            out *= nr[:, None, :]
        return stack, norms

    def linearise(self, x):
        """e (r, N) and Jacobian (r, N, 6) of eq. (4)."""
        stack, _ = self._linearise(x)
        return stack[:, 6].copy(), np.swapaxes(stack[:, :6], 1, 2).copy()

    def normal(self, x, rows):
        """Cost (r,), J^T J (r, 6, 6) and J^T e (r, 6); with ``newton`` the first matrix
        is the exact Hessian J^T J + sum e H_e where it is safely positive definite.

        The Hessian of |r| = |a - Gamma o| is Gamma^T (I - u u^T) Gamma / |r| with
        u = r / |r|; Gamma^T u is the Jacobian block, so the term is a fixed per-sample
        table Gamma^T Gamma weighted by e / |r|, minus the Jacobian's weighted outer
        products. Gauss-Newton alone converges linearly where the residuals stay large.
        All products of the Jacobian come from one batched product of a stack of rows
        (Jacobian, e, Jacobian blocks times e / |r|) with the Jacobian.
        """
        stack, inv = self._linearise(x, rows)
        e = stack[:, 6]
        w = self._weights(rows)
        we = e if w is None else e * w
        cost = np.einsum("ij,ij->i", we, e, dtype=np.float64) / self._count(rows)
        used = 7
        if self.newton:
            used = 13
            for k in (0, 1):  # c = w e / |r_k| times each Jacobian row of sensor k
                np.multiply(inv[k], e, out=inv[k])
                np.multiply(stack[:, 3 * k:3 * k + 3], inv[k][:, None, :],
                            out=stack[:, 7 + 3 * k:10 + 3 * k])
        prod = (stack[:, :used] @ np.swapaxes(stack[:, :6], 1, 2)).astype(np.float64)
        jtj = prod[:, :6]
        jte = prod[:, 6]
        if not self.newton:
            return cost, jtj, jte
        hess = jtj.copy()
        for k, sign in ((0, 1.0), (1, -1.0)):  # e = |r1| - |r2|
            blk = slice(3 * k, 3 * k + 3)
            part = (inv[k] @ self.sensors[k][4]).astype(np.float64)[:, SYMMETRIC]
            part -= prod[:, 7 + 3 * k:10 + 3 * k, blk]
            hess[:, blk, blk] += sign * part
        return cost, safe_newton(jtj, hess), jte


def offset_profile(signals, rate, search):
    """``result -> refit(deltas)``: eq. (3) over candidate offsets, the joint position
    refitted from ``result`` at each: (D, M) residuals and (D, 6) positions, m
    (:func:`imucal.time_offset.fit_with_offset`).

    Returns
    -------
    profile : callable
        ``result -> refit``, where ``refit(deltas)`` (D,) s gives the (D, M) residuals,
        m/s^2, and the (D, 6) refitted positions, m.
    """
    g1, a1, g2, a2 = signals

    def profile(first):
        cutoff = first.settings["cutoff_hz"]
        index = profile_samples(first.sample_index, g1.shape[0], rate, search)
        first_f, second_f = _filtered_sensors(((g1, a1), (g2, a2)), rate, cutoff)
        own = [arr[index] for arr in first_f]
        read = delayed(np.concatenate(second_f, axis=1), rate)
        x = np.concatenate([first.o1, first.o2])
        # (every: a coarser look, one sample in so many, :func:`estimate_offset`)
        return lambda deltas, every=1: _refit_offsets(
            [arr[::every] for arr in own], np.split(read(index[::every], deltas), 3, axis=2), x)
    return profile


def _refit_offsets(own, other, x) -> tuple[np.ndarray, np.ndarray]:
    """(D, M) residuals of eq. (3) and the (D, 6) positions after ``OFFSET_STEPS`` plain
    Gauss-Newton steps from ``x`` (6,), for each of D offset candidates at once: ``own``
    the first sensor's (g, dg/dt, a), each (M, 3) (or (D, M, 3), one per candidate:
    :func:`_rate_doubt`), ``other`` the second's, each (D, M, 3) (the profile cost of
    each, without the solver's restart machinery).

    Each step is the minimum-norm least-squares step, as ``numpy.linalg.lstsq`` takes it:
    along a hinge's axis the data do not fix the position (a singular value below
    ``eps max(M, 6)`` times the largest counts as zero).
    """
    # component-major (k, i, M) layouts: every operation below runs over samples; the
    # first sensor's are shared by every candidate, or one per candidate (D, M, 3)
    own = [arr if arr.ndim == 3 else arr[None] for arr in own]
    gam1 = np.ascontiguousarray(np.moveaxis(gamma_rows(*own[:2]), -3, -1))  # (1|D, 3, 3, M)
    gam2 = np.ascontiguousarray(np.moveaxis(gamma_rows(*other[:2]), -3, -1))  # (D, 3, 3, M)
    a1, a2 = np.swapaxes(own[2], 1, 2), np.swapaxes(other[2], 1, 2)  # (1|D, 3, M), (D, 3, M)
    y = np.repeat(x[None, :], a2.shape[0], axis=0)

    def linearise(y):
        r1 = a1 - sum(gam1[:, :, i] * y[:, i, None, None] for i in range(3))
        r2 = a2 - sum(gam2[:, :, i] * y[:, 3 + i, None, None] for i in range(3))
        n1, n2 = (np.sqrt(np.sum(r * r, axis=1)) for r in (r1, r2))
        # d|a - Gamma o| / do = -Gamma^T (a - Gamma o) / |a - Gamma o| (eq. 4); e = |r1| -
        # |r2|, so the second sensor's enters negated
        jac = np.concatenate([
            -sum(gam1[:, k] * r1[:, k, None] for k in range(3)) / np.maximum(n1, 1e-12)[:, None],
            sum(gam2[:, k] * r2[:, k, None] for k in range(3)) / np.maximum(n2, 1e-12)[:, None],
        ], axis=1)
        return n1 - n2, np.swapaxes(jac, 1, 2)

    for _ in range(OFFSET_STEPS):
        e, jac = linearise(y)
        u, sv, vt = np.linalg.svd(jac, full_matrices=False)
        keep = sv > np.finfo(float).eps * max(jac.shape[1:]) * sv[:, :1]
        inverse = np.where(keep, 1.0 / np.where(keep, sv, 1.0), 0.0)
        coeff = inverse * np.einsum("dnk,dn->dk", u, -e)
        y = y + np.einsum("dkj,dk->dj", vt, coeff)
    return linearise(y)[0], y


def _offset_moved(result, a, b) -> dict:
    """{"o1", "o2"}: distances between two refitted positions ``a``, ``b`` (6,), mm; for
    a hinge, between their closest points on the axis line (along it nothing is known)."""
    if result.line is not None:
        a, b = closest_point_on_axis(np.stack([a, b]), result.line)
    return {k: float(1000 * np.linalg.norm(a[sl] - b[sl]))
            for k, sl in (("o1", slice(0, 3)), ("o2", slice(3, 6)))}


def _filtered_sensors(sensors, rate, cutoff) -> list[tuple]:
    """Per (g, a) in ``sensors``: the low-passed rates, their derivative and the
    low-passed specific force (full rate), all channels in one filter call (each channel
    is filtered on its own; the call's fixed cost is that of several)."""
    parts = np.split(lowpass(np.concatenate([arr for pair in sensors for arr in pair], axis=1),
                             rate, cutoff, JOINT_FILTER_ORDER), 2 * len(sensors), axis=1)
    return [(gf, derivative(gf, rate), af) for gf, af in zip(parts[0::2], parts[1::2],
                                                             strict=True)]


def _refits(data, x, line, size, max_iterations) -> tuple[dict, dict]:
    """({"o1", "o2"} time blocks, {"o1", "o2"} model term), mm, from refits that start at
    the estimate ``x``: the delete-one-block jackknife (each leaves out one contiguous
    time block of the samples used) and the model term.

    The model term is ``MODEL_MOVE_FACTOR`` times the move of a refit whose samples are
    weighed by ``size**2``, ``size`` (N,) being |r1| + |r2| at the estimate: the
    squared-norm form of eq. (3), |r1|^2 - |r2|^2 = (|r1| - |r2|)(|r1| + |r2|), to first
    order. Where eq. (3) holds, any weighting of its samples has the true centre as its
    minimum, so the two fits differ by noise; soft tissue (or a joint that is no ball)
    makes every weighting find its own compromise, an error the time blocks miss when
    every block shares it. The move is a size for that error, not a bound: the factor was
    set on imucal's simulator (see ``MODEL_MOVE_FACTOR``)."""
    masks = block_masks(data[0].shape[0])
    starts = np.repeat(x[None, :], masks.shape[0] + 1, axis=0)
    y = np.vstack([SPHEROIDAL.refit(data, masks, starts[1:], max_iterations),
                   SPHEROIDAL.refit(_weighted(data, size), None, starts[:1], max_iterations)])
    if line is not None:
        y = closest_point_on_axis(y, line)
    moved = {k: 1000 * np.linalg.norm(y[:, sl] - x[sl], axis=1)
             for k, sl in (("o1", slice(0, 3)), ("o2", slice(3, 6)))}
    return ({k: jackknife_sigma(d[:-1]) for k, d in moved.items()},
            # a refit that failed leaves the model error unknown: infinite, like the blocks'
            {k: float(MODEL_MOVE_FACTOR * d[-1]) if np.isfinite(d[-1]) else float("inf")
             for k, d in moved.items()})


def _bias_move(bias, x, line) -> dict:
    """{"o1", "o2"}: how far, mm, the centre ``x`` moves when constant gyroscope biases are
    fitted with it (``bias``, :func:`imucal.gyr_bias.joint_centre_with_bias`; across the
    axis for a hinge), 0 where the refit could not be made (a residual of 0)."""
    if bias is None:
        return {"o1": 0.0, "o2": 0.0}
    y = bias.o if line is None else closest_point_on_axis(bias.o, line)
    return {k: float(1000 * np.linalg.norm(y[sl] - x[sl]))
            for k, sl in (("o1", slice(0, 3)), ("o2", slice(3, 6)))}


def _acc_error_move(full: _SpheroidalProblem, x: np.ndarray, jac: np.ndarray,
                    free: np.ndarray, acc_error: float) -> dict:
    """{"o1", "o2"}: 1-sigma, mm, of the centre ``x`` due to accelerometer errors eq. (3)
    cannot see: a constant offset (1-sigma ``acc_error`` m/s^2 per axis) and a scale error
    (``acc_error`` / 1 g per axis) of each accelerometer, as consider parameters.

    A bias b in a1 enters eq. (3) as -u1 . b (u1 = r1 / |r1|): where Gamma hardly
    changes (steady circling at rate w) a shift of the centre by about b / w^2 mimics it,
    and the fit takes that shift for the centre. The centre's linear response to the
    errors, ``S = -(J^T J)^-1 J^T J_c`` (across the axis for a hinge), carries their
    priors into its covariance: smaller the better the motion tells an offset from a
    centre (simulated knee centres: 6-12 mm on gait, 17-63 mm on circling)."""
    if acc_error == 0:  # exact accelerometers: nothing to carry, even where J^T J is singular
        return {"o1": 0.0, "o2": 0.0}
    cols = []
    for k, sign in ((0, -1.0), (1, 1.0)):
        r = full._r(k, x[None, 3 * k:3 * k + 3].astype(full.dtype))[0].T.astype(float)
        u = r / np.maximum(np.linalg.norm(r, axis=1), 1e-12)[:, None]
        a = np.asarray(full.sensors[k][0], dtype=float).T
        # a_measured = (1 + s) a + b, so the model's r = a_measured - b - s a - Gamma o
        cols += [sign * acc_error * u, sign * acc_error / ACC_UNITS["g"] * u * a]
    jc = np.hstack(cols)
    jo = jac @ free
    try:
        s = -np.linalg.solve(jo.T @ jo, jo.T @ jc)
    except np.linalg.LinAlgError:
        return {"o1": float("inf"), "o2": float("inf")}
    move = free @ s  # (6, 12): the centre's shift per unit (prior-scaled) error
    return {k: float(1000 * np.sqrt(np.sum(move[sl] ** 2)))
            for k, sl in (("o1", slice(0, 3)), ("o2", slice(3, 6)))}


def _acc_at_rest_warnings(sensors, rate: float, acc_error: float) -> list[str]:
    """A warning per sensor whose reading at rest (:func:`imucal.rest.norm_at_rest`) is
    further from 1 g than ``ACC_REST_SIGMAS`` of the error ``acc_error`` allows along
    gravity (an offset and a scale error: sqrt(2) ``acc_error``), beyond local gravity's
    spread: the accelerometer part of the 1-sigma then assumes too little. The shared
    real recording's sensors read 9.69-10.15 m/s^2 at rest."""
    out = []
    for which, (gyr, acc) in zip(("first", "second"), sensors, strict=True):
        norm = norm_at_rest(gyr, acc, rate)
        if norm is None:
            continue
        off = abs(norm - GRAVITY_M_S2)
        if off > ACC_REST_SIGMAS * np.sqrt(2) * acc_error + LOCAL_GRAVITY_SPREAD_M_S2:
            out.append(
                f"the {which} sensor reads {norm:.2f} m/s^2 at rest, {off:.2f} from 1 g: its "
                f"accelerometer is further off than --acc-error {acc_error:g} m/s^2 "
                "assumes, so the 1-sigma may be too small where the motion cannot tell "
                "such an error from a move of the centre; calibrate the accelerometers, "
                f"or pass --acc-error {off:.2f}")
    return out


def _weighted(data, size) -> tuple:
    """``data`` (g1, gdot1, a1, g2, gdot2, a2) scaled per sample so that eq. (3) on it
    weighs each sample's squared residual by ``size**2`` (normalised to mean 1).

    The problem's subset weights are 0/1 (its normal equations multiply them in twice);
    a weight is a scaling instead: ``Gamma(g, gdot)`` is quadratic in g and linear in
    gdot, so with g scaled by sqrt(c), gdot and a by c, every |a - Gamma o| and the
    residual scale by c, and the squared residual by c^2."""
    mean = float(np.mean(size**2))
    c = (size / np.sqrt(mean) if mean > 0 else np.ones_like(size))[:, None]
    g1, gdot1, a1, g2, gdot2, a2 = data
    root = np.sqrt(c)
    return g1 * root, gdot1 * c, a1 * c, g2 * root, gdot2 * c, a2 * c


def _position_distance(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Larger of |o1 - o1'| and |o2 - o2'|, m."""
    return np.maximum(
        np.linalg.norm(x[..., :3] - y[..., :3], axis=-1),
        np.linalg.norm(x[..., 3:] - y[..., 3:], axis=-1),
    )


def _spheroidal_problem(data, mask, dtype, newton) -> _SpheroidalProblem:
    return _SpheroidalProblem(*data, mask, dtype, newton)


#: Eq. (3) in the staged multistart (:mod:`imucal.multistart`).
SPHEROIDAL = Stages(
    problem=_spheroidal_problem, retract=lambda x, step: x + step,
    distance=_position_distance, agreement=AGREEMENT_M, step_tolerance=STEP_TOLERANCE,
    restart_step_tolerance=RESTART_STEP_TOLERANCE,
    coarse_step_tolerance=COARSE_STEP_TOLERANCE, coarse_samples=COARSE_SAMPLES,
    coarse_iterations=COARSE_ITERATIONS, cost_tolerance=COST_TOLERANCE, max_step=MAX_STEP,
    contraction=True,
)
