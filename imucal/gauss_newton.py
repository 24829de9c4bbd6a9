"""Batched, safeguarded Gauss-Newton: many restarts of one least-squares problem at once.

Every restart is a row of a state array; residuals and Jacobians of all active restarts
come from one vectorised call, the normal equations of all restarts are solved as one
stacked ``numpy.linalg.solve``. Restarts that have converged drop out of the batch, so
late iterations only cost what the slow restarts need.

Safeguards (so no restart produces NaN or runs away):

- a tiny Levenberg damping relative to the trace of J^T J keeps the normal equations
  solvable when the problem is rank-deficient (e.g. joint position on a hinge, where
  every point of the axis fits);
- a step is capped at ``max_step`` (in the units of the local coordinates);
- a step must not increase the cost; otherwise it is halved up to ``MAX_HALVINGS`` times,
  and a restart that still cannot descend stops (it sits at a minimum to machine
  precision).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

MAX_HALVINGS = 12
#: Halved step lengths tried per cost call (:func:`_descend`).
HALVINGS_PER_CALL = 4
#: Largest step ratio trusted when estimating the distance left (``contraction``).
MAX_CONTRACTION = 0.99
#: Damping added to J^T J, relative to its mean diagonal.
RELATIVE_DAMPING = 1e-10


@dataclass
class BatchResult:
    """Outcome of :func:`gauss_newton` for R restarts with state size s.

    Attributes
    ----------
    x : (R, s) final states.
    iterations : (R,) accepted Gauss-Newton steps taken by each restart.
    converged : (R,) True where the step or cost tolerance was met or no step could
        lower the cost; False where the iteration limit stopped the restart.
    cost : (R, K + 1) cost (mean squared residual) at the start and after each
        iteration; NaN after a restart stopped. K is the largest iteration count.
    path : (K + 1, R, s) state at the start and after each iteration; after a restart
        stopped its last state is repeated.
    degenerate : (R,) True where a restart was dropped because its cost or normal
        equations stopped being finite (overflow on extreme data); it keeps its last
        finite state, is not converged, and never counts as an estimate if its cost is
        not finite.
    """

    x: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    cost: np.ndarray
    path: np.ndarray
    degenerate: np.ndarray | None = None

    def __post_init__(self):
        if self.degenerate is None:
            self.degenerate = np.zeros(self.x.shape[0], dtype=bool)

    @property
    def final_cost(self) -> np.ndarray:
        """(R,) cost at each restart's final state."""
        return self.cost[np.arange(self.x.shape[0]), self.iterations]


