"""Aggregated validation of a :class:`~linflex.scene._scene.Scene`: every problem, with its path.

Each entry checks itself (``entry.problems(path, context)``, in :mod:`._entries`, :mod:`._joints`,
:mod:`._devices`, :mod:`._world`); this module adds the checks that span entries: the scene's
name and effects, unique names, the joint tree, the orbit the effects need, joints that would
turn a body without rotational inertia, and the registered effects' own checks.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._contacts import Constraint
from ._devices import (
    Actuator,
    Controller,
    Disturbance,
    InputProfile,
    Sensor,
    Surface,
    Wheel,
    actuator_width,
    sensor_width,
)
from ._entries import ACTUATOR_TYPES, SENSOR_TYPES, Body, Pendulum, PointMass, Spring
from ._joints import Joint, LoopJoint
from ._problems import Problems, SceneContext, hint
from ._registry import registered_effects
from ._requirements import Requirements
from ._values import inertia_matrix, vector3, wheel_inertia
from ._variable import Boom, Tank, ThermalLoad
from ._world import Environment, Frame, Limits, Orbit

__all__ = ["scene_problems", "sensor_width", "actuator_width", "locked_translations"]

#: The scene's lists and the class of their entries (the TOML arrays of tables ``[[bodies]]``, ...).
ENTRY_CLASSES = {"bodies": Body, "joints": Joint, "loop_joints": LoopJoint, "constraints": Constraint,
                 "point_masses": PointMass, "pendulums": Pendulum, "springs": Spring, "wheels": Wheel,
                 "surfaces": Surface, "sensors": Sensor, "actuators": Actuator, "disturbances": Disturbance,
                 "controllers": Controller, "inputs": InputProfile, "booms": Boom, "tanks": Tank,
                 "thermal": ThermalLoad}
#: The scene's lists of entries, in the order they are checked (the inputs after them).
ENTRY_LISTS = tuple(key for key in ENTRY_CLASSES if key != "inputs")
#: A moment of inertia at or below this fraction of the largest is zero (16 round-offs: the
#: parallel-axis sums cancel to about 1e-16 of the largest moment).
_SINGULAR = 16 * np.finfo(float).eps
_SINGLE = {"frame": Frame, "orbit": Orbit, "environment": Environment, "limits": Limits,
           "requirements": Requirements}


def locked_translations(joint) -> tuple[str, ...]:
    """The translation coordinates a free joint holds fixed (``locked = ["x", "z"]``)."""
    return tuple(joint.locked) if isinstance(joint.locked, (tuple, list)) else ()


def scene_problems(scene) -> list[str]:
    """Every problem of ``scene`` as ``"path: message"`` strings, in one pass (empty when valid)."""
    context = SceneContext(scene, registered_effects(), SENSOR_TYPES, ACTUATOR_TYPES, kinds=ENTRY_CLASSES)
    out = Problems(context.limits)
    _check_top(out, scene, context)
    _check_names(out, scene)
    malformed = [key for key in ENTRY_LISTS if not isinstance(getattr(scene, key), tuple)]
    for key in ENTRY_LISTS:
        items = getattr(scene, key)
        if not isinstance(items, tuple):
            single = callable(getattr(items, "problems", None))
            out.add(key, f"expected a list of entries, got {items!r}" + (f" (one entry: write {key}=[...])" if single else ""))
            continue
        for i, item in enumerate(items):
            if not _of_another_list(out, key, i, item):
                out.extend(_entry_problems(item, f"{key}[{i}]", context))
    for key, cls in _SINGLE.items():
        value = getattr(scene, key)
        if value is None and key == "orbit":
            continue
        if not isinstance(value, cls):
            out.add(key, f"expected a {cls.__name__}, got {value!r}")
        else:
            out.extend(_entry_problems(value, key, context))
    inputs = getattr(scene, "inputs", ())
    if not isinstance(inputs, tuple):
        out.add("inputs", f"expected a list of entries, got {inputs!r}")
    for i, item in enumerate(inputs if isinstance(inputs, tuple) else ()):
        if not _of_another_list(out, "inputs", i, item):
            out.extend(_entry_problems(item, f"inputs[{i}]", context))
    _check_orbit_needed(out, scene, context)
    if not malformed:  # the checks across entries walk every list (a list that is none is reported above)
        _check_tree(out, scene)
        _check_rotational_inertia(out, scene, context)
        _check_effects(out, scene, context)
    return list(out)


def _of_another_list(out: Problems, key: str, i: int, item: Any) -> bool:
    """Report (and return True for) a scene entry in the wrong list: a Body among the wheels."""
    kind = ENTRY_CLASSES[key]
    if not callable(getattr(item, "problems", None)) or isinstance(item, kind):
        return False
    out.add(f"{key}[{i}]", f"{type(item).__name__} {getattr(item, 'name', '')!r} in the list {key}, which takes "
                           f"{kind.__name__} entries")
    return True


def _entry_problems(entry: Any, path: str, context: SceneContext) -> list[str]:
    """An entry's own problems; a value that cannot even be checked is a problem, not a traceback."""
    if not callable(getattr(entry, "problems", None)):
        return [f"{path}: expected a scene entry, got {entry!r}"]
    try:
        return entry.problems(path, context)
    except (TypeError, ValueError, AttributeError, KeyError, IndexError, ZeroDivisionError) as err:
        return [f"{path}: cannot be checked ({type(err).__name__}: {err}); its values are malformed"]


