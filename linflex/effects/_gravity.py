"""Gravity: uniform, central (orbital) and the gravity gradient."""

from __future__ import annotations

import casadi as ca

from ..dynamics._kane import KaneBuilder, cross
from ..scene._registry import Effect, register_effect
from ..scene._values import vector3


def _orbit_gravity(b: KaneBuilder, r):
    """Point-mass gravity at the origin + r minus the origin's (the frame is in free fall)."""
    R = b.R_O + r
    return -b.mu * R / ca.norm_2(R) ** 3 + b.mu * b.R_O / ca.norm_2(b.R_O) ** 3


# -- gravity -----------------------------------------------------------------------------------


class UniformGravity(Effect):
    """``gravity``: uniform field ``environment.gravity`` (inertial axes) on every mass."""

    name = "gravity"

    def loads(self, b, scene):
        g_F = b.C_NF.T @ ca.DM(vector3(scene.environment.gravity))
        for el in b.elements:
            if el.has_mass:
                b.add_force_at(el.r, el.mass * g_F)
                b.add_potential(-el.mass * ca.dot(g_F, el.r))


class CentralGravity(Effect):
    """``central_gravity``: point-mass Earth on every mass (exact, relative to the free-falling
    frame origin on the reference orbit)."""

    name = "central_gravity"
    needs_orbit = True

    def loads(self, b, scene):
        for el in b.elements:
            if el.has_mass:
                b.add_force_at(el.r, el.mass * _orbit_gravity(b, el.r))


class GravityGradient(Effect):
    """``gravity_gradient``: first-order gradient torque ``3 mu / R^5 R x (I R)`` on every element
    with inertia (instantaneous inertia, body axes), and, without ``central_gravity``, the
    first-order tidal force ``m mu / r0^3 (3 (e.r) e - r)`` on every mass (Hill's equations)."""

    name = "gravity_gradient"
    needs_orbit = True

    def loads(self, b, scene):
        tidal = "central_gravity" not in scene.effects
        r0 = ca.norm_2(b.R_O)
        e = b.R_O / r0
        for el in b.elements:
            if el.has_inertia:
                R_B = el.C.T @ (b.R_O + el.r)
                I = el.I
                b.add_element_torque(el, 3 * b.mu / ca.norm_2(R_B) ** 5 * cross(R_B, I @ R_B))
            if tidal and el.has_mass:
                F = el.mass * b.mu / r0**3 * (3 * ca.dot(e, el.r) * e - el.r)
                b.add_force_at(el.r, F)


# -- surfaces ----------------------------------------------------------------------------------


for _effect in (UniformGravity(), CentralGravity(), GravityGradient(),):
    register_effect(_effect)
