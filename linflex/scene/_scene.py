"""Scenes: frozen descriptions of a multibody spacecraft, validated at once, loaded from TOML.

A :class:`Scene` lists bodies, joints, point masses, slosh pendulums, springs (spring-mass dampers),
momentum wheels, surfaces, sensors, actuators and controllers, the frame attitude is measured in,
the orbit, the environment and the effects to include. Constructors never raise on bad values:
they keep what they are given (lists become tuples) so that :meth:`Scene.validate` can report
every problem in one :class:`~linflex.ModelError`, each with the path of the offending entry.
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from ..system._errors import ModelError
from ._check import ENTRY_CLASSES
from ._contacts import Constraint
from ._devices import Actuator, Controller, Disturbance, InputProfile, Sensor, Surface, Wheel
from ._entries import Body, Pendulum, PointMass, Spring
from ._joints import Joint, LoopJoint
from ._problems import hint
from ._requirements import Requirements
from ._variable import Boom, Tank, ThermalLoad
from ._world import Environment, Frame, Limits, Orbit

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

#: Each list of a scene and the class of its entries (one table, in linflex/scene/_check.py).
_LISTS = ENTRY_CLASSES
_TABLES = {"frame": Frame, "orbit": Orbit, "environment": Environment, "limits": Limits,
           "requirements": Requirements}

__all__ = [
    "Actuator",
    "Body",
    "Constraint",
    "Controller",
    "Disturbance",
    "Environment",
    "Frame",
    "InputProfile",
    "Joint",
    "Limits",
    "LoopJoint",
    "Orbit",
    "Pendulum",
    "PointMass",
    "Requirements",
    "Scene",
    "Sensor",
    "Spring",
    "Surface",
    "Wheel",
    "load_scene",
]

@dataclass(frozen=True)
class Scene:
    """A multibody spacecraft scene; see the module docstring and ``examples/*.toml``.

    Parameters
    ----------
    name : str
        The scene's name (reports, tables and file names use it).
    effects : sequence of str
        Registered effect names (:func:`linflex.registered_effects`) to include.
    bodies, joints, point_masses, pendulums, springs, wheels, surfaces, sensors, actuators, disturbances, controllers, loop_joints, constraints
        Sequences of the entry dataclasses (or mappings with the same keys); ``loop_joints``
        close kinematic loops of the joint tree (:class:`LoopJoint`); ``constraints`` are
        non-holonomic contacts with the ground (:class:`Constraint`: rolling wheels, knife edges).
    frame : Frame
        The frame attitude is measured in and the joint tree hangs from (``"ground"``):
        inertial (the default), LVLH on ``orbit``, or spinning at a constant rate [rad/s].
    orbit : Orbit, optional
        The circular reference orbit the scene's origin follows (radius [m], ``mu``
        [m^3/s^2]); required by the ``lvlh`` frame and the effects ``central_gravity``,
        ``gravity_gradient`` and ``aerodynamic_drag``. None (the default): no orbit.
    environment : Environment
        Uniform gravity [m/s^2], Sun direction [-], solar pressure [N/m^2] and atmosphere
        density [kg/m^3] for the effects that use them; default :class:`Environment`'s values.
    limits : Limits
        The physically meaningful ranges of masses [kg], inertias [kg m^2], lengths [m] and
        rates [rad/s] outside which validation refuses a number; default :class:`Limits`'s.
    requirements : Requirements
        Stability requirements the report checks (margins in dB, deg, s; sensitivity peaks in
        dB), global or per loop; default none.
    inputs : sequence of InputProfile
        Time profiles of actuator commands and disturbances (:class:`InputProfile`) that
        :func:`linflex.simulate` applies when it is given no inputs; default none.
    booms, tanks, thermal
        Deploying booms (:class:`Boom`, effect ``deployment``), propellant tanks feeding
        thrusters (:class:`Tank`, effect ``mass_flow``) and thermal loads on flexible bodies
        (:class:`ThermalLoad`, effect ``thermal``).

    Examples
    --------
    >>> from linflex import Scene, Body, Joint
    >>> s = Scene("rod", bodies=[Body("rod", 1.0, [0.1, 0.1, 0.01])],
    ...           joints=[Joint("hinge", "revolute", "rod", axis=[0, 1, 0])])
    >>> s.validate() is s
    True
    """

    name: str = "scene"
    effects: tuple[str, ...] = ()
    bodies: tuple[Body, ...] = ()
    joints: tuple[Joint, ...] = ()
    point_masses: tuple[PointMass, ...] = ()
    pendulums: tuple[Pendulum, ...] = ()
    springs: tuple[Spring, ...] = ()
    wheels: tuple[Wheel, ...] = ()
    surfaces: tuple[Surface, ...] = ()
    sensors: tuple[Sensor, ...] = ()
    actuators: tuple[Actuator, ...] = ()
    disturbances: tuple[Disturbance, ...] = ()
    controllers: tuple[Controller, ...] = ()
    frame: Frame = field(default_factory=Frame)
    orbit: Orbit | None = None
    environment: Environment = field(default_factory=Environment)
    loop_joints: tuple[LoopJoint, ...] = ()
    constraints: tuple[Constraint, ...] = ()
    limits: Limits = field(default_factory=Limits)
    requirements: Requirements = field(default_factory=Requirements)
    inputs: tuple[InputProfile, ...] = ()
    booms: tuple[Boom, ...] = ()
    tanks: tuple[Tank, ...] = ()
    thermal: tuple[ThermalLoad, ...] = ()

    def __post_init__(self) -> None:
        if isinstance(self.effects, str):
            object.__setattr__(self, "effects", (self.effects,))
        elif isinstance(self.effects, (list, tuple)):
            object.__setattr__(self, "effects", tuple(self.effects))
        # Entries given as mappings (same keys as TOML) become dataclasses; unknown or missing
        # keys are reported together with every other problem of the scene, with their paths.
        problems: list[str] = []
        covered: set[str] = set()
        for key, cls in _LISTS.items():
            items = getattr(self, key)
            if isinstance(items, (list, tuple)):
                object.__setattr__(self, key, tuple(
                    cls.from_dict(item, f"{key}[{i}]", problems, covered) if isinstance(item, Mapping) else item
                    for i, item in enumerate(items)))
        for key, cls in _TABLES.items():
            value = getattr(self, key)
            if isinstance(value, Mapping):
                object.__setattr__(self, key, cls.from_dict(value, key, problems, covered) or cls())
        if problems:
            _raise_all(f"scene {self.name!r}", problems, covered, self)

    def replace(self, **changes: Any) -> Scene:
        """A copy with some fields replaced (``dataclasses.replace``).

        Parameters
        ----------
        **changes
            New values by field name (``bodies=...``, ``effects=...``; mappings are accepted
            for the entries as in the constructor).

        Returns
        -------
        Scene
            The new scene (not validated; call :meth:`validate`).

        Raises
        ------
        TypeError
            For a name that is not a field of :class:`Scene`.
        ModelError
            For entries given as mappings with unknown or missing keys.
        """
        return dataclasses.replace(self, **changes)

    # -- validation ----------------------------------------------------------------------------

    def problems(self) -> list[str]:
        """Every problem of this scene as ``"path: message (hint)"`` strings; empty when valid.

        Returns
        -------
        list of str
            One message per problem, prefixed by the path of the entry (``"joints[1].axis"``).
        """
        from ._check import scene_problems

        return scene_problems(self)

    def validate(self) -> Scene:
        """Return the scene itself when valid.

        Returns
        -------
        Scene
            ``self``, so that ``Scene(...).validate()`` chains.

        Raises
        ------
        ModelError
            Listing every problem found, each with the path of the entry and a hint.
        """
        problems = self.problems()
        if problems:
            raise ModelError(f"scene {self.name!r} has {len(problems)} problem(s):\n  - " + "\n  - ".join(problems))
        return self

    # -- TOML ----------------------------------------------------------------------------------

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, source: str = "scene") -> Scene:
        """Build a scene from a mapping with the TOML vocabulary (unknown keys are problems).

        Parameters
        ----------
        data : mapping
            The scene as parsed TOML: top-level keys ``name``, ``effects``, tables ``frame``,
            ``orbit``, ``environment``, ``limits`` and arrays of tables ``bodies``, ``joints``, ...
            (SI units).
        source : str
            Where ``data`` came from (a file name), for the error messages.

        Returns
        -------
        Scene
            The scene (not validated: :func:`load_scene` validates).

        Raises
        ------
        ModelError
            When a key is unknown or missing or an entry is not a table: listing those with
            every other problem of the scene (one pass), prefixed by ``source``.
        """
        kwargs, problems, covered = _parse(data)
        scene = cls(**kwargs)
        if problems:
            _raise_all(source, problems, covered, scene)
        return scene

    def to_dict(self) -> dict[str, Any]:
        """The scene as plain data with the TOML vocabulary (defaults omitted).

        Returns
        -------
        dict
            Keys as in the TOML files (SI units); :meth:`from_dict` reads it back to an equal
            scene.
        """
        out: dict[str, Any] = {"name": self.name, "effects": list(self.effects)}
        if self.frame != Frame():
            out["frame"] = self.frame.to_dict()
        if self.orbit is not None:
            out["orbit"] = self.orbit.to_dict()
        if self.environment != Environment():
            out["environment"] = self.environment.to_dict()
        if self.limits != Limits():
            out["limits"] = self.limits.to_dict()
        if self.requirements != Requirements():
            out["requirements"] = self.requirements.to_dict()
        for key in _LISTS:
            items = getattr(self, key)
            if items:
                out[key] = [item.to_dict() for item in items]
        return out

    def to_toml(self) -> str:
        """The scene as TOML text that :func:`load_scene` reads back to an equal scene.

        Returns
        -------
        str
            The TOML document (SI units; defaults omitted).

        Raises
        ------
        ModelError
            When an entry holds a value TOML cannot express (a callable time profile).
        """
        from ._toml import dumps

        return dumps(self.to_dict())

    def save(self, path: str | Path) -> None:
        """Write :meth:`to_toml` to ``path``.

        Parameters
        ----------
        path : str or Path
            The file to write (UTF-8; replaced if it exists).

        Raises
        ------
        ModelError
            When an entry holds a value TOML cannot express (a callable time profile).
        OSError
            When the file cannot be written.
        """
        Path(path).write_text(self.to_toml(), encoding="utf-8")


def load_scene(path: str | Path) -> Scene:
    """Load and validate a scene from a TOML file.

    Parameters
    ----------
    path : str or Path
        A TOML file with the scene vocabulary (see ``examples/*.toml``).

    Returns
    -------
    Scene
        The validated scene.

    Raises
    ------
    ModelError
        For malformed TOML (with the file name and the line), unknown keys, and every problem
        :meth:`Scene.validate` finds.
    FileNotFoundError
        When the file does not exist.

    Examples
    --------
    >>> from linflex import load_scene
    >>> scene = load_scene("examples/double_pendulum.toml")
    >>> scene.name, [b.name for b in scene.bodies]
    ('double_pendulum', ['upper', 'lower'])
    """
    path = Path(path)
    raw = path.read_bytes()
    if raw.startswith(b"\xef\xbb\xbf"):
        raise ModelError(f"{path}: the file starts with a UTF-8 byte-order mark (BOM), which TOML does not allow; "
                         "save it as UTF-8 without BOM")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise ModelError(f"{path}: not UTF-8 text (byte {err.start}: {raw[err.start:err.start + 1]!r}); "
                         "TOML files are UTF-8") from err
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ModelError(f"{path}: malformed TOML: {err}") from err
    kwargs, problems, covered = _parse(data)
    # Modal-data files named in the scene are relative to the scene file.
    if isinstance(kwargs.get("bodies"), tuple):
        kwargs["bodies"] = tuple(
            dataclasses.replace(b, modal_data=str(path.parent / b.modal_data))
            if isinstance(b.modal_data, str) and not Path(b.modal_data).is_absolute() else b
            for b in kwargs["bodies"])
    scene = Scene(**kwargs)
    _raise_all(str(path), problems, covered, scene, name=True)
    return scene


def _parse(data: Mapping[str, Any]) -> tuple[dict[str, Any], list[str], set[str]]:
    """Scene keyword arguments from TOML data, with the problems of its keys (checked on, not raised).

    Returns the arguments, the problems (unknown keys, missing keys, entries that are not tables),
    and the paths of missing keys (their later problems repeat them and are dropped).
    """
    problems: list[str] = []
    covered: set[str] = set()
    kwargs: dict[str, Any] = {}
    if not isinstance(data, Mapping):
        return kwargs, [f"expected a table of scene keys, got {type(data).__name__}"], covered
    top = [f.name for f in fields(Scene)]
    if "analysis" in data or "grid" in data or "sample" in data:
        # a sweep spec given where the scene goes (the two files of linflex sweep swapped)
        problems.append("this looks like a sweep spec (analysis, [grid], [sample]), not a scene: a spec goes "
                        "second to linflex sweep (SCENE SPEC), or after --sweep to linflex report")
    for key, value in data.items():
        if key not in top:
            problems.append(f"{key}: unknown key{hint(key, sorted(top))}")
        elif key in _LISTS:
            if not isinstance(value, list):
                problems.append(f"{key}: expected an array of tables ([[{key}]]), got {type(value).__name__} {value!r}")
                continue
            items = [_LISTS[key].from_dict(item, f"{key}[{i}]", problems, covered) for i, item in enumerate(value)]
            kwargs[key] = tuple(item for item in items if item is not None)
        elif key in _TABLES:
            entry = _TABLES[key].from_dict(value, key, problems, covered)
            if entry is not None:
                kwargs[key] = entry
        else:
            kwargs[key] = value
    return kwargs, problems, covered


def _raise_all(source: str, problems: list[str], covered: set[str], scene: Scene, *, name: bool = False) -> None:
    """Raise one ModelError with the key problems and every problem of ``scene`` (none: return)."""
    found = [p for p in problems]
    found += [p for p in scene.problems() if p.split(": ", 1)[0] not in covered]
    if found:
        what = f"{source}: scene {scene.name!r} has" if name else f"{source}:"
        raise ModelError(f"{what} {len(found)} problem(s):\n  - " + "\n  - ".join(found))
