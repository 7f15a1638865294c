"""Aggregated validation of a :class:`~linflex.scene._scene.Scene`: every problem, with its path."""

from __future__ import annotations

import dataclasses
import math
from difflib import get_close_matches
from typing import Any

import numpy as np

from ..system._errors import ModelError
from ._entries import (
    ACTUATOR_TYPES,
    CONTROLLER_TYPES,
    FRAME_KINDS,
    JOINT_TYPES,
    LOOP_JOINT_TYPES,
    PROFILES,
    SENSOR_TYPES,
)
from ._registry import registered_effects

__all__ = ["scene_problems", "sensor_width", "actuator_width", "locked_translations"]


def _hint(value: Any, known) -> str:
    known = [str(k) for k in known]
    match = get_close_matches(str(value), known, n=1, cutoff=0.5)
    if match:
        return f" (did you mean {match[0]!r}?)"
    return f"; known: {', '.join(known)}" if known else "; none defined"


class _Checker:
    def __init__(self) -> None:
        self.problems: list[str] = []

    def add(self, path: str, message: str) -> None:
        self.problems.append(f"{path}: {message}")

    def number(self, value: Any, path: str, unit: str, *, positive=False, nonnegative=False, optional=False) -> bool:
        if value is None and optional:
            return True
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
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
        return True

    def array(self, value: Any, path: str, shape: tuple[int, ...], unit: str, what: str) -> np.ndarray | None:
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            self.add(path, f"expected {what} [{unit}], got {value!r}")
            return None
        if arr.shape != shape:
            self.add(path, f"expected {what} [{unit}], got shape {arr.shape}")
            return None
        if not np.all(np.isfinite(arr)):
            self.add(path, f"not finite: {value!r} [{unit}]")
            return None
        return arr

    def vector(self, value: Any, path: str, unit: str, *, nonzero=False) -> np.ndarray | None:
        arr = self.array(value, path, (3,), unit, "a 3-vector")
        if arr is not None and nonzero and not np.linalg.norm(arr) > 0:
            self.add(path, "must not be the zero vector (it gives a direction)")
            return None
        return arr

    def name_ref(self, value: Any, path: str, known, what: str) -> bool:
        if value not in known:
            self.add(path, f"unknown {what} {value!r}{_hint(value, known)}")
            return False
        return True

    def choice(self, value: Any, path: str, known, what: str) -> bool:
        if value not in known:
            self.add(path, f"unknown {what} {value!r}{_hint(value, known)}")
            return False
        return True


def sensor_width(sensor) -> int:
    """Number of output signals of a sensor (1 with an axis or for wheel speeds, else 3)."""
    return 1 if sensor.type == "wheel_speed" or sensor.axis is not None else 3


def locked_translations(joint) -> tuple[str, ...]:
    """The translation coordinates a free joint holds fixed (``locked = ["x", "z"]``)."""
    return tuple(joint.locked) if isinstance(joint.locked, (tuple, list)) else ()


def actuator_width(actuator) -> int:
    """Number of command signals of an actuator (or of a disturbance)."""
    return 1 if actuator.type == "wheel_torque" or actuator.axis is not None else 3


