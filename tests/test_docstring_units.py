"""Public docstrings are complete numpydoc and give the unit of every physical quantity (STYLE.md 16-18).

What is checked mechanically, over the ``__all__`` of the five packages and the public methods and
properties of their classes:

* a callable that takes parameters (besides ``self``/``cls``) has a ``Parameters`` section that
  names every one of them (``a, b : type`` entries and ``*args``/``**kwargs`` count);
* a callable that returns something (a return annotation other than ``None``, or, without one, a
  ``return value`` statement in its source) has a ``Returns`` (or ``Yields``) section;
* a public property has a docstring;
* a class whose docstring documents constructor ``Parameters`` (a class users build, not a
  result) has an ``Examples`` section (``tests/test_docstrings.py`` runs it);
* every ``Parameters``/``Attributes`` entry, and every property, whose name is in ``UNIT_NAMES``
  (names whose meaning is unambiguous across the API: frequencies, times, masses, inertias,
  stiffnesses, margins, ...) states a bracketed unit: ``[rad/s]``, ``[s]``, ``[kg m^2]``, ``[-]``
  for a dimensionless ratio, ``[state units]``.

The Examples sections are tested in ``tests/test_docstrings.py`` (present on every public function,
and they run); they are not checked again here. A failure names the object and the parameter.
"""

import ast
import importlib
import inspect
import re
import textwrap

import pytest

PACKAGES = ["linflex", "linflex.linearize", "linflex.frequency", "linflex.stability", "linflex.stability.report",
            "linflex.design"]

# numpydoc section heading: a title on its own line, underlined with dashes
HEADING = re.compile(r"^(?P<title>[A-Z][A-Za-z ]+)\n-{3,}[ \t]*$", re.MULTILINE)
# an entry line of a Parameters/Attributes section: "name", "name : type", "a, b : type", "**kwargs"
ENTRY = re.compile(r"^(?P<names>\*{0,2}\w+(?:\s*,\s*\*{0,2}\w+)*)\s*(?::\s*(?P<type>.*))?$")
# a unit in brackets that opens a word: "[rad/s]", "[-]", "[N m/rad]"; not an index such as ``x[0]``
UNIT = re.compile(r"(?:^|[\s(,;:])\[[^\[\]`]+\]")

# Names whose meaning is the same wherever they occur in the public API, each a physical quantity.
UNIT_NAMES = frozenset({
    # frequencies [rad/s] (or [Hz] at the report boundary)
    "omega", "omega_max", "frequency", "frequencies", "natural_frequency", "damped_frequency",
    "pole_frequencies", "zero_frequencies", "fixed_interface_frequencies", "frequency_hz",
    "gain_crossovers", "phase_crossovers", "min_gain_margin_frequency", "min_phase_margin_frequency",
    # eigenvalues [1/s] or [rad/s]
    "eigenvalue", "eigenvalues", "poles", "zeros",
    # times [s]
    "timepts", "times", "time", "t", "time_step", "time_constant", "pole_time_constants",
    "zero_time_constants", "seconds", "setup_seconds", "build_seconds", "case_seconds",
    "delay_margin", "delay_margins",
    # rates
    "rate", "rates", "spin_rate",
    # mass properties and structure
    "mass", "masses", "mass_per_length", "inertia", "torsional_inertia_per_length", "com",
    "stiffness", "damping", "damping_ratio", "pole_damping", "zero_damping", "zeta_max",
    "EI", "EIy", "EIz", "EA", "GJ", "length", "segment_length", "energy", "momentum",
    # loop gains and margins
    "gains", "gain_margin", "gain_margins", "phase_margin", "phase_margins", "min_gain_margin",
    "min_phase_margin", "gain_increase_margin", "gain_reduction_margin",
    # decibels, magnitudes, phases and ratios
    "resolution_db", "peak_resolution_db", "gain_margin_db", "gain_margins_db", "min_gain_margin_db",
    "magnitude", "phase", "natural_frequencies", "damping_ratios", "max_relative_error_estimate",
})


def _sections(doc):
    """``{title: body}`` of the numpydoc sections of a docstring."""
    doc = inspect.cleandoc(doc or "")
    headings = list(HEADING.finditer(doc))
    ends = [h.start() for h in headings[1:]] + [len(doc)]
    return {h.group("title").strip(): doc[h.end():end].strip("\n") for h, end in zip(headings, ends)}


def _entries(section):
    """``{name: description}`` of a Parameters/Attributes section (the type line included)."""
    entries, current = {}, []
    for line in (section or "").splitlines():
        if line and not line[0].isspace():
            match = ENTRY.match(line.strip())
            current = [n.strip().lstrip("*") for n in match.group("names").split(",")] if match else []
            for name in current:
                entries[name] = (match.group("type") or "") + " "
        else:
            for name in current:
                entries[name] += " " + line.strip()
    return entries


