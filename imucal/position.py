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

from dataclasses import dataclass, field

import numpy as np

from .axis import AxisResult, estimate_axis
from .errors import InputError
from .gauss_newton import BatchResult, gauss_newton, smallest_singular_ratio
from .preprocess import (
    FILTER_ORDER,
    check_pair,
    check_rate,
    default_cutoff,
    derivative,
    lowpass,
    resolve_subsample,
    stillness_warning,
    window_slice,
)
from .restarts import best_restart, check_restarts, random_subsets, resolve_seed

JOINTS = ("spheroidal", "hinge")
#: Two estimates agree when both o1 and o2 are within this distance, m.
AGREEMENT_M = 0.01
#: Initial offsets are uniform in [-INIT_BOX_M, INIT_BOX_M]^3 per sensor, m: a sensor
#: strapped to a thigh, shank or foot sits well within half a metre of the joint.
INIT_BOX_M = 0.5
MAX_ITERATIONS = 50
#: Stop when the step is below this, m (0.01 mm).
STEP_TOLERANCE = 1e-5
COST_TOLERANCE = 1e-9
#: Largest step per iteration, m.
MAX_STEP = 0.5
SUBSET_FRACTION = 0.5
MIN_SAMPLES = 30
MIN_AGREEING_FRACTION = 0.8
MAX_RELATIVE_RESIDUAL = 0.25
#: Smallest over largest singular value of the Jacobian at the estimate below which one
#: direction of (o1, o2) is not determined by the data (the point slides along a line).
MIN_SINGULAR_RATIO = 0.04
#: A sensor strapped to a thigh, shank or foot is never this far from the joint, m.
MAX_PLAUSIBLE_OFFSET_M = 1.0