def gauss_newton(
    normal: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]],
    cost: Callable[[np.ndarray, np.ndarray], np.ndarray],
    retract: Callable[[np.ndarray, np.ndarray], np.ndarray],
    x0: np.ndarray,
    *,
    max_iterations: int,
    step_tolerance: float,
    cost_tolerance: float,
    max_step: float,
    contraction: bool = False,
) -> BatchResult:
    """Run Gauss-Newton from every row of ``x0`` at once.

    Parameters
    ----------
    normal
        ``(x, rows) -> (cost, JtJ, Jte)``: the cost (r,) (mean squared residual), J^T J
        (r, k, k) and J^T e (r, k) with respect to the k local step coordinates, for
        states ``x`` (r, s) of restarts ``rows``.
    cost
        ``(x, rows) -> cost`` (r,), the cost alone (cheaper, for trial steps).
    retract
        ``(x, step) -> x_new``: apply a local step (r, k) to states (r, s).
    x0
        (R, s) initial states.
    max_iterations
        Limit on accepted steps per restart.
    step_tolerance
        Stop when the step norm falls below this (local-coordinate units).
    cost_tolerance
        Stop when a step lowers the cost by less than this fraction of it.
    max_step
        Largest step norm allowed in one iteration.
    contraction
        Apply ``step_tolerance`` to the estimated distance to the minimum instead of the
        step: Gauss-Newton on a problem with residuals converges linearly, each step
        about rho times the last, so the distance left is about step rho / (1 - rho),
        with rho the ratio of the last two steps (0.5 after the first; at most 0.99).
        Restarts in flat valleys (rho near 1) then go on until they are as close as the
        rest, and quickly contracting ones stop a step or two earlier.

    Returns
    -------
    BatchResult
        Per restart the final state ``x`` (R, s), accepted steps ``iterations`` (R,),
        ``converged`` and ``degenerate`` (R,), the cost after each step ``cost``
        (R, K + 1, NaN after the restart stopped) and the states ``path`` (K + 1, R, s),
        K the largest number of steps taken. A restart whose cost or normal equations
        stop being finite is dropped (``degenerate``), never raised on.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.gauss_newton import gauss_newton
    >>> target = np.array([1.0, -2.0])  # cost |x - target|^2 / 2, linear residual
    >>> def cost(x, rows):
    ...     return 0.5 * np.sum((x - target) ** 2, axis=1)
    >>> def normal(x, rows):
    ...     return cost(x, rows), np.repeat(np.eye(2)[None], len(x), 0), x - target
    >>> r = gauss_newton(normal, cost, lambda x, step: x + step, np.zeros((3, 2)),
    ...                  max_iterations=10, step_tolerance=1e-9, cost_tolerance=1e-12,
    ...                  max_step=10.0)
    >>> r.x.round(6), r.converged, r.cost.shape
    (array([[ 1., -2.],
           [ 1., -2.],
           [ 1., -2.]]), array([ True,  True,  True]), (3, 3))
    """
    x = np.array(x0, dtype=np.float64, copy=True)
    n_restarts = x.shape[0]
    iterations = np.zeros(n_restarts, dtype=int)
    converged = np.zeros(n_restarts, dtype=bool)
    active = np.arange(n_restarts)
    costs = [None] * (max_iterations + 1)
    path = [x.copy()]
    last_taken = np.full(n_restarts, np.nan)

    degenerate = np.zeros(n_restarts, dtype=bool)
    c0, jtj, jte = normal(x, active)
    costs[0] = c0.copy()
    current = c0.copy()
    jtj, jte, active = _drop_degenerate(c0, jtj, jte, active, degenerate)

    for it in range(1, max_iterations + 1):
        if active.size == 0:
            break
        step = _gauss_newton_step(jtj, jte)
        norm = _norms(step)
        step *= np.minimum(1.0, max_step / np.maximum(norm, 1e-300))[:, None]
        norm = np.minimum(norm, max_step)

        x_old = x[active]
        c_old = current[active]
        # The full step is tried with ``normal``: it is accepted almost always, and then
        # its normal equations serve the next iteration (no second pass over the data).
        # Restarts that stop after this step whether or not it is accepted (small enough,
        # or at the iteration limit) need its cost only, about a third of the work.
        x_try = retract(x_old, step)
        last = _last_step(norm, last_taken[active], contraction,
                          step_tolerance) | (iterations[active] + 1 >= max_iterations)
        c_try, jtj_try, jte_try = _try(normal, cost, x_try, active, last, jtj.shape)
        first = np.isfinite(c_try) & (c_try <= c_old)
        x_new, c_new, taken, ok = _descend(cost, retract, x_old, step, c_old, active,
                                           x_try, c_try, first)

        x[active] = x_new
        current[active] = c_new
        iterations[active[ok]] += 1
        left = _remaining(taken, last_taken[active], contraction)
        last_taken[active] = taken
        small = (left < step_tolerance) | (c_old - c_new <= cost_tolerance * c_old)
        # A restart whose step cannot lower the cost even when halved many times sits
        # at a minimum to machine precision: that is convergence, too.
        converged[active[(ok & small) | ~ok]] = True
        row_costs = np.full(n_restarts, np.nan)
        row_costs[active] = c_new
        costs[it] = row_costs
        path.append(x.copy())

        keep = ok & ~small & (iterations[active] < max_iterations)
        halved = keep & ~first  # accepted after halving: their equations are still due
        jtj, jte = jtj_try[keep], jte_try[keep]
        active = active[keep]
        if halved.any():
            where = np.flatnonzero(halved[keep])
            _, jtj[where], jte[where] = normal(x[active[where]], active[where])
        jtj, jte, active = _drop_degenerate(current[active], jtj, jte, active, degenerate)

    n_rows = sum(c is not None for c in costs)
    cost_table = np.stack(costs[:n_rows], axis=1)
    # A restart that stopped early has NaN from the next column on; its accepted
    # iterations fill the columns 0..iterations.
    for_col = np.arange(n_rows)[None, :]
    cost_table = np.where(for_col <= iterations[:, None], cost_table, np.nan)
    return BatchResult(
        x=x, iterations=iterations, converged=converged, cost=cost_table, path=np.stack(path),
        degenerate=degenerate,
    )


