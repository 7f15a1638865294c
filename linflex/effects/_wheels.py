"""Momentum wheels' gyroscopic coupling."""

from __future__ import annotations

import casadi as ca

from ..dynamics._kane import MassElement
from ..scene._registry import Effect, register_effect
from ..scene._values import unit_vector, wheel_inertia


class WheelGyroscopics(Effect):
    """``wheel_gyroscopics``: rotors spinning relative to their body (to the node axes for a wheel
    at a node of a flexible body); constant-speed wheels add their angular momentum, torque-mode
    wheels a speed state ``<wheel>.speed`` (relative rate [rad/s]). Without it a wheel is a
    locked rigid part of its body (of its node)."""

    name = "wheel_gyroscopics"
    order = 10

    def check(self, scene):
        # A torque-driven wheel's speed is a generalized speed whose only inertia is the spin
        # inertia: at zero the mass matrix has a zero row (a singular solve in every evaluation).
        return [f"wheels[{i}].spin_inertia: a torque-driven wheel needs a positive spin inertia [kg m^2] "
                f"(its speed state has no other inertia), got {w.spin_inertia!r}; give the rotor's inertia "
                "about its axis, or use mode = \"constant\""
                for i, w in enumerate(scene.wheels) if w.mode == "torque" and isinstance(w.spin_inertia, (int, float))
                and w.spin_inertia == 0]

    def structure(self, b, scene):
        for w in scene.wheels:
            a = unit_vector(w.axis)
            if w.mode == "torque":
                _, speed = b.add_coordinates([], [f"{w.name}.speed"])
                omega = speed[0]
            else:
                omega = ca.SX(float(w.speed))
            b.wheel_speeds[w.name] = omega
            if w.node is not None:
                # At a node of a flexible body: the rotor spins relative to the node axes, which
                # turn with the structure (the gyroscopic torque then couples into the modes).
                element = b.node_wheels[w.name]
                element.w_axes = element.w
                element.w = element.w + ca.DM(a) * omega
                continue
            b.detach(w.body, ("wheel_rotor", w.name))
            frame = b.frames[w.body]
            b.add_element(MassElement(f"{w.name}.rotor", 0.0, wheel_inertia(w), frame.r, frame.C,
                                      frame.w + ca.DM(a) * omega, body=w.body, w_axes=frame.w))


for _effect in (WheelGyroscopics(),):
    register_effect(_effect)