def _check_top(out: Problems, scene, context: SceneContext) -> None:
    """The scene's name and its list of effects."""
    if not isinstance(scene.name, str) or not scene.name.strip():
        out.add("name", f"expected a non-empty string, got {scene.name!r}")
    if not isinstance(scene.effects, tuple):
        out.add("effects", f"expected a list of effect names (effects = [\"gravity\", ...]), got "
                           f"{type(scene.effects).__name__} {scene.effects!r}")
        return
    registry = context.registry
    seen: set[str] = set()
    for i, eff in enumerate(scene.effects):
        if not isinstance(eff, str) or eff not in registry:
            out.add(f"effects[{i}]", f"unknown effect {eff!r}{hint(eff, sorted(registry))}; "
                                     f"registered: {', '.join(sorted(registry))}")
        elif eff in seen:
            out.add(f"effects[{i}]", f"effect {eff!r} named twice")
        seen.add(eff)


def _check_names(out: Problems, scene) -> None:
    """Names are non-empty, free of path characters, unique across the scene; 'ground' is reserved."""
    all_names: dict[str, str] = {}
    for key in ENTRY_LISTS:
        items = getattr(scene, key)
        for i, item in enumerate(items if isinstance(items, tuple) else ()):
            path = f"{key}[{i}].name"
            name = getattr(item, "name", None)
            if not isinstance(name, str) or not name.strip() or any(c in name for c in " .[]\"'"):
                out.add(path, f"expected a non-empty name without spaces, dots or brackets, got {name!r}")
                continue
            if name == "ground":
                out.add(path, "'ground' is reserved for the scene frame")
            elif name in all_names:
                out.add(path, f"name {name!r} is already used by {all_names[name]}")
            else:
                all_names[name] = f"{key}[{i}]"


def _check_tree(out: Problems, scene) -> None:
    """Every body has exactly one inboard joint, and the joints form a tree hanging from 'ground'."""
    bodies = [b.name for b in scene.bodies if isinstance(b, Body)]
    parent_of: dict[str, tuple[str, int]] = {}
    for i, j in enumerate(scene.joints):
        if not isinstance(j, Joint) or not isinstance(j.child, str) or j.child not in bodies:
            continue
        if j.child in parent_of:
            out.add(f"joints[{i}].child", f"body {j.child!r} is already the child of joints[{parent_of[j.child][1]}] "
                                          "(each body has exactly one inboard joint; close a loop with a "
                                          "[[loop_joints]] entry)")
        else:
            parent_of[j.child] = (j.parent, i)
    for i, name in enumerate(bodies):
        if name not in parent_of:
            out.add(f"bodies[{i}]", f"body {name!r} is attached by no joint (add a [[joints]] entry with "
                                    f"child = {name!r})")
    # Loops: walk up from each body; a body reached twice is on a cycle.
    reported: set[str] = set()
    for start in bodies:
        path, node = [start], start
        while node in parent_of and parent_of[node][0] != "ground":
            node = parent_of[node][0]
            if node in path:
                cycle = path[path.index(node):] + [node]
                if min(cycle) not in reported:
                    reported.add(min(cycle))
                    out.add(f"joints[{parent_of[start][1]}]", f"loop in the joint tree: {' -> '.join(cycle)} "
                                                              "(a tree is required; every chain must end at "
                                                              "'ground'; close loops with [[loop_joints]])")
                break
            path.append(node)


