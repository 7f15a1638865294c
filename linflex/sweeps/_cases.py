"""The cases of a sweep and the scene of each: grids (:func:`parameter_grid`), seeded samples
(:func:`parameter_sample`), and a scene with some of its values changed (:func:`vary_scene`),
addressed by paths in the scene's own vocabulary (see :mod:`._sweep`)."""

from __future__ import annotations

import copy
import itertools
import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..scene._scene import Scene
from ..system._errors import ModelError

__all__ = ["DISTRIBUTIONS", "parameter_grid", "parameter_sample", "vary_scene"]

#: Distributions understood by :func:`parameter_sample`, with their parameters.
DISTRIBUTIONS = {"uniform": ("low", "high"), "normal": ("mean", "std")}

_TOKEN = re.compile(r"^([^.\[\]]+)((?:\[\d+\])*)$")


def parameter_grid(values: Mapping[str, Sequence[float]]) -> tuple[dict[str, float], ...]:
    """Every combination of the given parameter values (the first parameter varies slowest).

    Parameters
    ----------
    values : mapping of str to sequence of float
        Parameter name -> the values it takes.

    Returns
    -------
    tuple of dict
        ``prod(len(v))`` cases.

    Raises
    ------
    ModelError
        If a parameter has no values or a value is not a finite number.

    Examples
    --------
    >>> parameter_grid({"bodies.hub.mass": [900, 1000], "controllers.pd.kp": [1, 2, 3]})[1]
    {'bodies.hub.mass': 900.0, 'controllers.pd.kp': 2.0}
    """
    if not isinstance(values, Mapping) or not values:
        raise ModelError(f"parameter_grid needs a non-empty mapping of parameter -> values, got {values!r}")
    names, columns = [], []
    for name, vals in values.items():
        if isinstance(vals, (str, bytes)) or not isinstance(vals, Sequence | np.ndarray) or np.ndim(vals) != 1 \
                or len(vals) == 0:
            raise ModelError(f"parameter_grid: {name!r} needs a non-empty sequence of values, got {vals!r}")
        columns.append([_finite(v, name) for v in vals])
        names.append(str(name))
    return tuple(dict(zip(names, combo)) for combo in itertools.product(*columns))