def scene_problems(scene) -> list[str]:  # noqa: C901 - one pass over the whole vocabulary

    ck = _Checker()
    if not isinstance(scene.name, str) or not scene.name.strip():
        ck.add("name", f"expected a non-empty string, got {scene.name!r}")

    # -- effects ------------------------------------------------------------------------------
    registry = registered_effects()
    seen_effects: set[str] = set()
    for i, eff in enumerate(scene.effects):
        if eff not in registry:
            ck.add(f"effects[{i}]", f"unknown effect {eff!r}{_hint(eff, sorted(registry))}; "
                   f"registered: {', '.join(sorted(registry))}")
        elif eff in seen_effects:
            ck.add(f"effects[{i}]", f"effect {eff!r} named twice")
        seen_effects.add(eff)

    # -- names ---------------------------------------------------------------------------------
    all_names: dict[str, str] = {}
    for key in ("bodies", "joints", "loop_joints", "point_masses", "pendulums", "springs", "wheels", "surfaces",
                "sensors", "actuators", "disturbances", "controllers"):
        for i, item in enumerate(getattr(scene, key)):
            path = f"{key}[{i}].name"
            name = getattr(item, "name", None)
            if not isinstance(name, str) or not name.strip() or any(c in name for c in " .[]\"'"):
                ck.add(path, f"expected a non-empty name without spaces, dots or brackets, got {name!r}")
                continue
            if name == "ground":
                ck.add(path, "'ground' is reserved for the scene frame")
            elif name in all_names:
                ck.add(path, f"name {name!r} is already used by {all_names[name]}")
            else:
                all_names[name] = f"{key}[{i}]"

    # -- bodies --------------------------------------------------------------------------------
    bodies = [b.name for b in scene.bodies]
    for i, b in enumerate(scene.bodies):
        p = f"bodies[{i}]"
        if b.type == "flexible":
            ck.number(b.mass, f"{p}.mass", "kg")
            if isinstance(b.mass, (int, float)) and b.mass < 0:
                ck.add(f"{p}.mass", "must be non-negative [kg]")
        else:
            ck.number(b.mass, f"{p}.mass", "kg", positive=True)
        ck.vector(b.com, f"{p}.com", "m")
        if b.type not in ("rigid", "flexible"):
            ck.add(f"{p}.type", f"unknown body type {b.type!r}{_hint(b.type, ('rigid', 'flexible'))}")
        elif b.type == "flexible":
            _check_flexible(ck, p, b)
        elif b.modal_data is not None:
            ck.add(f"{p}.modal_data", "only flexible bodies take modal data (set type = 'flexible')")
        try:
            arr = np.asarray(b.inertia, dtype=float)
        except (TypeError, ValueError):
            arr = None
        if arr is None or arr.shape not in ((3,), (3, 3)):
            ck.add(f"{p}.inertia", "expected 3 principal values or a 3x3 matrix [kg m^2], got "
                   + (f"shape {arr.shape}" if arr is not None else repr(b.inertia)))
        elif not np.all(np.isfinite(arr)):
            ck.add(f"{p}.inertia", f"not finite: {b.inertia!r} [kg m^2]")
        else:
            mat = np.diag(arr) if arr.shape == (3,) else arr
            if not np.allclose(mat, mat.T, rtol=1e-12, atol=1e-14 * max(1.0, np.abs(mat).max())):
                ck.add(f"{p}.inertia", "not symmetric positive definite (not symmetric)")
            else:
                eig = np.linalg.eigvalsh(mat)
                if eig.min() < -1e-12 * max(1.0, eig.max()):
                    ck.add(f"{p}.inertia", f"not symmetric positive definite (eigenvalue {eig.min():.3g} < 0; "
                           "zero is allowed for point-like bodies)")
                elif eig[0] + eig[1] < eig[2] * (1 - 1e-12):
                    ck.add(f"{p}.inertia", "violates the triangle inequality I1 + I2 >= I3 (not a physical body)")

    # -- joints: references, types, tree -------------------------------------------------------
    parent_of: dict[str, tuple[str, int]] = {}
    for i, j in enumerate(scene.joints):
        p = f"joints[{i}]"
        ck.choice(j.type, f"{p}.type", JOINT_TYPES, "joint type")
        if j.parent != "ground":
            ck.name_ref(j.parent, f"{p}.parent", bodies + ["ground"], "body")
        if ck.name_ref(j.child, f"{p}.child", bodies, "body"):
            if j.child in parent_of:
                ck.add(f"{p}.child", f"body {j.child!r} is already the child of joints[{parent_of[j.child][1]}] "
                       "(each body has exactly one inboard joint; close a loop with a [[loop_joints]] entry)")
            else:
                parent_of[j.child] = (j.parent, i)
        if j.child == j.parent:
            ck.add(f"{p}", f"joins body {j.child!r} to itself")
        ck.vector(j.axis, f"{p}.axis", "-", nonzero=True)
        ck.vector(j.parent_point, f"{p}.parent_point", "m")
        ck.vector(j.child_point, f"{p}.child_point", "m")
        ck.number(j.stiffness, f"{p}.stiffness", "N m/rad or N/m", nonnegative=True)
        ck.number(j.damping, f"{p}.damping", "N m s/rad or N s/m", nonnegative=True)
        ck.number(j.rest, f"{p}.rest", "rad or m")
        scalar = j.type in ("revolute", "prismatic")
        if isinstance(j.locked, (tuple, list)):
            if j.type != "free":
                ck.add(f"{p}.locked", f"a list of locked coordinates is for free joints (this joint is {j.type!r}; use true or false)")
            else:
                for k, c in enumerate(j.locked):
                    if c not in ("x", "y", "z"):
                        ck.add(f"{p}.locked[{k}]", f"unknown coordinate {c!r}; a free joint can lock its translations 'x', 'y', 'z'")
        elif j.locked not in (True, False):
            ck.add(f"{p}.locked", f"expected true, false or (free joints) a list of 'x', 'y', 'z', got {j.locked!r}")
        elif j.locked is True and not scalar:
            ck.add(f"{p}.locked", f"only revolute and prismatic joints lock as a whole; a free joint takes a list of "
                   f"translations to lock (this joint is {j.type!r})")
        if j.prescribed is not None:
            if not scalar:
                ck.add(f"{p}.prescribed", f"only revolute and prismatic coordinates can be prescribed (this joint is {j.type!r})")
            elif j.locked:
                ck.add(f"{p}.prescribed", "a coordinate cannot be both locked and prescribed")
            elif not callable(j.prescribed):
                if not isinstance(j.prescribed, dict) or j.prescribed.get("profile") not in PROFILES:
                    got = j.prescribed.get("profile") if isinstance(j.prescribed, dict) else j.prescribed
                    ck.add(f"{p}.prescribed", f"unknown profile {got!r}{_hint(got, PROFILES)}")
                else:
                    kind = j.prescribed["profile"]
                    allowed = PROFILES[kind]
                    for key, value in j.prescribed.items():
                        if key == "profile":
                            continue
                        if key not in allowed:
                            ck.add(f"{p}.prescribed.{key}", f"unknown key{_hint(key, allowed)}")
                        elif kind != "table":
                            ck.number(value, f"{p}.prescribed.{key}", "SI")
                    _check_profile(ck, f"{p}.prescribed", j.prescribed)
        nq, nu = {"free": (7, 6), "spherical": (4, 3), "revolute": (1, 1), "prismatic": (1, 1),
                  "fixed": (0, 0)}.get(j.type, (None, None))
        for key, n in (("q0", nq), ("u0", nu)):
            value = getattr(j, key)
            if value is None or n is None:
                continue
            value = [value] if isinstance(value, (int, float)) else value
            arr = ck.array(value, f"{p}.{key}", (n,), "SI", f"{n} values for a {j.type} joint")
            if arr is not None and key == "q0" and j.type in ("free", "spherical"):
                quat = arr[-4:]
                if abs(np.linalg.norm(quat) - 1) > 1e-9:
                    ck.add(f"{p}.q0", f"the quaternion {quat.tolist()} is not a unit quaternion (norm {np.linalg.norm(quat):.12g})")
    for i, name in enumerate(bodies):
        if name not in parent_of:
            ck.add(f"bodies[{i}]", f"body {name!r} is attached by no joint (add a [[joints]] entry with child = {name!r})")
    # Loops: walk up from each body; a body reached twice is on a cycle.
    reported: set[str] = set()
    for start in bodies:
        path, node = [start], start
        while node in parent_of and parent_of[node][0] != "ground":
            node = parent_of[node][0]
            if node in path:
                cycle = path[path.index(node):] + [node]
                key = min(cycle)
                if key not in reported:
                    reported.add(key)
                    idx = parent_of[start][1]
                    ck.add(f"joints[{idx}]", f"loop in the joint tree: {' -> '.join(cycle)} "
                           "(a tree is required; every chain must end at 'ground'; close loops with "
                           "[[loop_joints]])")
                break
            path.append(node)
    _check_loop_joints(ck, scene, bodies)

    # -- attached items ------------------------------------------------------------------------
    for i, pm in enumerate(scene.point_masses):
        p = f"point_masses[{i}]"
        ck.name_ref(pm.body, f"{p}.body", bodies, "body")
        ck.number(pm.mass, f"{p}.mass", "kg", positive=True)
        ck.vector(pm.point, f"{p}.point", "m")
    for i, pe in enumerate(scene.pendulums):
        p = f"pendulums[{i}]"
        ck.name_ref(pe.body, f"{p}.body", bodies, "body")
        ck.number(pe.mass, f"{p}.mass", "kg", positive=True)
        ck.number(pe.length, f"{p}.length", "m", positive=True)
        ck.number(pe.damping, f"{p}.damping", "N m s/rad", nonnegative=True)
        ck.vector(pe.point, f"{p}.point", "m")
        ck.vector(pe.direction, f"{p}.direction", "-", nonzero=True)
    for i, d in enumerate(scene.springs):
        p = f"springs[{i}]"
        ck.name_ref(d.body, f"{p}.body", bodies, "body")
        ck.number(d.mass, f"{p}.mass", "kg", positive=True)
        ck.number(d.stiffness, f"{p}.stiffness", "N/m", nonnegative=True)
        ck.number(d.damping, f"{p}.damping", "N s/m", nonnegative=True)
        ck.vector(d.point, f"{p}.point", "m")
        ck.vector(d.axis, f"{p}.axis", "-", nonzero=True)
    wheels = {w.name: w for w in scene.wheels}
    for i, w in enumerate(scene.wheels):
        p = f"wheels[{i}]"
        ck.name_ref(w.body, f"{p}.body", bodies, "body")
        ck.number(w.spin_inertia, f"{p}.spin_inertia", "kg m^2", nonnegative=True)
        ck.number(w.transverse_inertia, f"{p}.transverse_inertia", "kg m^2", nonnegative=True)
        ck.number(w.mass, f"{p}.mass", "kg", nonnegative=True)
        ck.number(w.speed, f"{p}.speed", "rad/s")
        ck.vector(w.axis, f"{p}.axis", "-", nonzero=True)
        ck.vector(w.point, f"{p}.point", "m")
        ck.choice(w.mode, f"{p}.mode", ("constant", "torque"), "wheel mode")
        if w.mode == "torque" and "wheel_gyroscopics" not in scene.effects:
            ck.add(f"{p}.mode", "a torque-driven wheel needs the 'wheel_gyroscopics' effect (add it to effects)")
        _check_node(ck, p, w, scene)
    for i, s in enumerate(scene.surfaces):
        p = f"surfaces[{i}]"
        ck.name_ref(s.body, f"{p}.body", bodies, "body")
        ck.number(s.area, f"{p}.area", "m^2", positive=True)
        ck.vector(s.normal, f"{p}.normal", "-", nonzero=True)
        ck.vector(s.point, f"{p}.point", "m")
        if ck.number(s.reflectivity, f"{p}.reflectivity", "-", nonnegative=True) and s.reflectivity > 1:
            ck.add(f"{p}.reflectivity", f"must lie in [0, 1], got {s.reflectivity}")
        ck.number(s.drag_coefficient, f"{p}.drag_coefficient", "-", nonnegative=True)

    # -- sensors and actuators -----------------------------------------------------------------
    sensors = {}
    for i, s in enumerate(scene.sensors):
        p = f"sensors[{i}]"
        if not ck.choice(s.type, f"{p}.type", SENSOR_TYPES, "sensor type"):
            continue
        sensors[s.name] = s
        if s.type == "wheel_speed":
            if ck.name_ref(s.wheel, f"{p}.wheel", list(wheels), "wheel") and "wheel_gyroscopics" not in scene.effects:
                ck.add(f"{p}", "a wheel_speed sensor needs the 'wheel_gyroscopics' effect")
        else:
            ck.name_ref(s.body, f"{p}.body", bodies, "body")
            if s.axis is not None:
                ck.vector(s.axis, f"{p}.axis", "-", nonzero=True)
            ck.vector(s.point, f"{p}.point", "m")
            _check_node(ck, p, s, scene)
    actuators = {}
    for i, a in enumerate(scene.actuators):
        p = f"actuators[{i}]"
        if not ck.choice(a.type, f"{p}.type", ACTUATOR_TYPES, "actuator type"):
            continue
        actuators[a.name] = a
        if a.type == "wheel_torque":
            if ck.name_ref(a.wheel, f"{p}.wheel", list(wheels), "wheel") and wheels[a.wheel].mode != "torque":
                ck.add(f"{p}.wheel", f"wheel {a.wheel!r} has mode {wheels[a.wheel].mode!r}; a wheel_torque actuator needs mode = 'torque'")
        else:
            ck.name_ref(a.body, f"{p}.body", bodies, "body")
            if a.axis is not None:
                ck.vector(a.axis, f"{p}.axis", "-", nonzero=True)
            elif a.type == "thruster":
                ck.add(f"{p}.axis", "a thruster needs an axis (its thrust direction in body axes)")
            ck.vector(a.point, f"{p}.point", "m")
            _check_node(ck, p, a, scene)

    for i, d in enumerate(scene.disturbances):
        p = f"disturbances[{i}]"
        ck.choice(d.type, f"{p}.type", ("torque", "force"), "disturbance type")
        ck.name_ref(d.body, f"{p}.body", bodies, "body")
        if d.axis is not None:
            ck.vector(d.axis, f"{p}.axis", "-", nonzero=True)
        ck.vector(d.point, f"{p}.point", "m")

    # -- controllers ---------------------------------------------------------------------------
    for i, c in enumerate(scene.controllers):
        p = f"controllers[{i}]"
        ck.choice(c.type, f"{p}.type", CONTROLLER_TYPES, "controller type")
        ins = [c.inputs] if isinstance(c.inputs, str) else list(c.inputs or ())
        outs = [c.outputs] if isinstance(c.outputs, str) else list(c.outputs or ())
        for k, name in enumerate(ins):
            if ck.name_ref(name, f"{p}.inputs[{k}]", list(sensors), "sensor"):
                if sensor_width(sensors[name]) != 1:
                    ck.add(f"{p}.inputs[{k}]", f"sensor {name!r} has 3 signals; give it an axis to feed a controller channel")
                if sensors[name].type == "acceleration":
                    ck.add(f"{p}.inputs[{k}]", "acceleration sensors cannot feed a controller (algebraic loop)")
        for k, name in enumerate(outs):
            if name not in actuators:
                ck.add(f"{p}.outputs[{k}]", f"{name!r} is no actuator{_hint(name, list(actuators))}")
            elif actuator_width(actuators[name]) != 1:
                ck.add(f"{p}.outputs[{k}]", f"actuator {name!r} has 3 commands; give it an axis to be a controller channel")
            elif actuators[name].type == "thruster" and "thrusters" not in scene.effects:
                ck.add(f"{p}.outputs[{k}]", f"actuator {name!r} is a thruster but the 'thrusters' effect is not included")
        n_in, n_out = len(ins), len(outs)
        if n_in == 0:
            ck.add(f"{p}.inputs", "a controller needs at least one sensor input")
        if n_out == 0:
            ck.add(f"{p}.outputs", "a controller needs at least one actuator output")
        if c.reference is not None:
            ref = [c.reference] if isinstance(c.reference, (int, float)) else c.reference
            ck.array(ref, f"{p}.reference", (n_in,), "sensor units", f"{n_in} values (one per input)")
        if c.type == "pid":
            if n_in != n_out:
                ck.add(f"{p}", f"a pid controller has one channel per input and output; got {n_in} inputs and {n_out} outputs")
            for key in ("kp", "ki", "kd"):
                value = getattr(c, key)
                vals = [value] if isinstance(value, (int, float)) else value
                ck.array(vals, f"{p}.{key}", (np.size(vals) if np.size(vals) in (1, n_in) else n_in,),
                         "command per sensor unit", f"a scalar or {n_in} gains")
            rates = c.rate_inputs
            kd_nonzero = _is_numeric(c.kd) and bool(np.any(np.asarray(c.kd, dtype=float) != 0))
            if rates is None:
                if kd_nonzero:
                    ck.add(f"{p}.kd", "a derivative gain needs rate_inputs (rate sensors, one per channel)")
            else:
                rates = [rates] if isinstance(rates, str) else list(rates)
                if len(rates) != n_in:
                    ck.add(f"{p}.rate_inputs", f"expected {n_in} sensor names (one per channel), got {len(rates)}")
                for k, name in enumerate(rates):
                    if ck.name_ref(name, f"{p}.rate_inputs[{k}]", list(sensors), "sensor") and sensor_width(sensors[name]) != 1:
                        ck.add(f"{p}.rate_inputs[{k}]", f"sensor {name!r} has 3 signals; give it an axis")
        elif c.type == "state_space":
            mats = {}
            for key in ("A", "B", "C", "D"):
                value = getattr(c, key)
                if value is None and key != "D":
                    ck.add(f"{p}.{key}", "required for a state_space controller")
                    continue
                if value is None:
                    continue
                arr = np.asarray(value, dtype=float) if _is_numeric(value) else None
                if arr is None or arr.ndim != 2 or not np.all(np.isfinite(arr)):
                    ck.add(f"{p}.{key}", f"expected a finite matrix (array of rows), got {value!r}")
                else:
                    mats[key] = arr
            if {"A", "B", "C"} <= set(mats):
                nx = mats["A"].shape[0]
                expect = {"A": (nx, nx), "B": (nx, n_in), "C": (n_out, nx), "D": (n_out, n_in)}
                for key, arr in mats.items():
                    if arr.shape != expect[key]:
                        ck.add(f"{p}.{key}", f"has shape {arr.shape} but {expect[key]} was expected "
                               f"({nx} controller states, {n_in} inputs, {n_out} outputs)")
        elif c.type == "transfer_function":
            if n_in != n_out:
                ck.add(f"{p}", f"a transfer_function controller has one channel per input and output; got {n_in} and {n_out}")
            for key in ("num", "den"):
                value = getattr(c, key)
                arr = np.asarray(value, dtype=float) if value is not None and _is_numeric(value) else None
                if arr is None or arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
                    ck.add(f"{p}.{key}", f"expected a list of polynomial coefficients, got {value!r}")
                elif key == "den" and arr[0] == 0:
                    ck.add(f"{p}.den", "the leading coefficient must not be zero")
            if _is_numeric(c.num) and _is_numeric(c.den) and np.size(c.num) > np.size(c.den):
                ck.add(f"{p}.num", "improper transfer function (numerator degree above the denominator's)")
    if scene.controllers and "control" not in scene.effects:
        pass  # controllers are simply not compiled without the 'control' effect

    # -- frame, orbit, environment -------------------------------------------------------------
    fr = scene.frame
    ck.choice(fr.kind, "frame.kind", FRAME_KINDS, "frame kind")
    if fr.kind == "spin":
        ck.number(fr.rate, "frame.rate", "rad/s")
        ck.vector(fr.axis, "frame.axis", "-", nonzero=True)
    needs_orbit = [e for e in scene.effects if e in registry and registry[e].needs_orbit]
    if fr.kind == "lvlh":
        needs_orbit = ["frame.kind = 'lvlh'"] + needs_orbit
    ob = scene.orbit
    if ob is None:
        if needs_orbit:
            ck.add("orbit", f"an [orbit] table is required by {', '.join(needs_orbit)}")
    else:
        ck.choice(ob.kind, "orbit.kind", ("circular",), "orbit kind")
        if (ob.radius is None) == (ob.altitude is None):
            ck.add("orbit", "give exactly one of radius [m] or altitude [m]")
        elif ob.radius is not None:
            ck.number(ob.radius, "orbit.radius", "m", positive=True)
        else:
            ck.number(ob.altitude, "orbit.altitude", "m", nonnegative=True)
        ck.number(ob.mu, "orbit.mu", "m^3/s^2", positive=True)
    env = scene.environment
    ck.vector(env.gravity, "environment.gravity", "m/s^2")
    ck.vector(env.sun_direction, "environment.sun_direction", "-", nonzero=True)
    ck.number(env.solar_pressure, "environment.solar_pressure", "N/m^2", nonnegative=True)
    ck.number(env.density, "environment.density", "kg/m^3", nonnegative=True)
    ck.number(env.reference_altitude, "environment.reference_altitude", "m")
    ck.number(env.scale_height, "environment.scale_height", "m", positive=True)

    # -- effect-specific checks (third-party effects may add their own) --------------------------
    for name in scene.effects:
        if name in registry:
            for problem in registry[name].check(scene):
                ck.problems.append(problem)
    return ck.problems


