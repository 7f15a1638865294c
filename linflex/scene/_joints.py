"""Scene entries, part two: joints of the tree and loop-closing joints."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._entries import JOINT_TYPES, LOOP_JOINT_TYPES, PROFILES, _Entry
from ._problems import Problems, SceneContext, hint

#: Coordinates and speeds of each joint type (``q0`` and ``u0`` lengths).
JOINT_SIZES = {"free": (7, 6), "spherical": (4, 3), "revolute": (1, 1), "prismatic": (1, 1), "fixed": (0, 0)}


@dataclass(frozen=True)
class Joint(_Entry):
    """A joint between ``parent`` (a body or ``"ground"``, the scene frame) and ``child``.

    Parameters
    ----------
    name : str
        Unique name of the joint; its states are ``<name>.angle``, ``<name>.rate``, ...
    type : {"free", "revolute", "prismatic", "spherical", "fixed"}
        Free joints use a position [m] in parent axes with its rate, a quaternion
        (scalar first, child relative to parent) and the child's inertial angular velocity in
        child axes as generalized speeds; spherical joints the quaternion and that angular
        velocity; revolute and prismatic joints the angle [rad] or displacement [m] along
        ``axis`` and its rate.
    child : str
        The body the joint attaches (its inboard joint: every body has exactly one).
    parent : str
        The body it is attached to, or ``"ground"`` (the scene frame; the default).
    axis : sequence of 3 floats
        Joint axis, a unit vector [-] in parent (= child at zero angle) axes; normalized when
        compiled, so any nonzero length will do.
    parent_point, child_point : sequence of 3 floats
        Joint location in the parent's and the child's frame [m].
    stiffness, damping : float
        Joint spring [N m/rad or N/m] and damper [N m s/rad or N s/m] (``joint_springs``).
    rest : float
        Angle [rad] (revolute) or displacement [m] (prismatic) at which the joint spring is
        relaxed: the spring load is ``-stiffness (q - rest)``.
    locked : bool or sequence of str
        ``true``: a revolute or prismatic joint held at ``q0``; for a free joint a list of the
        translations held at ``q0`` (``["x", "y", "z"]`` leaves only the attitude free).
    prescribed : mapping or callable, optional
        A time profile for a revolute or prismatic coordinate ([rad] or [m]): a mapping with
        ``profile`` and that profile's keys, each ``key`` [unit] meaning:
        ``"constant"``: ``value`` [rad or m] the coordinate at all times;
        ``"ramp"``: ``offset`` [rad or m] the coordinate at t = 0; ``rate`` [rad/s or m/s] its
        constant rate;
        ``"sine"``: ``offset`` [rad or m] the mean value; ``amplitude`` [rad or m] the
        amplitude; ``frequency`` [rad/s] the angular frequency; ``phase`` [rad] the phase at
        t = 0;
        ``"spinup"``: ``offset`` [rad or m] the coordinate at t = 0; ``rate`` [rad/s or m/s]
        the final rate W; ``ramp_time`` [s] the duration T of the classic smooth spin-up, rate
        ``(W/T)(t - T/(2 pi) sin(2 pi t/T))`` until ``T``, then ``W``;
        ``"step"``: ``time`` [s] the instant of the step; ``before`` [rad or m] the coordinate
        before it; ``after`` [rad or m] the coordinate after it;
        ``"table"``: ``times`` [s] the sample times, increasing; ``values`` [rad or m] the
        coordinate at those times, through which a cubic spline passes (held at the end values
        outside them);
        ``"transition"``: ``start`` [s] the instant the change begins; ``duration`` [s] its
        length T; ``before`` [rad or m] the coordinate until ``start``; ``after`` [rad or m]
        the coordinate from ``start + T`` on, reached along the cycloidal blend
        ``s - sin(2 pi s)/(2 pi)`` of ``s = (t - start)/T`` (rate and acceleration continuous,
        zero at both ends).
        From Python also a callable ``q(t)`` that accepts a CasADi symbol.
    q0 : float or sequence of floats, optional
        Initial coordinates (default zero, the identity quaternion): revolute, the angle [rad];
        prismatic, the displacement [m]; spherical, the unit quaternion ``qw, qx, qy, qz`` [-]
        (scalar first, child relative to parent); free, the position ``x, y, z`` [m] of the
        child point relative to the parent point in parent axes, then that quaternion [-]
        (7 values). A locked joint, or a locked translation, is held at its ``q0``.
    u0 : float or sequence of floats, optional
        Initial relative rates (default zero): revolute, the angular rate [rad/s]; prismatic,
        the velocity [m/s]; spherical, ``wx, wy, wz``, the angular rate relative to the parent
        in child axes [rad/s]; free, the velocity ``vx, vy, vz`` [m/s] (the rate of ``x, y,
        z``, parent axes), then ``wx, wy, wz`` [rad/s] as for spherical (6 values).

    Examples
    --------
    A hinge released at 0.1 rad about the parent's y axis, and a free-floating bus spinning at
    0.1 rad/s about its z axis (the identity quaternion: aligned with the scene frame):

    >>> from linflex import Body, Joint, Scene, compile_model
    >>> hinge = Joint("hinge", "revolute", "rod", axis=[0, 1, 0], q0=0.1)  # [rad]
    >>> hinge.parent, hinge.axis
    ('ground', (0, 1, 0))
    >>> bus = Joint("float", "free", "bus", q0=[0, 0, 0, 1, 0, 0, 0], u0=[0, 0, 0, 0, 0, 0.1])
    >>> model = compile_model(Scene("bus", bodies=[Body("bus", 100.0, [10, 12, 8])], joints=[bus]))
    >>> model.states[:7]
    ('float.x', 'float.y', 'float.z', 'float.qw', 'float.qx', 'float.qy', 'float.qz')
    >>> model.x0[-3:].tolist()  # float.wx, .wy, .wz [rad/s]
    [0.0, 0.0, 0.1]
    """

    name: str
    type: str
    child: str
    parent: str = "ground"
    axis: Any = (0.0, 0.0, 1.0)
    parent_point: Any = (0.0, 0.0, 0.0)
    child_point: Any = (0.0, 0.0, 0.0)
    stiffness: float = 0.0
    damping: float = 0.0
    rest: float = 0.0
    locked: bool = False
    prescribed: Any = None
    q0: Any = None
    u0: Any = None

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.choice(self.type, f"{path}.type", JOINT_TYPES, "joint type")
        if self.parent != "ground":
            out.name_ref(self.parent, f"{path}.parent", context.body_names + ["ground"], "body")
        out.name_ref(self.child, f"{path}.child", context.body_names, "body")
        if self.child == self.parent:
            out.add(path, f"joins body {self.child!r} to itself")
        scalar = self.type in ("revolute", "prismatic")
        out.vector(self.axis, f"{path}.axis", "-", nonzero=True)
        out.inapplicable(self, "axis", path, scalar or self.type not in JOINT_TYPES,
                         f"a {self.type} joint has no axis (revolute and prismatic joints do)")
        out.vector(self.parent_point, f"{path}.parent_point", "m", kind="length")
        out.vector(self.child_point, f"{path}.child_point", "m", kind="length")
        out.number(self.stiffness, f"{path}.stiffness", "N m/rad or N/m", nonnegative=True)
        out.number(self.damping, f"{path}.damping", "N m s/rad or N s/m", nonnegative=True)
        out.number(self.rest, f"{path}.rest", "rad or m")
        for key in ("stiffness", "damping", "rest"):
            out.inapplicable(self, key, path, scalar or self.type not in JOINT_TYPES,
                             f"joint springs act on revolute and prismatic joints only (this one is {self.type!r})")
        self._check_locked(out, path, scalar)
        if self.prescribed is not None:
            self._check_prescribed(out, f"{path}.prescribed", scalar)
        self._check_initial(out, path)

    def _check_locked(self, out: Problems, path: str, scalar: bool) -> None:
        if isinstance(self.locked, (tuple, list)):
            if self.type != "free":
                out.add(f"{path}.locked", f"a list of locked coordinates is for free joints (this joint is "
                                          f"{self.type!r}; use true or false)")
            else:
                for k, c in enumerate(self.locked):
                    if c not in ("x", "y", "z"):
                        out.add(f"{path}.locked[{k}]", f"unknown coordinate {c!r}; a free joint can lock its "
                                                       "translations 'x', 'y', 'z'")
        elif not isinstance(self.locked, bool):
            out.add(f"{path}.locked", f"expected true, false or (free joints) a list of 'x', 'y', 'z', "
                                      f"got {self.locked!r}")
        elif self.locked and not scalar:
            out.add(f"{path}.locked", f"only revolute and prismatic joints lock as a whole; a free joint takes a "
                                      f"list of translations to lock (this joint is {self.type!r})")

    def _check_prescribed(self, out: Problems, path: str, scalar: bool) -> None:
        prescribed = self.prescribed
        if not scalar:
            out.add(path, f"only revolute and prismatic coordinates can be prescribed (this joint is {self.type!r})")
        elif self.locked:
            out.add(path, "a coordinate cannot be both locked and prescribed")
        elif callable(prescribed):
            return
        else:
            profile_table_problems(out, path, prescribed)

    def _check_initial(self, out: Problems, path: str) -> None:
        nq, nu = JOINT_SIZES.get(self.type, (None, None))
        for key, n in (("q0", nq), ("u0", nu)):
            value = getattr(self, key)
            if value is None or n is None:
                continue
            value = [value] if isinstance(value, (int, float)) else value
            arr = out.array(value, f"{path}.{key}", (n,), "SI", f"{n} values for a {self.type} joint")
            if arr is None:
                continue
            if key == "q0" and self.type in ("free", "spherical"):
                quat = arr[-4:]
                if abs(np.linalg.norm(quat) - 1) > 1e-9:
                    out.add(f"{path}.q0", f"the quaternion {quat.tolist()} is not a unit quaternion "
                                          f"(norm {np.linalg.norm(quat):.12g})")
            if key == "u0" and self.type != "prismatic":
                w = arr if self.type != "free" else arr[3:]
                out.in_range(float(np.linalg.norm(w)), f"{path}.u0", "rate", value)


@dataclass(frozen=True)
class LoopJoint(_Entry):
    """A loop-closing joint: constraints between two bodies that are already joined by the tree.

    The joints form a tree (every body has one inboard joint); a loop joint closes a kinematic
    loop (a four-bar mechanism, a closed truss) by constraining ``point_a`` of ``body_a`` to
    ``point_b`` of ``body_b`` with undetermined multipliers (Banerjee 2016, section 1.6 and 8.7;
    see :func:`linflex.compile_model`). Its constraint force and torque are model outputs.

    Parameters
    ----------
    name : str
        Unique name of the loop joint; its outputs are ``<name>.force.*`` (and ``.torque.*``).
    type : {"ball", "revolute", "weld"}
        ``"ball"``: the two points coincide (3 constraints); ``"revolute"``: and ``axis`` of
        ``body_a`` stays parallel to ``axis_b`` of ``body_b`` (5 constraints); ``"weld"``: and
        the axes of the two bodies stay parallel (6 constraints; the bodies' axes must be
        aligned where the loop closes).
    body_a, body_b : str
        Bodies (or ``"ground"``, the scene frame) the joint connects.
    point_a, point_b : sequence of 3 floats
        The joint location in ``body_a``'s and in ``body_b``'s frame [m] (on a flexible body:
        fixed in its reference frame, the modes' clamped frame).
    node_a, node_b : str, optional
        On a flexible body, a node of its modal data where the joint is instead: it moves with
        the structure (translation ``Phi q``, small rotation ``Psi q`` as a proper rotation, see
        ``KaneBuilder.node_frame``), and ``point_a``/``point_b`` are unused; ``axis`` is in
        the node's axes (the body axes when undeformed).
    axis : sequence of 3 floats
        Hinge axis of a revolute loop joint, a unit vector [-] in ``body_a`` axes (normalized
        when compiled).
    axis_b : sequence of 3 floats, optional
        The same hinge axis, a unit vector [-] in ``body_b`` axes (normalized when compiled);
        default ``axis``.
    baumgarte : sequence of 2 floats
        Gains ``(kd [1/s], kp [1/s^2])`` of the constraint stabilization
        ``e'' + kd e' + kp e = 0`` of each constraint ``e`` (Baumgarte 1972): a drifting
        constraint returns critically damped at 10 rad/s by default; ``(0, 0)`` switches it off.
    solve_for : sequence of str, optional
        Tree joints whose coordinates and speeds :func:`linflex.compile_model` adjusts so that
        the initial state closes the loop (the others keep their ``q0`` and ``u0``); default:
        the coordinates a QR factorization with column pivoting of the constraint Jacobian picks.

    Notes
    -----
    Outputs: ``<name>.force.x``, ``.y``, ``.z``, the constraint force on ``body_a`` at
    ``point_a`` in scene axes [N] (``body_b`` receives the opposite), and for revolute and weld
    joints ``<name>.torque.x``, ``.y``, ``.z``, the constraint torque on ``body_a`` in scene
    axes [N m]. Where the joint's constraints are not independent (a planar loop closed by a
    revolute joint: the tree's hinges already keep it planar), the dependent ones carry no force.

    Examples
    --------
    The pin that closes the four-bar of ``examples/four_bar.toml``: the coupler's tip, 1.2 m
    along its x axis, on the rocker's, 0.9 m along its x axis.

    >>> from linflex import LoopJoint, compile_model, load_scene
    >>> pin = LoopJoint("pin", "revolute", "coupler", "rocker", point_a=[1.2, 0, 0], point_b=[0.9, 0, 0])
    >>> pin.axis, pin.baumgarte  # [-]; (kd [1/s], kp [1/s^2])
    ((0.0, 0.0, 1.0), (20.0, 100.0))
    >>> scene = load_scene("examples/four_bar.toml")
    >>> scene.loop_joints[0] == pin
    True
    >>> [name for name in compile_model(scene).outputs if name.startswith("pin.")]  # [N], [N m]
    ['pin.force.x', 'pin.force.y', 'pin.force.z', 'pin.torque.x', 'pin.torque.y', 'pin.torque.z']
    """

    name: str
    type: str
    body_a: str
    body_b: str = "ground"
    point_a: Any = (0.0, 0.0, 0.0)
    point_b: Any = (0.0, 0.0, 0.0)
    axis: Any = (0.0, 0.0, 1.0)
    axis_b: Any = None
    baumgarte: Any = (20.0, 100.0)
    solve_for: Any = None
    node_a: str | None = None
    node_b: str | None = None

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.choice(self.type, f"{path}.type", LOOP_JOINT_TYPES, "loop joint type")
        known = context.body_names + ["ground"]
        ok_a = out.name_ref(self.body_a, f"{path}.body_a", known, "body")
        ok_b = out.name_ref(self.body_b, f"{path}.body_b", known, "body")
        if ok_a and ok_b and self.body_a == self.body_b:
            out.add(path, f"joins {self.body_a!r} to itself (a loop joint connects two different bodies)")
        out.vector(self.point_a, f"{path}.point_a", "m", kind="length")
        out.vector(self.point_b, f"{path}.point_b", "m", kind="length")
        for side in ("a", "b"):
            node, body = getattr(self, f"node_{side}"), getattr(self, f"body_{side}")
            out.inapplicable(self, f"point_{side}", path, node is None, f"a loop joint at node_{side} sits there")
            if node is not None and body == "ground":
                out.add(f"{path}.node_{side}", "the ground has no nodes (nodes belong to flexible bodies)")
            else:
                context.check_node(out, f"{path}.node_{side}", body, node)
        out.vector(self.axis, f"{path}.axis", "-", nonzero=True)
        if self.axis_b is not None:
            out.vector(self.axis_b, f"{path}.axis_b", "-", nonzero=True)
            if self.type != "revolute":
                out.add(f"{path}.axis_b", f"only revolute loop joints take a hinge axis (this one is {self.type!r})")
        out.inapplicable(self, "axis", path, self.type != "ball",
                         "a ball loop joint has no axis (revolute loop joints do; weld joints align the body axes)")
        if self.solve_for is not None:
            names = [self.solve_for] if isinstance(self.solve_for, str) else list(self.solve_for)
            for k, name in enumerate(names):
                joint = context.joints.get(name) if isinstance(name, str) else None
                if out.name_ref(name, f"{path}.solve_for[{k}]", list(context.joints), "joint") and (
                        joint.type == "fixed" or joint.locked is True or joint.prescribed is not None):
                    out.add(f"{path}.solve_for[{k}]", f"joint {name!r} has no free coordinate to adjust")
        gains = out.array(self.baumgarte, f"{path}.baumgarte", (2,), "1/s, 1/s^2", "two gains (kd, kp)")
        if gains is not None and np.any(gains < 0):
            out.add(f"{path}.baumgarte", f"gains must not be negative, got {gains.tolist()} (use (0, 0) to switch "
                                         "the stabilization off)")


def profile_table_problems(out: Problems, path: str, prescribed: Any) -> None:
    """A time-profile table (``{profile = "...", ...}``, the keys of :data:`PROFILES`): its kind,
    its keys and their values (joints' ``prescribed``, booms' ``length``, thermal loads)."""
    if not isinstance(prescribed, dict) or prescribed.get("profile") not in PROFILES:
        got = prescribed.get("profile") if isinstance(prescribed, dict) else prescribed
        out.add(path, f"unknown profile {got!r}{hint(got, PROFILES)}")
        return
    kind = prescribed["profile"]
    allowed = PROFILES[kind]
    for key, value in prescribed.items():
        if key == "profile":
            continue
        if key not in allowed:
            out.add(f"{path}.{key}", f"unknown key{hint(key, allowed)}")
        elif kind != "table":
            out.number(value, f"{path}.{key}", "SI")
    _profile_problems(out, path, prescribed)


def _profile_problems(out: Problems, path: str, prescribed: dict) -> None:
    """Keys a profile cannot do without, and the table's points."""
    kind = prescribed["profile"]
    required = {"spinup": ("rate", "ramp_time"), "step": ("time", "before", "after"), "table": ("times", "values"),
                "transition": ("start", "duration", "before", "after")}
    for key in required.get(kind, ()):
        if key not in prescribed:
            out.add(f"{path}.{key}", f"a {kind!r} profile needs {key!r}")
    if kind == "spinup" and isinstance(prescribed.get("ramp_time"), (int, float)) and prescribed["ramp_time"] <= 0:
        out.add(f"{path}.ramp_time", "must be positive [s]")
    if kind == "transition" and isinstance(prescribed.get("duration"), (int, float)) and prescribed["duration"] <= 0:
        out.add(f"{path}.duration", "must be positive [s]")
    if kind == "table" and "times" in prescribed and "values" in prescribed:
        try:
            times = np.asarray(prescribed["times"], dtype=float)
            values = np.asarray(prescribed["values"], dtype=float)
        except (TypeError, ValueError):
            out.add(path, "times and values must be lists of numbers")
            return
        if times.ndim != 1 or values.shape != times.shape or times.size < 4:
            out.add(path, f"times and values must be equally long lists of at least 4 points "
                          f"(a cubic spline), got {times.size} and {values.size}")
        elif not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
            out.add(path, "times and values must be finite")
        elif np.any(np.diff(times) <= 0):
            out.add(f"{path}.times", "must increase strictly")
