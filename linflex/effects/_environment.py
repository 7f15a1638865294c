"""The orbital environment's surface forces: solar radiation pressure and aerodynamic drag."""

from __future__ import annotations

import casadi as ca

from ..scene._registry import Effect, register_effect
from ..scene._values import R_EARTH, unit_vector, vector3


class SolarPressure(Effect):
    """``solar_pressure``: flat plates, ``F = -P A max(c, 0) [(1 - rho) s + 2 rho c n]`` with
    ``c = n . s``, ``s`` the Sun direction (fixed in inertial axes), ``P`` the pressure, ``rho``
    the specular reflectivity (Wertz, Spacecraft Attitude Determination and Control, 17.2)."""

    name = "solar_pressure"

    def loads(self, b, scene):
        env = scene.environment
        s_F = b.C_NF.T @ ca.DM(unit_vector(env.sun_direction))
        for surf in scene.surfaces:
            frame = b.frames[surf.body]
            n_F = frame.C @ ca.DM(unit_vector(surf.normal))
            c = ca.dot(n_F, s_F)
            lit = ca.fmax(c, 0)
            rho = float(surf.reflectivity)
            F = -float(env.solar_pressure) * float(surf.area) * lit * ((1 - rho) * s_F + 2 * rho * c * n_F)
            b.add_force(surf.body, vector3(surf.point), F)


class AerodynamicDrag(Effect):
    """``aerodynamic_drag``: flat plates in an exponential atmosphere,
    ``F = -1/2 rho Cd A |v| max(n . v/|v|, 0) v`` with ``v`` the inertial velocity of the plate's
    centre (orbital plus local; the atmosphere does not rotate)."""

    name = "aerodynamic_drag"
    needs_orbit = True

    def loads(self, b, scene):
        env = scene.environment
        for surf in scene.surfaces:
            frame = b.frames[surf.body]
            r, rdot, _, _ = b.point_kinematics(surf.body, vector3(surf.point))
            v = b.inertial_velocity(r, rdot)
            speed = ca.norm_2(v)
            altitude = ca.norm_2(b.R_O + r) - R_EARTH
            rho = float(env.density) * ca.exp(-(altitude - float(env.reference_altitude)) / float(env.scale_height))
            n_F = frame.C @ ca.DM(unit_vector(surf.normal))
            proj = ca.fmax(ca.dot(n_F, v) / speed, 0)
            F = -0.5 * rho * float(surf.drag_coefficient) * float(surf.area) * speed * proj * v
            b.add_force(surf.body, vector3(surf.point), F)


# -- internal degrees of freedom -----------------------------------------------------------------


for _effect in (SolarPressure(), AerodynamicDrag(),):
    register_effect(_effect)