def _remaining(taken, prev, contraction: bool):
    """Estimated distance left to the minimum after steps of norm ``taken`` that
    followed steps of norm ``prev`` (NaN: none yet); see :func:`gauss_newton`."""
    if not contraction:
        return taken
    rho = np.where(np.isnan(prev), 0.5, taken / np.maximum(prev, 1e-300))
    rho = np.minimum(rho, MAX_CONTRACTION)
    return taken * rho / (1.0 - rho)


def _last_step(norm, prev, contraction: bool, step_tolerance: float) -> np.ndarray:
    """(r,) restarts that converge after the step of norm ``norm``, taken in full or
    halved: the distance left only shrinks with the step taken."""
    return _remaining(norm, prev, contraction) < step_tolerance


def _try(normal, cost, x_try, rows, last, shape):
    """Cost, J^T J and J^T e at the trial states; only the cost where ``last`` (their
    normal equations are never used: those rows get zeros)."""
    if not last.any():
        return normal(x_try, rows)
    c_try = np.empty(rows.size)
    jtj = np.zeros((rows.size,) + shape[1:])
    jte = np.zeros((rows.size, shape[-1]))
    go_on = ~last
    if go_on.any():
        c_try[go_on], jtj[go_on], jte[go_on] = normal(x_try[go_on], rows[go_on])
    c_try[last] = cost(x_try[last], rows[last])
    return c_try, jtj, jte


def _drop_degenerate(cost, jtj, jte, active, degenerate):
    """Stop the active restarts whose cost or normal equations are not finite (marking
    them in ``degenerate``): one such row would otherwise poison the stacked solve."""
    finite = (np.isfinite(cost) & np.isfinite(jtj).all(axis=(1, 2))
              & np.isfinite(jte).all(axis=1))
    if finite.all():
        return jtj, jte, active
    degenerate[active[~finite]] = True
    return jtj[finite], jte[finite], active[finite]


def _gauss_newton_step(jtj: np.ndarray, jte: np.ndarray) -> np.ndarray:
    k = jtj.shape[-1]
    scale = np.trace(jtj, axis1=1, axis2=2) / k
    damping = RELATIVE_DAMPING * scale + 1e-300
    jtj = jtj + damping[:, None, None] * np.eye(k)
    try:
        step = -np.linalg.solve(jtj, jte[..., None])[..., 0]
    except np.linalg.LinAlgError:
        # One exactly singular matrix fails the whole stacked solve (damping below the
        # rounding of huge entries): every row then takes a scaled gradient step, which
        # the step cap and the halving keep safe.
        step = -jte / np.maximum(scale, 1e-300)[:, None]
    return np.where(np.isfinite(step), step, 0.0)


def _descend(cost, retract, x_old, step, c_old, rows, x_full, c_full, good_full):
    """Take ``step`` where it lowers the cost; halve it where it does not.

    ``x_full``, ``c_full``, ``good_full``: the full step, already tried. Returns the new
    states and costs, the norm of the step actually taken (0 where none was) and where a
    step was taken.

    Each restart takes the longest of the halved steps that does not raise the cost, as
    if it halved one step at a time; the trials are made ``HALVINGS_PER_CALL`` lengths at
    a time in one cost call, because a call's fixed cost exceeds that of a few more rows.
    """
    if good_full.all():  # the usual case: every full step lowered the cost
        return x_full, c_full, _norms(step), good_full
    x_new = np.where(good_full[:, None], x_full, x_old)
    c_new = np.where(good_full, c_full, c_old)
    taken = np.where(good_full, 1.0, 0.0)  # fraction of the step taken
    trial = np.flatnonzero(~good_full)
    for first in range(1, MAX_HALVINGS + 1, HALVINGS_PER_CALL):
        fractions = 0.5 ** np.arange(first, min(first + HALVINGS_PER_CALL, MAX_HALVINGS + 1))
        m, t = fractions.size, trial.size
        # fraction-major: trial state (i, q) is row i * t + q
        x_try = retract(np.tile(x_old[trial], (m, 1)),
                        (fractions[:, None, None] * step[trial][None]).reshape(m * t, -1))
        c_try = cost(x_try, np.tile(rows[trial], m)).reshape(m, t)
        good = np.isfinite(c_try) & (c_try <= c_old[trial])
        found = good.any(axis=0)
        longest = np.argmax(good, axis=0)[found]  # the first fraction that descends
        q = np.flatnonzero(found)
        x_new[trial[q]] = x_try.reshape(m, t, -1)[longest, q]
        c_new[trial[q]] = c_try[longest, q]
        taken[trial[q]] = fractions[longest]
        trial = trial[~found]
        if trial.size == 0:
            break
    return x_new, c_new, taken * _norms(step), taken > 0


