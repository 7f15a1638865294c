"""Mass flow: propellant tanks that feed thrusters, with the momentum the exhaust carries away.

A tank's propellant is a point mass ``m_p`` at the tank (output ``<tank>.propellant``; the state
``<tank>.propellant_used`` [kg] is the mass spent, zero at the start). Each fed
thruster of thrust ``F`` (its command [N], along its axis ``d``) expels ``|F| / c`` kg/s with the
exhaust velocity ``c``: the mass leaves at the thruster's point ``r_n`` with the velocity
``v_n - sign(F) c d``. Kane's generalized inertia forces of the vehicle (propellant included,
``-m V^T a`` with the current masses) then balance the thrust and the transport of the
propellant from the tank to the thruster::

    sum m a = F d  -  |m'| (v_n - v_t)          (v_t: the tank's velocity)

(the second term, applied as forces ``-|m'| v_n`` at the thruster and ``+|m'| v_t`` at the
tank, holds the jet damping). The vehicle's momentum and angular momentum then change exactly
by what the exhaust carries away: outputs ``<tank>.exhaust_momentum_rate`` ``|m'| v_n - F d``
and ``<tank>.exhaust_angular_momentum_rate`` ``r_n x (|m'| v_n - F d)`` (inertial axes, about
the scene origin), whose integrals added to the vehicle's stay constant. In free space the
vehicle's speed change is Tsiolkovsky's ``c ln(m0 / m1)``.
"""

from __future__ import annotations

import casadi as ca

from ..dynamics._kane import MassElement, cross
from ..scene._registry import Effect, register_effect
from ..scene._values import unit_vector, vector3


class MassFlow(Effect):
    """``mass_flow``: propellant tanks (``tanks``) whose mass (output ``<tank>.propellant`` [kg];
    state ``<tank>.propellant_used``) the thrusters they feed consume at
    ``|thrust| / exhaust_velocity``, with the momentum the
    exhaust carries (jet damping included); outputs ``<tank>.exhaust_momentum_rate`` [N] and
    ``<tank>.exhaust_angular_momentum_rate`` [N m]. Thrust needs the ``thrusters`` effect."""

    name = "mass_flow"
    order = 30  # after thrusters (10), whose commands it reads

    def check(self, scene):
        return [f"tanks[{i}]: a propellant tank needs the 'thrusters' effect (add it to effects)"
                for i, _ in enumerate(scene.tanks) if "thrusters" not in scene.effects]

    def structure(self, b, scene):
        for tank in scene.tanks:
            used = b.add_state([f"{tank.name}.propellant_used"])
            frame = b.frames[tank.body]
            b.add_element(MassElement(f"{tank.name}.propellant", float(tank.mass) - used[0], None,
                                      frame.r + frame.C @ ca.DM(vector3(tank.point)), frame.C, frame.w,
                                      body=tank.body))

    def loads(self, b, scene):
        wF = ca.DM(b.w_F)
        for tank in scene.tanks:
            element = next(el for el in b.elements if el.name == f"{tank.name}.propellant")
            mass = element.mass
            c = float(tank.exhaust_velocity)
            r_t = element.r
            v_t = b.rate(r_t) + cross(wF, r_t)
            flow = ca.SX(0)
            momentum = ca.SX.zeros(3, 1)
            angular = ca.SX.zeros(3, 1)
            for a in tank.fed_thrusters(scene):
                frame = b.frames[a.body]
                thrust = b.commands[a.name]
                m_dot = ca.fabs(thrust) / c
                r_n = frame.r + frame.C @ ca.DM(vector3(a.point))
                v_n = b.rate(r_n) + cross(wF, r_n)
                b.add_force_at(r_n, -m_dot * v_n)
                b.add_force_at(r_t, m_dot * v_t)
                exhaust = m_dot * v_n - frame.C @ ca.DM(unit_vector(a.axis)) * thrust
                flow += m_dot
                momentum += exhaust
                angular += cross(r_n, exhaust)
            used = b.aux_parts[self._block(b, tank)]
            b.set_rate(used, ca.if_else(mass > 0, flow, 0))
            b.add_output([f"{tank.name}.propellant"], mass)
            b.add_output([f"{tank.name}.exhaust_momentum_rate.{x}" for x in "xyz"], b.C_NF @ momentum)
            b.add_output([f"{tank.name}.exhaust_angular_momentum_rate.{x}" for x in "xyz"], b.C_NF @ angular)

    @staticmethod
    def _block(b, tank) -> int:
        """The index of the tank's state block in ``b.aux_parts``."""
        start = b.aux_names.index(f"{tank.name}.propellant_used")
        offset = 0
        for k, part in enumerate(b.aux_parts):
            if offset == start:
                return k
            offset += part.numel()
        raise KeyError(tank.name)


for _effect in (MassFlow(),):
    register_effect(_effect)
