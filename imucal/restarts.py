"""What both estimators do around the solver: seeds, data subsets, and the consensus.

Sec. IV of the paper runs 100 restarts, each from random initial values and on a
different subset of the data, and shows that they all land on the same estimate. imucal
does the same and then reports the consensus: the restart that most other restarts
agree with (within a tolerance), refined on all samples.
"""

from __future__ import annotations

import numpy as np


def resolve_seed(seed: int | None) -> int:
    """``seed`` itself, or a fresh one (recorded in results so the run can be repeated)."""
    if seed is None:
        return int(np.random.SeedSequence().generate_state(1, dtype=np.uint32)[0])
    seed = int(seed)
    if seed < 0:
        raise ValueError(f"seed must be non-negative, got {seed}")
    return seed


def random_subsets(n: int, restarts: int, fraction: float, rng: np.random.Generator) -> np.ndarray:
    """(restarts, m) sorted sample indices, each row a random subset of ``fraction`` of ``n``."""
    if not 0 < fraction <= 1:
        raise ValueError(f"subset fraction must be in (0, 1], got {fraction}")
    m = max(1, int(round(fraction * n)))
    if m >= n:
        return np.broadcast_to(np.arange(n), (restarts, n))
    keys = rng.random((restarts, n))
    return np.sort(np.argpartition(keys, m - 1, axis=1)[:, :m], axis=1)


def consensus(distances: np.ndarray, tolerance: float, costs: np.ndarray) -> int:
    """Index of the restart with the most others within ``tolerance``; ties: lowest cost.

    ``distances`` is the (R, R) symmetric matrix of distances between final values
    (NaN for restarts that ended non-finite, which then agree with nobody).
    """
    close = np.nan_to_num(distances, nan=np.inf) <= tolerance
    support = close.sum(axis=1)
    best = np.flatnonzero(support == support.max())
    return int(best[np.argmin(np.nan_to_num(costs[best], nan=np.inf))])
