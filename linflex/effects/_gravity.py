"""Gravity: uniform, central (orbital) and the gravity gradient."""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..dynamics._kane import KaneBuilder, cross
from ..scene._registry import Effect, register_effect
from ..scene._values import vector3


def _orbit_gravity(b: KaneBuilder, r):
    """Point-mass gravity at the origin + r minus the origin's (the frame is in free fall)."""
    R = b.R_O + r
    return -b.mu * R / ca.norm_2(R) ** 3 + b.mu * b.R_O / ca.norm_2(b.R_O) ** 3


def _flexible_points(b: KaneBuilder):
    """The mass points of the flexible bodies, which are not mass elements of the builder.

    Yields ``(mass [kg], r, inertia, C, w)``: the point's position with its modal translation
    ``Phi q`` (scene axes; the modal kinematics are first order in ``q``), its inertia (body
    axes, 3x3, or None), the body axes ``C`` (to scene axes; the inertia's undeformed
    orientation) and the point's angular velocity ``w + Psi q'`` (body axes). Points without
    mass or inertia are left out.
    """
    for fe in b.flexible:
        data, frame = fe.data, fe.frame
        for m, x, inertia, Phi, Psi in zip(data.masses, data.positions, data.inertias, data.translations,
                                           data.rotations):
            if m or np.any(inertia):
                r = frame.r + frame.C @ (ca.DM(x) + ca.DM(Phi) @ fe.q)
                yield (float(m), r, ca.DM(inertia) if np.any(inertia) else None, frame.C,
                       frame.w + ca.DM(Psi) @ fe.qd)


def _flexible_centres(b: KaneBuilder):
    """``(mass [kg], r)`` of each flexible body's material: its mass and mass centre (scene axes,
    deformed to first order, ``sum m_i (x_i + Phi_i q) / m``), where a uniform field acts."""
    for fe in b.flexible:
        data, frame = fe.data, fe.frame
        mass = float(np.sum(data.masses))
        if mass > 0:
            first = data.masses @ data.positions  # sum m_i x_i [kg m]
            modal = np.einsum("i,ijk->jk", data.masses, data.translations)  # sum m_i Phi_i
            yield mass, frame.r + frame.C @ ((ca.DM(first) + ca.DM(modal) @ fe.q) / mass)


# -- gravity -----------------------------------------------------------------------------------


class UniformGravity(Effect):
    """``gravity``: uniform field ``environment.gravity`` (inertial axes) on every mass, the
    flexible bodies' material included (at its deformed mass centre)."""

    name = "gravity"

    def loads(self, b, scene):
        g_F = b.C_NF.T @ ca.DM(vector3(scene.environment.gravity))
        masses = [(el.mass, el.r) for el in b.elements if el.has_mass] + list(_flexible_centres(b))
        for mass, r in masses:
            b.add_force_at(r, mass * g_F)
            b.add_potential(-mass * ca.dot(g_F, r))


class CentralGravity(Effect):
    """``central_gravity``: point-mass Earth on every mass, the flexible bodies' mass points
    included (exact, relative to the free-falling frame origin on the reference orbit)."""

    name = "central_gravity"
    needs_orbit = True

    def loads(self, b, scene):
        masses = [(el.mass, el.r) for el in b.elements if el.has_mass]
        masses += [(m, r) for m, r, _, _, _ in _flexible_points(b) if m]
        for mass, r in masses:
            b.add_force_at(r, mass * _orbit_gravity(b, r))


class GravityGradient(Effect):
    """``gravity_gradient``: first-order gradient torque ``3 mu / R^5 R x (I R)`` on every element
    with inertia (instantaneous inertia, body axes), and, without ``central_gravity``, the
    first-order tidal force ``m mu / r0^3 (3 (e.r) e - r)`` on every mass (Hill's equations);
    the flexible bodies' mass points (deformed positions) and their inertias included."""

    name = "gravity_gradient"
    needs_orbit = True

    def loads(self, b, scene):
        tidal = "central_gravity" not in scene.effects
        r0 = ca.norm_2(b.R_O)
        e = b.R_O / r0
        # Rigid elements (their axes), then the flexible bodies' mass points (body axes).
        parts = [(el.mass if el.has_mass else None, el.r, el.I if el.has_inertia else None, el.C, el.w)
                 for el in b.elements]
        parts += [(m or None, r, I, C, w) for m, r, I, C, w in _flexible_points(b)]
        for mass, r, I, C, w in parts:
            if I is not None:
                R_B = C.T @ (b.R_O + r)
                b.add_torque_at(w, 3 * b.mu / ca.norm_2(R_B) ** 5 * cross(R_B, I @ R_B))
            if tidal and mass is not None:
                b.add_force_at(r, mass * b.mu / r0**3 * (3 * ca.dot(e, r) * e - r))


# -- surfaces ----------------------------------------------------------------------------------


for _effect in (UniformGravity(), CentralGravity(), GravityGradient(),):
    register_effect(_effect)
