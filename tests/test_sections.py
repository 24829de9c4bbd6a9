"""Docstring sections of every public function (issue 14): what it returns, and for the
library's public API examples that run."""

from __future__ import annotations

import ast
import doctest
import inspect
import re
from pathlib import Path

import pytest
from test_documented import _public_functions

import imucal

ROOT = Path(__file__).resolve().parents[1]


def _section(doc: str, name: str) -> bool:
    return re.search(rf"^\s*{name}\n\s*-+\n", doc, re.M) is not None


def _returns_a_value(func) -> bool:
    """Whether ``func`` itself (not a nested function) returns something or yields."""
    todo = list(func.body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda,
                             ast.ClassDef)):
            continue
        if isinstance(node, (ast.Yield, ast.YieldFrom)):
            return True
        if isinstance(node, ast.Return) and node.value is not None and not (
                isinstance(node.value, ast.Constant) and node.value.value is None):
            return True
        todo.extend(ast.iter_child_nodes(node))
    return False


def _is_property(func) -> bool:
    return any(ast.unparse(d).split(".")[-1] in ("property", "cached_property", "setter")
               for d in func.decorator_list)


def test_every_public_function_that_returns_says_what_in_a_section():
    missing = [where for where, func in _public_functions()
               if not _is_property(func) and _returns_a_value(func)
               and not (_section(ast.get_docstring(func) or "", "Returns")
                        or _section(ast.get_docstring(func) or "", "Yields"))]
    assert not missing, "no Returns/Yields section:\n" + "\n".join(missing)


def _api():
    """The library's public API: the names ``imucal`` exports and the public methods of
    its classes, and the headless runner's and study's front doors."""
    from imucal import runner, study

    for name in imucal.__all__:
        obj = getattr(imucal, name)
        if callable(obj) and not isinstance(obj, type):
            yield name, obj
        elif isinstance(obj, type) and not issubclass(obj, Exception):
            for attr, member in vars(obj).items():
                if not attr.startswith("_") and callable(member):
                    yield f"{name}.{attr}", member
    for module in (runner, study):
        for attr in module.__all__:
            if inspect.isfunction(getattr(module, attr)):
                yield f"{module.__name__}.{attr}", getattr(module, attr)


@pytest.mark.parametrize("name, obj", list(_api()), ids=lambda v: v if isinstance(v, str)
                         else "")
def test_the_public_api_has_examples_that_run(name, obj, monkeypatch):
    doc = getattr(obj, "__doc__", "") or ""
    assert _section(doc, "Examples"), f"{name}: no Examples section"
    monkeypatch.chdir(ROOT)  # the examples read sample_data/
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE
                                   | doctest.ELLIPSIS)
    for test in doctest.DocTestFinder(recurse=False).find(obj, name, globs={}):
        runner.run(test)
    summary = runner.summarize(verbose=False)
    assert summary.failed == 0 and summary.attempted >= 1, name


def _modules():
    import importlib
    import pkgutil

    for info in pkgutil.walk_packages(imucal.__path__, "imucal."):
        if info.name != "imucal.__main__":  # importing it runs the command line
            yield importlib.import_module(info.name)


@pytest.mark.parametrize("module", list(_modules()), ids=lambda m: m.__name__)
def test_every_example_in_the_package_runs(module, monkeypatch):
    monkeypatch.chdir(ROOT)
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE
                                   | doctest.ELLIPSIS)
    for test in doctest.DocTestFinder().find(module, module.__name__, globs={}):
        runner.run(test)
    assert runner.summarize(verbose=False).failed == 0, module.__name__