def _check_loop_joints(ck, scene, bodies: list[str]) -> None:
    """Loop-closing joints: type, the two bodies (distinct; "ground" allowed), points, axes, gains."""
    for i, lj in enumerate(scene.loop_joints):
        p = f"loop_joints[{i}]"
        ck.choice(lj.type, f"{p}.type", LOOP_JOINT_TYPES, "loop joint type")
        known = bodies + ["ground"]
        ok_a = ck.name_ref(lj.body_a, f"{p}.body_a", known, "body")
        ok_b = ck.name_ref(lj.body_b, f"{p}.body_b", known, "body")
        if ok_a and ok_b and lj.body_a == lj.body_b:
            ck.add(p, f"joins {lj.body_a!r} to itself (a loop joint connects two different bodies)")
        ck.vector(lj.point_a, f"{p}.point_a", "m")
        ck.vector(lj.point_b, f"{p}.point_b", "m")
        for side in ("a", "b"):
            node, body = getattr(lj, f"node_{side}"), getattr(lj, f"body_{side}")
            if node is not None and body == "ground":
                ck.add(f"{p}.node_{side}", "the ground has no nodes (nodes belong to flexible bodies)")
            elif node is not None:
                _check_node(ck, p, _NodeRef(node, body), scene, key=f"node_{side}")
        ck.vector(lj.axis, f"{p}.axis", "-", nonzero=True)
        if lj.axis_b is not None:
            ck.vector(lj.axis_b, f"{p}.axis_b", "-", nonzero=True)
            if lj.type != "revolute":
                ck.add(f"{p}.axis_b", f"only revolute loop joints take a hinge axis (this one is {lj.type!r})")
        if lj.solve_for is not None:
            joints = {j.name: j for j in scene.joints}
            names = [lj.solve_for] if isinstance(lj.solve_for, str) else list(lj.solve_for)
            for k, name in enumerate(names):
                if ck.name_ref(name, f"{p}.solve_for[{k}]", list(joints), "joint") and (
                        joints[name].type == "fixed" or joints[name].locked is True or joints[name].prescribed is not None):
                    ck.add(f"{p}.solve_for[{k}]", f"joint {name!r} has no free coordinate to adjust")
        gains = ck.array(lj.baumgarte, f"{p}.baumgarte", (2,), "1/s, 1/s^2", "two gains (kd, kp)")
        if gains is not None and np.any(gains < 0):
            ck.add(f"{p}.baumgarte", f"gains must not be negative, got {gains.tolist()} (use (0, 0) to switch "
                   "the stabilization off)")


