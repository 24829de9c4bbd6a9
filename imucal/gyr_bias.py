"""Constant gyroscope bias seen through the joint constraints themselves: removed from the
hinge axis where eq. (1) asks for it, and from a joint centre where eq. (3) asks for it
(:func:`joint_centre_with_bias`, by the same rule), else a 1-sigma part of it.

A constant bias ``b`` in a gyroscope's reading adds ``-b x j`` to the joint-plane rate
``g x j`` of eq. (1) at every sample. It does not average out: on imucal's simulator
(protocol and gait, 30 s, bias 0.02 rad/s per sensor) it turns the knee axis by
0.2-0.9 deg, against 0.01-0.04 deg without it. The biases' components across each
axis are visible to eq. (1), so the hinge fit can carry them as extra parameters::

    e(t) = |(g1(t) - b1) x j1| - |(g2(t) - b2) x j2|

with a Gaussian prior of ``PRIOR_RAD_S`` per component on ``b1``, ``b2``: the component
along each axis is invisible to eq. (1) and the prior keeps it at zero; everything the
prior lets through must be paid for by the data. The biases are removed only where
that lowers the mean squared residual by ``MIN_COST_RATIO`` (simulated bias
0.02 rad/s: 1.6-3.7; no bias: 1.00; the shared real recording's knees: 1.00-1.04) with
biases a gyroscope can have (``MAX_PLAUSIBLE_RAD_S``; soft tissue sometimes passes the
ratio, 1.1-3.8, but only with biases of 0.06-0.29 rad/s), so where the data do not ask
for it the axis is the plain eq. (1) fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .vectors import cross_rows, gamma_rows, joint_plane_rate, tangent_basis, unit

#: Prior standard deviation of each bias component, rad/s (MEMS gyroscopes after warm-up:
#: 0.005-0.05 rad/s).
PRIOR_RAD_S = 0.02
#: The biases are removed only when they lower the mean squared residual by this factor.
MIN_COST_RATIO = 1.5
#: A constant bias larger than this is not a warmed-up gyroscope's, rad/s (3.4 deg/s):
#: what such a fit absorbs is a smooth model error. Simulated soft tissue (1 deg / 2 mm,
#: 2 deg / 3 mm) that passes the cost ratio asks for 0.11-0.29 rad/s; simulated biases
#: of 0.02 rad/s per sensor are found at 0.007-0.033.
MAX_PLAUSIBLE_RAD_S = 0.06
#: The screening fit uses at most this many samples; a screening cost ratio below
#: ``SCREEN_RATIO`` x ``MIN_COST_RATIO`` is final (real knees: 1.00-1.04; simulated
#: biases of 0.02 rad/s: 1.6 and up).
SCREEN_SAMPLES = 600
SCREEN_RATIO = 0.85
#: Largest number of damped Gauss-Newton steps of a bias fit (it starts at the axis
#: estimate; 3-6 steps reach the minimum).
MAX_STEPS = 20
#: A fit stops when a step lowers the cost by less than this fraction of it; the
#: screening fit only decides, and its cost ratio is reported to three digits.
TOLERANCE = 1e-6
SCREEN_TOLERANCE = 1e-4


class _Biases:
    """What the axis's and the joint centre's bias fits share: biases ``b1``, ``b2``
    (rad/s) and the ``cost_ratio`` they gain, one rule for removing them."""

    b1: np.ndarray
    b2: np.ndarray
    cost_ratio: float

    @property
    def size(self) -> float:
        """The larger of the two biases' magnitudes, rad/s."""
        return float(max(np.linalg.norm(self.b1), np.linalg.norm(self.b2)))

    @property
    def significant(self) -> bool:
        """Worth removing: the biases lower the residual by at least ``MIN_COST_RATIO``
        and are no larger than a gyroscope's bias can be (``MAX_PLAUSIBLE_RAD_S``)."""
        return self.cost_ratio >= MIN_COST_RATIO and self.size <= MAX_PLAUSIBLE_RAD_S

    def _block(self, applied: bool, **extra) -> dict:
        """The JSON block (rad/s)."""
        return {"applied": applied, "b1_rad_s": self.b1.tolist(),
                "b2_rad_s": self.b2.tolist(), "cost_ratio": self.cost_ratio, **extra,
                "prior_rad_s": PRIOR_RAD_S, "min_cost_ratio": MIN_COST_RATIO,
                "max_plausible_rad_s": MAX_PLAUSIBLE_RAD_S}


