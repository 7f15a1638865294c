"""The built-in effects, one module per kind (gravity, environment, wheels, slosh, joints, actuation, structure,
deployment, mass flow, thermal), and scene controllers as linear systems.

Importing this package registers every built-in effect in the scene's effect vocabulary
(:func:`linflex.registered_effects`).
"""

from . import (
    _actuation,
    _deployment,
    _environment,
    _gravity,
    _joints,
    _mass_flow,
    _slosh,
    _structure,
    _thermal,
    _wheels,
)
from ._controllers import controller_chain, controller_reference, controller_system

__all__ = ["controller_chain", "controller_reference", "controller_system"]
