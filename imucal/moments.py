"""The restarts' least-squares problems from sufficient statistics: each Gauss-Newton step
of every restart costs the same however many samples there are.

Eq. (1) and eq. (3) compare two norms per sample. Their squared-norm form,

    e = |g1 x j1|^2 - |g2 x j2|^2                       (hinge, from eq. 1)
    e = |a1 - Gamma_1 o1|^2 - |a2 - Gamma_2 o2|^2         (joint centre, from eq. 3)

is, per sample t, a fixed linear combination ``e_t = c_t . q(x)`` of a few monomials
``q(x)`` of the state (the products ``j_a j_b``; for the joint centre also 1 and ``o``).
So the cost of any state over any set of samples is ``q^T C q`` with the moment matrix
``C = sum_t c_t c_t^T``, and so are its Jacobian products: ``J^T e = Q^T C q`` and
``J^T J = Q^T C Q`` with ``Q = dq/dx``. Summing ``C`` once per restart subset (one matrix
product of the 0/1 subset weights with the per-sample products ``c c^T``) makes every
later step independent of the number of samples.

The squared form has the same zero-residual solutions as the norms themselves, and
near them the same minimum; with residuals left (noise, soft tissue) it weighs each
sample's misfit by the sum of the two norms, and two nearly equal minima of the paper's
cost may be one of its. The restarts therefore use it only for their first, large steps
from random starts on their subsets (and the subset spread); they are then refined with
the paper's residual on all samples (:mod:`imucal.multistart`).

The moments are summed in double precision: the cost at a minimum is a small difference
of large moments.
"""

from __future__ import annotations

import numpy as np

from .vectors import tangent_basis

#: Upper triangle of a symmetric 3 x 3 matrix as (row, column) pairs, and the factor each
#: off-diagonal product carries in ``j^T M j = sum_(a<=b) KAPPA M_ab j_a j_b``.
UPPER = np.triu_indices(3)
KAPPA = np.where(UPPER[0] == UPPER[1], 1.0, 2.0)
#: Entry (i, k) of a symmetric 3 x 3 matrix stored as its upper triangle (6,).
SYMMETRIC = np.array([[0, 1, 2], [1, 3, 4], [2, 4, 5]])


def quadratic_monomials(v: np.ndarray) -> np.ndarray:
    """(r, 6) products ``v_a v_b`` (a <= b) of the rows of ``v`` (r, 3)."""
    return v[:, UPPER[0]] * v[:, UPPER[1]]


def monomial_jacobian(v: np.ndarray) -> np.ndarray:
    """(r, 6, 3) derivatives of :func:`quadratic_monomials` with respect to ``v``."""
    r = v.shape[0]
    out = np.zeros((r, 6, 3))
    rows = np.arange(6)
    out[:, rows, UPPER[0]] += v[:, UPPER[1]]
    out[:, rows, UPPER[1]] += v[:, UPPER[0]]
    return out


def monomial_curvature(w: np.ndarray) -> np.ndarray:
    """(..., 3, 3): ``sum_k w_k`` times the Hessian of monomial k, for weights ``w``
    (..., 6) (the Hessian of ``v_a v_b`` is ``E_ab + E_ba``)."""
    doubled = np.where(UPPER[0] == UPPER[1], 2.0, 1.0) * w
    return doubled[..., SYMMETRIC]


