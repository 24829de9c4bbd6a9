"""The staged multistart every estimator runs (Sec. IV of the paper), for any problem.

Sec. IV runs 100 restarts, each from random initial values on a different subset of the
data. imucal runs them as one batch through four stages:

1. **coarse**: every restart on its subset of a shared random sample of a few hundred
   samples, for a few steps: the first, large steps from a random start only have to
   find the basin, and there they cost a fraction of a step on all the data;
2. **restarts**: every restart on its own random subset, in single precision, with
   Newton steps near the minimum, to a tolerance far finer than anything reported about
   the restarts (their agreement and spread);
3. **refine**: every restart continued on all samples (comparable costs: the lowest is
   the least-squares answer, and the share of restarts reaching it measures independence
   from the start), still in single precision;
4. **polish**: the best restart alone, in double precision, to the final tolerance.

A problem plugs in as a :class:`Stages`: how to build its batched residual ("problem":
``normal`` and ``cost`` over many restarts, :func:`imucal.gauss_newton.gauss_newton`),
how a local step moves a state, and how far two states are apart.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from threadpoolctl import ThreadpoolController

from .gauss_newton import BatchResult, chain, gauss_newton
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
#: Restarts x samples one call of a problem's normal equations or cost works on at most:
#: its work arrays grow with both (the joint position's 18 single-precision values per
#: restart and sample), so 10 000 restarts of 3000 samples took 3.7 GB at once; beyond
#: this size the restarts go through in blocks (100 restarts of 3000 samples: one).
MAX_CELLS_PER_CALL = 1_000_000
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

    numpy's floating-point warnings are silenced inside: the estimators detect what does
    not stay finite and say so in their own words (degenerate restarts, "no restart
    produced a finite result"); rates of 1e30 rad/s printed a dozen numpy lines with
    imucal's source lines before that one line.

    Returns
    -------
    callable
        ``estimator`` wrapped (its name, docstring and signature kept by functools.wraps),
        returning what ``estimator`` returns.
    """
    @functools.wraps(estimator)
    def limited(*args, **kwargs):
        _enter_one_thread()
        try:
            with np.errstate(all="ignore"):
                return estimator(*args, **kwargs)
        finally:
            _leave_one_thread()
    return limited


# BLAS's thread count is the process's: calls from several threads (a ThreadPoolExecutor
# in a notebook) or nested ones share one limit, set by the first to enter and restored by
# the last to leave. Each call restoring its own left BLAS at 1 thread for the rest of the
# session after a threaded run (its save and restore crossed; a new-user trial).
_LIMIT_LOCK = threading.Lock()
_LIMIT_USERS = 0
_LIMITER = None


def _enter_one_thread() -> None:
    global _BLAS, _LIMIT_USERS, _LIMITER
    with _LIMIT_LOCK:
        if _BLAS is None:
            _BLAS = ThreadpoolController()
        if _LIMIT_USERS == 0:
            _LIMITER = _BLAS.limit(limits=1, user_api="blas")
        _LIMIT_USERS += 1


def _leave_one_thread() -> None:
    global _LIMIT_USERS, _LIMITER
    with _LIMIT_LOCK:
        _LIMIT_USERS -= 1
        if _LIMIT_USERS == 0 and _LIMITER is not None:
            _LIMITER.restore_original_limits()
            _LIMITER = None


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

    Returns
    -------
    (r, k, k) ndarray
        Row by row ``hess`` where safe, else ``jtj`` (``hess`` itself when every row is
        safe).
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
    # a row whose J^T J is not finite either is dropped by the solver
    safe = finite & _positive_definite(np.where(finite[:, None, None], shifted, -np.eye(k)))
    return np.where(safe[:, None, None], hess, jtj)


def _positive_definite(a: np.ndarray) -> np.ndarray:
    """(r,) whether each symmetric (r, k, k) matrix is positive definite: Gaussian
    elimination without pivoting, all rows at once; every pivot is positive exactly when
    every leading principal minor is (Sylvester's criterion). A few element-wise
    operations per column, less than eigenvalues or k determinants (measured: 110 against
    200 us for 100 4 x 4 matrices)."""
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