def _check_orbit_needed(out: Problems, scene, context: SceneContext) -> None:
    """An ``[orbit]`` table is required by the LVLH frame and by effects that need one."""
    registry = context.registry
    needs = [e for e in context.effects if e in registry and registry[e].needs_orbit]
    if getattr(scene.frame, "kind", None) == "lvlh":
        needs = ["frame.kind = 'lvlh'"] + needs
    if scene.orbit is None and needs:
        out.add("orbit", f"an [orbit] table is required by {', '.join(needs)}")


def _check_rotational_inertia(out: Problems, scene, context: SceneContext) -> None:
    """A joint that lets a body turn needs rotational inertia about its free axes.

    Checked for a rigid assembly at the end of a chain (a rigid body and the rigid bodies fixed
    to it, no other joints below, no loop joints): its inertia about the joint point, with
    everything mounted on it (point masses, slosh bobs, spring masses, wheels, taken as rigidly
    attached: a part that moves can only lower the inertia, so no good scene is refused), must
    be positive about the hinge axis (revolute) or in every direction (spherical, free); else its
    angular acceleration is undetermined (a singular mass matrix) and the model would fail at its
    first evaluation.
    """
    children: dict[str, list[Joint]] = {}
    for j in scene.joints:
        if isinstance(j, Joint) and isinstance(j.parent, str):
            children.setdefault(j.parent, []).append(j)
    looped = {name for lj in scene.loop_joints if isinstance(lj, LoopJoint) for name in (lj.body_a, lj.body_b)}
    for i, j in enumerate(scene.joints):
        body = context.bodies.get(j.child) if isinstance(j, Joint) and isinstance(j.child, str) else None
        if (body is None or j.type not in ("revolute", "spherical", "free")
                or j.locked is True or j.prescribed is not None):
            continue
        locked = set(locked_translations(j))
        if j.type == "free" and locked not in (set(), {"x", "y", "z"}):
            continue  # partly held translations: the condition mixes both; the integrator will tell
        try:
            with np.errstate(all="raise"):
                parts = _assembly_parts(scene, context, body, children, looped, set())
                if parts is None:
                    continue
                axis = vector3(j.axis) / np.linalg.norm(vector3(j.axis)) if j.type == "revolute" else None
                # Moving translations: what must turn is the inertia about the mass centre.
                free = _free_rotation(parts, vector3(j.child_point), axis, central=j.type == "free" and not locked)
        except (TypeError, ValueError, ZeroDivisionError, FloatingPointError, np.linalg.LinAlgError):
            continue  # malformed values are reported with their entries
        if free is not None:
            k = [b.name for b in scene.bodies].index(body.name)
            out.add(f"joints[{i}]", f"the {j.type} joint turns {body.name!r}, which has no rotational inertia about "
                                    f"the axis {[round(float(c), 6) + 0.0 for c in free]} through the joint point "
                                    "(its inertia is zero about that axis and all its mass lies on it): its "
                                    f"acceleration is undetermined; give bodies[{k}].inertia a positive moment "
                                    "about that axis or move mass off it")


