"""``compile_model(scene) -> Model``: Kane's equations of a scene as CasADi functions."""

from __future__ import annotations

import dataclasses
import io
import os
import pickle
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from difflib import get_close_matches
from typing import Any

import casadi as ca
import numpy as np

from ..dynamics._constraints import LoopClosure
from ..dynamics._kane import (
    BodyFrame,
    FlexibleElement,
    KaneBuilder,
    MassElement,
    quat_rate,
    quat_to_dcm,
    rot_axis,
)
from ..dynamics._kane_linear import KaneEquations
from ..dynamics._order_n import FORMULATIONS, order_n_solver
from ..scene._check import actuator_width, locked_translations, sensor_width
from ..scene._registry import registered_effects
from ..scene._scene import Scene, load_scene
from ..scene._values import inertia_matrix, profile_function, vector3, wheel_inertia
from ..system._errors import ModelError
from ..system._model import NonlinearModel
from ._block_solve import block_solve, constant_block
from ._parametric import elastic_loads, modal_nominal, sweep_compiler

__all__ = ["CompiledScene", "GraphCache", "Model", "compile_model"]

_XYZ = ("x", "y", "z")


@dataclass(frozen=True)
class CompiledScene:
    """What :func:`compile_model` knows about a model beyond its functions: its construction data.

    One frozen record, shared (not copied) by the variants of a model (:meth:`Model.with_params`).
    The fields are read through :class:`Model`'s attributes of the same names; see there.
    """

    scene: Any = None
    x0: Any = None
    effects: tuple[str, ...] = ()
    energy: Any = None
    momentum: Any = None
    monitors: Any = None
    quaternions: tuple[int, ...] = ()
    n_coordinates: int = 0
    n_speeds: int = 0
    graph_size: int = 0
    build_seconds: float = 0.0
    constraints: Any = None
    sampled_controllers: tuple = ()  # the control effect's sampled controllers, run by simulate

    def __post_init__(self) -> None:
        if self.x0 is not None:
            x0 = np.array(self.x0, dtype=float)
            x0.setflags(write=False)
            object.__setattr__(self, "x0", x0)
        for key, kind in (("effects", tuple), ("quaternions", tuple), ("n_coordinates", int),
                          ("n_speeds", int), ("graph_size", int), ("build_seconds", float)):
            object.__setattr__(self, key, kind(getattr(self, key)))

    def __reduce__(self):
        # Through the constructor, so that an unpickled x0 is read-only again.
        return (CompiledScene, tuple(getattr(self, f.name) for f in dataclasses.fields(self)))


class GraphCache:
    """The symbolic Kane's equations of a compiled model: an explicit cache, outside the model's value.

    A :class:`Model` is frozen; the equations (:class:`KaneEquations`, CasADi SX graphs) are
    what Kane's direct linearization reads, and SX graphs do not pickle on their own. This cache
    holds them and pickles them as data: the Python structure around the graphs with every SX
    and MX replaced by its index, and the graphs themselves serialized by CasADi in one stream
    (so that the symbols the expressions share stay shared). An unpickled cache unpacks the
    graphs on first use (:meth:`get`); nothing is compiled again. The cache's own slots are the
    only state that changes (the packed bytes are kept once made, the graphs once unpacked),
    and :class:`Model` exposes the result read-only as ``model.equations``.
    """

    __slots__ = ("_equations", "_packed", "_lock")

    def __init__(self, equations: KaneEquations | None = None, packed: tuple[bytes, str] | None = None) -> None:
        self._equations = equations
        self._packed = packed
        self._lock = threading.Lock()

    def get(self) -> KaneEquations | None:
        """The equations, unpacked from the stored graphs on the first call after unpickling.

        Returns
        -------
        KaneEquations or None
            The symbolic equations; None for a model compiled without them.
        """
        with self._lock:
            if self._equations is None and self._packed is not None:
                structure, graphs = self._packed
                leaves = ca.StringDeserializer(graphs).unpack()
                self._equations = _GraphUnpickler(io.BytesIO(structure), leaves).load()
            return self._equations

    def packed(self) -> tuple[bytes, str] | None:
        """The equations as ``(pickled structure, CasADi-serialized graphs)`` (made once, then kept).

        Returns
        -------
        tuple of (bytes, str) or None
            What a pickled cache carries; None without equations.
        """
        with self._lock:
            if self._packed is None and self._equations is not None:
                leaves: list[Any] = []
                buffer = io.BytesIO()
                _GraphPickler(buffer, leaves).dump(self._equations)
                serializer = ca.StringSerializer()
                serializer.pack(leaves)
                self._packed = (buffer.getvalue(), serializer.encode())
            return self._packed

    def __reduce__(self):
        return (GraphCache, (None, self.packed()))


class _GraphPickler(pickle.Pickler):
    """Pickles everything but CasADi SX/MX graphs, which it collects (for one CasADi stream)."""

    def __init__(self, file, leaves: list) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self.leaves = leaves

    def persistent_id(self, obj: Any) -> int | None:
        if isinstance(obj, (ca.SX, ca.MX)):
            self.leaves.append(obj)
            return len(self.leaves) - 1
        return None


