"""Every result attribute and every parameter of the front doors is documented (the
gaitmap convention): a field nobody explains is a field nobody can trust."""

from __future__ import annotations

import dataclasses
import inspect
import re
from pathlib import Path

import pytest
from conftest import simulated

import imucal
from imucal import report
from imucal.angles import JointAngle
from imucal.axis import AxisResult, estimate_axis
from imucal.calibration import JointCalibration
from imucal.gauss_newton import BatchResult
from imucal.position import PositionResult, estimate_position
from imucal.result import EstimateResult
from imucal.settings import AxisSettings, PositionSettings


def _documented_names(doc: str) -> set[str]:
    # "name : ..." or "name, other : ..." at the start of a docstring line, or a
    # numpydoc parameter line "name" / "name, other" on its own
    names = set()
    for line in doc.splitlines():
        head = line.strip().split(" : ")[0]
        if re.fullmatch(r"[a-z_0-9]+(, [a-z_0-9]+)*", head):
            names.update(head.split(", "))
    return names


def test_every_solver_result_attribute_is_documented():
    missing = {f.name for f in dataclasses.fields(BatchResult)} - _documented_names(
        BatchResult.__doc__)
    assert not missing, f"BatchResult: undocumented {sorted(missing)}"


@pytest.mark.parametrize("func", [estimate_axis, estimate_position, imucal.calibrate,
                                  imucal.joint_angles, imucal.load_recording,
                                  imucal.make_recording, imucal.load_calibration])
def test_every_parameter_is_documented(func):
    params = set(inspect.signature(func).parameters)
    missing = params - _documented_names(func.__doc__)
    assert not missing, f"{func.__name__}: undocumented {sorted(missing)}"


def _class_docs(cls) -> set[str]:
    """Names documented by ``cls`` or any result class it builds on."""
    return set().union(*(_documented_names(c.__doc__ or "") for c in cls.__mro__))


@pytest.mark.parametrize("cls", [AxisResult, PositionResult, EstimateResult,
                                 imucal.Calibration, imucal.JointAngles, imucal.Recording,
                                 JointAngle, JointCalibration])
def test_every_field_is_documented_with_inherited_ones(cls):
    missing = {f.name for f in dataclasses.fields(cls)} - _class_docs(cls)
    assert not missing, f"{cls.__name__}: undocumented {sorted(missing)}"


@pytest.mark.parametrize("cls", [AxisSettings, PositionSettings])
def test_every_setting_is_documented_and_a_keyword_of_its_estimator(cls):
    names = {f.name for f in dataclasses.fields(cls)}
    assert not names - _class_docs(cls), f"{cls.__name__}: undocumented"
    estimator = estimate_axis if cls is AxisSettings else estimate_position
    assert names <= set(inspect.signature(estimator).parameters)
    assert set(cls().as_kwargs()) == names  # the keys the runner passes on


def _keys(doc: dict) -> set[str]:
    """Every key of the JSON blocks below (nested), without the array entries."""
    keys = set()
    for key, value in doc.items():
        keys.add(key)
        if isinstance(value, dict):
            keys |= _keys(value)
    return keys


@pytest.fixture(scope="module")
def reports():
    rec, _ = simulated(1)
    th, sh, ft = (rec.sensor(n) for n in ("thigh", "shank", "foot"))
    axis = estimate_axis(th.gyr, sh.gyr, rate=rec.rate, restarts=4, seed=1)
    spheroidal = estimate_position(sh.gyr, sh.acc, ft.gyr, ft.acc, rate=rec.rate,
                                   restarts=4, seed=1)
    hinge = estimate_position(th.gyr, th.acc, sh.gyr, sh.acc, rate=rec.rate, restarts=4,
                              seed=1, joint="hinge", axis=axis)
    info = {"path": "x.h5", "sensors": ["a", "b"]}
    return [report.axis_report(axis, input_info=info),
            report.position_report(spheroidal, input_info=info),
            report.position_report(hinge, input_info=info)]


