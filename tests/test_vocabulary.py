"""The public API speaks one vocabulary (docs/glossary.md): argument names, result fields, plots."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import typing
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MODULES = ("linflex", "linflex.linearize", "linflex.frequency", "linflex.stability", "linflex.stability.report")

#: Names the glossary retires, with the name that replaced each.
RETIRED_ARGUMENTS = {
    "L": "loop", "loop_or_sys": "loop", "sys_or_loop": "loop", "sys_or_zpk": "sys", "data": "result",
    "w": "omega", "freqs": "omega",
}
RETIRED_FIELDS = {
    "evaluations": "n_evaluations", "n_eigenvalue_solves": "n_evaluations",
    "open_loop_rhp_poles": "open_loop_unstable_poles", "closed_loop_rhp_poles": "closed_loop_unstable_poles",
    "state_names": "states", "output_names": "outputs", "input_names": "inputs",
}
#: Fields that hold names, never data.
NAME_FIELDS = ("states", "inputs", "outputs", "dofs")


def public_objects():
    seen = set()
    for module_name in MODULES:
        module = importlib.import_module(module_name)
        for name in module.__all__:
            obj = getattr(module, name)
            if id(obj) not in seen and (inspect.isfunction(obj) or inspect.isclass(obj)):
                seen.add(id(obj))
                yield f"{module_name}.{name}", obj


FUNCTIONS = [(n, o) for n, o in public_objects() if inspect.isfunction(o)]
# Results and systems; scene entries (linflex.scene) take what a file says and are validated later.
RESULTS = [(n, o) for n, o in public_objects()
           if inspect.isclass(o) and dataclasses.is_dataclass(o) and not o.__module__.startswith("linflex.scene")]


def test_the_glossary_names_every_retired_word():
    glossary = (ROOT / "docs" / "glossary.md").read_text()
    for new in set(RETIRED_ARGUMENTS.values()) | set(RETIRED_FIELDS.values()):
        assert f"`{new}`" in glossary, f"docs/glossary.md does not define {new!r}"


@pytest.mark.parametrize("name, function", FUNCTIONS, ids=[n for n, _ in FUNCTIONS])
def test_argument_names(name, function):
    params = inspect.signature(function).parameters
    retired = {p: RETIRED_ARGUMENTS[p] for p in params if p in RETIRED_ARGUMENTS}
    assert not retired, f"{name}: rename {retired} (docs/glossary.md)"


@pytest.mark.parametrize("name, cls", RESULTS, ids=[n for n, _ in RESULTS])
def test_result_fields(name, cls):
    fields = {f.name: f for f in dataclasses.fields(cls)}
    retired = {f: RETIRED_FIELDS[f] for f in fields if f in RETIRED_FIELDS}
    assert not retired, f"{name}: rename {retired} (docs/glossary.md)"
    hints = typing.get_type_hints(cls) if any(f in fields for f in NAME_FIELDS) else {}
    for field in NAME_FIELDS:
        if field in fields:
            assert hints[field] in (tuple[str, ...], typing.Tuple[str, ...]), (  # noqa: UP006
                f"{name}.{field} must hold names (tuple of str), not {hints[field]}")


PLOTS = [(n, o) for n, o in FUNCTIONS if n.endswith("_plot")]


@pytest.mark.parametrize("name, function", PLOTS, ids=[n for n, _ in PLOTS])
def test_plots_return_one_handle_and_take_ax(name, function):
    signature = inspect.signature(function)
    assert "ax" in signature.parameters, f"{name} takes no ax="
    assert signature.return_annotation in ("PlotHandle", "linflex.PlotHandle"), (
        f"{name} must return a PlotHandle, annotated {signature.return_annotation!r}")