class _GraphUnpickler(pickle.Unpickler):
    """The inverse of :class:`_GraphPickler`: graph indices become the deserialized graphs."""

    def __init__(self, file, leaves: list) -> None:
        super().__init__(file)
        self.leaves = leaves

    def persistent_load(self, pid: int) -> Any:
        return self.leaves[pid]


def _compiled(name: str, doc: str) -> property:
    """A read-only attribute of :class:`Model` that reads ``model.compiled.<name>``."""

    def read(self):
        return getattr(self.compiled, name)

    read.__doc__ = doc
    return property(read)


@dataclass(frozen=True, init=False, eq=False)
class Model(NonlinearModel):
    """A compiled scene: a :class:`~linflex.NonlinearModel` with the scene's extras.

    ``f`` and ``h`` are ``casadi.Function``s of ``(x, u, t)`` (or ``(x, u, p, t)`` with exposed
    parameters). States are the joint and internal coordinates (``q``), then the generalized
    speeds (``u``), then the controller states; see ``model.states``.

    Parameters
    ----------
    f, h, states, inputs, outputs, params
        As for :class:`~linflex.NonlinearModel`.
    compiled : CompiledScene
        The construction data below (``scene``, ``x0``, ``effects``, ...), one frozen record.
    equations : KaneEquations or GraphCache, optional
        The symbolic equations the functions were built from, or a cache holding them.

    Attributes
    ----------
    compiled : CompiledScene
        The construction data; the attributes below read it.
    scene : Scene
        The validated scene it was compiled from.
    x0 : ndarray, shape (n_states,)
        The scene's initial state [state units] (read-only): the joints' ``q0`` and ``u0``
        ([rad] or [m], [rad/s] or [m/s], quaternions [-]), the wheels' speeds, zero elsewhere;
        with loop joints, corrected to close the loops.
    effects : tuple of str
        The effects compiled in.
    energy, momentum : casadi.Function or None
        Total mechanical energy [J] and angular momentum about the frame origin in inertial axes
        [N m s] as functions of ``(x, t)``; None for scenes on an orbit (not conservative in
        the orbiting frame).
    monitors : casadi.Function or None
        Both at once, ``(energy [J], momentum [N m s])``, of the same arguments (shared
        subexpressions; used by simulate); None with an orbit.
    quaternions : tuple of int
        Index of the scalar part of each quaternion in ``x``.
    n_coordinates, n_speeds : int
        Number of generalized coordinates and speeds.
    graph_size : int
        Elementary operations in the compiled equations (the SX instructions of ``f`` and
        ``h``, or of the partial-velocity function that feeds the numeric solve): what an
        effect adds, and what an omitted effect does not.
    build_seconds : float
        Time taken by :func:`compile_model` [s].
    constraints : LoopConstraints or None
        The loop-closing and contact constraints (scenes with ``loop_joints`` or ``constraints``): their rows, the independent
        rows, and ``position``, ``velocity``, ``jacobians`` as functions of ``(x, p, t)``.
    equations : KaneEquations
        The symbolic equations the functions were built from (Kane's direct linearization,
        ``linearize(model, method="kane")``, works on them); held by a :class:`GraphCache`,
        which pickles them as serialized graphs (no recompilation after unpickling).

    Examples
    --------
    A hinged rod; a variant with another parameter value shares the construction data:

    >>> from linflex import Body, Joint, Scene, compile_model
    >>> s = Scene("rod", effects=["gravity"], bodies=[Body("rod", 1.0, [0.1, 0.1, 0.01], com=[0, 0, -1])],
    ...           joints=[Joint("hinge", "revolute", "rod", axis=[0, 1, 0], q0=0.2)])
    >>> model = compile_model(s, params=["rod.mass"])
    >>> model.x0.tolist(), model.n_speeds  # hinge.angle [rad], hinge.rate [rad/s]
    ([0.2, 0.0], 1)
    >>> model.with_params(**{"rod.mass": 2.0}).compiled is model.compiled
    True
    """

    compiled: CompiledScene
    _graphs: GraphCache  # the explicit cache behind ``equations`` (not part of the model's value)

    def __init__(self, f, h=None, *, states, inputs=0, outputs=None, params=None,
                 compiled: CompiledScene | None = None, equations: KaneEquations | GraphCache | None = None) -> None:
        super().__init__(f, h, states=states, inputs=inputs, outputs=outputs, params=params)
        compiled = CompiledScene() if compiled is None else compiled
        if compiled.x0 is None:
            compiled = dataclasses.replace(compiled, x0=np.zeros(self.n_states))
        object.__setattr__(self, "compiled", compiled)
        object.__setattr__(self, "_graphs", equations if isinstance(equations, GraphCache) else GraphCache(equations))

    scene = _compiled("scene", "The validated scene it was compiled from.")
    x0 = _compiled("x0", "The scene's initial state [state units] (read-only).")
    effects = _compiled("effects", "The effects compiled in.")
    energy = _compiled("energy", "Total mechanical energy [J] as a function of ``(x, t)``; None with an orbit.")
    momentum = _compiled("momentum", "Angular momentum [N m s] about the frame origin, inertial axes, as a "
                                     "function of ``(x, t)``; None with an orbit.")
    monitors = _compiled("monitors", "``(energy [J], momentum [N m s])`` of ``(x, t)``; None with an orbit.")
    quaternions = _compiled("quaternions", "Index of the scalar part of each quaternion in ``x``.")
    n_coordinates = _compiled("n_coordinates", "Number of generalized coordinates.")
    n_speeds = _compiled("n_speeds", "Number of generalized speeds.")
    graph_size = _compiled("graph_size", "Elementary operations in the compiled equations.")
    build_seconds = _compiled("build_seconds", "Time taken by :func:`compile_model` [s].")
    constraints = _compiled("constraints", "The loop-closing constraints, or None.")

    @property
    def equations(self) -> KaneEquations | None:
        """The symbolic Kane's equations the functions were built from (see the class docstring)."""
        return self._graphs.get()

    def with_params(self, **values: float) -> Model:
        """A copy with some parameter values replaced (by name); the graph is shared.

        Parameters
        ----------
        **values : float
            New nominal values of parameters exposed by ``compile_model(scene, params=...)``,
            by name, in the parameter's unit: ``"<body>.mass"`` [kg], ``"<body>.Ixx"`` and the
            other inertias [kg m^2], ``"<joint>.stiffness"`` [N m/rad or N/m],
            ``"<joint>.damping"`` [N m s/rad or N s/m]. The others keep their values.

        Returns
        -------
        Model
            The same functions, construction data and equations with the new ``param_values``;
            nothing is compiled again.

        Raises
        ------
        ModelError
            For a name that is not a parameter of this model.

        Examples
        --------
        >>> from linflex import Body, Joint, Scene, compile_model
        >>> s = Scene("rod", effects=["joint_springs"], bodies=[Body("rod", 1.0, [0.1, 0.1, 0.01])],
        ...           joints=[Joint("hinge", "revolute", "rod", axis=[0, 1, 0], stiffness=4.0)])
        >>> model = compile_model(s, params=["hinge.stiffness"])
        >>> model.with_params(**{"hinge.stiffness": 9.0}).param_values.tolist()  # [N m/rad]
        [9.0]
        """
        new = dict(zip(self.params, self.param_values))
        for key, value in values.items():
            if key not in new:
                raise ModelError(f"params: unknown parameter {key!r}; this model has {list(self.params)}")
            new[key] = float(value)
        return Model(self.f, self.h, states=self.states, inputs=self.inputs, outputs=self.outputs, params=new,
                     compiled=self.compiled, equations=self._graphs)

    def __repr__(self) -> str:
        name = getattr(self.scene, "name", "?")
        return (f"Model({name!r}, states={self.n_states}, inputs={list(self.inputs)!r}, "
                f"outputs={list(self.outputs)!r}, effects={list(self.effects)!r})")


