"""The registry of linearization methods: name -> description, options, models it applies to, function.

:func:`linflex.linearize.linearize` dispatches through it, the ``linflex report --method``
command line reads its choices from it, and ``linearize``'s docstring lists it. Adding a method
is one :func:`register_method` call, here for the built-in ones::

    register_method(LinearizationMethod(
        "name", "one line: what it does and how exact it is", NameOptions, function, models="any"))

with ``NameOptions`` a frozen dataclass whose fields are made with :func:`option` (default,
unit, one-line description; validation in ``__post_init__``) and ``function(problem, options)``
taking a :class:`LinearizationProblem` and returning a :class:`MethodResult`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

from linflex import MethodUnavailableError, ModelError, NonlinearModel
from linflex.system import check_positive

from ._autodiff import autodiff_linearization
from ._differences import central_jacobian, complex_step_jacobian, model_function, perturbation_jacobian
from ._direct import direct_linearization
from ._result import LinearizationProblem, MethodResult

__all__ = ["METHODS", "LinearizationMethod", "OptionInfo", "option", "register_method", "unregister_method"]


# -- options ---------------------------------------------------------------------------------------


def option(default: Any, unit: str, description: str) -> Any:
    """A field of a method's options dataclass with its unit and one-line description.

    Parameters
    ----------
    default : object
        The default value [the option's unit].
    unit : str
        The unit in brackets (``"[-]"``, ``"[s]"``), or ``""`` for a flag.
    description : str
        One line: what the option does.

    Returns
    -------
    dataclasses.Field
    """
    return dataclasses.field(default=default, metadata={"unit": unit, "description": description})


@dataclass(frozen=True)
class OptionInfo:
    """One option of a method, for listings (docs, command-line help)."""

    name: str
    default: Any
    unit: str
    description: str

    def __str__(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        return f"{self.name} = {self.default!r}{unit}: {self.description}"


def _number(value) -> bool:
    """A finite real number (not a bool)."""
    return (not isinstance(value, (bool, np.bool_)) and isinstance(value, (int, float, np.integer, np.floating))
            and bool(np.isfinite(value)))


def _rel_step(value) -> None:
    if not _number(value) or not (0 < value < 1):
        raise ModelError(f"rel_step must lie in (0, 1), got {value!r}")


def _integer(name: str, value, least: int, what: str) -> None:
    if not _number(value) or int(value) != value or value < least:
        raise ModelError(f"{name} must be {what}, got {value!r}")


@dataclass(frozen=True)
class PerturbationOptions:
    """Options of ``"perturbation"``."""

    digits: float = option(6, "[-]", "significant digits two successive estimates must share")
    rel_step: float = option(0.01, "[-]", "initial step relative to max(abs(z_j), scale_j) (the classic 1 %)")
    zero_step: float = option(1e-6, "[variable units]", "step of a variable whose value and scale are zero, and the smallest initial step")
    max_halvings: int = option(10, "[-]", "cap on step halvings per variable")
    abs_tol: float = option(0.0, "[entry units]", "absolute agreement floor per Jacobian entry")

    def __post_init__(self) -> None:
        check_positive(self.digits, "digits")
        _rel_step(self.rel_step)
        check_positive(self.zero_step, "zero_step")
        _integer("max_halvings", self.max_halvings, 1, "a positive integer")
        check_positive(self.abs_tol, "abs_tol", allow_zero=True)


@dataclass(frozen=True)
class CentralOptions:
    """Options of ``"central"``."""

    digits: float = option(6, "[-]", "accuracy in significant digits an entry must reach to count as converged")
    rel_step: float = option(1e-3, "[-]", "largest step relative to max(abs(z_j), scale_j)")
    zero_step: float = option(1e-6, "[variable units]", "step of a variable whose value and scale are zero, and the smallest initial step")
    levels: int = option(3, "[-]", "step levels of the Richardson table, at least 2")

    def __post_init__(self) -> None:
        check_positive(self.digits, "digits")
        _rel_step(self.rel_step)
        check_positive(self.zero_step, "zero_step")
        _integer("levels", self.levels, 2, "an integer of at least 2")


@dataclass(frozen=True)
class ComplexStepOptions:
    """Options of ``"complex-step"``."""

    complex_step: float = option(1e-20, "[-]", "imaginary step relative to max(abs(z_j), 1)")

    def __post_init__(self) -> None:
        check_positive(self.complex_step, "complex_step")


@dataclass(frozen=True)
class AutodiffOptions:
    """``"autodiff"`` has no options."""


@dataclass(frozen=True)
class KaneOptions:
    """Options of ``"kane"``."""

    premature: bool = option(False, "", "take the partial velocities from the linearized velocities (premature "
                                        "linearization, Banerjee 2016, Eqs. 1.66-1.67): loses the motion-induced "
                                        "stiffness unless the scene has the geometric_stiffness effect; for showing "
                                        "that error, not for use")

    def __post_init__(self) -> None:
        if not isinstance(self.premature, (bool, np.bool_)):
            raise ModelError(f"premature must be True or False, got {self.premature!r}")


# -- the models a method applies to ----------------------------------------------------------------


@dataclass(frozen=True)
class _ModelKind:
    needs: str  # "method 'x' needs ..."
    test: Callable[[NonlinearModel], bool]
    compiled_scenes: bool  # whether a compiled scene is such a model


def _is_scene(model: NonlinearModel) -> bool:
    return getattr(model, "equations", None) is not None


_MODEL_KINDS = {
    "any": _ModelKind("any model", lambda model: True, True),
    "numpy": _ModelKind("a model of numpy callables that propagate complex numbers", lambda model: not model.is_casadi,
                        False),
    "casadi": _ModelKind("a CasADi model (NonlinearModel.from_casadi or a compiled scene)",
                         lambda model: model.is_casadi, True),
    "scene": _ModelKind("a compiled scene (compile_model): it linearizes Kane's equations, which other models "
                        "do not have", _is_scene, True),
}


def _what(model: NonlinearModel) -> str:
    if _is_scene(model):
        return "a compiled scene (a CasADi model)"
    return "a CasADi model" if model.is_casadi else "a model of numpy callables"


def _either(names) -> str:
    quoted = [repr(n) for n in names]
    return quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " or " + quoted[-1]


# -- the registry ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class LinearizationMethod:
    """A registered linearization method.

    Attributes
    ----------
    name : str
        The name ``linearize(..., method=name)`` takes.
    description : str
        One line: what it does and how exact it is.
    options : type
        A frozen dataclass of its options, each field made with :func:`option`.
    function : callable
        ``function(problem, options) -> MethodResult``.
    models : {"any", "numpy", "casadi", "scene"}
        The models it applies to: any, numpy callables only, CasADi models (compiled scenes
        included), compiled scenes only.
    """

    name: str
    description: str
    options: type
    function: Callable[[LinearizationProblem, Any], MethodResult]
    models: str = "any"

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name or self.name == "auto":
            raise ModelError(f"name must be a non-empty string other than 'auto', got {self.name!r}")
        if not isinstance(self.description, str) or not self.description or "\n" in self.description:
            raise ModelError(f"description of method {self.name!r} must be one line of text")
        if not (dataclasses.is_dataclass(self.options) and isinstance(self.options, type)):
            raise ModelError(f"options of method {self.name!r} must be a dataclass type")
        no_default = [f.name for f in dataclasses.fields(self.options) if f.default is dataclasses.MISSING]
        if no_default:
            raise ModelError(f"options of method {self.name!r} need defaults (made with option()): {no_default}")
        if not callable(self.function):
            raise ModelError(f"function of method {self.name!r} must be callable")
        if self.models not in _MODEL_KINDS:
            raise ModelError(f"models of method {self.name!r} must be one of {list(_MODEL_KINDS)}, got {self.models!r}")

    @property
    def option_infos(self) -> tuple[OptionInfo, ...]:
        """Each option's name, default, unit and description, in declaration order."""
        return tuple(OptionInfo(f.name, f.default, f.metadata.get("unit", ""), f.metadata.get("description", ""))
                     for f in dataclasses.fields(self.options))

    @property
    def option_names(self) -> tuple[str, ...]:
        """The names of its options."""
        return tuple(f.name for f in dataclasses.fields(self.options))

    @property
    def applies_to(self) -> str:
        """What models it applies to, in words."""
        return _MODEL_KINDS[self.models].needs

    @property
    def applies_to_compiled_scenes(self) -> bool:
        """Whether it can linearize a compiled scene (a CasADi model with Kane's equations)."""
        return _MODEL_KINDS[self.models].compiled_scenes

    def applies(self, model: NonlinearModel) -> bool:
        """Whether it can linearize ``model``.

        Parameters
        ----------
        model : NonlinearModel
            The model.

        Returns
        -------
        bool
        """
        return bool(_MODEL_KINDS[self.models].test(model))

    def check_model(self, model: NonlinearModel) -> None:
        """Raise ``MethodUnavailableError`` when it cannot linearize ``model``, naming the methods that can.

        Parameters
        ----------
        model : NonlinearModel
            The model.

        Raises
        ------
        MethodUnavailableError
            When the method does not apply to this kind of model.
        """
        if self.applies(model):
            return
        others = [m.name for m in METHODS.values() if m.applies(model)]
        hint = f": use {_either(others)}" if others else ""
        raise MethodUnavailableError(f"method {self.name!r} needs {self.applies_to}; this is {_what(model)}{hint}")

    def make_options(self, given: dict) -> Any:
        """The options dataclass from keyword arguments (None means the default).

        Parameters
        ----------
        given : dict
            Option names and values.

        Returns
        -------
        object
            An instance of ``options``.

        Raises
        ------
        ModelError
            For an option this method does not take (naming the methods that do, and the options
            this one takes), or an invalid value.
        """
        names = self.option_names
        for key, value in given.items():
            if key in names:
                continue
            takers = [m.name for m in METHODS.values() if key in m.option_names]
            mine = f"{self.name!r} takes {', '.join(names)}" if names else f"{self.name!r} takes no options"
            if takers:
                which = f"method {takers[0]!r}" if len(takers) == 1 else "methods " + ", ".join(map(repr, takers))
                raise ModelError(f"{key}={value!r} applies to {which} only, not to {self.name!r}; {mine}")
            raise ModelError(f"unknown option {key!r} for method {self.name!r}; {mine}")
        return self.options(**{k: v for k, v in given.items() if v is not None})

    def summary(self) -> str:
        """Its name, description, the models it applies to and its options, as indented lines.

        Returns
        -------
        str
        """
        lines = [f"{self.name}: {self.description}", f"    applies to {self.applies_to}"]
        lines += [f"    {info}" for info in self.option_infos] or ["    no options"]
        return "\n".join(lines)


_REGISTRY: dict[str, LinearizationMethod] = {}

#: The registered methods by name, read-only and live (registration order).
METHODS = MappingProxyType(_REGISTRY)


def register_method(method: LinearizationMethod, *, replace: bool = False) -> None:
    """Register ``method`` under ``method.name``.

    Parameters
    ----------
    method : LinearizationMethod
        The method.
    replace : bool
        Allow replacing a method registered under that name.

    Raises
    ------
    ModelError
        When the name is taken and ``replace`` is false, or ``method`` is not a
        ``LinearizationMethod``.
    """
    if not isinstance(method, LinearizationMethod):
        raise ModelError(f"method must be a LinearizationMethod, got {type(method).__name__}")
    if method.name in _REGISTRY and not replace:
        raise ModelError(f"method {method.name!r} is already registered; pass replace=True to override it")
    _REGISTRY[method.name] = method


def unregister_method(name: str) -> None:
    """Remove the method registered under ``name``.

    Parameters
    ----------
    name : str
        Its name.

    Raises
    ------
    ModelError
        When no method has that name.
    """
    if name not in _REGISTRY:
        raise ModelError(f"no linearization method is registered as {name!r}")
    del _REGISTRY[name]


def describe_methods(indent: str = "") -> str:
    """Every registered method's :meth:`LinearizationMethod.summary`, for docs and help texts.

    Parameters
    ----------
    indent : str
        Prefix of every line.

    Returns
    -------
    str
    """
    return "\n".join(indent + line for m in METHODS.values() for line in m.summary().splitlines())


# -- the numerical methods: differences of the stacked function g(z) = [f; h], z = [x; u] -----------


def _differences(jacobian: Callable, *, uses_scale: bool) -> Callable[[LinearizationProblem, Any], MethodResult]:
    def run(problem: LinearizationProblem, options) -> MethodResult:
        model = problem.model
        n = model.n_states
        g = model_function(model, problem.p, problem.t)
        z0 = np.concatenate([problem.x, problem.u])
        g0 = g(z0)
        f0, y0 = g0[:n], g0[n:]
        model.check_values(f0, y0)  # before differencing: a bad nominal value is named as such
        kwargs = dataclasses.asdict(options)
        if uses_scale:
            kwargs["scale"] = problem.scale
        result = jacobian(g, z0, g0, **kwargs)
        return MethodResult(f0, y0, result.J, result.error, result.converged, result.evaluations)

    return run


def _complex_step(g, z0, g0, *, complex_step, scale):
    # the exact derivative, checked by real one-sided differences (kinks, dropped imaginary parts)
    return complex_step_jacobian(g, z0, step=complex_step, g0=g0, scale=scale)


# -- the built-in methods (registration order is the order of METHODS) ----------------------------

register_method(LinearizationMethod(
    "perturbation",
    "classic three-point quadratic fit with step halving (DISCOS, reference notes linear-analysis-discos.md 1); "
    "per-entry error estimate",
    PerturbationOptions, _differences(perturbation_jacobian, uses_scale=True)))
register_method(LinearizationMethod(
    "central",
    "central differences with Richardson extrapolation; per-entry error estimate",
    CentralOptions, _differences(central_jacobian, uses_scale=True)))
register_method(LinearizationMethod(
    "complex-step",
    "complex-step derivative (Squire and Trapp 1998): exact to round-off, for numpy models that propagate "
    "complex numbers",
    ComplexStepOptions, _differences(_complex_step, uses_scale=True), models="numpy"))
register_method(LinearizationMethod(
    "autodiff",
    "exact Jacobians of the CasADi graph (algorithmic differentiation); error estimate zero",
    AutodiffOptions, autodiff_linearization, models="casadi"))
register_method(LinearizationMethod(
    "kane",
    "Kane's direct linearization of a compiled scene (Banerjee 2016, 1.4): exact, with the second-order form "
    "and its stiffness and damping by origin",
    KaneOptions, direct_linearization, models="scene"))
