"""Scene entries: bodies, joints, point masses, pendulums, springs, wheels, surfaces, sensors,
actuators, disturbances, controllers, the frame, the orbit and the environment.

Constructors never raise on bad values: they keep what they are given (lists become tuples) so
that :meth:`~linflex.Scene.validate` can report every problem at once, each with its entry path.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from difflib import get_close_matches
from typing import Any

import numpy as np

from ..system._errors import ModelError
from ._values import MU_EARTH, R_EARTH

JOINT_TYPES = ("free", "revolute", "prismatic", "spherical", "fixed")
LOOP_JOINT_TYPES = ("ball", "revolute", "weld")
SENSOR_TYPES = ("attitude", "rate", "position", "velocity", "acceleration", "wheel_speed")
ACTUATOR_TYPES = ("torque", "force", "wheel_torque", "thruster")
CONTROLLER_TYPES = ("pid", "state_space", "transfer_function")
FRAME_KINDS = ("inertial", "lvlh", "spin")
PROFILES = {
    "constant": ("value",),
    "ramp": ("offset", "rate"),
    "sine": ("offset", "amplitude", "frequency", "phase"),
    "spinup": ("offset", "rate", "ramp_time"),
    "step": ("time", "before", "after"),
    "table": ("times", "values"),
}


def _tuplify(value: Any) -> Any:
    """Lists (nested) become tuples so that frozen scenes are hashable-ish and immutable."""
    if isinstance(value, (list, tuple)):
        return tuple(_tuplify(v) for v in value)
    if isinstance(value, np.ndarray):
        return _tuplify(value.tolist())
    return value


class _Entry:
    """Mixin: lists become tuples after construction; ``from_dict`` with unknown-key hints."""

    def __post_init__(self) -> None:
        for f in fields(self):  # type: ignore[arg-type]
            value = getattr(self, f.name)
            if isinstance(value, (list, np.ndarray)) or (isinstance(value, tuple) and value):
                object.__setattr__(self, f.name, _tuplify(value))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], path: str, problems: list[str]):
        if not isinstance(data, Mapping):
            problems.append(f"{path}: expected a table, got {type(data).__name__}")
            return None
        names = [f.name for f in fields(cls)]  # type: ignore[arg-type]
        kwargs = {}
        for key, value in data.items():
            if key not in names:
                problems.append(f"{path}.{key}: unknown key{_hint(key, names)}")
            else:
                kwargs[key] = value
        required = [f.name for f in fields(cls) if f.default is dataclasses.MISSING  # type: ignore[arg-type]
                    and f.default_factory is dataclasses.MISSING]
        missing = [k for k in required if k not in kwargs]
        if missing:
            problems.append(f"{path}: missing required key(s) {', '.join(missing)}")
            return None
        return cls(**kwargs)

    def to_dict(self) -> dict[str, Any]:
        out = {}
        for f in fields(self):  # type: ignore[arg-type]
            value = getattr(self, f.name)
            default = f.default if f.default is not dataclasses.MISSING else (
                f.default_factory() if f.default_factory is not dataclasses.MISSING else dataclasses.MISSING)
            if value is None or (default is not dataclasses.MISSING and _tuplify(default) == value):
                continue
            out[f.name] = value
        return out


def _hint(key: str, known) -> str:
    match = get_close_matches(str(key), list(known), n=1, cutoff=0.5)
    if match:
        return f" (did you mean {match[0]!r}?)"
    return f"; known: {', '.join(map(str, known))}" if known else ""


@dataclass(frozen=True)
class Body(_Entry):
    """A rigid or flexible body.

    Parameters
    ----------
    name : str
        Unique name of the body; joints, sensors, actuators and the other entries refer to it.
    mass : float
        Mass [kg] (of the rigid part, for a flexible body; it may be 0 there).
    inertia : sequence
        Inertia about the mass centre in body axes [kg m^2]: three principal values or a 3x3
        symmetric positive definite matrix.
    com : sequence of 3 floats
        Mass centre in the body frame [m], relative to the body's reference point.
    type : str
        ``"rigid"`` or ``"flexible"``.
    modal_data : ModalData or str, optional
        For a flexible body: its modal data (:func:`linflex.beam_modal_data`,
        :func:`linflex.load_modal_data`) or the path of an ``.npz``/``.json`` modal-data file
        (relative paths are relative to the scene file when loaded from TOML). The deformation
        is measured in the body frame, whose origin is the clamped reference point of the modes.
    beam : mapping, optional
        For a flexible body instead of ``modal_data``: a beam clamped at the body origin,
        ``{length [m], EI or EIy and EIz [N m^2], EA [N], GJ [N m^2], mass_per_length [kg/m],
        torsional_inertia_per_length [kg m], elements, direction (default [1, 0, 0]),
        damping}``; its modes come from :func:`linflex.beam_modal_data` (with the geometric
        stiffness of the unit inertia loads).
    modes : int, optional
        Number of the lowest modes to keep (default all; 6 for a ``beam``).

    Examples
    --------
    A rigid rod of 2 kg with its mass centre 0.5 m below the body origin, and a flexible boom:
    a 2 m cantilever beam whose first bending frequency is Euler-Bernoulli's
    ``1.875^2 sqrt(EI / (m L^4))`` = 8.79 rad/s.

    >>> import numpy as np
    >>> from linflex import Body
    >>> rod = Body("rod", 2.0, inertia=[0.17, 0.17, 0.001], com=[0, 0, -0.5])  # [kg], [kg m^2], [m]
    >>> rod.inertia, rod.com
    ((0.17, 0.17, 0.001), (0, 0, -0.5))
    >>> boom = Body("boom", 0.0, type="flexible", modes=2,
    ...             beam={"length": 2.0, "EI": 50.0, "EA": 1e6, "GJ": 40.0, "mass_per_length": 0.5})
    >>> np.round(boom.resolved_modal_data().frequencies, 2)  # [rad/s], bending about y and z
    array([8.79, 8.79])
    """

    name: str
    mass: float
    inertia: Any = (0.0, 0.0, 0.0)
    com: Any = (0.0, 0.0, 0.0)
    type: str = "rigid"
    modal_data: Any = None
    modes: Any = None
    beam: Any = None

    def resolved_modal_data(self):
        """The body's :class:`ModalData` (from ``beam``, or loaded if a path), ``modes`` kept.

        Returns
        -------
        ModalData
            The modal data of a flexible body: built from ``beam`` (clamped at the body origin),
            or ``modal_data`` itself or loaded from its path, truncated to the lowest ``modes``.

        Raises
        ------
        ModelError
            For unknown ``beam`` keys, or a modal-data file that cannot be loaded (see
            :func:`linflex.load_modal_data`).
        """
        from ..structures._modal_data import ModalData, load_modal_data

        if self.beam is not None:
            return _beam_body_modes(dict(self.beam), 6 if self.modes is None else int(self.modes))
        data = self.modal_data if isinstance(self.modal_data, ModalData) else load_modal_data(self.modal_data)
        return data if self.modes is None else data.truncated(int(self.modes))


BEAM_KEYS = ("length", "EI", "EIy", "EIz", "EA", "GJ", "mass_per_length", "torsional_inertia_per_length",
             "elements", "direction", "damping")


def _beam_body_modes(spec: dict, n_modes: int):
    """Modal data of a ``[bodies.beam]`` table (clamped at the body origin)."""
    from ..structures._beam import Beam, beam_modal_data

    unknown = set(spec) - set(BEAM_KEYS)
    if unknown:
        raise ModelError(f"unknown beam keys {sorted(unknown)}; known: {', '.join(BEAM_KEYS)}")
    EI = spec.get("EI")
    direction = np.asarray(spec.get("direction", (1.0, 0.0, 0.0)), dtype=float)
    direction = direction / np.linalg.norm(direction)
    beam = Beam((0.0, 0.0, 0.0), tuple(float(spec["length"]) * direction),
                EA=float(spec["EA"]), EIy=float(spec.get("EIy", EI)), EIz=float(spec.get("EIz", EI)),
                GJ=float(spec["GJ"]), mass_per_length=float(spec["mass_per_length"]),
                torsional_inertia_per_length=float(spec.get("torsional_inertia_per_length", 0.0)),
                elements=int(spec.get("elements", 10)))
    return beam_modal_data(beam, n_modes, damping=float(spec.get("damping", 0.0)))


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
        A time profile for a revolute or prismatic coordinate: ``{"profile": "sine",
        "offset": .., "amplitude": .., "frequency": [rad/s], "phase": ..}``, ``"ramp"``
        (``offset``, ``rate``), ``"constant"`` (``value``), ``"spinup"`` (``offset``, ``rate``
        [rad/s], ``ramp_time`` [s]: the classic smooth spin-up of the rate
        ``(W/T)(t - T/(2 pi) sin(2 pi t/T))`` until ``T``, then ``W``), ``"step"`` (``time``,
        ``before``, ``after``) or ``"table"`` (``times`` [s], ``values``: a cubic spline
        through the points, held at the end values outside them); from Python also a
        callable ``q(t)`` that accepts a CasADi symbol.
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


@dataclass(frozen=True)
class PointMass(_Entry):
    """A particle of ``mass`` [kg] fixed at ``point`` [m] of ``body``."""

    name: str
    body: str
    mass: float
    point: Any = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Pendulum(_Entry):
    """A spherical pendulum (fuel slosh): a bob of ``mass`` [kg] on a massless rod of ``length``
    [m] hinged at ``point`` of ``body``, hanging along ``direction`` (body axes) at rest, with
    viscous hinge ``damping`` [N m s/rad]. Needs the ``slosh`` effect to move."""

    name: str
    body: str
    mass: float
    length: float
    point: Any = (0.0, 0.0, 0.0)
    direction: Any = (0.0, 0.0, 1.0)
    damping: float = 0.0


@dataclass(frozen=True)
class Spring(_Entry):
    """A point ``mass`` [kg] on a spring-damper sliding along ``axis`` of ``body`` through
    ``point`` (a nutation damper), ``stiffness`` [N/m], ``damping`` [N s/m]. Needs the
    ``dampers`` effect to move."""

    name: str
    body: str
    mass: float
    stiffness: float
    damping: float = 0.0
    point: Any = (0.0, 0.0, 0.0)
    axis: Any = (0.0, 0.0, 1.0)


@dataclass(frozen=True)
class Wheel(_Entry):
    """A momentum wheel on ``body`` spinning about ``axis`` (body axes).

    ``spin_inertia`` and ``transverse_inertia`` [kg m^2] about the wheel's centre, ``mass``
    [kg] at ``point`` [m]. ``mode="constant"`` keeps the relative ``speed`` [rad/s];
    ``mode="torque"`` makes the speed a state driven by a ``wheel_torque`` actuator (``speed``
    is then its initial value). Gyroscopic coupling needs the ``wheel_gyroscopics`` effect;
    without it the wheel is a locked rigid part of its body.

    On a flexible body without ``node`` the wheel sits on the body's rigid part (its frame, at
    ``point``). With ``node``, naming a node of its modal data, the wheel sits there: its mass
    moves with the node (translation ``Phi q``) and its spin axis turns with the node's small
    rotation (``Psi q``), so its gyroscopic torque couples into the modes; ``axis`` is in body
    axes (the node axes when undeformed) and ``point`` is then unused. The wheel's mass is not
    part of the modal data: its inertia loads are not in the ``geometric_stiffness`` matrices
    (add it to the modal data, for example with :class:`linflex.PointMassAt`, when they matter).
    """

    name: str
    body: str
    spin_inertia: float
    axis: Any = (0.0, 0.0, 1.0)
    transverse_inertia: float = 0.0
    mass: float = 0.0
    point: Any = (0.0, 0.0, 0.0)
    mode: str = "constant"
    speed: float = 0.0
    node: str | None = None


@dataclass(frozen=True)
class Surface(_Entry):
    """A flat plate of ``area`` [m^2] on ``body`` with outward ``normal`` and centre of pressure
    ``point`` (body axes), ``reflectivity`` (specular fraction, 0..1) for ``solar_pressure`` and
    ``drag_coefficient`` for ``aerodynamic_drag``."""

    name: str
    body: str
    area: float
    normal: Any = (1.0, 0.0, 0.0)
    point: Any = (0.0, 0.0, 0.0)
    reflectivity: float = 0.0
    drag_coefficient: float = 2.2


@dataclass(frozen=True)
class Sensor(_Entry):
    """A sensor on ``body`` (or on ``wheel`` for ``wheel_speed``).

    ``attitude``: the small-angle attitude of the body relative to the scene frame,
    ``vee((C - C^T)/2)`` [rad]; ``rate``: inertial angular velocity in body axes [rad/s]
    (relative to the scene frame with ``relative = true``); ``position``, ``velocity``: of
    ``point`` relative to the scene frame in scene axes [m, m/s]; ``acceleration``: inertial
    acceleration of ``point`` in body axes [m/s^2]; ``wheel_speed`` [rad/s]. With ``axis`` the
    sensor has one output (the projection), otherwise three (``name.x``, ``.y``, ``.z``).
    On a flexible body, ``node`` names a node of its modal data: the sensor then moves with the
    structure there (translation ``Phi q``, small rotation ``Psi q``) and ``point`` is unused.
    """

    name: str
    type: str
    body: str | None = None
    wheel: str | None = None
    point: Any = (0.0, 0.0, 0.0)
    axis: Any = None
    relative: bool = False
    node: str | None = None


@dataclass(frozen=True)
class Actuator(_Entry):
    """An actuator whose command is an input of the model.

    ``torque`` [N m] on ``body`` about ``axis`` (body axes; three commands without ``axis``);
    ``force`` [N] at ``point`` along ``axis`` (body axes); ``thruster`` [N] likewise, active
    with the ``thrusters`` effect; ``wheel_torque`` [N m] of the motor of ``wheel`` (reaction on
    its body). On a flexible body, ``node`` names a node of its modal data where the torque or
    force acts (axes turned by the node's small rotation); ``point`` is then unused.
    """

    name: str
    type: str
    body: str | None = None
    wheel: str | None = None
    point: Any = (0.0, 0.0, 0.0)
    axis: Any = None
    node: str | None = None


@dataclass(frozen=True)
class Disturbance(_Entry):
    """A named disturbance input: a ``torque`` [N m] on ``body`` about ``axis`` or a ``force``
    [N] at ``point`` along ``axis`` (body axes; three inputs ``name.x``, ``.y``, ``.z`` without
    ``axis``). Unlike an actuator it has no command output and no controller drives it."""

    name: str
    type: str
    body: str
    point: Any = (0.0, 0.0, 0.0)
    axis: Any = None


@dataclass(frozen=True)
class Controller(_Entry):
    """A controller from sensor signals to actuator commands (the ``control`` effect).

    The controller sees ``e = reference - y`` for its ``inputs`` (scalar sensor signals, one per
    channel) and adds its outputs to the commands of ``outputs`` (scalar actuators).
    ``pid``: ``u = kp e + ki int(e) - kd r`` with ``r`` the signals of ``rate_inputs`` (gains are
    scalars or one per channel); ``state_space``: ``xc' = A xc + B e``, ``u = C xc + D e``;
    ``transfer_function``: ``num``, ``den`` (highest power first), the same for every channel.
    """

    name: str
    type: str
    inputs: Any
    outputs: Any
    reference: Any = None
    rate_inputs: Any = None
    kp: Any = 0.0
    ki: Any = 0.0
    kd: Any = 0.0
    A: Any = None
    B: Any = None
    C: Any = None
    D: Any = None
    num: Any = None
    den: Any = None


@dataclass(frozen=True)
class Frame(_Entry):
    """The frame attitude is measured in: ``inertial``, ``lvlh`` (x along the orbital velocity, y
    opposite the orbit normal, z to the Earth's centre) or ``spin`` (``rate`` [rad/s] about
    ``axis``)."""

    kind: str = "inertial"
    rate: float = 0.0
    axis: Any = (0.0, 0.0, 1.0)


@dataclass(frozen=True)
class Orbit(_Entry):
    """A circular reference orbit of ``radius`` [m] (or ``altitude`` [m] above ``R_EARTH``) with
    gravitational parameter ``mu`` [m^3/s^2]."""

    kind: str = "circular"
    radius: float | None = None
    altitude: float | None = None
    mu: float = MU_EARTH

    @property
    def r0(self) -> float:
        """Orbit radius [m]."""
        return float(self.radius) if self.radius is not None else R_EARTH + float(self.altitude)

    @property
    def mean_motion(self) -> float:
        """Orbital rate ``n = sqrt(mu / r^3)`` [rad/s]."""
        return math.sqrt(self.mu / self.r0**3)


@dataclass(frozen=True)
class Environment(_Entry):
    """Uniform ``gravity`` [m/s^2] (inertial axes), ``sun_direction`` (unit vector toward the
    Sun, inertial axes), ``solar_pressure`` [N/m^2], and an exponential atmosphere
    ``density`` [kg/m^3] at ``reference_altitude`` [m] with ``scale_height`` [m]."""

    gravity: Any = (0.0, 0.0, -9.81)
    sun_direction: Any = (1.0, 0.0, 0.0)
    solar_pressure: float = 4.56e-6
    density: float = 3.0e-12
    reference_altitude: float = 500e3
    scale_height: float = 60e3


_LISTS = {
    "bodies": Body,
    "joints": Joint,
    "loop_joints": LoopJoint,
    "point_masses": PointMass,
    "pendulums": Pendulum,
    "springs": Spring,
    "wheels": Wheel,
    "surfaces": Surface,
    "sensors": Sensor,
    "actuators": Actuator,
    "disturbances": Disturbance,
    "controllers": Controller,
}