def _assembly_parts(scene, context: SceneContext, body: Body, children, looped, seen: set[str]):
    """:func:`_mounted_parts` of ``body`` and of the rigid bodies fixed to it (in its frame), or None
    when something below it moves (a joint other than fixed), bends (a flexible body) or closes a
    loop."""
    if body.type != "rigid" or body.name in looped or body.name in seen:
        return None
    seen.add(body.name)
    parts = _mounted_parts(scene, body)
    for k in children.get(body.name, ()):
        child = context.bodies.get(k.child) if isinstance(k.child, str) else None
        below = None if k.type != "fixed" or child is None else _assembly_parts(scene, context, child, children,
                                                                              looped, seen)
        if below is None:
            return None
        # A fixed joint keeps the child's axes parallel to the parent's, its origin at
        # parent_point - child_point.
        offset = vector3(k.parent_point) - vector3(k.child_point)
        parts += [(m, where + offset, inertia) for m, where, inertia in below]
    return parts


def _mounted_parts(scene, body: Body) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """``(mass [kg], position [m], central inertia [kg m^2])`` of a rigid body and of what is mounted on it."""
    parts = [(float(body.mass), vector3(body.com), inertia_matrix(body.inertia))]
    for item in (*scene.point_masses, *scene.springs, *scene.pendulums, *scene.wheels):
        if getattr(item, "body", None) != body.name:
            continue
        where = vector3(item.point)
        if isinstance(item, Pendulum):
            where = where + float(item.length) * vector3(item.direction) / np.linalg.norm(vector3(item.direction))
        rotor = wheel_inertia(item) if hasattr(item, "spin_inertia") else np.zeros((3, 3))
        if isinstance(item, (PointMass, Spring, Pendulum)) or hasattr(item, "spin_inertia"):
            parts.append((float(item.mass), where, rotor))
    return parts


def _free_rotation(parts, point: np.ndarray, axis: np.ndarray | None, *, central: bool) -> np.ndarray | None:
    """An axis through ``point`` (or through the mass centre) about which the parts have no inertia, or None.

    Decided structurally, not by the size of an eigenvalue of the summed inertia (whose
    parallel-axis terms can dwarf a genuine small moment): the moment about ``n`` vanishes
    exactly when the summed central inertias have none about ``n`` and every mass lies on the
    line along ``n``. With ``axis`` (a hinge) only ``n = axis`` can turn.
    """
    masses = np.array([m for m, _, _ in parts])
    if central and masses.sum() > 0:
        point = sum(m * w for m, w, _ in parts) / masses.sum()
    offsets = np.array([w - point for m, w, _ in parts if m > 0]).reshape(-1, 3)
    lengths = np.linalg.norm(offsets, axis=1)
    directions = offsets[lengths > 1e-12 * max(lengths.max(initial=0.0), 1e-300)]
    directions = directions / np.linalg.norm(directions, axis=1)[:, None]
    inertia = sum(c for _, _, c in parts)
    eig, vec = np.linalg.eigh((inertia + inertia.T) / 2)
    tol = _SINGULAR * max(float(eig.max()), 0.0)
    if axis is not None:
        candidates = [axis]
    elif len(directions):
        # Masses off the point: only the line they all lie on (if they do) can be a free axis.
        candidates = [] if np.linalg.matrix_rank(directions, tol=1e-9) > 1 else [directions[0]]
    else:
        candidates = [vec[:, k] for k in np.flatnonzero(eig <= tol)]
    for n in candidates:
        if float(n @ inertia @ n) <= tol and all(np.linalg.norm(np.cross(d, n)) <= 1e-9 for d in directions):
            return n
    return None


def _check_effects(out: Problems, scene, context: SceneContext) -> None:
    """The registered effects' own checks; a path already reported by the entries is not repeated."""
    reported = {problem.split(": ", 1)[0] for problem in out}
    for name in context.effects:
        effect = context.registry.get(name)
        if effect is None:
            continue
        try:
            problems = effect.check(scene)
        except (TypeError, ValueError, AttributeError, KeyError, IndexError) as err:
            problems = [f"effects: the {name!r} effect cannot check this scene ({type(err).__name__}: {err}); "
                        "fix the problems above first"]
        out.extend(p for p in problems if p.split(": ", 1)[0] not in reported)