def parameter_sample(distributions: Mapping[str, Mapping[str, Any]], n: int, *, seed: int = 0) -> tuple[dict[str, float], ...]:
    """A reproducible Monte Carlo sample of ``n`` cases.

    Parameters
    ----------
    distributions : mapping of str to mapping
        Parameter name -> ``{"distribution": "normal", "mean": m, "std": s}`` or
        ``{"distribution": "uniform", "low": a, "high": b}`` (in the parameter's own units).
    n : int
        Number of cases.
    seed : int
        Seed of ``numpy.random.default_rng``: the same seed gives the same cases on every backend.

    Returns
    -------
    tuple of dict

    Raises
    ------
    ModelError
        For an unknown distribution, missing or extra keys, non-finite values, ``std < 0`` or
        ``high < low``, a range ``high - low`` beyond the floats, ``n < 1``, or a seed that is
        not a non-negative integer.

    Examples
    --------
    >>> cases = parameter_sample({"bodies.hub.mass": {"distribution": "uniform", "low": 900, "high": 1100}}, 3)
    >>> len(cases), all(900 <= c["bodies.hub.mass"] <= 1100 for c in cases)
    (3, True)
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ModelError(f"parameter_sample: n must be a positive integer number of cases, got {n!r}")
    if not isinstance(distributions, Mapping) or not distributions:
        raise ModelError("parameter_sample needs a non-empty mapping of parameter -> distribution")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ModelError(f"parameter_sample: seed must be a non-negative integer, got {seed!r}")
    rng = np.random.default_rng(seed)
    columns = {}
    for name, spec in distributions.items():
        if not isinstance(spec, Mapping) or spec.get("distribution") not in DISTRIBUTIONS:
            raise ModelError(f"parameter_sample: {name!r} needs a mapping with distribution = one of "
                             f"{sorted(DISTRIBUTIONS)}, got {spec!r}")
        kind = spec["distribution"]
        keys = DISTRIBUTIONS[kind]
        given = set(spec) - {"distribution"}
        if given != set(keys):
            raise ModelError(f"parameter_sample: {name!r} ({kind}) needs exactly the keys {list(keys)}, got {sorted(given)}")
        a, b = (_finite(spec[k], f"{name}.{k}") for k in keys)
        if kind == "uniform":
            if b < a:
                raise ModelError(f"parameter_sample: {name!r} has high = {b} below low = {a}")
            if not math.isfinite(b - a):
                raise ModelError(f"parameter_sample: {name!r} has a range high - low = {b} - {a} beyond the floats")
            columns[str(name)] = rng.uniform(a, b, int(n))
        else:
            if b < 0:
                raise ModelError(f"parameter_sample: {name!r} has a negative std = {b}")
            columns[str(name)] = rng.normal(a, b, int(n))
    return tuple({k: float(col[i]) for k, col in columns.items()} for i in range(int(n)))


def _finite(value, what: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError) as err:
        raise ModelError(f"{what}: expected a number, got {value!r}") from err
    if not math.isfinite(x):
        raise ModelError(f"{what}: expected a finite number, got {value!r}")
    return x


# -- varying a scene --------------------------------------------------------------------------


def vary_scene(scene: Scene, values: Mapping[str, float]) -> Scene:
    """A copy of ``scene`` with the parameters at the given paths set, validated.

    Parameters
    ----------
    scene : Scene
    values : mapping of str to float
        Path (``"bodies.hub.mass"``, ``"bodies.hub.inertia[0]"``, ``"controllers.pd_x.kp"``)
        -> value, in the units of the scene file.

    Returns
    -------
    Scene

    Raises
    ------
    ModelError
        If a path does not lead to an entry of the scene (naming what is there), two paths name
        one entry (or an entry and a part of it: ``"bodies.hub.inertia"`` and
        ``"bodies[0].inertia[1]"``), or the varied scene is invalid (every problem listed, as
        :meth:`Scene.validate` does).

    Examples
    --------
    >>> from linflex import Body, Joint, Scene
    >>> s = Scene("rod", bodies=[Body("rod", 1.0, [0.1, 0.1, 0.01])],
    ...           joints=[Joint("hinge", "revolute", "rod", axis=[0, 1, 0])])
    >>> vary_scene(s, {"bodies.rod.mass": 2.5}).bodies[0].mass
    2.5
    """
    return _scene_from(_thaw(scene.to_dict()), values, f"{scene.name} (varied)").validate()


def _scene_from(data: dict, values: Mapping[str, float], source: str) -> Scene:
    """The scene of a dict form with the parameters at ``values`` set (on a private copy: the
    dict may be shared by serial cases or a Dask worker's threads); not yet validated."""
    data = copy.deepcopy(data)
    entries: dict[tuple, str] = {}
    for path, value in values.items():
        where = _set_path(data, str(path), value)
        # two names of one entry ("bodies.hub.mass" and "bodies[0].mass"), or an entry and a
        # part of it: the last one set would win while the table shows both
        for other, other_path in entries.items():
            if where[:len(other)] == other or other[:len(where)] == where:
                raise ModelError(f"parameters {other_path!r} and {str(path)!r} both set "
                                 f"{_location(other if len(other) <= len(where) else where)}; vary it once")
        entries[where] = str(path)
    return Scene.from_dict(data, source=source)


def _location(where: tuple) -> str:
    """``("bodies", 0, "inertia", 1)`` as ``bodies[0].inertia[1]``."""
    return "".join(f"[{k}]" if isinstance(k, int) else f".{k}" for k in where).lstrip(".")


def _thaw(value):
    """Tables and arrays of a scene's dict form as plain, mutable dicts and lists."""
    if isinstance(value, Mapping):
        return {k: _thaw(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_thaw(v) for v in value]
    return value


def _set_path(data: dict, path: str, value) -> tuple:
    """Set ``data`` at a dotted path whose list entries are chosen by ``name`` (or index); the
    keys and indices that lead there (``("bodies", 0, "mass")``)."""
    tokens = path.split(".")
    node: Any = data
    where = ""
    location: list = []
    for depth, token in enumerate(tokens):
        match = _TOKEN.match(token)
        if not match:
            raise ModelError(f"parameter {path!r}: cannot read {token!r} (expected key, key[i] or an entry name)")
        key, index_text = match.group(1), match.group(2)
        indices = [int(i) for i in re.findall(r"\[(\d+)\]", index_text)]
        last = depth == len(tokens) - 1
        if isinstance(node, list):
            names = [item.get("name") for item in node if isinstance(item, dict)]
            if key not in names:
                raise ModelError(f"parameter {path!r}: {where or 'the scene'} has no entry named {key!r} "
                                 f"(entries: {names})")
            child_key: Any = names.index(key)
        elif isinstance(node, dict):
            if key not in node and not (last and not indices):
                raise ModelError(f"parameter {path!r}: {where or 'the scene'} has no {key!r} "
                                 f"(keys: {sorted(node)})")
            child_key = key
        else:
            raise ModelError(f"parameter {path!r}: {where} is a value, not a table")
        where = f"{where}.{key}" if where else key
        location.append(child_key)
        if last and not indices:
            node[child_key] = value
            return tuple(location)
        child = node[child_key]
        for j, i in enumerate(indices):
            if not isinstance(child, list) or i >= len(child):
                raise ModelError(f"parameter {path!r}: {where} has no element [{i}]")
            location.append(i)
            if last and j == len(indices) - 1:
                child[i] = value
                return tuple(location)
            child = child[i]
            where = f"{where}[{i}]"
        if last:
            return tuple(location)  # pragma: no cover -- the loop above returned
        node = child
    raise ModelError(f"parameter {path!r}: empty path")  # pragma: no cover
