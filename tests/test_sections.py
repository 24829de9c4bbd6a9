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


def _own_nodes(func):
    """The nodes of ``func``'s own body: not those of a nested function or class."""
    todo = list(func.body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda,
                             ast.ClassDef)):
            continue
        yield node
        todo.extend(ast.iter_child_nodes(node))


def _returns_a_value(func) -> bool:
    """Whether ``func`` itself (not a nested function) returns something or yields."""
    return any(isinstance(node, (ast.Yield, ast.YieldFrom)) or (
        isinstance(node, ast.Return) and node.value is not None and not (
            isinstance(node.value, ast.Constant) and node.value.value is None))
        for node in _own_nodes(func))


def _is_property(func) -> bool:
    return any(ast.unparse(d).split(".")[-1] in ("property", "cached_property", "setter")
               for d in func.decorator_list)


def test_every_public_function_that_returns_says_what_in_a_section():
    missing = [where for where, func in _public_functions()
               if not _is_property(func) and _returns_a_value(func)
               and not (_section(ast.get_docstring(func) or "", "Returns")
                        or _section(ast.get_docstring(func) or "", "Yields"))]
    assert not missing, "no Returns/Yields section:\n" + "\n".join(missing)


def _exception_factories() -> dict[str, str]:
    """Functions of the package annotated to return an exception class (``twice(...) ->
    InputError``): function name -> that class's name, where the name is unambiguous."""
    found: dict[str, set[str]] = {}
    for path in sorted(Path(imucal.__file__).parent.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and node.returns is not None:
                found.setdefault(node.name, set()).add(
                    ast.unparse(node.returns).split(".")[-1])
    return {name: cls.pop() for name, cls in found.items()
            if len(cls) == 1 and re.fullmatch(r"[A-Z]\w*(Error|Exception|Exit)", next(iter(cls)))}


def _raised_in_own_body(func, factories: dict[str, str]) -> set[str]:
    """Exception classes ``func``'s own body (not a nested function or class) raises by
    name: ``raise Name(...)``, ``raise Name``, ``raise module.Name(...)``, and
    ``raise factory(...)`` of a function annotated to return one. Left out: a bare
    ``raise`` and ``raise err`` of an exception held in a variable (a re-raise of what
    something else raised), and ``typer.*`` (``Exit``, ``BadParameter``): the command
    line's way to exit, which typer handles and no caller ever catches."""
    names = set()
    for node in _own_nodes(func):
        if isinstance(node, ast.Raise) and node.exc is not None:
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            text = ast.unparse(exc)
            name = text.split(".")[-1]
            if text.startswith("typer."):
                pass
            elif name[:1].isupper():
                names.add(name)
            elif isinstance(node.exc, ast.Call) and name in factories:
                names.add(factories[name])
    return names


def _raises_entries(doc: str) -> set[str]:
    """The exception names a numpydoc ``Raises`` section lists (its unindented lines,
    e.g. ``InputError`` or ``InputError, ValueError``); empty without the section."""
    m = re.search(r"^Raises\n-+\n(.*?)(?=^\S[^\n]*\n-+\n|\Z)", doc, re.M | re.S)
    if m is None:
        return set()
    return {word for line in m.group(1).splitlines() if line[:1].strip()
            for word in re.findall(r"\w+", line)}


def test_every_public_function_that_raises_says_what_in_a_section():
    """Every public function and public method (not a property; typer commands are left
    out by ``_public_functions``, their docstring is the --help text) whose own body raises
    an exception class by name has a ``Raises`` section listing that class (see
    ``_raised_in_own_body`` for what counts). What a function raises through the helpers
    it calls is not checked here."""
    factories = _exception_factories()
    missing = []
    for where, func in _public_functions():
        if _is_property(func):
            continue
        unlisted = _raised_in_own_body(func, factories) - _raises_entries(
            ast.get_docstring(func) or "")
        if unlisted:
            missing.append(f"{where}: raises {sorted(unlisted)}, not in a Raises section")
    assert not missing, "\n".join(missing)


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