@dataclass(frozen=True)
class GyrBias(_Biases):
    """Constant gyroscope biases estimated with the hinge axis.

    Attributes
    ----------
    b1, b2 : (3,) bias of the first and second gyroscope across its axis, rad/s, in that
        sensor's frame (the component along the axis is not observable and is 0).
    j1, j2 : (3,) unit axis of the joint fitted together with the biases.
    cost_ratio : mean squared eq. (1) residual without the biases over that with them.
    inflation : (2,) how much estimating the biases widens each axis's uncertainty:
        sqrt(trace) of the axis's covariance with the biases free (under their prior)
        over that with the biases known, >= 1.
    """

    b1: np.ndarray
    b2: np.ndarray
    j1: np.ndarray
    j2: np.ndarray
    cost_ratio: float
    inflation: tuple[float, float] = (1.0, 1.0)

    @property
    def implausible(self) -> bool:
        """The residual asks for a bias no gyroscope has: a smooth model error."""
        return self.cost_ratio >= MIN_COST_RATIO and self.size > MAX_PLAUSIBLE_RAD_S

    def report(self) -> dict:
        """The JSON block (rad/s).

        Returns
        -------
        dict
            "applied" (:attr:`significant`), "b1_rad_s", "b2_rad_s" ((3,) lists, rad/s,
            sensor frames), "cost_ratio", "inflation" ([j1, j2]) and the rule's
            constants "prior_rad_s", "min_cost_ratio", "max_plausible_rad_s".
        """
        return self._block(self.significant, inflation=list(self.inflation))


def estimate_gyr_bias(gyr1: np.ndarray, gyr2: np.ndarray, j1: np.ndarray,
                      j2: np.ndarray) -> GyrBias:
    """Fit (j1, j2, b1, b2) to eq. (1) from the axis estimate ``j1``, ``j2``.

    ``gyr1``, ``gyr2`` (N, 3) are the rates the axis was fitted on, rad/s; ``j1``, ``j2``
    (3,) the unit axis in each sensor's frame. A first fit on every k-th sample (at most
    ``SCREEN_SAMPLES``) decides; only biases that may be worth removing are fitted again
    on all samples.

    Returns
    -------
    GyrBias
        The biases across the fitted axes (rad/s, sensor frames), the axes fitted with
        them, the gain in mean squared residual ``cost_ratio`` and the uncertainty
        ``inflation``; zero biases, the given axes and ratio 1 when the residual is zero
        or not finite or the fit has fewer than 20 samples.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, eq. 1 (the constraint;
    the bias terms and their prior are imucal's).
    """
    step = max(1, int(np.ceil(np.shape(gyr1)[0] / SCREEN_SAMPLES)))
    if step > 1:
        screen = _fit(gyr1[::step], gyr2[::step], j1, j2, SCREEN_TOLERANCE)
        if screen.cost_ratio < SCREEN_RATIO * MIN_COST_RATIO:
            return screen
    return _fit(gyr1, gyr2, j1, j2)


def _fit(gyr1, gyr2, j1, j2, tolerance: float = TOLERANCE) -> GyrBias:
    g1 = np.asarray(gyr1, dtype=float)
    g2 = np.asarray(gyr2, dtype=float)
    e0 = _residual(g1, g2, j1, j2, np.zeros(3), np.zeros(3))
    cost0 = float(np.mean(e0**2))
    if not np.isfinite(cost0) or cost0 <= 0 or g1.shape[0] < 20:
        zero = np.zeros(3)
        return GyrBias(zero, zero, np.asarray(j1, float), np.asarray(j2, float), 1.0)
    # Weighting the prior rows by the residual's own scale makes it a prior of
    # PRIOR_RAD_S per component against samples of that noise level.
    weight = np.sqrt(cost0) / PRIOR_RAD_S

    def rows(p):
        e = _residual(g1, g2, unit(p[:3]), unit(p[3:6]), p[6:9], p[9:12])
        return np.concatenate([e, weight * p[6:12]])

    def jacobian(p):
        jac = np.zeros((g1.shape[0] + 6, 12))
        for k, (g, sign) in enumerate(((g1, 1.0), (g2, -1.0))):
            q = p[3 * k:3 * k + 3]
            j = unit(q)
            h = g - p[6 + 3 * k:9 + 3 * k]
            u = cross_rows(h, j)
            n = np.maximum(np.linalg.norm(u, axis=1), 1e-12)[:, None]
            # d|h x j|/dj = (u x h)/n, taken back through j = q/|q|; d/db = (u x j)/n
            dj = cross_rows(u, h) / n
            jac[:-6, 3 * k:3 * k + 3] = sign * (dj - (dj @ j)[:, None] * j) / np.linalg.norm(q)
            jac[:-6, 6 + 3 * k:9 + 3 * k] = sign * cross_rows(u, j) / n
        jac[-6:, 6:] = weight * np.eye(6)
        return jac

    p = _levenberg_marquardt(rows, jacobian, np.concatenate([j1, j2, np.zeros(6)]),
                             tolerance)
    k1, k2 = unit(p[:3]), unit(p[3:6])
    b1, b2 = _across(p[6:9], k1), _across(p[9:12], k2)
    cost = float(np.mean(_residual(g1, g2, k1, k2, b1, b2) ** 2))
    ratio = cost0 / cost if cost > 0 else float("inf")
    inflation = _inflation(jacobian(np.concatenate([k1, k2, b1, b2]))[:-6], k1, k2, weight)
    return GyrBias(b1, b2, k1, k2, float(ratio), inflation)


