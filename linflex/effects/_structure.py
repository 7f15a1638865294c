"""Motion-induced geometric stiffness of flexible bodies."""

from __future__ import annotations

from ..scene._registry import Effect, register_effect
from ..system._errors import ModelError


class GeometricStiffness(Effect):
    """``geometric_stiffness``: the motion-induced stiffness of flexible bodies, from the projected
    geometric stiffness of the unit inertia loads combined with the current accelerations and
    rates (Banerjee Eqs. 5.13-5.25 as corrected in the reference notes). Without it, modal
    models are linearized prematurely: spin softens a beam instead of stiffening it."""

    name = "geometric_stiffness"

    def structure(self, b, scene):
        for fe in b.flexible:
            if fe.data.geometric_stiffness is None:
                raise ModelError(f"geometric_stiffness: flexible body {fe.name!r} has no geometric-stiffness "
                                 "matrices in its modal data (beam_modal_data computes them)")
            fe.geometric = True


for _effect in (GeometricStiffness(),):
    register_effect(_effect)