def _frame_motion(scene: Scene, b: KaneBuilder) -> None:
    fr, t = scene.frame, b.t
    if fr.kind == "spin":
        axis = vector3(fr.axis)
        b.w_F = float(fr.rate) * axis / np.linalg.norm(axis)
    elif fr.kind == "lvlh":
        b.w_F = np.array([0.0, -scene.orbit.mean_motion, 0.0])
    rate = np.linalg.norm(b.w_F)
    b.C_NF = ca.SX(ca.DM.eye(3)) if rate == 0 else rot_axis(b.w_F / rate, rate * t)
    if scene.orbit is not None:
        r0, n = scene.orbit.r0, scene.orbit.mean_motion
        b.n_orbit, b.mu = n, float(scene.orbit.mu)
        R_N = r0 * ca.vertcat(ca.sin(n * t), 0, -ca.cos(n * t))
        V_N = r0 * n * ca.vertcat(ca.cos(n * t), 0, ca.sin(n * t))
        b.R_O, b.V_O = b.C_NF.T @ R_N, b.C_NF.T @ V_N


def _joint_order(scene: Scene) -> list:
    children: dict[str, list] = {}
    for j in scene.joints:
        children.setdefault(j.parent, []).append(j)
    order, stack = [], ["ground"]
    while stack:
        node = stack.pop(0)
        for j in children.get(node, []):
            order.append(j)
            stack.append(j.child)
    return order


