"""The batched solver: stage chaining, the contraction stop, and the axis's Newton steps."""

from __future__ import annotations

import numpy as np
from conftest import simulated

from imucal import estimate_axis
from imucal.axis import _HingeProblem, _random_unit, _retract
from imucal.gauss_newton import chain, gauss_newton
from imucal.restarts import settled


class _Quadratic:
    """Restart r minimises sum (a_r (x - c_r))^2: Gauss-Newton is exact, but the capped
    step makes far starts take several iterations."""

    def __init__(self, c, a):
        self.c, self.a = c, a

    def normal(self, x, rows):
        e = self.a[rows] * (x - self.c[rows])
        jtj = (self.a[rows, 0] ** 2)[:, None, None] * np.eye(2)
        return np.sum(e**2, axis=1), jtj, self.a[rows] * e

    def cost(self, x, rows):
        return np.sum((self.a[rows] * (x - self.c[rows])) ** 2, axis=1)


def _run(problem, x0, limit, **kw):
    return gauss_newton(problem.normal, problem.cost, lambda x, s: x + s, x0,
                        max_iterations=limit, step_tolerance=1e-9, cost_tolerance=0.0,
                        max_step=1.0, **kw)


def test_chained_stages_equal_one_run():
    rng = np.random.default_rng(1)
    problem = _Quadratic(rng.standard_normal((5, 2)), rng.uniform(0.2, 1.0, (5, 1)))
    x0 = 10 * rng.standard_normal((5, 2))
    whole = _run(problem, x0, 50)
    first = _run(problem, x0, 3)
    rows = np.array([0, 2, 3])
    sub = _Quadratic(problem.c[rows], problem.a[rows])
    joined = chain(first, _run(sub, first.x[rows], 50), rows)
    assert joined.iterations[rows].tolist() == whole.iterations[rows].tolist()
    assert joined.iterations[[1, 4]].tolist() == [3, 3]
    for r in rows:
        k = whole.iterations[r]
        assert np.allclose(joined.cost[r, : k + 1], whole.cost[r, : k + 1])
        assert np.isnan(joined.cost[r, k + 1:]).all()
        assert np.allclose(joined.path[: k + 1, r], whole.path[: k + 1, r])
        assert np.allclose(joined.path[k:, r], whole.x[r])
    assert np.array_equal(joined.x[[1, 4]], first.x[[1, 4]])


def test_contraction_stop_goes_on_in_a_flat_valley():
    # x -> 0.95 x per step: a plain step tolerance stops far from the minimum at 0, the
    # distance estimate step * rho / (1 - rho) does not.
    def normal(x, rows):
        return np.sum(x**2, axis=1), np.tile(np.eye(1), (x.shape[0], 1, 1)) * 20.0, x

    def cost(x, rows):
        return np.sum(x**2, axis=1)

    kw = dict(max_iterations=500, step_tolerance=1e-3, cost_tolerance=0.0, max_step=1.0)
    x0 = np.array([[1.0]])
    plain = gauss_newton(normal, cost, lambda x, s: x + s, x0, **kw)
    aware = gauss_newton(normal, cost, lambda x, s: x + s, x0, contraction=True, **kw)
    assert abs(plain.x[0, 0]) > 0.01  # stopped at a step of 1e-3: 0.02 from the minimum
    assert abs(aware.x[0, 0]) < 1e-3


def test_hinge_hessian_matches_finite_differences():
    rng = np.random.default_rng(3)
    g1, g2 = rng.standard_normal((300, 3)), rng.standard_normal((300, 3))
    problem = _HingeProblem(g1, g2, None, newton=True)
    # near a minimum, where the Hessian is positive definite and used
    x = np.concatenate([_random_unit(rng, 1), _random_unit(rng, 1)], axis=1)
    x = gauss_newton(problem.normal, problem.cost, _retract, x, max_iterations=50,
                     step_tolerance=1e-10, cost_tolerance=0.0, max_step=1.0).x
    _, hess, grad = problem.normal(x, np.arange(1))

    def f(s):
        return 300 * problem.cost(_retract(x, s[None, :]), np.arange(1))[0] / 2

    h, eye = 1e-4, np.eye(4)
    numeric = np.array([[(f(h * (eye[i] + eye[k])) - f(h * (eye[i] - eye[k]))
                          - f(h * (eye[k] - eye[i])) + f(-h * (eye[i] + eye[k])))
                         / (4 * h * h) for k in range(4)] for i in range(4)])
    assert np.allclose(hess[0], numeric, rtol=1e-4, atol=1e-4 * np.abs(numeric).max())
    _, jtj, _ = _HingeProblem(g1, g2, None).normal(x, np.arange(1))
    assert np.abs(hess[0] - jtj[0]).max() > 0.05 * np.abs(jtj[0]).max()  # not just J^T J
    assert np.abs(grad).max() < 1e-6


