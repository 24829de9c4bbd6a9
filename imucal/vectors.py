"""Unit vectors, their tangent planes, row-wise cross products, the joint-plane rate of
eq. (1) and the Gamma matrices of eq. (3): the geometry the estimators (axis, joint
position, gyroscope bias) share."""

from __future__ import annotations

import numpy as np


def unit(v) -> np.ndarray:
    """``v`` scaled to length 1, as float64."""
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def tangent_basis(j: np.ndarray) -> np.ndarray:
    """(m, 3, 2) columns u, v: orthonormal and perpendicular to each unit row of ``j``.

    The branch-free construction of Duff et al. (2017, "Building an orthonormal basis,
    revisited"): a few element-wise operations, because this runs twice per Gauss-Newton
    iteration. It jumps where j's z component changes sign; the solver does not mind, as
    every step is applied in the basis it was computed in.
    """
    x, y, z = j[:, 0], j[:, 1], j[:, 2]
    sign = np.copysign(1.0, z)
    a = -1.0 / (sign + z)
    b = x * y * a
    basis = np.empty((j.shape[0], 3, 2))
    basis[:, 0, 0] = 1.0 + sign * x * x * a
    basis[:, 1, 0] = sign * b
    basis[:, 2, 0] = -sign * x
    basis[:, 0, 1] = b
    basis[:, 1, 1] = sign + y * y * a
    basis[:, 2, 1] = -y
    return basis


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a x b of (N, 3) arrays (either may be one (3,) vector): numpy's cross
    spends more on moving axes than on a few thousand products."""
    a, b = np.broadcast_arrays(a, b)
    out = np.empty(a.shape)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def joint_plane_rate(g: np.ndarray, j: np.ndarray) -> np.ndarray:
    """|g x j| per sample: the rate's part in the joint plane of the unit axis ``j``
    (eq. 1), via |g|^2 - (g.j)^2 (no cross product)."""
    return np.sqrt(np.maximum(np.sum(g * g, axis=1) - (g @ j) ** 2, 0.0))


def gamma_rows(g, gdot) -> np.ndarray:
    """(..., M, 3, 3) matrices Gamma = g g^T - |g|^2 I + [gdot]x of eq. (3) for rates
    ``g`` and their derivatives ``gdot`` (..., M, 3), rad/s and rad/s^2."""
    gam = g[..., :, None] * g[..., None, :]
    gam -= np.sum(g * g, axis=-1)[..., None, None] * np.eye(3)
    gam[..., 0, 1] -= gdot[..., 2]
    gam[..., 0, 2] += gdot[..., 1]
    gam[..., 1, 0] += gdot[..., 2]
    gam[..., 1, 2] -= gdot[..., 0]
    gam[..., 2, 0] -= gdot[..., 1]
    gam[..., 2, 1] += gdot[..., 0]
    return gam
