"""The effects registry: the vocabulary of effect names a scene may list.

An effect is a plug-in that contributes terms to the Kane builder (:class:`~linflex.dynamics._kane.KaneBuilder`)
when a scene names it in ``effects``; an effect a scene does not name adds nothing to the compiled
graph. An effect is an object with a ``name`` and up to four methods, each optional:

``check(scene) -> list[str]``
    Extra validation problems (``"path: message"``), reported by :meth:`Scene.validate`.
``structure(builder, scene)``
    Before the kinematics are closed: add coordinates and speeds (``add_coordinates``,
    ``set_kinematics``), mass elements (``add_element``), inputs (``add_input``), or ``detach`` a
    part that is otherwise rigidly attached to its body so that the effect can make it move.
``signals(builder, scene)``
    With the kinematics known: add states (``add_state``/``set_rate``), outputs, and terms to
    the actuator commands in ``builder.commands`` (sensor signals are in ``builder.sensor_signals``).
``loads(builder, scene)``
    Forces and torques (``add_force``, ``add_force_at``, ``add_torque``,
    ``add_element_torque``, ``add_generalized_force``) and potential energy (``add_potential``).

Register a new one with :func:`register_effect`; see ``Effect`` for a base class.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import TYPE_CHECKING

from ..system._errors import ModelError

if TYPE_CHECKING:
    from ..dynamics._kane import KaneBuilder

__all__ = ["Effect", "register_effect", "registered_effects"]


class Effect:
    """Base class of effects: override the stages the effect needs.

    Attributes
    ----------
    name : str
        The name scenes use in ``effects``.
    needs_orbit : bool
        Whether the scene must have an ``[orbit]`` table.
    order : int
        Effects run in increasing ``order`` within each stage (ties: scene order).

    Examples
    --------
    A constant body torque, registered under a new name:

    >>> import numpy as np
    >>> from linflex import Effect, register_effect
    >>> class Bias(Effect):
    ...     name = "bias_torque"
    ...     def loads(self, b, scene):
    ...         b.add_torque(scene.bodies[0].name, np.array([0.0, 0.0, 1e-3]))
    >>> register_effect(Bias(), replace=True)
    """

    name: str = ""
    needs_orbit: bool = False
    order: int = 50

    def check(self, scene) -> list[str]:
        """Problems of ``scene`` that this effect cannot accept (run by scene validation).

        Parameters
        ----------
        scene : Scene
            The scene being validated (SI units throughout).

        Returns
        -------
        list of str
            One message per problem, each starting with the path of the entry
            (``"bodies[2].inertia: ..."``); empty when the scene is fine. The base class
            returns ``[]``.
        """
        return []

    def structure(self, b: KaneBuilder, scene) -> None:
        """Stage 1: add coordinates, states, inputs or mass elements, before the kinematics close.

        Parameters
        ----------
        b : KaneBuilder
            The equations under construction (``b.add_coordinates``, ``b.add_state``,
            ``b.add_input``, ``b.add_element``).
        scene : Scene
            The scene being compiled.
        """

    def signals(self, b: KaneBuilder, scene) -> None:
        """Stage 2: add outputs or replace sensor signals, once the kinematics are known.

        Parameters
        ----------
        b : KaneBuilder
            The equations under construction (``b.add_output``, ``b.sensor_signals``); outputs
            in SI units ([m], [rad], [rad/s], [N], [N m], ...).
        scene : Scene
            The scene being compiled.
        """

    def loads(self, b: KaneBuilder, scene) -> None:
        """Stage 3: add forces [N], torques [N m], generalized forces or a potential [J].

        Parameters
        ----------
        b : KaneBuilder
            The equations under construction (``b.add_force``, ``b.add_torque``,
            ``b.add_generalized_force``, ``b.add_potential``); ``b.origin`` is this effect's
            name, so that the linearization's stiffness split credits it.
        scene : Scene
            The scene being compiled.
        """

    def __repr__(self) -> str:
        return f"<effect {self.name!r}>"


_REGISTRY: dict[str, Effect] = {}


def register_effect(effect: Effect, *, replace: bool = False) -> None:
    """Register ``effect`` under ``effect.name``.

    Parameters
    ----------
    effect : Effect
        The effect; its ``name`` is the key scenes list in ``effects``.
    replace : bool, optional
        Allow replacing an effect already registered under that name.

    Returns
    -------
    None

    Raises
    ------
    ModelError
        When the name is empty or already registered (and ``replace`` is false), or the object
        has none of the stage methods.

    Examples
    --------
    >>> from linflex import Effect, register_effect, registered_effects
    >>> class NoLoad(Effect):
    ...     name = "no_load"
    ...     def loads(self, b, scene):
    ...         pass
    >>> register_effect(NoLoad(), replace=True)
    >>> "no_load" in registered_effects()
    True
    """
    name = getattr(effect, "name", "")
    if not isinstance(name, str) or not name.isidentifier():
        raise ModelError(f"effect.name must be an identifier string, got {name!r}")
    if name in _REGISTRY and not replace:
        raise ModelError(f"effect {name!r} is already registered; pass replace=True to override it")
    if not any(callable(getattr(effect, m, None)) for m in ("structure", "signals", "loads")):
        raise ModelError(f"effect {name!r} has none of the methods structure, signals, loads")
    _REGISTRY[name] = effect


def registered_effects() -> Mapping[str, Effect]:
    """A read-only view of the registered effects by name.

    Returns
    -------
    Mapping of str to Effect
        The registry, read-only (register with :func:`register_effect`).

    Examples
    --------
    >>> from linflex import registered_effects
    >>> "gravity" in registered_effects(), "joint_springs" in registered_effects()
    (True, True)
    """
    return MappingProxyType(_REGISTRY)