def test_estimate_is_polished_to_the_double_precision_minimum():
    rec, _ = simulated(2)
    g1, g2 = rec.sensor("thigh").gyr, rec.sensor("shank").gyr
    r = estimate_axis(g1, g2, rate=rec.rate, seed=2)
    x = np.concatenate([r.j1, r.j2])[None, :]
    problem = _HingeProblem(r.gyr1, r.gyr2, None, newton=True)
    more = gauss_newton(problem.normal, problem.cost, _retract, x, max_iterations=20,
                        step_tolerance=1e-12, cost_tolerance=0.0, max_step=1.0)
    moved = np.degrees(np.linalg.norm(more.x - x))
    assert moved < 1e-3, moved


def test_spread_leaves_out_subset_fits_stuck_in_a_local_minimum():
    # 40 Hz, seeds 3 and 8: some restarts end their subset fit about 45 deg off at 300 x
    # the typical cost, and still reach the estimate when refined on all samples
    for seed in (3, 8):
        rec, _ = simulated(seed, 40.0)
        r = estimate_axis(rec.sensor("thigh").gyr, rec.sensor("shank").gyr, rate=rec.rate,
                          seed=seed)
        assert r.spread_deg["j1"] < 3 * r.uncertainty_deg["j1"], (r.spread_deg, seed)
        assert r.spread_deg["j2"] < 3 * r.uncertainty_deg["j2"], (r.spread_deg, seed)
    costs = np.array([1.0, 1.1, 0.9, 300.0, 1.0, np.nan])
    reached = np.array([True, True, True, True, False, True])
    assert settled(costs, reached).tolist() == [True, True, True, False, False, False]


def test_spheroidal_newton_matrix_is_the_exact_hessian():
    """The position's Newton steps use the cost's exact Hessian: it matches central
    differences of (1/2) sum e^2 where Gauss-Newton's J^T J is 20 % off (large residuals),
    and J^T e matches the gradient."""
    from imucal.position import _SpheroidalProblem

    rng = np.random.default_rng(3)
    n = 200
    g1, g2 = 3 * rng.standard_normal((n, 3)), 3 * rng.standard_normal((n, 3))
    gd1, gd2 = 10 * rng.standard_normal((n, 3)), 10 * rng.standard_normal((n, 3))
    a1, a2 = 5 * rng.standard_normal((n, 3)), 5 * rng.standard_normal((n, 3))
    newton = _SpheroidalProblem(g1, gd1, a1, g2, gd2, a2, None, np.float64, True)
    plain = _SpheroidalProblem(g1, gd1, a1, g2, gd2, a2, None, np.float64, False)
    x = np.array([0.1, -0.2, 0.05, 0.2, 0.1, -0.1])
    rows = np.arange(1)

    def half_sum(y):
        return 0.5 * n * newton.cost(y[None, :], rows)[0]

    h, eye = 1e-4, np.eye(6) * 1e-4
    hess_fd = np.array([[(half_sum(x + eye[i] + eye[j]) - half_sum(x + eye[i] - eye[j])
                          - half_sum(x - eye[i] + eye[j]) + half_sum(x - eye[i] - eye[j]))
                         / (4 * h * h) for j in range(6)] for i in range(6)])
    grad_fd = np.array([(half_sum(x + eye[i]) - half_sum(x - eye[i])) / (2 * h)
                        for i in range(6)])
    _, hess, jte = newton.normal(x[None, :], rows)
    _, jtj, _ = plain.normal(x[None, :], rows)
    scale = np.abs(hess_fd).max()
    assert np.abs(hess[0] - hess_fd).max() < 1e-5 * scale
    assert np.abs(jtj[0] - hess_fd).max() > 0.1 * scale  # the test can tell them apart
    assert np.abs(jte[0] - grad_fd).max() < 1e-5 * np.abs(grad_fd).max()


def test_last_steps_cost_only_change_nothing(monkeypatch):
    """Restarts that stop after a step get only its cost, not normal equations: the
    iteration counts are those of the solver that always computed them, the states and
    cost traces agree to single-precision rounding (a product over fewer restarts may
    round differently), and fewer restarts go through the normal equations."""
    import imucal.gauss_newton as gn

    rec, _ = simulated(2)
    g1, g2 = rec.sensor("thigh").gyr[::5], rec.sensor("shank").gyr[::5]
    rng = np.random.default_rng(5)
    x0 = np.concatenate([_random_unit(rng, 20), _random_unit(rng, 20)], axis=1)

    def run():
        problem = _HingeProblem(g1, g2, None, np.float32, True)
        rows = [0]

        def normal(x, r):
            rows[0] += x.shape[0]
            return problem.normal(x, r)
        out = gauss_newton(normal, problem.cost, _retract, x0, max_iterations=30,
                           step_tolerance=1e-3, cost_tolerance=1e-12, max_step=0.5,
                           contraction=True)
        return out, rows[0]

    lean, lean_rows = run()
    monkeypatch.setattr(gn, "_last_step", lambda norm, *a: np.zeros(norm.shape, bool))
    full, full_rows = run()
    np.testing.assert_array_equal(lean.iterations, full.iterations)
    np.testing.assert_allclose(lean.x, full.x, rtol=0, atol=1e-5)
    np.testing.assert_allclose(lean.cost, full.cost, rtol=1e-4)
    assert lean_rows <= full_rows - 20  # every restart's last step saved its equations


