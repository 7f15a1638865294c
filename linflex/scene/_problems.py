"""The tools of scene validation: a problem collector with typed checks, and the context of a scene.

Each scene entry checks itself (``entry.problems(path, context)``); the checks that span entries
(names, references, the joint tree, effects that need an orbit) are in :mod:`._check`. Both
collect ``"path: message"`` strings in a :class:`Problems` list, so that one
:class:`~linflex.ModelError` reports every problem of a scene at once.

The physically meaningful ranges of scene numbers are module constants (:data:`LIMITS`); a
scene's ``[limits]`` table (:class:`~linflex.scene._world.Limits`) widens or narrows them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from difflib import get_close_matches
from typing import Any

import numpy as np

__all__ = ["LIMITS", "Problems", "SceneContext", "hint", "is_numeric"]

#: Magnitudes outside which a nonzero scene number is refused, by kind (SI units):
#: mass [kg] (a microgram to a large asteroid), inertia [kg m^2] (the mass range times the
#: length range squared), length [m] (a micrometre to a light-minute: points, lengths,
#: orbit radii), rate [rad/s] (joint, wheel and frame rates, the orbital rate; 1e5 rad/s is
#: about a million rpm). Zero stays allowed where the entry allows it (a massless flexible
#: body's rigid part, a point at the origin); what lies below the lower bound and above zero
#: is refused, as is anything above the upper bound.
LIMITS: Mapping[str, tuple[float, float]] = {
    "mass": (1e-9, 1e12),
    "inertia": (1e-21, 1e28),
    "length": (1e-6, 1e10),
    "rate": (0.0, 1e5),
}

_UNITS = {"mass": "kg", "inertia": "kg m^2", "length": "m", "rate": "rad/s"}


def hint(value: Any, known) -> str:
    """`` (did you mean 'x'?)`` for a near miss, else the list of known names."""
    known = [str(k) for k in known]
    match = get_close_matches(str(value), known, n=1, cutoff=0.5)
    if match:
        return f" (did you mean {match[0]!r}?)"
    return f"; known: {', '.join(known)}" if known else "; none defined"


def is_numeric(value: Any) -> bool:
    """Whether ``value`` converts to a float array (no strings, no None)."""
    if value is None or isinstance(value, str):
        return False
    try:
        np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    return True


def _is_number(value: Any) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float, np.floating, np.integer))


class Problems(list):
    """A list of ``"path: message"`` strings with the checks scene entries share.

    Every check adds its problem (naming the path, the value and what is expected) and returns
    whether the value passed, so that dependent checks can be skipped.
    """

    def __init__(self, limits: Mapping[str, tuple[float, float]] | None = None) -> None:
        super().__init__()
        self.limits = dict(LIMITS if limits is None else limits)

    def add(self, path: str, message: str) -> None:
        """Record a problem of the entry at ``path``."""
        self.append(f"{path}: {message}")

    def number(self, value: Any, path: str, unit: str, *, positive: bool = False, nonnegative: bool = False,
               optional: bool = False, kind: str | None = None) -> bool:
        """A finite real number (not a bool), optionally positive or non-negative and within ``LIMITS[kind]``."""
        if value is None and optional:
            return True
        if not _is_number(value):
            self.add(path, f"expected a number [{unit}], got {value!r}")
            return False
        if not math.isfinite(float(value)):
            self.add(path, f"not finite ({value}) [{unit}]")
            return False
        if positive and not value > 0:
            self.add(path, f"must be positive [{unit}], got {value}")
            return False
        if nonnegative and value < 0:
            self.add(path, f"must not be negative [{unit}], got {value}")
            return False
        return kind is None or self.in_range(abs(float(value)), path, kind, value)

    def in_range(self, magnitude: float, path: str, kind: str, shown: Any = None) -> bool:
        """A magnitude of kind ``mass``, ``inertia``, ``length`` or ``rate`` within the limits (0 passes)."""
        lo, hi = self.limits[kind]
        if magnitude == 0 or lo <= magnitude <= hi:
            return True
        shown = magnitude if shown is None else shown
        self.add(path, f"{shown!r} [{_UNITS[kind]}] is outside the physically meaningful {kind} range "
                       f"{lo:g} to {hi:g} {_UNITS[kind]} (in magnitude; change it with [limits] {kind} = [lo, hi])")
        return False

    def integer(self, value: Any, path: str, *, low: int | None = None, high: int | None = None) -> bool:
        """An integral number (``4.0`` passes, ``4.7`` and ``true`` do not) within ``[low, high]``."""
        if not _is_number(value) or not math.isfinite(float(value)) or float(value) != int(value):
            self.add(path, f"expected an integer, got {value!r}")
            return False
        if (low is not None and value < low) or (high is not None and value > high):
            bounds = f"from {low} to {high}" if high is not None else f"at least {low}"
            self.add(path, f"must be an integer {bounds}, got {value!r}")
            return False
        return True

    def array(self, value: Any, path: str, shape: tuple[int, ...], unit: str, what: str) -> np.ndarray | None:
        """A finite float array of ``shape``."""
        if not is_numeric(value) or (isinstance(value, (list, tuple)) and any(isinstance(v, bool) for v in value)):
            self.add(path, f"expected {what} [{unit}], got {value!r}")
            return None
        arr = np.asarray(value, dtype=float)
        if arr.shape != shape:
            self.add(path, f"expected {what} [{unit}], got shape {arr.shape}")
            return None
        if not np.all(np.isfinite(arr)):
            self.add(path, f"not finite: {value!r} [{unit}]")
            return None
        return arr

    def vector(self, value: Any, path: str, unit: str, *, nonzero: bool = False, kind: str | None = None) -> np.ndarray | None:
        """A finite 3-vector; ``nonzero`` for a direction; its length within ``LIMITS[kind]``."""
        arr = self.array(value, path, (3,), unit, "a 3-vector")
        if arr is not None and nonzero and not np.linalg.norm(arr) > 0:
            self.add(path, f"must not be the zero vector (it gives a direction), got {list(value)!r}")
            return None
        if arr is not None and kind is not None and np.linalg.norm(arr) > self.limits[kind][1]:
            # Points and offsets may be arbitrarily close to zero: only their size is bounded.
            self.in_range(float(np.linalg.norm(arr)), path, kind, list(value))
            return None
        return arr

    def name_ref(self, value: Any, path: str, known, what: str) -> bool:
        """``value`` is one of the ``known`` names of ``what`` (with a hint when not)."""
        if not isinstance(value, str) or value not in known:
            self.add(path, f"unknown {what} {value!r}{hint(value, known)}")
            return False
        return True

    choice = name_ref

    def inapplicable(self, entry: Any, key: str, path: str, applies: bool, why: str) -> None:
        """A key set away from its default where it has no effect is refused (never ignored)."""
        if applies:
            return
        default = type(entry).__dataclass_fields__[key].default
        value = getattr(entry, key)
        if value is not None and value != default:
            self.add(f"{path}.{key}", f"does not apply: {why} (got {value!r}; remove it)")


class SceneContext:
    """What entries need to know about the rest of their scene, collected once.

    Attributes
    ----------
    scene : Scene
        The scene being validated.
    effects : tuple of str
        Its effect names (empty when ``effects`` is not a list of names).
    bodies : dict of str to Body
        Bodies by name (entries with a valid name).
    joints, wheels : dict
        Joints and wheels by name.
    sensors, actuators : dict
        Sensors and actuators of a known type, by name.
    registry : Mapping of str to Effect
        The registered effects.

    Entries of another class than their list's (``kinds``: a Wheel among the sensors) are left out
    of these tables; the scene's check reports them.
    """

    def __init__(self, scene: Any, registry: Mapping[str, Any], sensor_types, actuator_types, *,
                 kinds: Mapping[str, type] | None = None) -> None:
        kinds = kinds or {}
        self.scene = scene
        effects = scene.effects
        self.effects = tuple(e for e in effects if isinstance(e, str)) if isinstance(effects, tuple) else ()
        self._effects_known = isinstance(effects, tuple)
        self.registry = registry
        limits = getattr(scene, "limits", None)
        self.limits = dict(LIMITS) if limits is None or not hasattr(limits, "as_dict") else limits.as_dict()
        self.bodies = {b.name: b for b in _entries(scene.bodies, kinds.get("bodies")) if isinstance(b.name, str)}
        self.joints = {j.name: j for j in _entries(scene.joints, kinds.get("joints")) if isinstance(j.name, str)}
        self.wheels = {w.name: w for w in _entries(scene.wheels, kinds.get("wheels")) if isinstance(w.name, str)}
        self.sensors = {s.name: s for s in _entries(scene.sensors, kinds.get("sensors"))
                        if getattr(s, "type", None) in sensor_types}
        self.actuators = {a.name: a for a in _entries(scene.actuators, kinds.get("actuators"))
                          if getattr(a, "type", None) in actuator_types}
        self._modal: dict[str, Any] = {}

    def lacks(self, effect: str) -> bool:
        """Whether the scene's effects (a valid list; else that is the problem) leave out ``effect``."""
        return self._effects_known and effect not in self.effects

    @property
    def body_names(self) -> list[str]:
        """The bodies' names, in scene order."""
        return list(self.bodies)

    def modal_data(self, body: str):
        """The modal data of a flexible body by name (all modes of a file, ``modes`` of a beam),
        resolved once per validation; raises what resolving raises."""
        if body not in self._modal:
            import dataclasses

            entry = self.bodies[body]
            try:
                self._modal[body] = dataclasses.replace(
                    entry, modes=None if entry.beam is None else entry.modes).resolved_modal_data()
            except Exception as err:  # noqa: BLE001 -- kept, and raised again to every caller
                self._modal[body] = err
        found = self._modal[body]
        if isinstance(found, Exception):
            raise found
        return found

    def node_names(self, body: str) -> tuple[str, ...] | None:
        """Node names of a flexible body's modal data; None when it cannot be resolved (reported with the body)."""
        try:
            return tuple(self.modal_data(body).node_names)
        except Exception:  # noqa: BLE001 -- the body's own check reports why
            return None

    def check_node(self, out: Problems, path: str, body: Any, node: Any) -> None:
        """A ``node`` must be a node of the modal data of the flexible ``body`` it names."""
        if node is None or body not in self.bodies:
            return  # no node, or the body reference is reported already
        entry = self.bodies[body]
        if entry.type != "flexible":
            out.add(path, f"nodes belong to flexible bodies; {body!r} is {entry.type}")
            return
        names = self.node_names(body)
        if names is not None and node not in names:
            out.add(path, f"unknown node {node!r} of {body!r}{hint(node, names)}")


def _entries(items: Any, kind: type | None = None) -> tuple:
    """The scene entries of one of a scene's lists (of class ``kind`` when given): what is not a
    list, or not such an entry, is left out here and reported by the scene's checks (``bodies:
    expected a list of entries``)."""
    if not isinstance(items, tuple):
        return ()
    return tuple(item for item in items if callable(getattr(item, "problems", None)) and hasattr(item, "name")
                 and (kind is None or isinstance(item, kind)))