def _build_tree(scene: Scene, b: KaneBuilder) -> dict[str, Any]:
    """Frames of all bodies; returns per-joint initial-value recipes for x0."""
    ground = BodyFrame("ground", ca.SX.zeros(3, 1), ca.SX(ca.DM.eye(3)), ca.SX(ca.DM(b.w_F)))
    frames = {"ground": ground}
    recipes = {}
    for j in _joint_order(scene):
        P = frames[j.parent]
        axis = vector3(j.axis) / np.linalg.norm(vector3(j.axis))
        trans = ca.SX.zeros(3, 1)
        if j.type == "fixed":
            C_PC, w_C = ca.SX(ca.DM.eye(3)), P.w
        elif j.type in ("revolute", "prismatic"):
            q0 = 0.0 if j.q0 is None else float(np.ravel(j.q0)[0])
            unit = "angle" if j.type == "revolute" else "position"
            if j.locked:
                coord, rate = ca.SX(q0), ca.SX(0)
            elif j.prescribed is not None:
                coord = ca.SX(profile_function(j.prescribed)(b.t))
                rate = ca.jacobian(coord, b.t)
            else:
                q, u = b.add_coordinates([f"{j.name}.{unit}"], [f"{j.name}.rate"])
                b.set_kinematics(q, u)
                coord, rate = q[0], u[0]
                b.joint_speeds[j.name] = (coord, rate)
                b.joint_speed_names[j.name] = f"{j.name}.rate"
                recipes[j.name] = ("scalar", q0, 0.0 if j.u0 is None else float(np.ravel(j.u0)[0]))
            if j.type == "revolute":
                C_PC = rot_axis(axis, coord)
                w_C = C_PC.T @ P.w + ca.DM(axis) * rate
            else:
                C_PC, w_C = ca.SX(ca.DM.eye(3)), P.w
                trans = ca.DM(axis) * coord
        else:  # free or spherical
            q0 = np.array([0, 0, 0, 1, 0, 0, 0.0] if j.type == "free" else [1, 0, 0, 0.0])
            if j.q0 is not None:
                q0 = np.asarray(j.q0, float)
            u0 = np.zeros(6 if j.type == "free" else 3) if j.u0 is None else np.asarray(j.u0, float)
            # A free joint's translations may be locked one by one (held at q0).
            locked = set(locked_translations(j))
            moving = [c for c in _XYZ if c not in locked] if j.type == "free" else []
            names_q = [f"{j.name}.{c}" for c in moving] + [f"{j.name}.q{c}" for c in ("w", "x", "y", "z")]
            names_u = [f"{j.name}.v{c}" for c in moving] + [f"{j.name}.w{c}" for c in _XYZ]
            q, u = b.add_coordinates(names_q, names_u)
            quat = q[-4:]
            w_C = u[-3:]
            C_PC = quat_to_dcm(quat)
            w_rel = w_C - C_PC.T @ P.w
            qdot = quat_rate(quat, w_rel)
            if j.type == "free":
                k = len(moving)
                trans = ca.vertcat(*[q[moving.index(c)] if c in moving else ca.SX(q0[i]) for i, c in enumerate(_XYZ)])
                qdot = ca.vertcat(u[:k], qdot)
            b.set_kinematics(q, qdot)
            recipes[j.name] = (j.type, q0, u0, w_C, P.w, C_PC)
        C_FC = P.C @ C_PC
        r_C = P.r + P.C @ (ca.DM(vector3(j.parent_point)) + trans) - C_FC @ ca.DM(vector3(j.child_point))
        frames[j.child] = BodyFrame(j.child, r_C, C_FC, w_C)
    del frames["ground"]
    b.frames.update(frames)
    return recipes


def _add_flexible_bodies(scene: Scene, b: KaneBuilder) -> None:
    """Modal coordinates ``<body>.eta<k>`` and rates ``<body>.eta<k>_rate`` of each flexible body."""
    for body in scene.bodies:
        if body.type != "flexible":
            continue
        data = body.resolved_modal_data()
        q, qd = b.add_coordinates([f"{body.name}.eta{k}" for k in range(data.n_modes)],
                                  [f"{body.name}.eta{k}_rate" for k in range(data.n_modes)])
        b.set_kinematics(q, qd)
        b.flexible.append(FlexibleElement(body.name, b.frames[body.name], q, qd, data))


def _attach_parts(scene: Scene, b: KaneBuilder) -> None:
    for body in scene.bodies:
        b.attach(body.name, ("body", body.name), b.param(f"{body.name}.mass", body.mass), vector3(body.com),
                 _body_inertia(b, body))
    for pm in scene.point_masses:
        b.attach(pm.body, ("point_mass", pm.name), pm.mass, vector3(pm.point))
    for p in scene.pendulums:
        d = vector3(p.direction)
        b.attach(p.body, ("pendulum", p.name), p.mass, vector3(p.point) + float(p.length) * d / np.linalg.norm(d))
    for d in scene.springs:
        b.attach(d.body, ("spring", d.name), d.mass, vector3(d.point))
    for w in scene.wheels:
        if w.node is not None:  # carried by the structure: _add_node_wheels
            continue
        b.attach(w.body, ("wheel_mass", w.name), w.mass, vector3(w.point))
        b.attach(w.body, ("wheel_rotor", w.name), 0.0, vector3(w.point), wheel_inertia(w))


def _add_node_wheels(scene: Scene, b: KaneBuilder) -> None:
    """Wheels at nodes of flexible bodies: one element with the wheel's mass and inertia that
    moves with the node (translation ``Phi q``, rotation ``Psi q``; :meth:`KaneBuilder.node_frame`).

    It is locked to the node axes; the ``wheel_gyroscopics`` effect makes it spin about its
    axis. The node axes coincide with the body axes when undeformed, so ``axis`` is given in
    body axes as for any wheel.
    """
    for w in scene.wheels:
        if w.node is None:
            continue
        r, C, w_node = b.node_frame(w.body, w.node)
        element = MassElement(f"{w.name}.wheel", float(w.mass), wheel_inertia(w), r, C, w_node, body=w.body)
        b.node_wheels[w.name] = element
        b.add_element(element)