@dataclass
class PositionResult:
    """Result of :func:`estimate_position`.

    Attributes
    ----------
    o1, o2 : (3,) vector from the joint centre to the first / second sensor's origin, in
        that sensor's frame, m.
    joint : "spheroidal" or "hinge".
    rms_residual : RMS of e(t) at the estimate, m/s^2.
    relative_residual : ``rms_residual`` over the RMS of |a_i - Gamma_i(o_i)|.
    singular_ratio : smallest / largest singular value of the Jacobian at the estimate
        (near 0: the position is only known along a line).
    convergence_fraction : fraction of restarts whose final value, refined on all samples,
        lies within ``AGREEMENT_M`` of the estimate, the refined result with the lowest
        cost (for a hinge: after moving each to its closest point on the axis).
    reached : (R,) which restarts did.
    spread_mm : RMS distance of the agreeing restarts' subset results from the estimate
        per vector, mm: how much the answer depends on the data.
    batch : the restarts on their subsets.
    refined : each restart's result refined on all samples.
    axis : for ``joint="hinge"``, the axis used (j1, j2 aligned), else None.
    warnings, settings, samples_used, window : as in :class:`imucal.axis.AxisResult`.
    """

    o1: np.ndarray
    o2: np.ndarray
    joint: str
    rms_residual: float
    relative_residual: float
    singular_ratio: float
    convergence_fraction: float
    reached: np.ndarray
    spread_mm: dict
    batch: BatchResult
    refined: BatchResult
    settings: dict
    samples_used: int
    window: tuple[float, float]
    axis: AxisResult | None = None
    warnings: list[str] = field(default_factory=list)

    @property
    def confident(self) -> bool:
        return not self.warnings

    @property
    def iterations(self) -> np.ndarray:
        return self.batch.iterations


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
        :func:`imucal.preprocess.default_cutoff` (10 Hz, at most 0.4 x rate); 0: no
        filter. ``gdot`` is the central difference of the filtered gyroscope signal, so
        some low-pass is needed against the noise the difference amplifies.
    subsample
        Use every k-th sample after filtering; None: about 2.5 samples per cut-off period.
    restarts, seed, subset, start, end, max_iterations
        As in :func:`imucal.estimate_axis`. Initial offsets are uniform in the box
        [-0.5, 0.5]^3 m per sensor.
    joint
        "spheroidal" (3 rotational DOF, e.g. the ankle) or "hinge" (e.g. the knee): for a
        hinge the point of the axis closest to both sensors is reported.
    axis
        For ``joint="hinge"``: the axis, as an :class:`AxisResult` or ``(j1, j2)``
        pointing the same physical way; None estimates it from ``gyr1``, ``gyr2`` with
        :func:`imucal.estimate_axis`'s defaults (the same axis ``imucal axis`` reports).
    """
    if joint not in JOINTS:
        raise InputError(f"joint must be one of {', '.join(JOINTS)}, got '{joint}'")
    g1, g2 = check_pair(gyr1, gyr2)
    a1, a2 = check_pair(acc1, acc2)
    if g1.shape != a1.shape:
        raise InputError(f"gyr and acc have different lengths ({g1.shape[0]}, {a1.shape[0]})")
    rate = check_rate(rate)
    restarts = check_restarts(restarts)
    seed = resolve_seed(seed)
    cutoff = default_cutoff(rate) if cutoff is None else float(cutoff)
    step = resolve_subsample(rate, cutoff, subsample)

    win = window_slice(g1.shape[0], rate, start, end)
    sensors = []
    for g, a in ((g1, a1), (g2, a2)):
        gf = lowpass(g, rate, cutoff)
        gdot = derivative(gf, rate)
        af = lowpass(a, rate, cutoff)
        sensors.append(tuple(arr[win][::step] for arr in (gf, gdot, af)))
    n = sensors[0][0].shape[0]
    if n < MIN_SAMPLES:
        raise InputError(
            f"only {n} samples left after window and subsampling; the joint position needs "
            f"at least {MIN_SAMPLES} (about {MIN_SAMPLES * step / rate:.1f} s of motion)"
        )

    line = None
    axis_result = None
    if joint == "hinge":
        if axis is None:
            axis_result = estimate_axis(
                g1, g2, rate=rate, restarts=restarts, seed=seed, subset=subset,
                start=start, end=end,
                max_iterations=max_iterations,
            )
            line = np.concatenate([axis_result.j1, axis_result.j2])
        elif isinstance(axis, AxisResult):
            axis_result = axis
            line = np.concatenate([axis.j1, axis.j2])
        else:
            line = np.concatenate([np.asarray(axis[0], float), np.asarray(axis[1], float)])
        line = np.concatenate([_unit(line[:3]), _unit(line[3:])])

    rng = np.random.default_rng(seed)
    x0 = rng.uniform(-INIT_BOX_M, INIT_BOX_M, size=(restarts, 6))
    idx = random_subsets(n, restarts, subset, rng)
    batch = _solve(_SpheroidalProblem(*sensors[0], *sensors[1], idx), x0, max_iterations)

    # As for the axis: refine every restart on all samples, agree on the refined values,
    # measure the data dependence on the subset values.
    full = _SpheroidalProblem(*sensors[0], *sensors[1], None)
    refined = _solve(full, batch.x, max_iterations)
    finals = refined.x if line is None else closest_point_on_axis(refined.x, line)
    subset_finals = batch.x if line is None else closest_point_on_axis(batch.x, line)
    # On a hinge every point of the line has the same cost, so comparing the projected
    # points with the lowest-cost one is fair.
    best, reached = best_restart(finals, refined.final_cost, _position_distance, AGREEMENT_M)
    x = finals[best]

    e, jac = full.linearise(x[None, :], np.arange(1))
    singular_ratio = smallest_singular_ratio(jac[0])
    r1 = full.joint_acceleration_norm(0, x[:3])
    r2 = full.joint_acceleration_norm(1, x[3:])
    rms = float(np.sqrt(np.mean(e**2)))
    scale = float(np.sqrt(np.mean((r1**2 + r2**2) / 2)))
    relative = rms / scale if scale > 0 else float("inf")

    fraction = float(reached.mean())
    spread = {}
    for name, sl in (("o1", slice(0, 3)), ("o2", slice(3, 6))):
        d = np.linalg.norm(subset_finals[reached, sl] - x[sl], axis=1) * 1000
        spread[name] = float(np.sqrt(np.mean(d**2))) if d.size else float("nan")

    warnings = stillness_warning(sensors[0][0], sensors[1][0])
    far = max(np.linalg.norm(x[:3]), np.linalg.norm(x[3:]))
    if far > MAX_PLAUSIBLE_OFFSET_M:
        warnings.append(
            f"the estimate puts the joint {far:.2f} m from a sensor, implausible on a limb: "
            "the data do not determine the joint position"
        )
    if line is None and singular_ratio < MIN_SINGULAR_RATIO:
        warnings.append(
            "the relative motion stays close to one plane (or the joint is a hinge): the "
            "joint position is only known along a line; use --joint hinge for a hinge"
        )
    if fraction < MIN_AGREEING_FRACTION:
        warnings.append(
            f"restarts disagree: only {fraction:.0%} of them reached the estimate (the lowest "
            "cost found): the answer depends on the starting point"
        )
    if relative > MAX_RELATIVE_RESIDUAL:
        warnings.append(
            f"the {joint} joint model fits poorly (residual {relative:.0%} of the signal)"
        )
    if axis_result is not None:
        warnings.extend(f"axis: {w}" for w in axis_result.warnings)

    settings = {
        "restarts": restarts,
        "seed": seed,
        "joint": joint,
        "cutoff_hz": cutoff,
        "filter": f"Butterworth order {FILTER_ORDER} low-pass, zero phase" if cutoff else None,
        "gdot": "central difference of the filtered gyroscope signal",
        "subsample": step,
        "subset_fraction": subset,
        "max_iterations": max_iterations,
        "step_tolerance_m": STEP_TOLERANCE,
        "cost_tolerance": COST_TOLERANCE,
        "agreement_mm": AGREEMENT_M * 1000,
        "initial_values": f"o1, o2 uniform in [-{INIT_BOX_M}, {INIT_BOX_M}]^3 m",
    }
    return PositionResult(
        o1=x[:3].copy(),
        o2=x[3:].copy(),
        joint=joint,
        rms_residual=rms,
        relative_residual=relative,
        singular_ratio=singular_ratio,
        convergence_fraction=fraction,
        reached=reached,
        spread_mm=spread,
        batch=batch,
        refined=refined,
        settings=settings,
        samples_used=n,
        window=(win.start / rate, win.stop / rate),
        axis=axis_result if joint == "hinge" else None,
        warnings=warnings,
    )


def closest_point_on_axis(x: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Move each (o1, o2) row of ``x`` along the hinge axis to the point closest to both sensors.

    ``line`` is (j1, j2), unit and pointing the same physical way. Moving the joint
    point by lambda along the axis changes o_i to o_i + lambda j_i; the sum of squared
    distances to both sensor origins is smallest at lambda = -(o1.j1 + o2.j2) / 2.
    """
    j1, j2 = line[:3], line[3:]
    lam = -(x[..., :3] @ j1 + x[..., 3:] @ j2) / 2
    return x + lam[..., None] * line


