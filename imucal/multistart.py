"""The staged multistart every estimator runs (Sec. IV of the paper), for any problem.

Sec. IV runs 100 restarts, each from random initial values on a different subset of the
data. imucal runs them as one batch through three stages:

1. **restarts**: every restart from its random start on its own random subset of the
   samples, on the squared-norm form of the constraint (:mod:`imucal.moments`): its cost
   and normal equations come from moment matrices summed once per subset, so a step
   costs the same however long the recording is. The large first steps from a random
   start only have to find the basin;
2. **refine**: every restart continued on all samples with the paper's own residual
   (differences of the norms), in single precision, with Newton steps near the minimum:
   the costs are comparable, so the lowest is the least-squares answer, and the share of
   restarts reaching it measures independence from the start;
3. **polish**: the best restart alone, in double precision, to the final tolerance.

The squared form has the same zero-residual solutions as the norms; where residuals
remain it weighs each sample's misfit by the size of its norms, so its minima lie near
but not on the paper's, and where the paper's cost has two nearly equal minima its
squared form may have one. That is why the restarts are refined with the paper's
residual: the basins the refinement finds, their costs and the restarts that reach the
estimate are those of the paper's cost.

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

from .gauss_newton import BatchResult, chain, gauss_newton
from .restarts import agreeing, best_restart, settled

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
    batch by one Cholesky factorisation, and where that fails row by row
    (:func:`_positive_definite`).
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
    safe = finite & _positive_definite(np.where(finite[:, None, None], shifted, -np.eye(k)))
    # a row whose J^T J is not finite either is dropped by the solver
    return np.where(safe[:, None, None], hess, jtj)


def _positive_definite(a: np.ndarray) -> np.ndarray:
    """(r,) whether each symmetric (r, k, k) matrix is positive definite: Gaussian
    elimination without pivoting, all rows at once; every pivot is positive exactly when
    every leading principal minor is (Sylvester's criterion). A few element-wise
    operations per column, a fraction of the cost of eigenvalues or k determinants."""
    a = a.copy()
    ok = np.ones(a.shape[0], dtype=bool)
    # huge entries (impacts on real data) may overflow: inf or NaN pivots read as "not
    # positive definite", which is the safe answer
    with np.errstate(over="ignore", invalid="ignore"):
        for m in range(a.shape[-1]):
            pivot = a[:, m, m]
            ok &= pivot > 0
            pivot = np.where(ok, pivot, 1.0)  # a failed row's later pivots do not matter
            below = a[:, m + 1:, m] / pivot[:, None]
            a[:, m + 1:, m + 1:] -= below[:, :, None] * a[:, m, None, m + 1:]
    return ok


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
    mean : ``(x, ref) -> m``: the mean of states ``x`` (k, s) next to ``ref`` (s,) (e.g.
        of axes without sign); None: the arithmetic mean.
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
    mean: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None

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
    batch : the restarts on their subsets (squared-norm form, :mod:`imucal.moments`).
    refined : each restart refined on all samples with the paper's residual; the best
        one polished.
    finals : the refined states as compared (after ``Stages.project``), (R, s).
    best : index of the estimate, the refined restart with the lowest cost.
    reached : (R,) restarts whose final state lies within ``Stages.agreement`` of it.
    centre : (s,) the mean of the settled subset results that reached the estimate (as
        compared, :func:`imucal.restarts.settled`): they scatter around it, not around
        the estimate, as the squared-norm form's minima lie off the paper's where
        residuals remain.
    """

    batch: BatchResult
    refined: BatchResult
    finals: np.ndarray
    best: int
    reached: np.ndarray
    centre: np.ndarray

    @property
    def estimate(self) -> np.ndarray:
        """The best refined (polished, projected) state (s,)."""
        return self.finals[self.best]


def multistart(stages: Stages, data: tuple, mask: np.ndarray | None, x0: np.ndarray,
               max_iterations: int) -> Multistart:
    """Every restart of ``x0`` (R, s) through the three stages (module docstring).

    ``data`` is the tuple of per-sample arrays ``stages.problem`` and ``stages.moments``
    take, ``mask`` the (R, N) subset weights (None: every restart sees all samples).
    """
    moments = stages.moments(data)
    batch = stages.solve(moments.with_mask(mask), x0, max_iterations,
                         stages.restart_step_tolerance)
    refined = stages.solve(stages.problem(data, None, RESTART_DTYPE, True), batch.x,
                           max_iterations, stages.restart_step_tolerance)
    project = stages.project or (lambda x: x)
    best, _ = best_restart(project(refined.x), refined.final_cost, stages.distance,
                           stages.agreement)
    polished = stages.solve(stages.problem(data, None, np.float64, True),
                            refined.x[best][None, :], max_iterations, stages.step_tolerance)
    refined = chain(refined, polished, np.array([best]))
    # best is not chosen again: the other restarts' costs are single precision
    finals = project(refined.x)
    reached = agreeing(finals, best, stages.distance, stages.agreement)
    keep = settled(batch.final_cost, reached)
    mean = stages.mean or (lambda x, ref: x.mean(axis=0))
    centre = mean(project(batch.x[keep]), finals[best]) if keep.any() else finals[best]
    return Multistart(batch, refined, finals, best, reached, centre)
