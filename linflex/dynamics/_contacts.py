"""The rows of non-holonomic contact constraints (a rolling wheel, a knife edge) on a Kane builder.

A scene's ``constraints`` (:class:`linflex.Constraint`) restrict velocities: the material point
of a rolling wheel at its contact with the ground plane does not slide, a knife edge does not
move sideways. Such constraints are linear in the generalized speeds, ``A(q, t) u + a(q, t) =
0``, and not integrable to constraints on the coordinates: non-holonomic (Banerjee 2016, Eq.
1.86). They join the loop joints' holonomic rows in :class:`~._constraints.LoopClosure`, whose
multipliers, Baumgarte stabilization, consistent initial state and choice of independent rows
serve both; a non-holonomic row has no position (``phi = 0``) and its velocity is given instead
of being the rate of a position.

Rolling (scene axes; see :class:`linflex.Constraint`): with the wheel's centre ``c``, spin axis
``a`` and the plane's normal ``n``, the contact point is ``p = c + R d``,
``d = -(n - (n.a) a)/|n - (n.a) a|``; the rows are ``n . p - h`` (holonomic: the rim's lowest
point on the plane; its rate is ``n . v_P`` because the rim's tangent there is level) and
``f . v_P``, ``l . v_P`` (no slip), with ``l`` the axis projected on the plane, ``f = n x l``
and ``v_P`` the velocity of the wheel's material point at ``p``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from ..scene._values import vector3
from ..system._errors import ModelError
from ._kane import KaneBuilder, cross

__all__ = ["ContactRows", "contact_rows", "check_not_flat", "FLAT_TOL"]

#: A rolling wheel whose axis is within this sine of the plane's normal lies flat: its contact
#: point is undefined and the constraint singular.
FLAT_TOL = 1e-6


def _unit(v) -> np.ndarray:
    v = vector3(v)
    return v / np.linalg.norm(v)


@dataclass
class ContactRows:
    """The rows of one contact: ``position`` (SX or None for a non-holonomic row) and
    ``velocity`` (SX, or None: the rate of the position), their labels, the force directions
    (scene axes) their multipliers act along, and ``flatness`` (the sine between the wheel's
    axis and the plane's normal, to refuse a wheel lying flat; 1 for a knife edge)."""

    name: str
    position: list[Any]
    velocity: list[Any]
    labels: list[str]
    directions: list[Any]
    flatness: Any


def _material_velocity(b: KaneBuilder, body: str, point) -> Any:
    """Velocity relative to the scene frame (scene axes) of the material point of ``body`` now at
    ``point`` (an expression of ``q`` in scene axes): the body-fixed offset is held."""
    frame = b.frames[body]
    rho = ca.SX.sym("rho", 3)
    v = b.rate(frame.r + frame.C @ rho)
    return ca.substitute(v, rho, frame.C.T @ (point - frame.r))


def contact_rows(b: KaneBuilder, c: Any) -> ContactRows:
    """The constraint rows of the scene entry ``c`` (a :class:`linflex.Constraint`) on ``b``."""
    frame = b.frames[c.body]
    axis = frame.C @ ca.DM(_unit(c.axis))
    point = frame.r + frame.C @ ca.DM(vector3(c.point))
    if c.kind == "knife_edge":
        v_P = _material_velocity(b, c.body, point)
        return ContactRows(c.name, [None], [ca.dot(axis, v_P)], [f"{c.name}.lateral"], [axis], ca.SX(1.0))
    n = ca.DM(_unit(c.normal))
    s = n - ca.dot(n, axis) * axis
    size = ca.norm_2(s)
    d = -s / size
    p = point + float(c.radius) * d
    lateral = axis - ca.dot(n, axis) * n
    lateral = lateral / ca.norm_2(lateral)
    forward = cross(n, lateral)
    v_P = _material_velocity(b, c.body, p)
    return ContactRows(c.name, [ca.dot(n, p) - float(c.height), None, None],
                       [None, ca.dot(forward, v_P), ca.dot(lateral, v_P)],
                       [f"{c.name}.normal", f"{c.name}.forward", f"{c.name}.lateral"], [n, forward, lateral], size)


def check_not_flat(scene: Any, rows: list[ContactRows], x, x0: np.ndarray, p, p0, t) -> None:
    """Refuse a rolling wheel lying flat at the initial state, time 0 (its contact point is undefined)."""
    for k, (c, r) in enumerate(zip(scene.constraints, rows)):
        if c.kind != "rolling":
            continue
        value = float(ca.Function("flatness", [x, p, t], [r.flatness])(x0, p0, 0.0))
        if not value > FLAT_TOL:
            raise ModelError(f"constraints[{k}] ({c.name!r}): the rolling constraint is singular at the initial "
                             f"configuration: the wheel's axis is along the ground's normal (sine {value:.3g}), a wheel "
                             "lying flat has no lowest rim point; give initial coordinates with the wheel upright or "
                             "leaning, or check the constraint's axis (body axes) and normal (scene axes)")