def test_cholesky_hessian_test_matches_eigenvalues():
    """safe_newton keeps the Hessian exactly where its lowest eigenvalue exceeds the
    bound, whether the whole batch passes the Cholesky test or not."""
    from imucal.multistart import MIN_HESSIAN_EIGENVALUE, safe_newton

    rng = np.random.default_rng(2)
    a = rng.standard_normal((50, 4, 4))
    jtj = a @ np.swapaxes(a, 1, 2) + 0.1 * np.eye(4)
    shift = rng.uniform(-1.0, 1.0, 50)
    hess = jtj + shift[:, None, None] * np.eye(4)
    expect = (np.linalg.eigvalsh(hess)[:, 0]
              > MIN_HESSIAN_EIGENVALUE * np.trace(jtj, axis1=1, axis2=2))
    assert 5 < expect.sum() < 45  # both kinds in the batch
    got = safe_newton(jtj, hess)
    np.testing.assert_array_equal(got[expect], hess[expect])
    np.testing.assert_array_equal(got[~expect], jtj[~expect])
    ok = np.flatnonzero(expect)  # a batch that passes as a whole keeps every Hessian
    np.testing.assert_array_equal(safe_newton(jtj[ok], hess[ok]), hess[ok])


def test_refine_problem_shares_tables_and_matches_a_fresh_one():
    """with_mask(None) gives the same normal equations as a problem built without a
    subset, for both estimators' problems."""
    from imucal.position import _SpheroidalProblem
    from imucal.restarts import subset_mask

    rng = np.random.default_rng(4)
    n, r = 300, 6
    data = tuple(rng.standard_normal((n, 3)) for _ in range(6))
    mask = subset_mask(n, r, 0.5, rng)
    rows = np.arange(r)
    x = np.concatenate([_random_unit(rng, r), _random_unit(rng, r)], axis=1)
    for build, state in ((lambda m: _HingeProblem(data[0], data[1], m, np.float32, True), x),
                         (lambda m: _SpheroidalProblem(*data, m, np.float32, True),
                          0.1 * rng.standard_normal((r, 6)))):
        shared, fresh = build(mask).with_mask(None), build(None)
        for a, b in zip(shared.normal(state, rows), fresh.normal(state, rows), strict=True):
            np.testing.assert_array_equal(a, b)


def test_halved_steps_tried_together_take_the_step_sequential_halving_takes():
    # cost (x - 1)^2 from x = 0: a full step s lowers the cost only where |s - 1| < 1,
    # i.e. after halving k times where s / 2^k < 2. Rows need 0 to 12 halvings, the last
    # never descends (a step of the wrong sign).
    from imucal.gauss_newton import MAX_HALVINGS, _descend

    def cost(x, rows):
        return ((x[:, 0] - 1.0) ** 2)

    steps = np.array([1.5, 3.0, 5.0, 9.0, 30.0, 100.0, 2000.0, 5000.0, -1.0])[:, None]
    x_old = np.zeros_like(steps)
    c_old = cost(x_old, None)
    x_full = x_old + steps
    c_full = cost(x_full, None)
    x_new, c_new, taken, ok = _descend(cost, lambda x, s: x + s, x_old, steps, c_old,
                                       np.arange(steps.shape[0]), x_full, c_full,
                                       c_full <= c_old)
    # sequential halving, one trial at a time
    expected = []
    for s in steps[:, 0]:
        k = next((k for k in range(MAX_HALVINGS + 1) if (s / 2**k - 1) ** 2 <= 1.0), None)
        expected.append(0.0 if k is None else s / 2**k)
    expected = np.array(expected)
    assert np.array_equal(x_new[:, 0], expected)
    assert np.array_equal(taken, np.abs(expected))
    assert np.array_equal(ok, expected != 0)
    assert np.array_equal(c_new, np.where(ok, (expected - 1) ** 2, c_old))