def _is_numeric(value: Any) -> bool:
    try:
        np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    return True


def _check_profile(ck, path: str, prescribed: dict) -> None:
    """Keys a profile cannot do without, and the table's points."""
    kind = prescribed["profile"]
    required = {"spinup": ("rate", "ramp_time"), "step": ("time", "before", "after"), "table": ("times", "values")}
    for key in required.get(kind, ()):
        if key not in prescribed:
            ck.add(f"{path}.{key}", f"a {kind!r} profile needs {key!r}")
    if kind == "spinup" and isinstance(prescribed.get("ramp_time"), (int, float)) and prescribed["ramp_time"] <= 0:
        ck.add(f"{path}.ramp_time", "must be positive [s]")
    if kind == "table" and "times" in prescribed and "values" in prescribed:
        try:
            times = np.asarray(prescribed["times"], dtype=float)
            values = np.asarray(prescribed["values"], dtype=float)
        except (TypeError, ValueError):
            ck.add(path, "times and values must be lists of numbers")
            return
        if times.ndim != 1 or values.shape != times.shape or times.size < 4:
            ck.add(path, f"times and values must be equally long lists of at least 4 points "
                         f"(a cubic spline), got {times.size} and {values.size}")
        elif not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
            ck.add(path, "times and values must be finite")
        elif np.any(np.diff(times) <= 0):
            ck.add(f"{path}.times", "must increase strictly")