def _public_api():
    """(dotted name, object, owning class or None) of every public function, class, method, property."""
    found, seen = [], set()

    def add(name, obj, owner=None):
        if id(obj) not in seen:
            seen.add(id(obj))
            found.append((name, obj, owner))

    for package in PACKAGES:
        module = importlib.import_module(package)
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.isfunction(obj):
                add(f"{package}.{name}", obj)
            elif inspect.isclass(obj):
                add(f"{package}.{name}", obj)
                for attr, member in vars(obj).items():
                    if attr.startswith("_"):
                        continue
                    if isinstance(member, (staticmethod, classmethod)):
                        member = member.__func__
                    if inspect.isfunction(member) or isinstance(member, property):
                        add(f"{package}.{name}.{attr}", member, obj)
    return found


API = _public_api()
CALLABLES = [(n, o) for n, o, _ in API if inspect.isfunction(o)]
CONSTRUCTED = [(n, o) for n, o, _ in API if inspect.isclass(o) and "Parameters" in _sections(o.__doc__)]
PROPERTIES = [(n, o) for n, o, _ in API if isinstance(o, property)]

def _params(check, items):
    """pytest params with the object's name as id (``check`` names the test's kind)."""
    return [pytest.param(name, obj, id=name) for name, obj in items]


def _signature_parameters(func):
    try:
        signature = inspect.signature(func)
    except (TypeError, ValueError):
        return []
    # a leading underscore marks a private parameter (an internal hook), not part of the documented API
    return [p.name for p in signature.parameters.values() if p.name not in ("self", "cls") and not p.name.startswith("_")]


def _returns_value(func):
    """Whether ``func`` returns something: by its annotation, else by a ``return value`` in its source."""
    annotation = inspect.signature(func).return_annotation
    if annotation is not inspect.Signature.empty:
        return annotation not in (None, "None")
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(func)))
    except (OSError, TypeError, SyntaxError):
        return False
    body = tree.body[0]
    nested = {id(n) for node in ast.walk(body) if node is not body and isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)) for n in ast.walk(node)}
    return any(
        isinstance(node, ast.Return) and node.value is not None and id(node) not in nested
        and not (isinstance(node.value, ast.Constant) and node.value.value is None)
        for node in ast.walk(body)
    )


def test_the_public_api_was_found():
    names = {n for n, _, _ in API}
    assert {"linflex.simulate", "linflex.frequency.frequency_response", "linflex.LinearSystem.subsystem"} <= names


@pytest.mark.parametrize(("name", "func"), _params("parameters", CALLABLES))
def test_parameters_are_documented(name, func):
    parameters = _signature_parameters(func)
    if not parameters:
        return
    sections = _sections(func.__doc__)
    assert "Parameters" in sections, f"{name} takes {parameters} but its docstring has no Parameters section"
    documented = {**_entries(sections["Parameters"]), **_entries(sections.get("Other Parameters"))}
    missing = [p for p in parameters if p not in documented]
    assert not missing, f"{name}: parameters {missing} are not in its Parameters section"


@pytest.mark.parametrize(("name", "func"), _params("returns", CALLABLES))
def test_returns_are_documented(name, func):
    if inspect.isclass(func) or not _returns_value(func):
        return
    sections = _sections(func.__doc__)
    assert "Returns" in sections or "Yields" in sections, f"{name} returns a value but its docstring has no Returns section"


@pytest.mark.parametrize(("name", "prop"), _params("property", PROPERTIES))
def test_properties_have_docstrings(name, prop):
    assert prop.fget is not None and (prop.fget.__doc__ or "").strip(), f"property {name} has no docstring"


@pytest.mark.parametrize(("name", "cls"), _params("class-examples", CONSTRUCTED))
def test_constructed_classes_have_examples(name, cls):
    assert "Examples" in _sections(cls.__doc__), f"class {name} documents its Parameters but has no Examples section"


def _unit_problems(name, obj):
    problems = []
    if isinstance(obj, property):
        attr = name.rsplit(".", 1)[1]
        if attr in UNIT_NAMES and not UNIT.search(" " + (obj.fget.__doc__ or "")):
            problems.append(f"property {name} gives no [unit]")
        return problems
    sections = _sections(obj.__doc__)
    for title in ("Parameters", "Other Parameters", "Attributes"):
        for entry, text in _entries(sections.get(title)).items():
            if entry in UNIT_NAMES and not UNIT.search(" " + text):
                problems.append(f"{name}: {title} entry {entry!r} gives no [unit]")
    return problems


@pytest.mark.parametrize(("name", "obj"), _params("units", [(n, o) for n, o, _ in API]))
def test_physical_quantities_give_units(name, obj):
    problems = _unit_problems(name, obj)
    assert not problems, "\n".join(problems)
