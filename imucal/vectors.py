"""Unit vectors, their tangent planes and the joint-plane rate of eq. (1): the geometry
the hinge estimators (axis, gyroscope bias) share."""

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


def joint_plane_rate(g: np.ndarray, j: np.ndarray) -> np.ndarray:
    """|g x j| per sample: the rate's part in the joint plane of the unit axis ``j``
    (eq. 1), via |g|^2 - (g.j)^2 (no cross product)."""
    return np.sqrt(np.maximum(np.sum(g * g, axis=1) - (g @ j) ** 2, 0.0))