def _check_flexible(ck, path: str, body) -> None:
    """A flexible body needs loadable modal data and a sensible number of modes."""
    if (body.modal_data is None) == (body.beam is None):
        ck.add(f"{path}.modal_data", "a flexible body needs modal data (a ModalData or an .npz/.json file) "
                                     "or a beam table, and not both")
        return
    if body.beam is not None:
        try:
            body.resolved_modal_data()
        except (ModelError, KeyError, TypeError, ValueError) as err:
            missing = f"missing key {err}" if isinstance(err, KeyError) else str(err)
            ck.add(f"{path}.beam", missing)
        return
    try:
        available = dataclasses.replace(body, modes=None).resolved_modal_data().n_modes
        if body.modes is not None and (int(body.modes) != body.modes or not 0 < body.modes <= available):
            ck.add(f"{path}.modes", f"must be an integer from 1 to {available} (the modes in the data)")
    except (ModelError, OSError, ValueError, TypeError) as err:  # report it; the check goes on
        ck.add(f"{path}.modal_data", str(err))


@dataclasses.dataclass(frozen=True)
class _NodeRef:
    """A node reference of an entry whose node field is not called ``node`` (loop joints)."""

    node: str
    body: str


def _check_node(ck, path: str, entry, scene, *, key: str = "node") -> None:
    """A ``node`` must be a node of the modal data of the (flexible) body it names."""
    node = getattr(entry, "node", None)
    if node is None:
        return
    body = next((b for b in scene.bodies if b.name == entry.body), None)
    if body is None:
        return  # the body reference is reported already
    if body.type != "flexible":
        ck.add(f"{path}.{key}", f"nodes belong to flexible bodies; {body.name!r} is {body.type}")
        return
    try:
        names = body.resolved_modal_data().node_names
    except (ModelError, OSError, KeyError, TypeError, ValueError):
        return  # the modal data's problem is reported with the body
    if node not in names:
        ck.add(f"{path}.{key}", f"unknown node {node!r} of {body.name!r}{_hint(node, names)}")