class QuadraticResidual:
    """Sum of squares of ``e_t = c_t . q(x)`` over each restart's samples, from moments.

    Subclasses give the monomials ``q`` (r, m), their Jacobian in the local step
    coordinates (r, m, k) and the second-order term of the exact Hessian. ``problem``
    interface of :func:`imucal.gauss_newton.gauss_newton`: ``normal`` and ``cost``.
    """

    def __init__(self, features: np.ndarray):
        """``features`` (N, m): the coefficients ``c_t`` of every sample."""
        n, m = features.shape
        self.n, self.m = n, m
        self.upper = np.triu_indices(m)
        # per-sample upper triangles of c c^T (N, m (m + 1) / 2): a restart subset's
        # moments are one weighted sum of their rows
        self.products = (features[:, self.upper[0]] * features[:, self.upper[1]])
        self.moments = self._full(self.products.sum(axis=0)[None])[0]
        self.count = np.array([float(n)])
        self.newton = True

    def _full(self, packed: np.ndarray) -> np.ndarray:
        """(r, m, m) symmetric matrices from their upper triangles (r, m (m + 1) / 2)."""
        out = np.zeros((packed.shape[0], self.m, self.m))
        out[:, self.upper[0], self.upper[1]] = packed
        out[:, self.upper[1], self.upper[0]] = packed
        return out

    def with_mask(self, mask: np.ndarray | None) -> QuadraticResidual:
        """The same samples with 0/1 subset weights ``mask`` (R, N) per restart (None:
        every restart sees all samples)."""
        other = object.__new__(type(self))
        other.__dict__.update(self.__dict__)
        if mask is None:
            other.count = np.array([float(self.n)])
        else:
            other.moments = self._full(mask @ self.products)
            other.count = mask.sum(axis=1, dtype=np.float64)
        return other

    def _moments(self, rows: np.ndarray) -> np.ndarray:
        return self.moments if self.moments.ndim == 2 else self.moments[rows]

    def _count(self, rows: np.ndarray) -> np.ndarray:
        return self.count if self.count.size == 1 else self.count[rows]

    def cost(self, x: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """(r,) mean squared residual over each restart's samples."""
        q = self.monomials(x)
        v = q @ self._moments(rows) if self.moments.ndim == 2 else \
            (self._moments(rows) @ q[..., None])[..., 0]
        return np.maximum(np.sum(q * v, axis=1), 0.0) / self._count(rows)

    def normal(self, x: np.ndarray, rows: np.ndarray):
        """Cost (r,), the Newton matrix where safely positive definite else J^T J
        (r, k, k), and J^T e (r, k) in local step coordinates."""
        from .multistart import safe_newton  # (multistart imports this module)

        c = self._moments(rows)
        q = self.monomials(x)
        geometry = self.geometry(x)
        jac = self.jacobian(x, geometry)  # (r, m, k)
        if c.ndim == 2:
            v = q @ c
            cq = np.einsum("ij,rjk->rik", c, jac)
        else:
            v = (c @ q[..., None])[..., 0]
            cq = c @ jac
        jt = np.swapaxes(jac, 1, 2)
        jtj = jt @ cq
        jte = (jt @ v[..., None])[..., 0]
        cost = np.maximum(np.sum(q * v, axis=1), 0.0) / self._count(rows)
        if not self.newton:
            return cost, jtj, jte
        return cost, safe_newton(jtj, jtj + self.curvature(x, q, v, geometry)), jte

    def geometry(self, x: np.ndarray):
        """Whatever :meth:`jacobian` and :meth:`curvature` share at ``x`` (None)."""
        return None


class HingeMoments(QuadraticResidual):
    """``e = |g1 x j1|^2 - |g2 x j2|^2``; state (r, 6) = unit j1, j2; local steps in the
    two tangent planes (as :func:`imucal.axis` retracts them)."""

    def __init__(self, g1: np.ndarray, g2: np.ndarray):
        """``g1``, ``g2`` (N, 3): angular rates, rad/s."""
        feats = []
        for g, sign in ((g1, 1.0), (g2, -1.0)):
            # |g x j|^2 = j^T (|g|^2 I - g g^T) j
            m = -g[:, UPPER[0]] * g[:, UPPER[1]]
            m[:, [0, 3, 5]] += np.sum(g * g, axis=1)[:, None]
            feats.append(sign * KAPPA * m)
        super().__init__(np.concatenate(feats, axis=1))

    def monomials(self, x):
        return np.concatenate([quadratic_monomials(x[:, :3]), quadratic_monomials(x[:, 3:])],
                              axis=1)

    def geometry(self, x):
        """The tangent bases of j1 and j2, each (r, 3, 2)."""
        r = x.shape[0]
        both = tangent_basis(x.reshape(2 * r, 3))  # rows j1, j2, j1, j2, ...
        return both[0::2], both[1::2]

    def jacobian(self, x, geometry):
        r = x.shape[0]
        jac = np.zeros((r, 12, 4))
        for k, b in enumerate(geometry):
            j = x[:, 3 * k:3 * k + 3]
            # d(j_a j_b) along a tangent column u is j_a u_b + j_b u_a
            jac[:, 6 * k:6 * k + 6, 2 * k:2 * k + 2] = (
                j[:, UPPER[0], None] * b[:, UPPER[1], :] + j[:, UPPER[1], None] * b[:, UPPER[0], :])
        return jac

    def curvature(self, x, q, v, geometry):
        """sum e * Hessian of e in the tangent planes, with the sphere's own term: the
        retraction bends a step back toward the sphere by ``-|step|^2 j / 2``, which
        adds ``-(gradient . j) I``; the gradient of the quadratic form ``q_s . v_s`` of
        sensor s along its own j is ``2 q_s . v_s``."""
        r = x.shape[0]
        b = np.stack(geometry, axis=1)  # (r, 2, 3, 2)
        w = v.reshape(r, 2, 6)
        side = np.swapaxes(b, 2, 3) @ monomial_curvature(w) @ b  # (r, 2, 2, 2)
        along = 2.0 * np.sum(q.reshape(r, 2, 6) * w, axis=2)
        side -= along[:, :, None, None] * np.eye(2)
        out = np.zeros((r, 4, 4))
        out[:, :2, :2], out[:, 2:, 2:] = side[:, 0], side[:, 1]
        return out


class SpheroidalMoments(QuadraticResidual):
    """``e = |a1 - Gamma_1 o1|^2 - |a2 - Gamma_2 o2|^2``; state (r, 6) = o1, o2 in m,
    Euclidean steps."""

    def __init__(self, gam1: np.ndarray, a1: np.ndarray, gam2: np.ndarray, a2: np.ndarray):
        """``gam`` (N, 3, 3): each sample's ``Gamma`` (``Gamma o`` is the joint centre's
        acceleration relative to the sensor's); ``a`` (N, 3): specific force, m/s^2."""
        n = a1.shape[0]
        feats = np.empty((n, 19))
        feats[:, 0] = np.sum(a1 * a1, axis=1) - np.sum(a2 * a2, axis=1)
        for k, (gam, a, sign) in enumerate(((gam1, a1, 1.0), (gam2, a2, -1.0))):
            # |a - G o|^2 = a.a - 2 (G^T a).o + o^T (G^T G) o
            gta = np.einsum("nki,nk->ni", gam, a)
            gtg = np.einsum("nki,nkj->nij", gam, gam)
            feats[:, 1 + 3 * k:4 + 3 * k] = -2.0 * sign * gta
            feats[:, 7 + 6 * k:13 + 6 * k] = sign * KAPPA * gtg[:, UPPER[0], UPPER[1]]
        super().__init__(feats)

    def monomials(self, x):
        r = x.shape[0]
        return np.concatenate([np.ones((r, 1)), x, quadratic_monomials(x[:, :3]),
                               quadratic_monomials(x[:, 3:])], axis=1)

    def jacobian(self, x, geometry):
        r = x.shape[0]
        jac = np.zeros((r, 19, 6))
        jac[:, 1:7, :] = np.eye(6)
        jac[:, 7:13, :3] = monomial_jacobian(x[:, :3])
        jac[:, 13:19, 3:] = monomial_jacobian(x[:, 3:])
        return jac

    def curvature(self, x, q, v, geometry):
        out = np.zeros((x.shape[0], 6, 6))
        out[:, :3, :3] = monomial_curvature(v[:, 7:13])
        out[:, 3:, 3:] = monomial_curvature(v[:, 13:19])
        return out
