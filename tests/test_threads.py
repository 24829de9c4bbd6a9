"""The estimators limit BLAS to one thread themselves, so Python callers get the command
line's speed without setting environment variables."""

from __future__ import annotations

from conftest import simulated
from threadpoolctl import threadpool_info, threadpool_limits

import imucal.multistart
from imucal import estimate_axis, estimate_position


def _blas_threads() -> int:
    return max(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas")


def test_estimators_run_blas_on_one_thread_and_restore_it(monkeypatch):
    seen = []
    solve = imucal.multistart.gauss_newton

    def spy(*args, **kwargs):
        seen.append(_blas_threads())
        return solve(*args, **kwargs)

    monkeypatch.setattr(imucal.multistart, "gauss_newton", spy)
    rec, _ = simulated(2)
    th, sh, ft = (rec.sensor(n) for n in ("thigh", "shank", "foot"))
    with threadpool_limits(2, user_api="blas"):  # as an interactive session may run
        estimate_axis(th.gyr, sh.gyr, rate=rec.rate, restarts=3, seed=1, time_offset=0)
        estimate_position(sh.gyr, sh.acc, ft.gyr, ft.acc, rate=rec.rate, restarts=3, seed=1,
                          time_offset=0)
        after = _blas_threads()
    assert len(seen) >= 8 and set(seen) == {1}
    assert after == 2  # the caller's setting is back


def test_estimators_in_threads_restore_the_callers_blas_threads():
    # each call saved and restored the process-wide limit on its own: calls overlapping in
    # a ThreadPoolExecutor restored each other's 1, and BLAS stayed at 1 thread for the
    # rest of the session (a new-user trial, 3 of 3 runs; a race: this test caught the old
    # code in about 1 run of 3, and cannot fail on a shared limit)
    from concurrent.futures import ThreadPoolExecutor

    rec, _ = simulated(2)
    th, sh = rec.sensor("thigh"), rec.sensor("shank")

    def one(seed):
        return estimate_axis(th.gyr, sh.gyr, rate=rec.rate, restarts=20, seed=seed)

    original = threadpool_limits(2, user_api="blas")  # as a session sets it, for good
    try:
        one(1)
        with ThreadPoolExecutor(4) as pool:
            list(pool.map(one, range(12)))
        assert _blas_threads() == 2  # the caller's setting is back
    finally:
        original.restore_original_limits()