_INERTIA_KEYS = {"Ixx": (0, 0), "Iyy": (1, 1), "Izz": (2, 2), "Ixy": (0, 1), "Ixz": (0, 2), "Iyz": (1, 2)}


def _expose_params(scene: Scene, b: KaneBuilder, params: Sequence[str]) -> dict[str, float]:
    """Create the parameter symbols in the requested order; return their nominal values."""
    if isinstance(params, str):
        params = [params]
    known: dict[str, float] = {}
    for body in scene.bodies:
        known[f"{body.name}.mass"] = float(body.mass)
        inertia = inertia_matrix(body.inertia)
        for key, (i, j) in _INERTIA_KEYS.items():
            known[f"{body.name}.{key}"] = float(inertia[i, j])
    for joint in scene.joints:
        if joint.type in ("revolute", "prismatic"):
            known[f"{joint.name}.stiffness"] = float(joint.stiffness)
            known[f"{joint.name}.damping"] = float(joint.damping)
    known.update(modal_nominal(scene, params))
    nominal: dict[str, float] = {}
    springs = {f"{j.name}.{key}" for j in scene.joints for key in ("stiffness", "damping")} & set(known)
    for k, name in enumerate(params):
        if name not in known:
            hint = get_close_matches(str(name), list(known), n=1, cutoff=0.5)
            raise ModelError(f"params[{k}]: unknown parameter {name!r}"
                             + (f" (did you mean {hint[0]!r}?)" if hint else f"; known: {', '.join(list(known)[:12])}"))
        if name in nominal:
            raise ModelError(f"params[{k}]: {name!r} given twice")
        if name in springs and "joint_springs" not in scene.effects:  # it would change nothing
            raise ModelError(f"params[{k}]: {name!r} acts through the 'joint_springs' effect; add it to the effects")
        nominal[name] = known[name]
        b.params[name] = ca.SX.sym(name)
    return nominal


def _body_inertia(b: KaneBuilder, body) -> Any:
    """A body's central inertia: numeric, or SX with the exposed entries as symbols."""
    inertia = inertia_matrix(body.inertia)
    keys = [k for k in _INERTIA_KEYS if f"{body.name}.{k}" in b.params]
    if not keys:
        return inertia
    out = ca.SX(ca.DM(inertia))
    for key in keys:
        i, j = _INERTIA_KEYS[key]
        out[i, j] = b.params[f"{body.name}.{key}"]
        out[j, i] = b.params[f"{body.name}.{key}"]
    return out


def _names(name: str, width: int) -> list[str]:
    return [name] if width == 1 else [f"{name}.{c}" for c in _XYZ]


def _sensor_signal(b: KaneBuilder, s) -> Any:
    if s.type == "wheel_speed":
        return ca.vec(b.wheel_speeds[s.wheel])
    frame = b.frames[s.body]
    C, w = frame.C, frame.w
    if s.node is not None:  # a node of a flexible body: it moves with the structure
        r_node, C, w = b.node_motion(s.body, s.node)
    if s.type == "attitude":
        sig = 0.5 * ca.vertcat(C[2, 1] - C[1, 2], C[0, 2] - C[2, 0], C[1, 0] - C[0, 1])
    elif s.type == "rate":
        sig = w - C.T @ ca.DM(b.w_F) if s.relative else w
    else:
        if s.node is not None:
            r, rdot, V, a_t = b.kinematics_of(r_node)
        else:
            r, rdot, V, a_t = b.point_kinematics(s.body, vector3(s.point))
        if s.type == "position":
            sig = r
        elif s.type == "velocity":
            sig = rdot
        else:
            sig = C.T @ (a_t + V @ b.udot)
    if s.axis is None:
        return sig
    a = vector3(s.axis)
    return ca.dot(ca.DM(a / np.linalg.norm(a)), sig)