def _levenberg_marquardt(rows, jacobian, p: np.ndarray, tolerance: float) -> np.ndarray:
    """A few damped Gauss-Newton steps from ``p``, which starts next to the minimum (the
    axis estimate, no bias): scipy's general solver spent 25 ms per axis on its
    bookkeeping for what takes a handful of 12 x 12 solves."""
    r = rows(p)
    cost = r @ r
    damping = 1e-3
    for _ in range(MAX_STEPS):
        jac = jacobian(p)
        jtj = jac.T @ jac
        grad = jac.T @ r
        # damping on the diagonal also fixes the lengths of j1, j2, which eq. (1) and
        # the unit vectors built from them do not see
        scale = np.diag(jtj) + 1e-12 * np.trace(jtj) + 1e-300
        try:
            step = -np.linalg.solve(jtj + damping * np.diag(scale), grad)
        except np.linalg.LinAlgError:
            break
        trial = p + step
        r_trial = rows(trial)
        cost_trial = r_trial @ r_trial
        if np.isfinite(cost_trial) and cost_trial < cost:
            converged = cost - cost_trial < tolerance * cost
            p, r, cost, damping = trial, r_trial, cost_trial, damping / 3
            if converged:
                break
        else:
            # a step whose own model promises less than the convergence tolerance cannot
            # be beaten by a more damped one (a shorter step promises less still): p sits
            # at the minimum to that tolerance, as an accepted step that gained so little
            # would say. Without this, a start at the minimum to rounding (the estimate)
            # failed its step and raised the damping ten times over, one Jacobian each.
            # (the model's drop of cost = r.r: |r|^2 - |r + J step|^2)
            promised = -(2.0 * (grad @ step) + step @ jtj @ step)
            if promised < tolerance * cost:
                break
            damping *= 10
            if damping > 1e8:
                break
    return p


def _inflation(jac: np.ndarray, j1: np.ndarray, j2: np.ndarray,
               weight: float) -> tuple[float, float]:
    """Each axis's covariance with the biases free over that with them known (sqrt of
    the traces' ratio), from the data rows' Jacobian ``jac`` (M, 12) at the joint fit."""
    t = [tangent_basis(j1[None, :])[0], tangent_basis(j2[None, :])[0]]
    jt = np.concatenate([jac[:, :3] @ t[0], jac[:, 3:6] @ t[1], jac[:, 6:]], axis=1)
    info = jt.T @ jt
    info[4:, 4:] += weight**2 * np.eye(6)  # the prior's information on the biases
    try:
        free = np.linalg.inv(info)[:4, :4]
        known = np.linalg.inv(info[:4, :4])
    except np.linalg.LinAlgError:
        return (1.0, 1.0)
    out = []
    for sl in (slice(0, 2), slice(2, 4)):
        ratio = np.trace(free[sl, sl]) / np.trace(known[sl, sl])
        out.append(float(np.sqrt(ratio)) if np.isfinite(ratio) and ratio >= 1 else 1.0)
    return out[0], out[1]


def _residual(g1, g2, j1, j2, b1, b2) -> np.ndarray:
    return joint_plane_rate(g1 - b1, j1) - joint_plane_rate(g2 - b2, j2)


def _across(b: np.ndarray, j: np.ndarray) -> np.ndarray:
    return b - (b @ j) * j


@dataclass(frozen=True)
class CentreBias(_Biases):
    """A joint centre refitted to eq. (3) together with constant gyroscope biases.

    Attributes
    ----------
    o : (6,) the refitted centre (o1, o2), m, each in its sensor's frame.
    b1, b2 : (3,) the biases of the first and second gyroscope, rad/s, in its frame.
    cost_ratio : mean squared eq. (3) residual of the centre refitted without the biases
        over that with them (both from the estimate, on the same samples).
    """

    o: np.ndarray
    b1: np.ndarray
    b2: np.ndarray
    cost_ratio: float

    def report(self, applied: bool) -> dict:
        """The JSON block (rad/s); ``applied``: the rates were corrected by these biases.

        Returns
        -------
        dict
            "applied", "b1_rad_s", "b2_rad_s" ((3,) lists, rad/s, sensor frames),
            "cost_ratio" and the rule's constants "prior_rad_s", "min_cost_ratio",
            "max_plausible_rad_s".
        """
        return self._block(applied)