def test_a_batch_of_repeated_rows_the_size_of_all_restarts_uses_their_own_subsets():
    # the halved-step trials repeat rows; when their count happens to equal the number
    # of restarts, each must still be weighted by its own restart's subset
    from imucal.position import _SpheroidalProblem

    rng = np.random.default_rng(4)
    rec, _ = simulated(2)
    mask = (rng.random((4, 300)) < 0.5).astype(float)
    g, a = rec.sensor("shank").gyr[:300], rec.sensor("shank").acc[:300]
    gd = np.gradient(g, axis=0) * rec.rate
    x = rng.normal(scale=0.1, size=(4, 6))
    g1, g2 = rec.sensor("thigh").gyr[:300], rec.sensor("shank").gyr[:300]
    j = _random_unit(rng, 8).reshape(4, 6)
    rows = np.array([1, 3, 1, 3])  # four rows, as many as the restarts
    for problem, state in ((_HingeProblem(g1, g2, mask), j),
                           (_SpheroidalProblem(g, gd, a, g, gd, a[::-1].copy(), mask), x)):
        single = np.array([problem.cost(state[[r]], np.array([r]))[0] for r in rows])
        assert np.allclose(problem.cost(state[rows], rows), single, rtol=1e-12)


def test_many_restarts_go_through_the_problem_in_blocks(monkeypatch):
    """Beyond MAX_CELLS_PER_CALL restarts x samples a problem sees the restarts in blocks
    (10 000 joint-position restarts of 3000 samples took 3.7 GB at once, now about 0.6):
    no call is larger, and the estimate is the one of a single block, to the restarts'
    single-precision rounding."""
    import imucal.multistart as ms
    from imucal import estimate_position
    from imucal.position import _SpheroidalProblem

    rec, _ = simulated(2)
    sh, ft = rec.sensor("shank"), rec.sensor("foot")

    def run():
        return estimate_position(sh.gyr, sh.acc, ft.gyr, ft.acc, rate=rec.rate,
                                 restarts=40, seed=4, time_offset=0)

    cells = []
    normal = _SpheroidalProblem.normal

    def spy(self, x, rows):
        cells.append(x.shape[0] * self.n)
        return normal(self, x, rows)
    monkeypatch.setattr(_SpheroidalProblem, "normal", spy)
    whole = run()
    assert max(cells) > 2 * 5000  # (the cap below splits the stages' calls)
    cells.clear()
    monkeypatch.setattr(ms, "MAX_CELLS_PER_CALL", 5000)
    blocks = run()
    assert max(cells) <= 5000
    np.testing.assert_allclose(blocks.o1, whole.o1, rtol=0, atol=1e-6)
    np.testing.assert_allclose(blocks.o2, whole.o2, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(blocks.reached, whole.reached)
    assert blocks.verdict == whole.verdict


def test_subsets_drawn_in_blocks_are_one_draw(monkeypatch):
    """The subset weights come in single precision, drawn in blocks of rows: the same
    subsets as one draw of all (R, n) numbers (the estimates stay the same)."""
    import imucal.restarts as restarts

    whole = restarts.subset_mask(1000, 50, 0.5, np.random.default_rng(3))
    monkeypatch.setattr(restarts, "MASK_DRAW_VALUES", 3000)  # blocks of 3 rows
    blocks = restarts.subset_mask(1000, 50, 0.5, np.random.default_rng(3))
    once = np.random.default_rng(3).random((50, 1000)) < 0.5
    assert blocks.dtype == np.float32
    np.testing.assert_array_equal(blocks, whole)
    np.testing.assert_array_equal(blocks, once)


def test_the_batched_problems_cost_is_the_constraints_own_residual():
    # the solvers' batched residuals (fast tables, single-precision blocks) are written
    # apart from eq. (1) and eq. (3) as the rest of imucal computes them
    # (vectors.joint_plane_rate, vectors.gamma_rows): tied here at random states
    from imucal.axis import _HingeProblem
    from imucal.position import _SpheroidalProblem
    from imucal.vectors import gamma_rows, joint_plane_rate

    rng = np.random.default_rng(7)
    g1, g2, gd1, gd2, a1, a2 = (rng.standard_normal((400, 3)) for _ in range(6))
    j = rng.standard_normal((5, 2, 3))
    j /= np.linalg.norm(j, axis=2, keepdims=True)
    x = j.reshape(5, 6)
    want = [np.mean((joint_plane_rate(g1, s[0]) - joint_plane_rate(g2, s[1])) ** 2)
            for s in j]
    got = _HingeProblem(g1, g2, None).cost(x, np.arange(5))
    np.testing.assert_allclose(got, want, rtol=1e-10)
    o = 0.2 * rng.standard_normal((5, 6))
    want = [np.mean((np.linalg.norm(a1 - gamma_rows(g1, gd1) @ s[:3], axis=1)
                     - np.linalg.norm(a2 - gamma_rows(g2, gd2) @ s[3:], axis=1)) ** 2)
            for s in o]
    got = _SpheroidalProblem(g1, gd1, a1, g2, gd2, a2, None).cost(o, np.arange(5))
    np.testing.assert_allclose(got, want, rtol=1e-10)
