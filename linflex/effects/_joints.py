"""Springs and dampers of the joints."""

from __future__ import annotations

from ..scene._registry import Effect, register_effect


class JointSprings(Effect):
    """``joint_springs``: ``-k (q - rest) - c q'`` on free revolute and prismatic coordinates."""

    name = "joint_springs"

    def check(self, scene):
        return [f"joints[{i}].stiffness: joint springs act on revolute and prismatic joints only (this one is {j.type!r})"
                for i, j in enumerate(scene.joints)
                if j.type not in ("revolute", "prismatic") and (j.stiffness or j.damping)]

    def loads(self, b, scene):
        for j in scene.joints:
            # A spring at zero is left out, unless its stiffness or damping is an exposed
            # parameter (swept from a zero nominal value).
            exposed = any(f"{j.name}.{key}" in b.params for key in ("stiffness", "damping"))
            if j.type not in ("revolute", "prismatic") or not (j.stiffness or j.damping or exposed):
                continue
            q, u = b.joint_speeds.get(j.name, (None, None))
            if u is None:
                continue
            index = b.u_names.index(b.joint_speed_names[j.name])
            k, c = b.param(f"{j.name}.stiffness", j.stiffness), b.param(f"{j.name}.damping", j.damping)
            b.add_generalized_force(index, -k * (q - float(j.rest)) - c * u)
            b.add_potential(0.5 * k * (q - float(j.rest)) ** 2)


for _effect in (JointSprings(),):
    register_effect(_effect)
