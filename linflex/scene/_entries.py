"""Scene entries, part one: the common base of every entry, bodies and the masses carried by bodies.

Joints are in :mod:`._joints`, wheels, surfaces, sensors, actuators, disturbances and controllers
in :mod:`._devices`, the frame, the orbit, the environment and the limits in :mod:`._world`.

Constructors never raise on bad values: they keep what they are given (lists become tuples) so
that :meth:`~linflex.Scene.validate` can report every problem at once, each with its entry path.
Each entry checks itself with ``problems(path, context)``; the checks across entries are in
:mod:`._check`.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from ..system._errors import ModelError
from ._problems import Problems, SceneContext, hint, is_numeric

JOINT_TYPES = ("free", "revolute", "prismatic", "spherical", "fixed")
LOOP_JOINT_TYPES = ("ball", "revolute", "weld")
CONSTRAINT_KINDS = ("rolling", "knife_edge")
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
    "transition": ("start", "duration", "before", "after"),
}
#: A modal frequency at or below this fraction of the body's highest is a zero-frequency
#: (rigid-body) mode.
ZERO_FREQUENCY = 1e-6


def _tuplify(value: Any) -> Any:
    """Lists (nested) become tuples so that frozen scenes are hashable-ish and immutable."""
    if isinstance(value, (list, tuple)):
        return tuple(_tuplify(v) for v in value)
    if isinstance(value, np.ndarray):
        return _tuplify(value.tolist())
    return value


_hint = hint


class _Entry:
    """Mixin: lists become tuples after construction; ``from_dict`` with unknown-key hints."""

    def __post_init__(self) -> None:
        for f in fields(self):  # type: ignore[arg-type]
            value = getattr(self, f.name)
            if isinstance(value, (list, np.ndarray)) or (isinstance(value, tuple) and value):
                object.__setattr__(self, f.name, _tuplify(value))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], path: str, problems: list[str], covered: set[str] | None = None):
        """The entry of a mapping with this entry's keys; unknown and missing keys go to ``problems``.

        Missing required keys are given as None (so that the rest of the entry is still
        checked); their paths go to ``covered``, whose later problems repeat the missing key.
        Returns None only when ``data`` is not a mapping.
        """
        if not isinstance(data, Mapping):
            problems.append(f"{path}: expected a table, got {type(data).__name__} {data!r}")
            return None
        names = [f.name for f in fields(cls)]  # type: ignore[arg-type]
        kwargs = {}
        for key, value in data.items():
            if key not in names:
                problems.append(f"{path}.{key}: unknown key{hint(key, names)}")
            else:
                kwargs[key] = value
        required = [f.name for f in fields(cls) if f.default is dataclasses.MISSING  # type: ignore[arg-type]
                    and f.default_factory is dataclasses.MISSING]
        missing = [k for k in required if k not in kwargs]
        if missing:
            problems.append(f"{path}: missing required key(s) {', '.join(missing)}")
            if covered is not None:
                covered.update(f"{path}.{k}" for k in missing)
        return cls(**kwargs, **dict.fromkeys(missing))

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

    def problems(self, path: str, context: SceneContext) -> list[str]:
        """Every problem of this entry as ``"path: message"`` strings (empty when it is fine).

        Parameters
        ----------
        path : str
            The entry's path in its scene (``"bodies[2]"``), prefixed to every message.
        context : SceneContext
            The rest of the scene: names of bodies, wheels, sensors, the effects, the limits.

        Returns
        -------
        list of str
            One message per problem.
        """
        out = Problems(context.limits)
        self._check(out, path, context)
        return list(out)

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        raise NotImplementedError


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
        ``{length [m] the beam's length, EI or EIy and EIz [N m^2] the bending stiffness about
        both transverse axes or about each, EA [N], GJ [N m^2], mass_per_length [kg/m],
        torsional_inertia_per_length [kg m], elements, direction [-] (default [1, 0, 0]) the
        unit vector from the root along the beam in body axes, damping}``; its modes come from :func:`linflex.beam_modal_data` (with the geometric
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

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        flexible = self.type == "flexible"
        # A flexible body's rigid part may be massless (the modal data carries the mass).
        out.number(self.mass, f"{path}.mass", "kg", positive=not flexible, nonnegative=flexible, kind="mass")
        out.vector(self.com, f"{path}.com", "m", kind="length")
        if self.type not in ("rigid", "flexible"):
            out.add(f"{path}.type", f"unknown body type {self.type!r}{hint(self.type, ('rigid', 'flexible'))}")
        elif flexible:
            self._check_flexible(out, path, context)
        else:
            if self.modal_data is not None:
                out.add(f"{path}.modal_data", "only flexible bodies take modal data (set type = 'flexible')")
            out.inapplicable(self, "beam", path, False, "only flexible bodies take a beam (set type = 'flexible')")
            out.inapplicable(self, "modes", path, False, "only flexible bodies have modes")
        inertia_problems(out, f"{path}.inertia", self.inertia)

    def _check_flexible(self, out: Problems, path: str, context: SceneContext) -> None:
        """A flexible body needs loadable modal data (or a valid beam), an integral number of modes,
        and no zero-frequency modes."""
        if (self.modal_data is None) == (self.beam is None):
            out.add(f"{path}.modal_data", "a flexible body needs modal data (a ModalData or an .npz/.json file) "
                                          "or a beam table, and not both")
            return
        if self.modes is not None and not out.integer(self.modes, f"{path}.modes", low=1):
            return
        where = f"{path}.beam" if self.beam is not None else f"{path}.modal_data"
        if self.beam is not None and not beam_problems(out, where, self.beam):
            return
        try:
            data = (context.modal_data(self.name) if context.bodies.get(self.name) is self else
                    dataclasses.replace(self, modes=None if self.beam is None else self.modes).resolved_modal_data())
        except (ModelError, OSError, KeyError, TypeError, ValueError) as err:  # report it; the check goes on
            out.add(where, f"missing key {err}" if isinstance(err, KeyError) else str(err))
            return
        if self.beam is None and self.modes is not None and not out.integer(self.modes, f"{path}.modes", low=1,
                                                                             high=data.n_modes):
            return
        w = data.frequencies[: data.n_modes if self.modes is None else int(self.modes)]
        rigid = np.flatnonzero(w <= ZERO_FREQUENCY * max(float(w.max(initial=0.0)), 0.0))
        if rigid.size:
            out.add(where, f"mode(s) {', '.join(map(str, rigid))} have zero frequency "
                           f"({', '.join(f'{v:.3g}' for v in w[rigid])} rad/s): rigid-body modes of an unrestrained "
                           "structure, which the body's joint already carries (the modes are measured in the body "
                           "frame, clamped at its origin); give modes of the structure clamped at the body origin "
                           "(beam_modal_data, craig_bampton)")


def inertia_problems(out: Problems, path: str, inertia: Any) -> np.ndarray | None:
    """Three principal values or a symmetric 3x3 matrix, positive semi-definite, physical, in range."""
    arr = np.asarray(inertia, dtype=float) if is_numeric(inertia) else None
    if arr is None or arr.shape not in ((3,), (3, 3)):
        out.add(path, "expected 3 principal values or a 3x3 matrix [kg m^2], got "
                + (f"shape {arr.shape}" if arr is not None else repr(inertia)))
        return None
    if not np.all(np.isfinite(arr)):
        out.add(path, f"not finite: {inertia!r} [kg m^2]")
        return None
    mat = np.diag(arr) if arr.shape == (3,) else arr
    if not np.allclose(mat, mat.T, rtol=1e-12, atol=1e-14 * max(1.0, np.abs(mat).max())):
        out.add(path, "not symmetric positive definite (not symmetric)")
        return None
    eig = np.linalg.eigvalsh(mat)
    if eig.min() < -1e-12 * max(1.0, eig.max()):
        out.add(path, f"not symmetric positive definite (eigenvalue {eig.min():.3g} < 0; "
                      "zero is allowed for point-like bodies)")
        return None
    if eig[0] + eig[1] < eig[2] * (1 - 1e-12):
        out.add(path, "violates the triangle inequality I1 + I2 >= I3 (not a physical body)")
        return None
    if not out.in_range(float(eig.max()), path, "inertia", inertia):
        return None
    return mat


BEAM_KEYS = ("length", "EI", "EIy", "EIz", "EA", "GJ", "mass_per_length", "torsional_inertia_per_length",
             "elements", "direction", "damping")


def beam_problems(out: Problems, path: str, spec: Any) -> bool:
    """The keys of a ``[bodies.beam]`` table: known, present, of the right kind; True when fine."""
    if not isinstance(spec, Mapping):
        out.add(path, f"expected a table of beam properties, got {spec!r}")
        return False
    before = len(out)
    for key in spec:
        if key not in BEAM_KEYS:
            out.add(f"{path}.{key}", f"unknown key{hint(key, BEAM_KEYS)}")
    for key in ("length", "EA", "GJ", "mass_per_length"):
        if key not in spec:
            out.add(path, f"missing key {key!r}")
    if "EI" not in spec and not ("EIy" in spec and "EIz" in spec):
        out.add(path, "missing key 'EI' (or both 'EIy' and 'EIz')")
    units = {"length": "m", "EI": "N m^2", "EIy": "N m^2", "EIz": "N m^2", "EA": "N", "GJ": "N m^2",
             "mass_per_length": "kg/m"}
    for key, unit in units.items():
        if key in spec:
            out.number(spec[key], f"{path}.{key}", unit, positive=True, kind="length" if key == "length" else None)
    if "torsional_inertia_per_length" in spec:
        out.number(spec["torsional_inertia_per_length"], f"{path}.torsional_inertia_per_length", "kg m",
                   nonnegative=True)
    if "damping" in spec:
        out.number(spec["damping"], f"{path}.damping", "-", nonnegative=True)
    if "elements" in spec:
        out.integer(spec["elements"], f"{path}.elements", low=1)
    if "direction" in spec:
        out.vector(spec["direction"], f"{path}.direction", "-", nonzero=True)
    return len(out) == before


def _beam_body_modes(spec: dict, n_modes: int):
    """Modal data of a ``[bodies.beam]`` table (clamped at the body origin)."""
    from ..structures._beam import Beam

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
    return _beam_modes(beam, n_modes, float(spec.get("damping", 0.0)))


@functools.lru_cache(maxsize=16)
def _beam_modes(beam, n_modes: int, damping: float):
    """``beam_modal_data`` of a (frozen, hashable) beam, kept for the next call with equal
    arguments: validating a scene and compiling it read the same modes (read-only arrays)."""
    from ..structures._beam import beam_modal_data

    return beam_modal_data(beam, n_modes, damping=damping)


@dataclass(frozen=True)
class PointMass(_Entry):
    """A particle of ``mass`` [kg] fixed at ``point`` [m] of ``body``.

    Parameters
    ----------
    name : str
        The entry's name, unique in the scene; other entries and signal names refer to it.
    body : str
        The body it is fixed to.
    mass : float
        Mass [kg].
    point : array_like of 3 floats
        Position in body axes [m].

    Examples
    --------
    >>> from linflex import PointMass
    >>> PointMass("tip", "hub", 2.0, point=(1.0, 0.0, 0.0)).mass
    2.0
    """

    name: str
    body: str
    mass: float
    point: Any = (0.0, 0.0, 0.0)

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.name_ref(self.body, f"{path}.body", context.body_names, "body")
        out.number(self.mass, f"{path}.mass", "kg", positive=True, kind="mass")
        out.vector(self.point, f"{path}.point", "m", kind="length")


@dataclass(frozen=True)
class Pendulum(_Entry):
    """A spherical pendulum (fuel slosh): a bob of ``mass`` [kg] on a massless rod of ``length``
    [m] hinged at ``point`` of ``body``, hanging along ``direction`` (body axes) at rest, with
    viscous hinge ``damping`` [N m s/rad]. Needs the ``slosh`` effect to move.

    Parameters
    ----------
    name : str
        The entry's name, unique in the scene; other entries and signal names refer to it.
    body : str
        The body the rod is hinged to.
    mass : float
        Mass of the bob [kg].
    length : float
        Rod length [m].
    point : array_like of 3 floats
        Hinge point in body axes [m].
    direction : array_like of 3 floats
        Direction the rod hangs along at rest, body axes [-] (normalized).
    damping : float
        Viscous hinge damping [N m s/rad].

    Examples
    --------
    >>> from linflex import Pendulum
    >>> fuel = Pendulum("fuel", "hub", mass=50.0, length=0.3, point=(0.0, 0.0, 0.5), damping=0.1)
    >>> fuel.length
    0.3
    """

    name: str
    body: str
    mass: float
    length: float
    point: Any = (0.0, 0.0, 0.0)
    direction: Any = (0.0, 0.0, 1.0)
    damping: float = 0.0

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.name_ref(self.body, f"{path}.body", context.body_names, "body")
        out.number(self.mass, f"{path}.mass", "kg", positive=True, kind="mass")
        out.number(self.length, f"{path}.length", "m", positive=True, kind="length")
        out.number(self.damping, f"{path}.damping", "N m s/rad", nonnegative=True)
        out.vector(self.point, f"{path}.point", "m", kind="length")
        out.vector(self.direction, f"{path}.direction", "-", nonzero=True)


@dataclass(frozen=True)
class Spring(_Entry):
    """A point ``mass`` [kg] on a spring-damper sliding along ``axis`` of ``body`` through
    ``point`` (a nutation damper), ``stiffness`` [N/m], ``damping`` [N s/m]. Needs the
    ``dampers`` effect to move.

    Parameters
    ----------
    name : str
        The entry's name, unique in the scene; other entries and signal names refer to it.
    body : str
        The body the damper is mounted in.
    mass : float
        Mass of the sliding point [kg].
    stiffness : float
        Spring stiffness [N/m].
    damping : float
        Viscous damping [N s/m].
    point : array_like of 3 floats
        Rest position of the mass in body axes [m].
    axis : array_like of 3 floats
        Sliding direction in body axes [-] (normalized).

    Examples
    --------
    >>> from linflex import Spring
    >>> Spring("damper", "hub", mass=1.0, stiffness=40.0, damping=2.0, axis=(0, 1, 0)).stiffness
    40.0
    """

    name: str
    body: str
    mass: float
    stiffness: float
    damping: float = 0.0
    point: Any = (0.0, 0.0, 0.0)
    axis: Any = (0.0, 0.0, 1.0)

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.name_ref(self.body, f"{path}.body", context.body_names, "body")
        out.number(self.mass, f"{path}.mass", "kg", positive=True, kind="mass")
        out.number(self.stiffness, f"{path}.stiffness", "N/m", nonnegative=True)
        out.number(self.damping, f"{path}.damping", "N s/m", nonnegative=True)
        out.vector(self.point, f"{path}.point", "m", kind="length")
        out.vector(self.axis, f"{path}.axis", "-", nonzero=True)