def every_row(rows: np.ndarray, n: int) -> bool:
    """Whether ``rows`` is each of ``n`` restarts once, in order (a problem may then use
    its per-restart tables as they are). Not the size alone: trial steps repeat rows.

    Returns
    -------
    bool
        True exactly when ``rows`` equals ``arange(n)``.
    """
    return rows.size == n and bool(np.array_equal(rows, np.arange(n)))


def _norms(v: np.ndarray) -> np.ndarray:
    """(r,) Euclidean norms of the rows of ``v`` (r, k): called a few times per
    iteration, where ``np.linalg.norm``'s own overhead exceeds the arithmetic."""
    return np.sqrt(np.einsum("ij,ij->i", v, v))


def chain(first: BatchResult, second: BatchResult, rows: np.ndarray | None = None) -> BatchResult:
    """One result for restarts run by ``first`` and then continued by ``second``.

    ``second`` started from ``first.x[rows]`` (None: every row). Each restart's costs and
    path are its ``first`` iterations followed by its ``second`` ones; restarts not in
    ``rows`` keep their ``first`` history. Both stages must measure the same cost for the
    traces to join smoothly (a stage on other samples shows as a step).

    Returns
    -------
    BatchResult
        R = ``first``'s restarts: ``x``, ``converged`` from ``second`` for ``rows`` (else
        ``first``), ``iterations`` the sum of both, ``degenerate`` in either, ``cost``
        (R, K + 1) and ``path`` (K + 1, R, s) joined per restart (``second``'s column 0,
        its start, not repeated), K the largest combined iteration count.
    """
    n_restarts = first.x.shape[0]
    rows = np.arange(n_restarts) if rows is None else np.asarray(rows)
    it2 = np.zeros(n_restarts, dtype=int)
    it2[rows] = second.iterations
    iterations = first.iterations + it2
    width = int(iterations.max()) + 1

    # column k of restart r: first's column k up to its last iteration, then second's
    # column k - first.iterations[r] (its column 0 repeats first's last state)
    k = np.arange(width)[None, :]
    it1 = first.iterations[:, None]
    in_first = k <= it1
    second_cost = np.full((n_restarts, second.cost.shape[1]), np.nan)
    second_cost[rows] = second.cost
    second_path = np.repeat(first.path[-1:], second.path.shape[0], axis=0)
    second_path[:, rows] = second.path
    k1 = np.minimum(k, first.cost.shape[1] - 1)
    k2 = np.clip(k - it1, 0, second.cost.shape[1] - 1)
    r = np.arange(n_restarts)[:, None]
    cost = np.where(in_first, first.cost[r, k1], second_cost[r, k2])
    cost = np.where(k <= iterations[:, None], cost, np.nan)
    path = np.where(in_first.T[..., None], first.path[k1.T, r.T], second_path[k2.T, r.T])

    x = first.x.copy()
    x[rows] = second.x
    converged = first.converged.copy()
    converged[rows] = second.converged
    degenerate = first.degenerate.copy()
    degenerate[rows] |= second.degenerate
    return BatchResult(x=x, iterations=iterations, converged=converged, cost=cost, path=path,
                       degenerate=degenerate)
