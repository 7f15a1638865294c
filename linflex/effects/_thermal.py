"""Thermal deformation of flexible bodies: bending moments or modal loads along a time profile."""

from __future__ import annotations

import casadi as ca

from ..scene._registry import Effect, register_effect
from ..scene._values import profile_function, vector3

__all__ = ["thermal_scale"]


def thermal_scale(load, t):
    """The profile ``scale(t)`` of a thermal load (a number or a profile table) at ``t`` [s]."""
    scale = load.scale
    if isinstance(scale, dict) or callable(scale):
        return profile_function(scale)(t)
    return float(scale) + 0 * t


class Thermal(Effect):
    """``thermal``: the scene's thermal loads (``thermal``) on flexible bodies, a bending moment
    as the pair ``+moment`` at ``node`` and ``-moment`` at ``opposite_node`` (or at the body
    origin), or ``modal_load`` on the modes, times the time profile ``scale``: thermal snap
    (a step or transition at a terminator crossing) and slow thermal bending."""

    name = "thermal"

    def loads(self, b, scene):
        for load in scene.thermal:
            fe = b._flexible_element(load.body)
            scale = thermal_scale(load, b.t)
            if load.modal_load is not None:
                values = [float(v) for v in load.modal_load]
                for k, value in enumerate(values):
                    b.add_generalized_force(b.speed_index(f"{load.body}.eta{k}_rate"), value * scale)
                continue
            moment = ca.DM(vector3(load.moment)) * scale
            w = fe.frame.w
            _, _, Psi = fe.data.node(load.node)
            b.add_torque_at(w + ca.DM(Psi) @ fe.qd, moment)
            if load.opposite_node is None:
                b.add_torque_at(w, -moment)  # the clamped origin turns with the body frame
            else:
                _, _, Psi = fe.data.node(load.opposite_node)
                b.add_torque_at(w + ca.DM(Psi) @ fe.qd, -moment)


for _effect in (Thermal(),):
    register_effect(_effect)