def joint_centre_with_bias(data: tuple, x: np.ndarray) -> CentreBias | None:
    """The joint centre (o1, o2), refitted to eq. (3) from ``x`` together with a constant
    bias of each gyroscope (Gaussian prior ``PRIOR_RAD_S`` per component, the residual's
    own scale per sample, as for the axis); None if it cannot be fitted.

    ``data`` is the position estimate's (g1, gdot1, a1, g2, gdot2, a2) (N, 3) each
    (rad/s, rad/s^2, m/s^2), ``x`` (6,) its estimate (o1, o2), m. A bias enters eq. (3)
    through ``g x (g x o)`` (its derivative is 0), and the position estimate has no
    term for it: simulated circling with 0.02-0.2 rad/s biases came out
    up to 3.7 sigma off, some `good` (4.2 and 5.4 sigma on one seed). Where the biases
    are worth removing (:attr:`CentreBias.significant`) the position is estimated again
    from corrected rates; otherwise how far the centre moves when biases the data cannot
    rule out are allowed (3-10 mm there, against 0.2-3 mm without bias) is a 1-sigma part
    of its own. Fitted on every k-th sample (at most ``SCREEN_SAMPLES``).

    Returns
    -------
    CentreBias or None
        The refitted centre ``o`` (6,), m, the biases ``b1``, ``b2`` (3,), rad/s, each in
        its sensor's frame, and ``cost_ratio`` (the centre refitted alone over refitted
        with the biases, same samples). None when the residual at ``x`` is zero or not
        finite, fewer than 20 samples remain, or a fit does not stay finite.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, eq. 3 (the constraint;
    the bias terms and their prior are imucal's).
    """

    step = max(1, int(np.ceil(np.shape(data[0])[0] / SCREEN_SAMPLES)))
    g1, gd1, a1, g2, gd2, a2 = (np.asarray(d, dtype=float)[::step] for d in data)
    sensors = ((g1, gd1, a1), (g2, gd2, a2))

    def parts(p):
        """Per sensor: o, h = g - b, Gamma(h, gdot) (M, 3, 3), r = a - Gamma o, |r|."""
        out = []
        for k, (g, gd, a) in enumerate(sensors):
            o, h = p[3 * k:3 * k + 3], g - p[6 + 3 * k:9 + 3 * k]
            gam = gamma_rows(h, gd)
            r = a - gam @ o
            out.append((o, h, gam, r, np.linalg.norm(r, axis=1)))
        return out

    def residual(p):
        (*_, n1), (*_, n2) = parts(p)
        return n1 - n2

    e0 = residual(np.concatenate([x, np.zeros(6)]))
    cost0 = float(np.mean(e0**2))
    if not np.isfinite(cost0) or cost0 <= 0 or e0.shape[0] < 20:
        return None
    weight = np.sqrt(cost0) / PRIOR_RAD_S

    def rows(p):
        return np.concatenate([residual(p), weight * p[6:12]])

    def jacobian(p):
        jac = np.zeros((e0.shape[0] + 6, 12))
        for k, ((o, h, gam, r, n), sign) in enumerate(zip(parts(p), (1.0, -1.0),
                                                           strict=True)):
            u = r / np.maximum(n, 1e-12)[:, None]
            # e = |r1| - |r2|, r = a - Gamma(h) o with h = g - b: dr/do = -Gamma, and
            # d(Gamma o)/dh = (h.o) I + h o^T - 2 o h^T, so dr/db is its positive
            db = ((h @ o)[:, None] * u + np.sum(u * h, axis=1)[:, None] * o
                  - 2.0 * (u @ o)[:, None] * h)
            jac[:-6, 3 * k:3 * k + 3] = -sign * np.einsum("mij,mi->mj", gam, u)
            jac[:-6, 6 + 3 * k:9 + 3 * k] = sign * db
        jac[-6:, 6:] = weight * np.eye(6)
        return jac

    start = np.concatenate([x, np.zeros(6)])
    p = _levenberg_marquardt(rows, jacobian, start, TOLERANCE)
    # The gain is judged against the centre refitted alone on the same samples: a hinge's
    # estimate is a chosen point of its axis line, and sliding along the line (65-156 mm
    # on real and soft-tissue knees) lowered the cost 2-10 times with biases of 0.003
    # rad/s, which then counted as biases worth removing (an independent review)
    q = _levenberg_marquardt(lambda c: residual(np.concatenate([c, np.zeros(6)])),
                             lambda c: jacobian(np.concatenate([c, np.zeros(6)]))[:-6, :6],
                             start[:6], TOLERANCE)
    if not (np.isfinite(p).all() and np.isfinite(q).all()):
        return None
    cost = float(np.mean(residual(p) ** 2))
    alone = float(np.mean(residual(np.concatenate([q, np.zeros(6)])) ** 2))
    return CentreBias(p[:6], p[6:9], p[9:12], alone / cost if cost > 0 else float("inf"))