class BatchedProblem:
    """Base of the problems a :class:`Stages` builds: ``n`` samples, per-restart 0/1
    subset weights ``mask`` ((R, n), or None: every sample for every restart) in the
    problem's ``dtype``, ``count`` samples each restart uses, and a work buffer ``_work``
    made on first use."""

    n: int
    dtype: type
    mask: np.ndarray | None
    count: float | np.ndarray
    _work: np.ndarray | None

    def with_mask(self, mask: np.ndarray | None):
        """The same data with other subset weights, sharing the per-sample tables (the
        refine stage reuses the subset stage's).

        Returns
        -------
        BatchedProblem
            A shallow copy, of the same class, with ``mask`` (R, n) cast to ``dtype`` (or
            None: every sample), ``count`` the samples per restart ((R,) float64, or float
            ``n``) and no work buffer yet.
        """
        other = object.__new__(type(self))  # a shallow copy
        other.__dict__.update(self.__dict__)
        other.mask = None if mask is None else mask.astype(self.dtype, copy=False)
        other.count = float(self.n) if mask is None else mask.sum(axis=1, dtype=np.float64)
        other._work = None
        return other


@dataclass(frozen=True)
class Stages:
    """One least-squares problem family and its staged multistart.

    Attributes
    ----------
    problem : ``(data, mask, dtype, newton) -> problem`` with ``normal(x, rows)`` and
        ``cost(x, rows)`` for many restarts and ``n``, its number of samples; ``data`` is
        a tuple of per-sample arrays (first axis: samples), ``mask`` (R, N) 0/1 subset
        weights or None (all samples), ``newton`` True for exact-Hessian steps where
        safe; and ``with_mask(mask)``, the same problem with other subset weights (no
        rebuilt tables; :class:`BatchedProblem` provides it).
    retract : ``(x, step) -> x``: apply local steps (R, k) to states (R, s).
    distance : ``(x, y) -> d``: distance between states (units of ``agreement``).
    agreement : two restarts within this distance found the same estimate.
    step_tolerance : the polished estimate's tolerance (local-coordinate units).
    restart_step_tolerance : the restarts' tolerance (subset and refine stages).
    coarse_step_tolerance : the coarse stage's tolerance (finding the basin).
    coarse_samples : samples shared by all restarts in the coarse stage; the stage runs
        when there are at least twice as many samples.
    coarse_iterations : the coarse stage's step limit.
    cost_tolerance : stop when a step lowers the cost by less than this fraction.
    max_step : largest local step per iteration.
    contraction : apply the tolerances to the estimated distance to the minimum
        (:func:`imucal.gauss_newton.gauss_newton`).
    project : ``x -> x`` applied to the refined states before they are compared (e.g. a
        hinge's point moved to its closest point on the axis); None: compared as they are.
    """

    problem: Callable
    retract: Callable[[np.ndarray, np.ndarray], np.ndarray]
    distance: Callable[[np.ndarray, np.ndarray], np.ndarray]
    agreement: float
    step_tolerance: float
    restart_step_tolerance: float
    coarse_step_tolerance: float
    coarse_samples: int
    coarse_iterations: int
    cost_tolerance: float
    max_step: float
    contraction: bool = False
    project: Callable[[np.ndarray], np.ndarray] | None = None

    def solve(self, problem, x0: np.ndarray, max_iterations: int,
              step_tolerance: float) -> BatchResult:
        """Batched Gauss-Newton / Newton on ``problem`` from every row of ``x0`` (R, s), at
        most ``MAX_CELLS_PER_CALL`` restarts x samples per call of its normal equations or
        cost.

        Returns
        -------
        BatchResult
            :func:`imucal.gauss_newton.gauss_newton`'s result for the R restarts.
        """
        block = max(1, MAX_CELLS_PER_CALL // max(1, problem.n))
        return gauss_newton(in_blocks(problem.normal, block), in_blocks(problem.cost, block),
                            self.retract, x0,
                            max_iterations=max_iterations, step_tolerance=step_tolerance,
                            cost_tolerance=self.cost_tolerance, max_step=self.max_step,
                            contraction=self.contraction)

    def refit(self, data: tuple, mask: np.ndarray | None, x0: np.ndarray,
              max_iterations: int) -> np.ndarray:
        """Refit from ``x0`` (R, s) on ``data`` with subset ``mask``, in the restarts'
        precision and tolerance (the quality refits: they start next to their minimum and
        are reported far more coarsely than the estimate).

        Returns
        -------
        x : (R, s) float64
            The refitted states.
        """
        problem = self.problem(data, mask, RESTART_DTYPE, True)
        return self.solve(problem, x0, max_iterations, self.restart_step_tolerance).x

    def refit_each(self, datasets: list[tuple], x: np.ndarray,
                   max_iterations: int) -> np.ndarray:
        """The state ``x`` (s,) refitted on each of the D ``datasets`` (tuples like ``data``,
        the same number of samples each), as one batch of D restarts, each on its own block
        of the stacked samples: one pass of the solver's fixed costs instead of D (the
        cut-off sensitivity refits).

        Returns
        -------
        x : (D, s) float64
            Row d: ``x`` refitted on ``datasets[d]``.
        """
        m = datasets[0][0].shape[0]
        own = np.zeros((len(datasets), len(datasets) * m))
        for k in range(len(datasets)):
            own[k, k * m:(k + 1) * m] = 1.0
        stacked = tuple(np.concatenate(parts) for parts in zip(*datasets, strict=True))
        return self.refit(stacked, own, np.repeat(x[None, :], len(datasets), axis=0),
                          max_iterations)


def in_blocks(fn: Callable, block: int) -> Callable:
    """``fn(x, rows)`` (a problem's ``normal`` or ``cost``) called on at most ``block``
    restarts at a time, its results joined: the same values, bounded memory.

    Returns
    -------
    callable
        ``(x, rows) -> result`` for all rows: ``fn``'s blocks concatenated along the
        restarts' axis (a tuple's entries each).
    """
    def call(x, rows):
        if x.shape[0] <= block:
            return fn(x, rows)
        parts = [fn(x[i:i + block], rows[i:i + block]) for i in range(0, x.shape[0], block)]
        if isinstance(parts[0], tuple):
            return tuple(np.concatenate(p) for p in zip(*parts, strict=True))
        return np.concatenate(parts)
    return call


@dataclass
class Multistart:
    """Outcome of :func:`multistart`.

    Attributes
    ----------
    batch : the restarts on their subsets (the coarse stage's steps first).
    refined : each restart refined on all samples; the best one polished.
    finals : the refined states as compared (after ``Stages.project``), (R, s).
    best : index of the estimate, the refined restart with the lowest cost.
    reached : (R,) restarts whose final state lies within ``Stages.agreement`` of it.
    """

    batch: BatchResult
    refined: BatchResult
    finals: np.ndarray
    best: int
    reached: np.ndarray

    @property
    def estimate(self) -> np.ndarray:
        """The best refined (polished, projected) state (s,)."""
        return self.finals[self.best]


def multistart(stages: Stages, data: tuple, mask: np.ndarray | None, x0: np.ndarray,
               max_iterations: int, rng: np.random.Generator) -> Multistart:
    """Every restart of ``x0`` (R, s) through the four stages (module docstring).

    ``data`` is the tuple of per-sample arrays ``stages.problem`` takes, ``mask`` the
    (R, N) subset weights (None: every restart sees all samples), ``rng`` draws the
    coarse stage's shared samples.

    Returns
    -------
    Multistart
        ``batch`` (coarse and subset stages chained), ``refined`` (every restart on all
        samples, the best one then polished in double precision), ``finals`` (R, s) after
        ``stages.project``, ``best`` and ``reached`` (R,).

    Raises
    ------
    InputError
        (from :func:`imucal.restarts.best_restart`) no restart produced a finite result.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, Sec. IV (restarts from
    random initial values on different subsets of the data).
    """
    n = data[0].shape[0]
    batch = None
    if n >= 2 * stages.coarse_samples:
        cols = np.sort(rng.choice(n, stages.coarse_samples, replace=False))
        coarse = stages.problem(tuple(d[cols] for d in data),
                                None if mask is None else mask[:, cols], RESTART_DTYPE, False)
        batch = stages.solve(coarse, x0, min(max_iterations, stages.coarse_iterations),
                             stages.coarse_step_tolerance)
    subset = stages.problem(data, mask, RESTART_DTYPE, True)
    fitted = stages.solve(subset, x0 if batch is None else batch.x, max_iterations,
                          stages.restart_step_tolerance)
    batch = fitted if batch is None else chain(batch, fitted)

    # the same data without subsets: share the subset problem's tables where it can
    everything = subset.with_mask(None)
    refined = stages.solve(everything, batch.x, max_iterations, stages.restart_step_tolerance)
    project = stages.project or (lambda x: x)
    best, _ = best_restart(project(refined.x), refined.final_cost, stages.distance,
                           stages.agreement)
    polished = stages.solve(stages.problem(data, None, np.float64, True),
                            refined.x[best][None, :], max_iterations, stages.step_tolerance)
    refined = chain(refined, polished, np.array([best]))
    # best is not chosen again: the other restarts' costs are single precision
    finals = project(refined.x)
    return Multistart(batch, refined, finals, best,
                      agreeing(finals, best, stages.distance, stages.agreement))