def compile_model(scene: Scene, *, params: Sequence[str] = (), symbolic: str = "auto",
                  formulation: str = "dense") -> Model:
    """Build the equations of motion of ``scene`` with Kane's method as CasADi functions.

    Parameters
    ----------
    scene : Scene, str or path
        Validated first (all problems are reported at once); a path is a scene file, read by
        :func:`~linflex.load_scene`.
    params : sequence of str, optional
        Scene numbers to expose as model parameters ``p`` (nominal values from the scene):
        ``"<body>.mass"``, ``"<body>.Ixx"`` (also ``Iyy``, ``Izz``, ``Ixy``, ``Ixz``, ``Iyz``),
        ``"<joint>.stiffness"``, ``"<joint>.damping"``, and a flexible body's modal stiffness
        and damping matrices ``"<body>.modal_stiffness[k,l]"``, ``"<body>.modal_damping[k,l]"``
        (``k <= l``, [N/m] and [N s/m] per modal coordinate). With parameters ``f`` and ``h`` take
        ``(x, u, p, t)`` and ``energy``/``momentum`` take ``(x, p, t)``; without, ``(x, u, t)``
        and ``(x, t)``. Inside a sweep that compiles once (``linflex.compiler._parametric``),
        a call without ``params`` returns the scene's structure compiled once, with the numbers
        the sweep varies as parameters at this scene's values.
    symbolic : {"auto", "SX", "MX"}
        ``"SX"`` expands the mass-matrix solve symbolically (one flat graph; fastest for a
        few speeds); ``"MX"`` keeps ``J^T M J`` and the solve as numeric nodes;
        ``"auto"`` picks SX up to 3 generalized speeds (the numeric solve evaluates faster
        from 4 on). Used by the dense formulation only.
    formulation : {"dense", "order-n"}
        ``"dense"`` forms the mass matrix ``M = J^T Mb J`` and solves it (cost cubic in the
        number of speeds); ``"order-n"`` solves the same equations with an articulated-body
        recursion (cost linear in the number of bodies; same states, inputs, outputs and
        results). Order-n supports trees of rigid and flexible bodies (every joint type) with
        load-only effects, geometric stiffness and the moving parts of the built-in effects
        (wheels at a constant rate or with a speed state, on a body or at a node of a flexible
        body; slosh pendulums; dampers), each a sub-body of its body with its own speeds, and
        loop joints (the recursion solves ``M^-1 [rhs, A^T]``, one column per independent
        constraint row), and raises :class:`ModelError` naming anything else (parts of other
        effects that move relative to their body).

    Returns
    -------
    Model
        ``f(x, u, t)``, ``h(x, u, t)``, named states, inputs (actuator commands, then
        disturbances) and outputs
        (sensor signals, then actuator commands ``<actuator>.command``), ``x0``, energy and
        momentum monitors.

    Raises
    ------
    ModelError
        For an invalid scene (every problem listed), a bad ``symbolic`` or ``formulation``, or
        a scene the order-n formulation does not support yet.

    Notes
    -----
    Kane's equations ``M(q) u' = C(q, u, t) + F(q, u, t)`` with nonlinear partial velocities
    from CasADi Jacobians (Banerjee 2016, Eqs. 1.5-1.9); free and spherical joints use the
    body-axis inertial angular velocity as generalized speeds and quaternion kinematics.

    Loop joints (``scene.loop_joints``) add constraints ``phi(q, t) = 0`` with undetermined
    multipliers: ``M u' = C + F + A^T lambda`` with ``A u' + b + kd phi' + kp phi = 0``
    (Banerjee 2016, Eqs. 1.85-1.95, with Baumgarte's stabilization), the multipliers as
    outputs ``<loop joint>.force.*`` and ``.torque.*``; ``x0`` closes the loops (Newton's
    method on the dependent coordinates, then the dependent speeds) to 1e-12, and
    ``model.constraints`` describes them (``linflex.linearize.constrained_linearization``
    linearizes onto independent coordinates). Contacts (``scene.constraints``: rolling wheels,
    knife edges) add non-holonomic rows ``A(q) u + a(q, t) = 0`` the same way, with their contact
    forces ``<constraint>.force.*`` (``linflex/dynamics/_contacts.py``). See ``linflex/dynamics/_constraints.py``.

    Examples
    --------
    >>> from linflex import Scene, Body, Joint, compile_model
    >>> s = Scene("rod", effects=["gravity"], bodies=[Body("rod", 1.0, [0.1, 0.1, 0.01], com=[0, 0, -1])],
    ...           joints=[Joint("hinge", "revolute", "rod", axis=[0, 1, 0])])
    >>> compile_model(s).states
    ('hinge.angle', 'hinge.rate')
    """
    if symbolic not in ("auto", "SX", "MX"):
        raise ModelError(f"symbolic must be 'auto', 'SX' or 'MX', got {symbolic!r}")
    if formulation not in FORMULATIONS:
        raise ModelError(f"formulation must be one of {', '.join(map(repr, FORMULATIONS))}, got {formulation!r}")
    if isinstance(scene, (str, os.PathLike)):
        scene = load_scene(scene)
    if not isinstance(scene, Scene):
        raise ModelError(f"scene must be a linflex.Scene or the path of a scene file, got {type(scene).__name__}")
    scene.validate()
    if not params and sweep_compiler() is not None:  # a sweep that compiles each structure once
        return sweep_compiler().model(scene, symbolic, formulation, compile_model)
    start = time.perf_counter()
    registry = registered_effects()
    effects = sorted((registry[name] for name in scene.effects),
                     key=lambda e: (e.order, scene.effects.index(e.name)))

    b = KaneBuilder(scene)
    nominal = _expose_params(scene, b, params)
    _frame_motion(scene, b)
    recipes = _build_tree(scene, b)
    _attach_parts(scene, b)
    _add_flexible_bodies(scene, b)
    _add_node_wheels(scene, b)
    for a in scene.actuators:
        if a.type != "thruster":
            b.commands[a.name] = b.add_input(_names(a.name, actuator_width(a)))
    disturbances = {d.name: b.add_input(_names(d.name, actuator_width(d))) for d in scene.disturbances}
    for eff in effects:
        eff.structure(b, scene)
    b.finalize_kinematics()
    if b.u.numel() == 0:
        raise ModelError(f"scene {scene.name!r} has no degrees of freedom (every joint fixed, locked or prescribed)")
    for s in scene.sensors:
        b.sensor_signals[s.name] = _sensor_signal(b, s)
    for eff in effects:
        eff.signals(b, scene)
    for s in scene.sensors:
        b.add_output(_names(s.name, sensor_width(s)), b.sensor_signals[s.name])
    for a in scene.actuators:
        if a.name in b.commands:
            b.add_output([f"{n}.command" for n in _names(a.name, actuator_width(a))], b.commands[a.name])
    for eff in effects:
        b.origin = eff.name
        eff.loads(b, scene)
    b.origin = "actuators"
    _actuator_loads(scene, b)
    b.origin = "structure"
    elastic_loads(b)
    b.origin = "disturbances"
    for d in scene.disturbances:
        _apply(b, d, disturbances[d.name])
    b.origin = "applied"
    missing = [n for n, d in zip(b.aux_names, b.auxdot_parts) if d is None]
    if missing:
        raise ModelError(f"an effect declared states without rates: {missing}")

    x = ca.vertcat(b.q, b.u, *b.aux_parts)
    uin = ca.vertcat(*b.in_parts) if b.in_parts else ca.SX(0, 1)
    auxdot = ca.vertcat(*b.auxdot_parts) if b.auxdot_parts else ca.SX(0, 1)
    # -- loop joints (linflex/dynamics/_constraints.py): multiplier outputs, consistent x0, independent rows
    loops = None if not (scene.loop_joints or scene.constraints) else LoopClosure(
        scene, b, x, _initial_state(scene, b, x, b.q_names + b.u_names + b.aux_names, recipes), list(nominal.values()))
    lam = ca.SX(0, 1) if loops is None else loops.multipliers
    # -- end loop joints
    y = ca.vertcat(*b.out_parts) if b.out_parts else ca.SX(0, 1)
    # Measured (CasADi 3.8, this machine): the numeric solve evaluates faster from 4 speeds on.
    use_sx = symbolic == "SX" or (symbolic == "auto" and b.u.numel() <= 3)
    t = b.t
    psym = ca.vertcat(*b.params.values()) if b.params else ca.SX(0, 1)
    equations = KaneEquations(b, x, uin, psym, y, auxdot, loops)  # before y's udot is substituted
    # NonlinearModel's convention: f(x, u, t) without parameters, f(x, u, p, t) with them.
    args, names_in = ([x, uin, psym, t], ["x", "u", "p", "t"]) if b.params else ([x, uin, t], ["x", "u", "t"])
    if formulation == "order-n":
        # Articulated-body recursion on the same builder (linflex/dynamics/_order_n.py): one flat SX graph
        # whose size grows linearly with the number of bodies.
        # With loop joints the same recursion solves M^-1 [rhs, A^T] (Eq. 8.81).
        rhs, solve = order_n_solver(scene, b, _joint_order(scene))
        udot, lam_ = (solve(rhs), lam) if loops is None else loops.accelerations_by(solve, rhs, x, psym, t)
        f = ca.Function("f", args, [ca.vertcat(b.qdot, udot, auxdot)], names_in, ["xdot"])
        h = ca.Function("h", args, [ca.substitute(y, ca.vertcat(b.udot, lam), ca.vertcat(udot, lam_))], names_in, ["y"])
        graph_size = f.n_instructions() + h.n_instructions()
    elif use_sx:
        J, Mb, c, g = b.assemble_parts()
        M, rhs = J.T @ (Mb @ J), g - J.T @ c
        udot, lam_ = (ca.solve(M, rhs), lam) if loops is None else loops.accelerations(M, rhs, x, psym, t)
        xdot = ca.vertcat(b.qdot, udot, auxdot)
        y = ca.substitute(y, ca.vertcat(b.udot, lam), ca.vertcat(udot, lam_))
        f = ca.Function("f", args, [xdot], names_in, ["xdot"])
        h = ca.Function("h", args, [y], names_in, ["y"])
        graph_size = f.n_instructions() + h.n_instructions()
    else:
        J, Mb, c, g = b.assemble_parts()
        # Large systems: the partial velocities J are an SX function (O(n^2) entries); the
        # products J^T Mb J and the solve stay numeric MX nodes instead of an O(n^3) symbolic
        # expansion.
        # Common subexpressions merged (16-mode arrays: 13% fewer instructions' time, built in 0.04 s).
        parts = ca.Function("kane", [x, uin, psym, t], [J, Mb, c, g, b.qdot, auxdot], {"cse": True})
        ysx = ca.Function("outputs", [x, uin, psym, t, b.udot, lam], [y])
        X, U, P, T = (ca.MX.sym("x", x.numel()), ca.MX.sym("u", uin.numel()), ca.MX.sym("p", psym.numel()),
                      ca.MX.sym("t"))
        J_, Mb_, c_, g_, qdot_, aux_ = parts(X, U, P, T)
        M_ = ca.mtimes(J_.T, ca.mtimes(Mb_, J_))
        rhs_ = g_ - ca.mtimes(J_.T, c_)
        # LAPACK's LU with partial pivoting (M is unsymmetric with geometric stiffness): half the
        # flops of the default sparse QR on this dense matrix (16-mode arrays: f 62 -> 51 us);
        # by blocks when modal speeds have a constant mass block (linflex/compiler/_block_solve.py).
        block = None if loops is not None else constant_block(J, Mb, ca.vertcat(x, uin, psym, t))
        udot_, lam_ = (((block_solve(M_, rhs_, *block) if block else ca.solve(M_, rhs_, "lapacklu")), ca.MX(0, 1))
                       if loops is None else loops.accelerations(M_, rhs_, X, P, T))
        margs = [X, U, P, T] if b.params else [X, U, T]
        f = ca.Function("f", margs, [ca.vertcat(qdot_, udot_, aux_)], names_in, ["xdot"])
        # Outputs need the solve only with acceleration sensors.
        needs_udot = b.udot.numel() > 0 and ca.depends_on(y, b.udot)
        h = ca.Function("h", margs, [ysx(X, U, P, T, udot_ if needs_udot else ca.MX.zeros(b.udot.numel()), lam_)],
                        names_in, ["y"])
        graph_size = parts.n_instructions() + ysx.n_instructions() + (0 if loops is None else loops.graph_size)

    energy = momentum = monitors = None
    if scene.orbit is None:
        eargs, enames = ([x, psym, t], ["x", "p", "t"]) if b.params else ([x, t], ["x", "t"])
        E, H = b.kinetic_energy() + b.potential, b.angular_momentum()
        energy = ca.Function("energy", eargs, [E], enames, ["energy"])
        momentum = ca.Function("momentum", eargs, [H], enames, ["momentum"])
        monitors = ca.Function("monitors", eargs, [E, H], enames, ["energy", "momentum"])

    states = b.q_names + b.u_names + b.aux_names
    x0 = _initial_state(scene, b, x, states, recipes) if loops is None else loops.x0
    compiled = CompiledScene(scene=scene, x0=x0, effects=scene.effects, energy=energy, momentum=momentum,
                             monitors=monitors, quaternions=equations.quaternions, n_coordinates=b.q.numel(), n_speeds=b.u.numel(),
                             graph_size=graph_size, constraints=None if loops is None else loops.info,
                             build_seconds=time.perf_counter() - start,
                             sampled_controllers=getattr(b, "sampled_controllers", ()))
    return Model(f, h, states=states, inputs=b.in_names, outputs=b.out_names, params=nominal or None,
                 compiled=compiled, equations=equations)


