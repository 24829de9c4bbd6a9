"""Every result attribute and every parameter of the front doors is documented (the
gaitmap convention): a field nobody explains is a field nobody can trust."""

from __future__ import annotations

import dataclasses
import inspect
import re

import pytest

from imucal.axis import AxisResult, estimate_axis
from imucal.gauss_newton import BatchResult
from imucal.position import PositionResult, estimate_position


def _documented_names(doc: str) -> set[str]:
    # "name : ..." or "name, other : ..." at the start of a docstring line, or a
    # numpydoc parameter line "name" / "name, other" on its own
    names = set()
    for line in doc.splitlines():
        head = line.strip().split(" : ")[0]
        if re.fullmatch(r"[a-z_0-9]+(, [a-z_0-9]+)*", head):
            names.update(head.split(", "))
    return names


@pytest.mark.parametrize("cls", [AxisResult, PositionResult, BatchResult])
def test_every_result_attribute_is_documented(cls):
    missing = {f.name for f in dataclasses.fields(cls)} - _documented_names(cls.__doc__)
    assert not missing, f"{cls.__name__}: undocumented {sorted(missing)}"


@pytest.mark.parametrize("func", [estimate_axis, estimate_position])
def test_every_parameter_is_documented(func):
    params = set(inspect.signature(func).parameters)
    missing = params - _documented_names(func.__doc__)
    assert not missing, f"{func.__name__}: undocumented {sorted(missing)}"
