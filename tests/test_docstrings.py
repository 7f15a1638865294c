"""Every public function documents itself with an Examples section, and every docstring example runs.

The public API is the ``__all__`` of the five packages below (STYLE.md rule 3). Rule 18 asks for a
short Examples section that runs: (a) every public function has one (classes are exempt unless they
already carry one), and (b) every example of every public function and class, methods included,
runs and prints what it claims. The examples run with the repository root as working directory, so
they may read the files shipped in ``examples/``, and with the Agg backend, so plots need no display.
"""

import doctest
import importlib
import inspect
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ["linflex", "linflex.linearize", "linflex.frequency", "linflex.stability", "linflex.stability.report",
            "linflex.design"]
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
# numpydoc section heading: the title on its own line, underlined with dashes
EXAMPLES_HEADING = re.compile(r"^\s*Examples\s*\n\s*-{3,}\s*$", re.MULTILINE)


def _doctests(obj):
    """The doctests of ``obj``'s docstring and of its methods' docstrings, those with examples only."""
    finder = doctest.DocTestFinder()
    return [t for t in finder.find(obj, obj.__qualname__, module=inspect.getmodule(obj)) if t.examples]


def _public_objects():
    """(id, object) of every function and class in the five ``__all__`` lists."""
    objects = []
    for package in PACKAGES:
        module = importlib.import_module(package)
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                objects.append(pytest.param(obj, id=f"{package}.{name}"))
    return objects


OBJECTS = _public_objects()
FUNCTIONS = [p for p in OBJECTS if inspect.isfunction(p.values[0])]
# every function (so that a missing example fails rather than vanishes), and the classes that have examples
WITH_EXAMPLES = [p for p in OBJECTS if inspect.isfunction(p.values[0]) or _doctests(p.values[0])]


@pytest.mark.parametrize("obj", FUNCTIONS)
def test_function_has_examples_section(obj):
    doc = inspect.getdoc(obj) or ""
    assert EXAMPLES_HEADING.search(doc), f"{obj.__module__}.{obj.__qualname__} has no numpydoc Examples section"


@pytest.mark.parametrize("obj", WITH_EXAMPLES)
def test_docstring_examples_run(obj, monkeypatch):
    monkeypatch.chdir(ROOT)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    try:
        import matplotlib

        matplotlib.use("Agg")
    except ImportError:
        pass
    tests = _doctests(obj)
    assert tests, f"{obj.__module__}.{obj.__qualname__}: no docstring examples found"
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    for test in tests:
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} docstring examples failed (see captured stdout)"
