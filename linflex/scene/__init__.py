"""Scenes: the entries a spacecraft is described with, their validation, the effect vocabulary, and TOML files."""

from ._contacts import Constraint
from ._devices import Actuator, Controller, Disturbance, InputProfile, Sensor, Surface, Wheel
from ._entries import Body, Pendulum, PointMass, Spring
from ._joints import Joint, LoopJoint
from ._registry import Effect, register_effect, registered_effects
from ._requirements import REQUIREMENTS, Requirements
from ._scene import Scene, load_scene
from ._segments import rigid_segment_beam, segment_spring_constants
from ._variable import Boom, Tank, ThermalLoad
from ._world import Environment, Frame, Limits, Orbit

__all__ = [
    "Actuator", "Body", "Constraint", "Controller", "Disturbance", "Environment", "Frame", "InputProfile", "Joint", "Limits", "LoopJoint", "Orbit",
    "Pendulum", "PointMass", "REQUIREMENTS", "Requirements", "Sensor", "Spring", "Surface", "Wheel", "Effect", "register_effect",
    "registered_effects", "Scene", "load_scene", "rigid_segment_beam", "segment_spring_constants",
    "Boom", "Tank", "ThermalLoad",
]
