"""Scene entries, part three: non-holonomic contact constraints (a wheel rolling on the ground, a knife edge)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._entries import CONSTRAINT_KINDS, _Entry
from ._problems import Problems, SceneContext


@dataclass(frozen=True)
class Constraint(_Entry):
    """A contact of a body with the ground plane that restricts its velocity (non-holonomic).

    ``"rolling"``: a thin wheel (a disk with a sharp rim, "knife-edge wheel") of ``radius``
    rolls on the plane without slipping: its lowest rim point stays on the plane (one
    holonomic constraint) and the material point of the wheel there has no velocity along the
    plane (two non-holonomic constraints). ``"knife_edge"``: the point ``point`` of the body
    cannot move along ``axis`` (one non-holonomic constraint: a skate, a sled's runner, the
    Chaplygin sleigh). The constraints enter Kane's equations with undetermined multipliers
    (Banerjee 2016, Eqs. 1.85-1.95; see :func:`linflex.compile_model`); the contact force is a
    model output, and :func:`linflex.linearize.constrained_linearization` linearizes onto the
    independent coordinates and speeds.

    Parameters
    ----------
    name : str
        Unique name; the outputs are ``<name>.force.x``, ``.y``, ``.z``.
    kind : {"rolling", "knife_edge"}
        ``"rolling"``: a thin wheel rolling on the plane without slipping (three constraints);
        ``"knife_edge"``: a point that cannot move along ``axis`` (one constraint).
    body : str
        The body in contact (the wheel, the sled).
    point : sequence of 3 floats
        Rolling: the wheel's centre; knife edge: the contact point; in body axes [m].
    axis : sequence of 3 floats
        Rolling: the wheel's spin axis; knife edge: the direction the contact point cannot
        move along; a unit vector [-] in body axes (normalized when compiled).
    radius : float
        Rolling: the wheel's radius [m] (required); a knife edge has none.
    normal : sequence of 3 floats
        The ground plane's normal pointing out of the ground, towards the body, a unit vector
        [-] in scene axes (normalized when compiled; the plane is fixed in the scene frame).
    height : float
        The plane is the set of points ``p`` with ``normal . p = height`` [m] (scene axes).
    baumgarte : sequence of 2 floats
        Gains ``(kd [1/s], kp [1/s^2])`` of the constraint stabilization, as for
        :class:`linflex.LoopJoint` (``kp`` acts on the rolling contact's height only: the velocity
        constraints have no position to return to).

    Notes
    -----
    Rows of a rolling contact with wheel centre ``c``, spin axis ``a`` (scene axes), the plane's
    normal ``n``: the contact point ``p = c + R d`` with ``d = -(n - (n.a) a)/|n - (n.a) a|``
    (the lowest rim point), the lateral direction ``l = (a - (n.a) n)/|...|`` and the
    longitudinal direction ``f = n x l``::

        n . p - height = 0                 (holonomic; its rate is n . v_P)
        f . v_P = 0,   l . v_P = 0         (non-holonomic)

    with ``v_P`` the velocity of the wheel's material point at ``p``. The multipliers are the
    components of the contact force on the wheel along ``n``, ``f`` and ``l``; the output
    ``<name>.force.*`` is that force in scene axes [N]. A wheel lying flat (``a`` along ``n``)
    has no lowest point: the constraint is singular there.

    Examples
    --------
    A wheel of radius 0.3 m spinning about its body y axis on level ground (scene z up):

    >>> from linflex import Constraint
    >>> c = Constraint("rear_contact", "rolling", "rear_wheel", axis=[0, 1, 0], radius=0.3)
    >>> c.normal, c.height, c.baumgarte  # [-], [m], (kd [1/s], kp [1/s^2])
    ((0.0, 0.0, 1.0), 0.0, (20.0, 100.0))
    """

    name: str
    kind: str
    body: str
    point: Any = (0.0, 0.0, 0.0)
    axis: Any = (0.0, 1.0, 0.0)
    radius: Any = None
    normal: Any = (0.0, 0.0, 1.0)
    height: float = 0.0
    baumgarte: Any = (20.0, 100.0)

    def _check(self, out: Problems, path: str, context: SceneContext) -> None:
        out.choice(self.kind, f"{path}.kind", CONSTRAINT_KINDS, "constraint kind")
        if out.name_ref(self.body, f"{path}.body", context.body_names, "body") and \
                getattr(context.bodies.get(self.body), "type", "rigid") != "rigid":
            out.add(f"{path}.body", f"{self.body!r} is flexible: a contact moves with a rigid body (it would not see "
                                    "the deformation)")
        out.vector(self.point, f"{path}.point", "m", kind="length")
        out.vector(self.axis, f"{path}.axis", "-", nonzero=True)
        out.vector(self.normal, f"{path}.normal", "-", nonzero=True)
        out.number(self.height, f"{path}.height", "m")
        if self.kind == "rolling":
            if self.radius is None:
                out.add(f"{path}.radius", "a rolling contact needs the wheel's radius [m]")
            else:
                out.number(self.radius, f"{path}.radius", "m", positive=True, kind="length")
        elif self.radius is not None:
            out.add(f"{path}.radius", f"only rolling contacts have a radius (this one is {self.kind!r})")
        gains = out.array(self.baumgarte, f"{path}.baumgarte", (2,), "1/s, 1/s^2", "two gains (kd, kp)")
        if gains is not None and np.any(gains < 0):
            out.add(f"{path}.baumgarte", f"gains must not be negative, got {gains.tolist()} (use (0, 0) to switch "
                                         "the stabilization off)")