class _SpheroidalProblem:
    """Residual (3) and Jacobian (4) for restarts on sample subsets."""

    def __init__(self, g1, gdot1, a1, g2, gdot2, a2, idx):
        """``idx`` (R, M): each restart's sample indices; None: all samples for all."""
        self.idx = idx
        self.data = [(g1, gdot1, a1, np.sum(g1 * g1, axis=1)),
                     (g2, gdot2, a2, np.sum(g2 * g2, axis=1))]

    def _r(self, k, rows, o):
        """a - Gamma_g(o) for sensor k, restarts ``rows``, offsets o (r, 3): (r, M, 3)."""
        if self.idx is None:
            g, gdot, a, gg = (arr[None] for arr in self.data[k])  # broadcast, no copy
        else:
            sel = self.idx[rows]
            g, gdot, a, gg = (arr[sel] for arr in self.data[k])
        o = o[:, None, :]
        # g x (g x o) = g (g.o) - o |g|^2
        gamma = g * np.sum(g * o, axis=-1, keepdims=True) - o * gg[..., None]
        gamma += np.cross(gdot, o)
        return a - gamma, g, gdot, gg

    def joint_acceleration_norm(self, k: int, o: np.ndarray) -> np.ndarray:
        """|a_k - Gamma(o)| per sample of restart 0's samples, m/s^2."""
        r, *_ = self._r(k, np.arange(1), o[None, :])
        return np.linalg.norm(r[0], axis=-1)

    def residual(self, x, rows):
        r1, *_ = self._r(0, rows, x[:, :3])
        r2, *_ = self._r(1, rows, x[:, 3:])
        return np.linalg.norm(r1, axis=-1) - np.linalg.norm(r2, axis=-1)

    def linearise(self, x, rows):
        parts = []
        norms = []
        for k, sl in ((0, slice(0, 3)), (1, slice(3, 6))):
            r, g, gdot, gg = self._r(k, rows, x[:, sl])
            nr = np.linalg.norm(r, axis=-1)
            # Gamma^T r = g (g.r) - r |g|^2 + r x gdot   (eq. 4)
            gtr = g * np.sum(g * r, axis=-1, keepdims=True) - r * gg[..., None]
            gtr += np.cross(r, gdot)
            parts.append(-gtr / np.maximum(nr, 1e-12)[..., None])
            norms.append(nr)
        return norms[0] - norms[1], np.concatenate([parts[0], -parts[1]], axis=-1)


def _solve(problem: _SpheroidalProblem, x0: np.ndarray, max_iterations: int) -> BatchResult:
    return gauss_newton(
        problem.linearise,
        problem.residual,
        lambda x, step: x + step,
        x0,
        max_iterations=max_iterations,
        step_tolerance=STEP_TOLERANCE,
        cost_tolerance=COST_TOLERANCE,
        max_step=MAX_STEP,
    )


def _unit(v: np.ndarray) -> np.ndarray:
    return np.asarray(v, dtype=np.float64) / np.linalg.norm(v)


def _position_distance(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Larger of |o1 - o1'| and |o2 - o2'|, m."""
    return np.maximum(
        np.linalg.norm(x[..., :3] - y[..., :3], axis=-1),
        np.linalg.norm(x[..., 3:] - y[..., 3:], axis=-1),
    )
