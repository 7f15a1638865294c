"""A beam as a chain of rigid segments joined by rotational springs (the validation reference).

The rigid finite-segment model computes large-deflection beam behaviour independently of any
modal model, from the same scene vocabulary (bodies, revolute joints with springs). Spring
constants from Banerjee, *Flexible Multibody Dynamics*, Eqs. 10.1-10.10 (reference notes,
section 9.1): with ``n`` joints at ``x_i = (i - 1/2) L`` from the clamped root (``L`` the
segment length; a clamped half segment at the root, a free half segment at the tip)::

    sigma_1 = 8/9 EI/L,   sigma_2 = (48 n - 72)/(42 n - 71) EI/L,   sigma_i = EI/L  (i >= 3)

which reproduce the Euler-Bernoulli deflection under a tip load exactly at joints 2..n.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..system._errors import ModelError
from ._entries import Body
from ._joints import Joint

__all__ = ["rigid_segment_beam", "segment_spring_constants"]


def segment_spring_constants(segments: int, EI: float, segment_length: float) -> np.ndarray:
    """The ``n`` rotational spring constants [N m/rad] of the book's discretization.

    Parameters
    ----------
    segments : int
        Number of joints ``n`` (at least 2).
    EI : float
        Bending stiffness [N m^2].
    segment_length : float
        Segment length [m].

    Returns
    -------
    ndarray, shape (n,)
        Spring constants [N m/rad], root first.

    Raises
    ------
    ModelError
        For fewer than 2 segments, or a number of segments that is not an integer.

    Examples
    --------
    >>> from linflex import segment_spring_constants
    >>> [round(float(k), 4) for k in segment_spring_constants(3, 1.0, 1.0)]
    [0.8889, 1.3091, 1.0]
    """
    n = _segment_count(segments)
    sigma = np.full(n, EI / segment_length)
    sigma[0] *= 8.0 / 9.0
    sigma[1] *= (48 * n - 72) / (42 * n - 71)
    return sigma


def rigid_segment_beam(
    name: str,
    *,
    length: float,
    EI: float,
    mass_per_length: float,
    segments: int,
    parent: str = "ground",
    root: ArrayLike = (0.0, 0.0, 0.0),
    direction: ArrayLike = (1.0, 0.0, 0.0),
    bending_axis: ArrayLike = (0.0, 0.0, 1.0),
    damping: float = 0.0,
) -> tuple[tuple[Body, ...], tuple[Joint, ...]]:
    """Bodies and revolute joints of a cantilever as rigid segments with rotational springs.

    Parameters
    ----------
    name : str
        Prefix of the body and joint names (``<name>_seg<k>``, ``<name>_joint<k>``).
    length : float
        Beam length from the clamped root [m].
    EI : float
        Bending stiffness in the plane normal to ``bending_axis`` [N m^2].
    mass_per_length : float
        [kg/m]. The clamped half segment at the root (``m L / 2``) does not move and is left to
        the parent body.
    segments : int
        Number of joints ``n`` (at least 2); the segment length is ``length / n``.
    parent : str
        The body (or ``"ground"``) the beam is clamped to.
    root : array_like
        The clamped root in the parent's frame [m].
    direction, bending_axis : array_like
        Unit vectors (parent axes at zero joint angles): along the beam, and the joints' axis.
    damping : float
        Rotational damping of every joint [N m s/rad].

    Returns
    -------
    bodies, joints : tuples
        Add them to a scene with the effect ``joint_springs``.

    Examples
    --------
    >>> from linflex import rigid_segment_beam
    >>> bodies, joints = rigid_segment_beam("arm", length=1.0, EI=1.0, mass_per_length=1.0, segments=3)
    >>> [b.name for b in bodies], [j.name for j in joints]
    (['arm_seg0', 'arm_seg1', 'arm_seg2'], ['arm_joint0', 'arm_joint1', 'arm_joint2'])
    """
    d = np.asarray(direction, dtype=float)
    axis = np.asarray(bending_axis, dtype=float)
    if not np.isclose(np.linalg.norm(d), 1.0) or not np.isclose(np.linalg.norm(axis), 1.0):
        raise ModelError("direction and bending_axis must be unit vectors")
    if abs(d @ axis) > 1e-9:
        raise ModelError("bending_axis must be normal to the beam direction")
    for label, value in (("length", length), ("EI", EI), ("mass_per_length", mass_per_length)):
        if not np.isfinite(value) or value <= 0:
            raise ModelError(f"{label} must be positive, got {value!r}")
    n = _segment_count(segments)
    L = length / n
    sigma = segment_spring_constants(n, EI, L)
    bodies, joints = [], []
    for k in range(n):
        piece = L if k < n - 1 else L / 2  # the last segment is the free half segment at the tip
        mass = mass_per_length * piece
        transverse = mass * piece**2 / 12
        # A thin rod: its inertia about its own axis is negligible but kept positive.
        inertia = transverse * (np.eye(3) - np.outer(d, d)) + 1e-6 * transverse * np.outer(d, d)
        body = f"{name}_seg{k}"
        bodies.append(Body(name=body, mass=mass, inertia=inertia.tolist(), com=tuple(d * piece / 2)))
        parent_point = np.asarray(root, dtype=float) + d * L / 2 if k == 0 else d * L
        joints.append(Joint(name=f"{name}_joint{k}", type="revolute", parent=parent if k == 0 else f"{name}_seg{k - 1}",
                            child=body, axis=tuple(axis), parent_point=tuple(parent_point),
                            stiffness=float(sigma[k]), damping=damping))
    return tuple(bodies), tuple(joints)


def _segment_count(segments) -> int:
    """``segments`` as an int: an integral number of at least 2 (4.7 is refused, not truncated)."""
    try:
        n = int(segments)
    except (TypeError, ValueError, OverflowError):
        n = None
    if n is None or isinstance(segments, bool) or n != segments:
        raise ModelError(f"segments must be an integer, got {segments!r}")
    if n < 2:
        raise ModelError(f"segments must be at least 2, got {segments!r}")
    return n
