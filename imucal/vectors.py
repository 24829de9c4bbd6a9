"""Unit vectors, their tangent planes, row-wise cross products, the joint-plane rate of
eq. (1) and the Gamma matrices of eq. (3): the geometry the estimators (axis, joint
position, gyroscope bias) share."""

from __future__ import annotations

import numpy as np


def unit(v) -> np.ndarray:
    """``v`` scaled to length 1, as float64.

    Returns
    -------
    u : float64 array, the shape of ``v`` (usually (3,))
        ``v`` / |v|: the whole array is normalised as one vector, not row by row; NaN for
        a zero ``v``.

    Examples
    --------
    >>> from imucal.vectors import unit
    >>> unit([3, 0, 4])
    array([0.6, 0. , 0.8])
    """
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def tangent_basis(j: np.ndarray) -> np.ndarray:
    """Orthonormal bases of the tangent planes of the unit rows of ``j`` (m, 3).

    The branch-free construction of Duff et al. (2017): a few element-wise operations,
    because this runs twice per Gauss-Newton iteration. It jumps where j's z component
    changes sign; the solver does not mind, as every step is applied in the basis it was
    computed in.

    Returns
    -------
    basis : (m, 3, 2) float64
        Columns u, v per row: unit, perpendicular to each other and to that row of ``j``
        (a local step (a, b) moves j along a u + b v).

    References
    ----------
    Duff, Burgess, Christensen, Hery, Kensler, Liani, Villemin (2017), "Building an
    orthonormal basis, revisited", Journal of Computer Graphics Techniques 6(1).

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.vectors import tangent_basis
    >>> b = tangent_basis(np.array([[0.0, 0.0, 1.0]]))
    >>> b.shape, b[0].T @ b[0], np.array([0.0, 0.0, 1.0]) @ b[0]
    ((1, 3, 2), array([[1., 0.],
           [0., 1.]]), array([0., 0.]))
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
    spends more on moving axes than on a few thousand products.

    Returns
    -------
    c : (N, 3) float64
        a[i] x b[i] per row, in the units of a times those of b.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.vectors import cross_rows
    >>> cross_rows(np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), np.array([0.0, 0.0, 1.0]))
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.]])
    """
    a, b = np.broadcast_arrays(a, b)
    out = np.empty(a.shape)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def joint_plane_rate(g: np.ndarray, j: np.ndarray) -> np.ndarray:
    """|g x j| per sample: the rate's part in the joint plane of the unit axis ``j``
    (eq. 1), via |g|^2 - (g.j)^2 (no cross product).

    Returns
    -------
    rate : (N,) float
        Length of each row of ``g`` (N, 3) projected into the plane normal to ``j`` (3,),
        in the units of ``g`` (rad/s for angular rates); ``j`` is in the same sensor
        frame as ``g``.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, Sec. II-A, eq. 1.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.vectors import joint_plane_rate
    >>> joint_plane_rate(np.array([[3.0, 4.0, 12.0]]), np.array([0.0, 0.0, 1.0]))
    array([5.])
    """
    return np.sqrt(np.maximum(np.sum(g * g, axis=1) - (g @ j) ** 2, 0.0))


def gamma_rows(g, gdot) -> np.ndarray:
    """Matrices Gamma = g g^T - |g|^2 I + [gdot]x of eq. (3) for rates ``g`` and their
    derivatives ``gdot`` (..., M, 3), rad/s and rad/s^2.

    Returns
    -------
    gamma : (..., M, 3, 3) float
        Per sample, the matrix with Gamma o = g x (g x o) + gdot x o: the radial and
        tangential acceleration (m/s^2) of a point at ``o`` (m) from the rotation centre,
        in the sensor's frame.

    References
    ----------
    Seel, Schauer, Raisch (2012), "Joint axis and position estimation from inertial
    measurement data by exploiting kinematic constraints", IEEE CCA, Sec. II-B, eq. 3.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.vectors import gamma_rows
    >>> g, gdot = np.array([[0.0, 0.0, 2.0]]), np.zeros((1, 3))
    >>> gamma_rows(g, gdot)[0] @ np.array([0.5, 0.0, 0.0])  # centripetal: -|g|^2 o
    array([-2.,  0.,  0.])
    """
    gam = g[..., :, None] * g[..., None, :]
    gam -= np.sum(g * g, axis=-1)[..., None, None] * np.eye(3)
    gam[..., 0, 1] -= gdot[..., 2]
    gam[..., 0, 2] += gdot[..., 1]
    gam[..., 1, 0] += gdot[..., 2]
    gam[..., 1, 2] -= gdot[..., 0]
    gam[..., 2, 0] -= gdot[..., 1]
    gam[..., 2, 1] += gdot[..., 0]
    return gam
