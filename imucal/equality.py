"""Equality by value for imucal's objects that hold arrays (recordings, results,
calibrations, angles).

A dataclass's own ``==`` compares its fields as a tuple, and a numpy array field makes that
raise ("the truth value of an array ... is ambiguous"): ``cal == load_calibration(path)``
or ``result == again`` failed in a notebook (a new-user trial of the Python API).
"""

from __future__ import annotations

import dataclasses
import numbers
from collections.abc import Mapping

import numpy as np


class ByValue:
    """Mixin: ``a == b`` when ``b`` is of ``a``'s type and every field is equal by value
    (:func:`same_value`). Not hashable: the objects hold arrays and lists."""

    __hash__ = None  # type: ignore[assignment]

    def __eq__(self, other):
        if type(other) is not type(self):
            return NotImplemented
        return same_value(self, other)


def same_value(a, b) -> bool:
    """Whether ``a`` and ``b`` hold the same values: arrays of one shape with equal
    elements (NaN equal to NaN), mappings with the same keys and values, sequences
    element by element, dataclasses field by field (but for fields declared with
    ``compare=False``), numbers by value (``1.0`` equals
    ``numpy.float64(1.0)``; NaN equals NaN), anything else by ``==``.

    Returns
    -------
    bool
        True when equal throughout.

    Examples
    --------
    >>> import numpy as np
    >>> from imucal.equality import same_value
    >>> same_value({"j1": np.array([1.0, np.nan])}, {"j1": np.array([1.0, np.nan])})
    True
    >>> same_value([1.0, 2.0], (1.0, 2.0)), same_value(np.zeros(2), np.zeros(3))
    (False, False)
    """
    if a is b:
        return True
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return _same_array(np.asarray(a), np.asarray(b))
    if _number(a) and _number(b):
        return bool(a == b) or (_nan(a) and _nan(b))
    if type(a) is not type(b):
        return False
    if dataclasses.is_dataclass(a):
        return all(same_value(getattr(a, f.name), getattr(b, f.name))
                   for f in dataclasses.fields(a) if f.compare)
    if isinstance(a, Mapping):
        return a.keys() == b.keys() and all(same_value(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple):
        return len(a) == len(b) and all(same_value(x, y) for x, y in zip(a, b, strict=True))
    return bool(a == b)


def _same_array(a: np.ndarray, b: np.ndarray) -> bool:
    if a.shape != b.shape:
        return False
    if a.dtype.kind in "fc" and b.dtype.kind in "fciub":
        return bool(np.array_equal(a, b, equal_nan=True))
    if a.dtype.kind == "O" or b.dtype.kind == "O":
        return all(same_value(x, y) for x, y in zip(a.ravel(), b.ravel(), strict=True))
    return bool(np.array_equal(a, b))


def _number(x) -> bool:
    # (numpy's bool is no numbers.Number: True == np.True_ read as different types)
    return isinstance(x, numbers.Number | np.bool_)


def _nan(x) -> bool:
    return isinstance(x, numbers.Real) and x != x