def _actuator_loads(scene: Scene, b: KaneBuilder) -> None:
    for a in scene.actuators:
        if a.type == "thruster":
            continue
        cmd = b.commands[a.name]
        if a.type == "wheel_torque":
            b.add_generalized_force(b.speed_index(f"{a.wheel}.speed"), cmd)
            continue
        _apply(b, a, cmd)


def _apply(b: KaneBuilder, a, cmd) -> None:
    """A torque or force actuator (or disturbance) with command ``cmd`` (1 or 3 values)."""
    direction = ca.DM.eye(3) if a.axis is None else ca.DM(vector3(a.axis) / np.linalg.norm(vector3(a.axis)))
    vec_B = direction @ cmd
    if getattr(a, "node", None) is not None:  # at a node of a flexible body
        r_node, C_node, w_node = b.node_motion(a.body, a.node)
        if a.type == "torque":  # node axes to body axes, where w_node is expressed
            b.add_torque_at(w_node, b.frames[a.body].C.T @ C_node @ vec_B)
        else:
            b.add_force_at(r_node, C_node @ vec_B)
    elif a.type == "torque":
        b.add_torque(a.body, vec_B)
    else:
        b.add_force(a.body, vector3(a.point), b.frames[a.body].C @ vec_B)


def _initial_state(scene: Scene, b: KaneBuilder, x, states: list[str], recipes) -> np.ndarray:
    x0 = np.zeros(len(states))
    for w in scene.wheels:
        if f"{w.name}.speed" in states:
            x0[states.index(f"{w.name}.speed")] = float(w.speed)
    for j in _joint_order(scene):
        if j.name not in recipes:
            continue
        rec = recipes[j.name]
        if rec[0] == "scalar":
            x0[states.index(f"{j.name}.{'angle' if j.type == 'revolute' else 'position'}")] = rec[1]
            x0[states.index(f"{j.name}.rate")] = rec[2]
            continue
        kind, q0, u0, w_C, w_P, C_PC = rec
        qn = ([f"{j.name}.{c}" for c in _XYZ] if kind == "free" else []) + [f"{j.name}.q{c}" for c in ("w", "x", "y", "z")]
        for name, value in zip(qn, q0):
            if name in states:
                x0[states.index(name)] = value
        fun = ca.Function("init", [x, b.t], [w_P, C_PC])
        wp, cpc = (np.asarray(v, float) for v in fun(x0, 0.0))
        w_abs = cpc.T @ wp.reshape(3) + u0[-3:]
        for c, value in zip(_XYZ, w_abs):
            x0[states.index(f"{j.name}.w{c}")] = value
        if kind == "free":
            for c, value in zip(_XYZ, u0[:3]):
                if f"{j.name}.v{c}" in states:
                    x0[states.index(f"{j.name}.v{c}")] = value
    return x0
