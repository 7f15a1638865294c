"""Fuel slosh as pendulums and spring-mass dampers."""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..dynamics._kane import MassElement, rot_axis
from ..scene._registry import Effect, register_effect
from ..scene._values import unit_vector, vector3


def _perpendicular(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.eye(3)[int(np.argmin(np.abs(d)))]
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(d, e1)


class Slosh(Effect):
    """``slosh``: spherical pendulums (fuel slosh); coordinates ``<p>.theta1``, ``<p>.theta2``
    (rotations of the rod about two axes normal to its rest direction) with their rates, viscous
    hinge damping on the rates. Without it the bob is fixed at its rest position."""

    name = "slosh"
    order = 20

    def structure(self, b, scene):
        for p in scene.pendulums:
            b.detach(p.body, ("pendulum", p.name))
            q, u = b.add_coordinates([f"{p.name}.theta1", f"{p.name}.theta2"],
                                     [f"{p.name}.rate1", f"{p.name}.rate2"])
            b.set_kinematics(q, u)
            d = unit_vector(p.direction)
            e1, e2 = _perpendicular(d)
            rod = rot_axis(e1, q[0]) @ rot_axis(e2, q[1]) @ ca.DM(d * float(p.length))
            frame = b.frames[p.body]
            r = frame.r + frame.C @ (ca.DM(vector3(p.point)) + rod)
            b.add_element(MassElement(p.name, float(p.mass), None, r, frame.C, frame.w, body=p.body))
            b.pendulum_speeds[p.name] = u

    def loads(self, b, scene):
        for p in scene.pendulums:
            if p.damping:
                for k in range(2):
                    b.add_generalized_force(b.speed_index(f"{p.name}.rate{k + 1}"),
                                            -float(p.damping) * b.pendulum_speeds[p.name][k])


class Dampers(Effect):
    """``dampers``: the scene's ``springs``, point masses sliding along a body axis on a
    spring-damper (nutation dampers), coordinate
    ``<d>.position`` [m] and rate ``<d>.speed``; force ``-k s - c s'``."""

    name = "dampers"
    order = 20

    def structure(self, b, scene):
        for d in scene.springs:
            b.detach(d.body, ("spring", d.name))
            q, u = b.add_coordinates([f"{d.name}.position"], [f"{d.name}.speed"])
            b.set_kinematics(q, u)
            frame = b.frames[d.body]
            r = frame.r + frame.C @ (ca.DM(vector3(d.point)) + ca.DM(unit_vector(d.axis)) * q[0])
            b.add_element(MassElement(d.name, float(d.mass), None, r, frame.C, frame.w, body=d.body))
            b.damper_coordinates[d.name] = (q[0], u[0])

    def loads(self, b, scene):
        for d in scene.springs:
            s, v = b.damper_coordinates[d.name]
            b.add_generalized_force(b.speed_index(f"{d.name}.speed"), -float(d.stiffness) * s - float(d.damping) * v)
            b.add_potential(0.5 * float(d.stiffness) * s**2)


for _effect in (Slosh(), Dampers(),):
    register_effect(_effect)
