"""The staged multistart every estimator runs (Sec. IV of the paper), for any problem.

Sec. IV runs 100 restarts, each from random initial values on a different subset of the
data. imucal runs them as one batch through three stages:

1. **restarts**: every restart on its own random subset of the samples, on the
   squared-norm form of the constraint (:mod:`imucal.moments`): its cost and normal
   equations come from moment matrices summed once per subset, so a step of a restart
   costs the same however long the recording is;
2. **refine**: every restart continued on all samples, on the same squared form (one
   moment matrix): comparable costs, so the lowest is that form's least-squares answer
   and the restarts that reach it measure independence from the start;
3. **polish**: every distinct minimum the restarts reached (restarts within
   ``Stages.agreement`` of each other are one), at most ``MAX_POLISHED`` of them, fitted
   in double precision on all samples to the paper's own residual (differences of the
   norms), to the final tolerance. The estimate is the polished minimum with the lowest
   cost; each restart ends at the polished minimum of its basin.

The squared form and the norms have the same zero-residual solutions; with residuals
left, the squared form weighs samples by the size of their norms, so its minima sit
near but not exactly on the norms' minima: the polish moves them there, in one or two
steps.

A problem plugs in as a :class:`Stages`: how to build its batched residual ("problem":
``normal`` and ``cost`` over many restarts, :func:`imucal.gauss_newton.gauss_newton`)
and its moments, how a local step moves a state, and how far two states are apart.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from threadpoolctl import ThreadpoolController

from .errors import InputError
from .gauss_newton import BatchResult, gauss_newton
from .restarts import agreeing, best_restart

#: Precision of the restarts' arithmetic: single precision halves the time of the
#: element-wise work; the estimate itself is polished in double precision.
RESTART_DTYPE = np.float32
#: Newton steps only where the Hessian's smallest eigenvalue exceeds this fraction of
#: the trace of J^T J (else Gauss-Newton): a nearly singular Hessian gives wild steps.
MIN_HESSIAN_EIGENVALUE = 1e-3
#: Iteration limit of the cut-off sensitivity refits (:meth:`Stages.refit_each`): they
#: start at the estimate, and a shift is only reported to a fraction of a degree or mm.
SENSITIVITY_ITERATIONS = 10
#: Entry (i, k) of a symmetric 3 x 3 matrix stored as its upper triangle (6,).
SYMMETRIC = np.array([[0, 1, 2], [1, 3, 4], [2, 4, 5]])


_BLAS: ThreadpoolController | None = None


def one_blas_thread(estimator: Callable) -> Callable:
    """Run ``estimator`` with BLAS limited to one thread (threadpoolctl), as the command
    line does.

    The estimators' matrix products are small (restarts x a few thousand samples): a
    BLAS thread pool spends more on waking and syncing its threads than it saves, and
    on a loaded machine far more. The controller is built on first use, when numpy's and
    scipy's BLAS libraries are loaded, and reused (about 20 us per call).
    """
    @functools.wraps(estimator)
    def limited(*args, **kwargs):
        global _BLAS
        if _BLAS is None:
            _BLAS = ThreadpoolController()
        with _BLAS.limit(limits=1, user_api="blas"):
            return estimator(*args, **kwargs)
    return limited


def safe_newton(jtj: np.ndarray, hess: np.ndarray) -> np.ndarray:
    """Per restart, the exact Hessian ``hess`` (r, k, k) where it is safely positive
    definite, else Gauss-Newton's ``jtj`` (r, k, k).

    Gauss-Newton alone converges only linearly when the residuals stay large; Newton
    steps converge quadratically near a minimum. Far from one the Hessian can be
    indefinite: there J^T J (always positive semi-definite) gives a descent direction.
    "Safely" means the lowest eigenvalue exceeds ``MIN_HESSIAN_EIGENVALUE`` times the
    trace of J^T J, i.e. ``hess - bound I`` is positive definite: tested for the whole
    batch by one Cholesky factorisation, and where that fails row by row by Sylvester's
    criterion (every leading principal minor positive: k small determinants per batch,
    a fraction of the cost of eigenvalues).
    """
    k = hess.shape[-1]
    bound = MIN_HESSIAN_EIGENVALUE * np.trace(jtj, axis1=1, axis2=2)
    shifted = hess - bound[:, None, None] * np.eye(k)
    finite = np.isfinite(shifted).all(axis=(1, 2))
    if finite.all():
        try:  # the usual case near a minimum: one factorisation of the whole batch
            np.linalg.cholesky(shifted)
            return hess
        except np.linalg.LinAlgError:
            pass
    shifted = np.where(finite[:, None, None], shifted, -np.eye(k))
    safe = finite.copy()
    for m in range(1, k + 1):
        safe &= np.linalg.det(shifted[:, :m, :m]) > 0
    # a row whose J^T J is not finite either is dropped by the solver
    return np.where(safe[:, None, None], hess, jtj)


@dataclass(frozen=True)
class Stages:
    """One least-squares problem family and its staged multistart.

    Attributes
    ----------
    problem : ``(data, mask, dtype, newton) -> problem`` with ``normal(x, rows)`` and
        ``cost(x, rows)`` for many restarts, the paper's residual; ``data`` is a tuple of
        per-sample arrays (first axis: samples), ``mask`` (R, N) 0/1 subset weights or
        None (all samples), ``newton`` True for exact-Hessian steps where safe.
    moments : ``data -> problem``: the squared-norm form of the same residual from
        moment matrices (:class:`imucal.moments.QuadraticResidual`), with
        ``with_mask(mask)`` for the restarts' subsets.
    retract : ``(x, step) -> x``: apply local steps (R, k) to states (R, s).
    distance : ``(x, y) -> d``: distance between states (units of ``agreement``).
    agreement : two restarts within this distance found the same estimate.
    step_tolerance : the polished estimate's tolerance (local-coordinate units).
    restart_step_tolerance : the restarts' tolerance (subset and refine stages, and the
        quality refits).
    cost_tolerance : stop when a step lowers the cost by less than this fraction.
    max_step : largest local step per iteration.
    contraction : apply the tolerances to the estimated distance to the minimum
        (:func:`imucal.gauss_newton.gauss_newton`).
    project : ``x -> x`` applied to the refined states before they are compared (e.g. a
        hinge's point moved to its closest point on the axis); None: compared as they are.
    """

    problem: Callable
    moments: Callable
    retract: Callable[[np.ndarray, np.ndarray], np.ndarray]
    distance: Callable[[np.ndarray, np.ndarray], np.ndarray]
    agreement: float
    step_tolerance: float
    restart_step_tolerance: float
    cost_tolerance: float
    max_step: float
    contraction: bool = False
    project: Callable[[np.ndarray], np.ndarray] | None = None

    def solve(self, problem, x0: np.ndarray, max_iterations: int,
              step_tolerance: float) -> BatchResult:
        """Batched Gauss-Newton / Newton on ``problem`` from every row of ``x0``."""
        return gauss_newton(problem.normal, problem.cost, self.retract, x0,
                            max_iterations=max_iterations, step_tolerance=step_tolerance,
                            cost_tolerance=self.cost_tolerance, max_step=self.max_step,
                            contraction=self.contraction)

    def refit(self, data: tuple, mask: np.ndarray | None, x0: np.ndarray,
              max_iterations: int) -> np.ndarray:
        """States (R, s) refitted from ``x0`` (R, s) on ``data`` with subset ``mask``, in
        the restarts' precision and tolerance (the quality refits: they start next to
        their minimum and are reported far more coarsely than the estimate)."""
        problem = self.problem(data, mask, RESTART_DTYPE, True)
        return self.solve(problem, x0, max_iterations, self.restart_step_tolerance).x

    def refit_each(self, datasets: list[tuple], x: np.ndarray,
                   max_iterations: int) -> np.ndarray:
        """(D, s): the state ``x`` (s,) refitted on each of the D ``datasets`` (tuples
        like ``data``, the same number of samples each), as one batch of D restarts, each
        on its own block of the stacked samples: one pass of the solver's fixed costs
        instead of D (the cut-off sensitivity refits)."""
        m = datasets[0][0].shape[0]
        own = np.zeros((len(datasets), len(datasets) * m))
        for k in range(len(datasets)):
            own[k, k * m:(k + 1) * m] = 1.0
        stacked = tuple(np.concatenate(parts) for parts in zip(*datasets, strict=True))
        return self.refit(stacked, own, np.repeat(x[None, :], len(datasets), axis=0),
                          max_iterations)


@dataclass
class Multistart:
    """Outcome of :func:`multistart`.

    Attributes
    ----------
    batch : the restarts on their subsets (squared-norm form).
    refined : each restart refined on all samples (squared-norm form).
    polished : the distinct minima of ``refined``, polished on all samples with the
        paper's residual; row k started from restart ``representatives[k]``.
    representatives : (P,) restart each polished row started from (the lowest-cost
        restart of its basin).
    basin : (R,) row of ``polished`` each restart's basin was polished in; -1 for a
        restart that ended nowhere finite or beyond the ``MAX_POLISHED`` lowest basins.
    finals : (R, s) each restart's polished minimum as compared (after
        ``Stages.project``); its own refined state where ``basin`` is -1.
    final_cost : (R,) the paper's cost (mean square) at ``finals``; NaN where ``basin``
        is -1.
    best : index of the restart the estimate came from (the lowest ``final_cost``).
    reached : (R,) restarts whose final state lies within ``Stages.agreement`` of it.
    """

    batch: BatchResult
    refined: BatchResult
    polished: BatchResult
    representatives: np.ndarray
    basin: np.ndarray
    finals: np.ndarray
    final_cost: np.ndarray
    best: int
    reached: np.ndarray

    @property
    def estimate(self) -> np.ndarray:
        """The best polished (projected) state (s,)."""
        return self.finals[self.best]


#: At most this many distinct minima of the restarts are polished (lowest costs first):
#: restarts scatter over a handful of basins, and a minimum found by none of the lowest
#: ones does not compete for the estimate.
MAX_POLISHED = 12


def multistart(stages: Stages, data: tuple, mask: np.ndarray | None, x0: np.ndarray,
               max_iterations: int) -> Multistart:
    """Every restart of ``x0`` (R, s) through the three stages (module docstring).

    ``data`` is the tuple of per-sample arrays ``stages.problem`` and ``stages.moments``
    take, ``mask`` the (R, N) subset weights (None: every restart sees all samples).
    """
    moments = stages.moments(data)
    batch = stages.solve(moments.with_mask(mask), x0, max_iterations,
                         stages.restart_step_tolerance)
    refined = stages.solve(moments.with_mask(None), batch.x, max_iterations,
                           stages.restart_step_tolerance)
    project = stages.project or (lambda x: x)
    representatives, basin = distinct_minima(project(refined.x), refined.final_cost,
                                             stages.distance, stages.agreement)
    polished = stages.solve(stages.problem(data, None, np.float64, True),
                            refined.x[representatives], max_iterations, stages.step_tolerance)
    finals = project(refined.x).copy()
    final_cost = np.full(finals.shape[0], np.nan)
    inside = basin >= 0
    finals[inside] = project(polished.x)[basin[inside]]
    final_cost[inside] = polished.final_cost[basin[inside]]
    best, _ = best_restart(finals[representatives], final_cost[representatives],
                           stages.distance, stages.agreement)
    best = int(representatives[best])
    return Multistart(batch, refined, polished, representatives, basin, finals, final_cost,
                      best, agreeing(finals, best, stages.distance, stages.agreement))


def distinct_minima(finals: np.ndarray, costs: np.ndarray, distance: Callable,
                    agreement: float) -> tuple[np.ndarray, np.ndarray]:
    """(representatives, basin): the lowest-cost restart of each group of ``finals``
    (R, s) within ``agreement`` of it, lowest costs first, at most ``MAX_POLISHED``; and
    each restart's group (-1: none). One pass per group, not per restart."""
    basin = np.full(finals.shape[0], -1)
    left = np.isfinite(costs) & np.isfinite(finals).all(axis=1)
    representatives = []
    while left.any() and len(representatives) < MAX_POLISHED:
        rep = int(np.flatnonzero(left)[np.argmin(costs[left])])
        near = left & (distance(finals, finals[rep]) <= agreement)
        basin[near] = len(representatives)
        representatives.append(rep)
        left &= ~near
    if not representatives:
        raise InputError("no restart produced a finite result")
    return np.array(representatives), basin