@pytest.mark.parametrize("block", ["settings", "quality", "convergence", "time_offset"])
def test_every_json_key_is_in_docs_json(reports, block):
    text = (Path(__file__).resolve().parents[1] / "docs" / "json.md").read_text()
    # names inside code spans: `quality.verdict`, `j1_uncertainty_deg`, `equal_minima.count`
    documented = {word for span in re.findall(r"`([^`]+)`", text)
                  for word in re.findall(r"[A-Za-z_][A-Za-z_0-9]*", span)}
    keys = set().union(*(_keys(r[block]) for r in reports if isinstance(r.get(block), dict)))
    keys |= {k for r in reports for k in r}  # top-level keys
    missing = keys - documented
    assert not missing, f"docs/json.md does not mention {sorted(missing)}"


@pytest.mark.parametrize("func", [estimate_axis, estimate_position, imucal.calibrate,
                                  imucal.joint_angles])
def test_public_estimators_have_numpydoc_sections(func):
    for section in ("Parameters", "Returns", "Raises", "References", "Examples"):
        assert re.search(rf"^\s*{section}\n\s*-+\n", func.__doc__, re.M), \
            f"{func.__name__}: no {section} section"


@pytest.mark.parametrize("func", [imucal.load_recording, imucal.make_recording,
                                  imucal.load_calibration])
def test_loaders_have_numpydoc_sections(func):
    for section in ("Parameters", "Returns", "Raises", "Examples"):
        assert re.search(rf"^\s*{section}\n\s*-+\n", func.__doc__, re.M), \
            f"{func.__name__}: no {section} section"


@pytest.mark.parametrize("func", [estimate_axis, estimate_position, imucal.calibrate,
                                  imucal.joint_angles, imucal.load_recording,
                                  imucal.make_recording, imucal.load_calibration])
def test_the_examples_run(func, monkeypatch):
    # the docstrings' examples use sample_data/ from the repository root
    import doctest

    monkeypatch.chdir(Path(__file__).resolve().parents[1])
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE)
    for test in doctest.DocTestFinder().find(func, func.__name__, globs={}):
        runner.run(test)
    assert runner.summarize(verbose=False).failed == 0
    assert runner.summarize(verbose=False).attempted >= 2


def _public_functions():
    """(where, function node) of every public function and public class's public method
    in the package; typer commands are left out (their docstring is the --help text)."""
    import ast

    root = Path(imucal.__file__).parent
    for path in sorted(root.rglob("*.py")):
        tree = ast.parse(path.read_text())
        for node in tree.body:
            found = []
            if isinstance(node, ast.FunctionDef) and not node.name.startswith("_"):
                found = [(node.name, node)]
            elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
                found = [(f"{node.name}.{m.name}", m) for m in node.body
                         if isinstance(m, ast.FunctionDef) and not m.name.startswith("_")]
            for name, func in found:
                if any("command" in ast.unparse(d) or "callback" in ast.unparse(d)
                       for d in func.decorator_list):
                    continue
                yield f"{path.relative_to(root.parent)}:{func.lineno} {name}", func


def _raised_classes(func) -> set[str]:
    """Exception classes ``func`` raises itself (``raise Name(...)``; not re-raises of a
    caught exception held in a variable)."""
    import ast

    names = set()
    for node in ast.walk(func):
        if isinstance(node, ast.Raise) and node.exc is not None:
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            name = ast.unparse(exc).split(".")[-1]
            if name[:1].isupper():
                names.add(name)
    return names


def test_every_public_function_has_a_docstring_naming_what_it_raises():
    import ast

    problems = []
    for where, func in _public_functions():
        doc = ast.get_docstring(func)
        if not doc:
            problems.append(f"{where}: no docstring")
            continue
        unnamed = {name for name in _raised_classes(func)
                   if not re.search(rf"\b{name}\b", doc)}
        if unnamed:
            problems.append(f"{where}: raises {sorted(unnamed)}, its docstring never says")
    assert not problems, "\n".join(problems)
