"""Stiffness by origin from Kane's direct linearization: which origin makes each mode stiff.

Kane's direct linearization itself (``linearize(model, op, method="kane")``) is computed by the
compiled equations, :meth:`linflex.dynamics._kane_linear.KaneEquations.linearization` (arrays in, arrays out),
which keeps each load's origin so that the stiffness and damping split by origin; this module
reads that split.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
import scipy.linalg

from linflex import ModelError
from linflex.system import frozen_array

from ._result import LinearizationProblem, MethodResult

__all__ = ["StiffnessShares", "direct_linearization", "stiffness_shares"]


def direct_linearization(problem: LinearizationProblem, options) -> MethodResult:
    """The ``"kane"`` method: Kane's direct linearization of a compiled scene's equations.

    ``options.premature`` selects premature linearization (see
    :meth:`linflex.dynamics._kane_linear.KaneEquations.linearization`); the second-order form and the
    stiffness and damping by origin come with the Jacobians.
    """
    lin = problem.model.equations.linearization(problem.x, problem.u, problem.p, problem.t,
                                                premature=options.premature)
    return MethodResult.exact(lin.f0, lin.y0, lin.A, lin.B, lin.C, lin.D, setup_seconds=lin.setup_seconds,
                              second_order=lin.second_order, stiffness=lin.stiffness, damping=lin.damping)


@dataclass(frozen=True)
class StiffnessShares:
    """Each origin's share of each undamped mode's squared frequency (see :func:`stiffness_shares`).

    Attributes
    ----------
    frequencies : ndarray, shape (n_modes,)
        Undamped natural frequencies [rad/s] of ``(M, sym(K))``, ascending (negative squared
        frequencies, i.e. divergent modes, give NaN here and a negative total below).
    squared : ndarray, shape (n_modes,)
        ``omega^2`` of each mode [rad^2/s^2] (the sum of the shares).
    shares : Mapping of str to ndarray, shape (n_modes,)
        ``phi^T K_origin phi / phi^T M phi`` for every origin [rad^2/s^2].
    shapes : ndarray, shape (n_dofs, n_modes)
        The mode shapes ``phi`` in the degrees of freedom ``dofs``, mass-normalized
        (``phi^T M phi = I``), so each row is in 1/sqrt of its dof's generalized mass unit:
        [1/sqrt(kg)] for a translation [m], [1/sqrt(kg m^2)] for a rotation [rad] (joint angles
        and the small rotations of quaternions).
    dofs : tuple of str
        The degrees of freedom, the rows of ``shapes`` (``lin.second_order.dofs``): joint
        angles and displacements, modal coordinates, ``<joint>.rx``, ``.ry``, ``.rz`` for the
        small rotation of each quaternion, ``<speed>.integral`` for a speed that no coordinate
        follows (a wheel's).
    """

    frequencies: np.ndarray
    squared: np.ndarray
    shares: MappingProxyType
    shapes: np.ndarray
    dofs: tuple[str, ...]


def stiffness_shares(lin) -> StiffnessShares:
    """Which origin makes each mode stiff: the Rayleigh quotient of each stiffness part.

    With the undamped modes ``phi_i`` of ``M d'' + K_s d = 0`` (``K_s``: the symmetric part of
    ``K``), ``omega_i^2 = sum_origin phi_i^T K_origin phi_i / phi_i^T M phi_i`` exactly, so each
    term says how much of a mode's stiffness comes from the structure, a spring, the
    centrifugal field of the inertia forces, geometric stiffness, gravity gradient, a control
    law... The damping and gyroscopic terms are left out (they move the modes' frequencies
    little when light; ``lin.damping`` has them).

    Parameters
    ----------
    lin : Linearization
        From ``linearize(model, op, method="kane")`` (it needs ``second_order`` and
        ``stiffness``).

    Returns
    -------
    StiffnessShares

    Raises
    ------
    ModelError
        For a linearization without the second-order form (another method than ``"kane"``).

    Examples
    --------
    The spinning-table bar of the reference notes (section 3.3): the spring gives 1, the
    centrifugal field 4 of the squared frequency 5 [rad^2/s^2].

    >>> from linflex import Body, Joint, Scene, compile_model
    >>> from linflex.linearize import linearize, stiffness_shares
    >>> bar = Scene("table", effects=["joint_springs"],
    ...             bodies=[Body("table", 10.0, (1, 1, 1)), Body("bar", 1.0, (0, 0, 0), com=[1.0, 0, 0])],
    ...             joints=[Joint("spin", "revolute", "table", prescribed={"profile": "ramp", "rate": 2.0}),
    ...                     Joint("hinge", "revolute", "bar", parent="table", parent_point=[1.0, 0, 0],
    ...                           stiffness=1.0)])
    >>> shares = stiffness_shares(linearize(compile_model(bar), method="kane"))
    >>> {k: round(float(v[0]), 12) for k, v in shares.shares.items()}
    {'joint_springs': 1.0, 'inertia': 4.0}
    """
    so, parts = getattr(lin, "second_order", None), getattr(lin, "stiffness", None)
    if so is None or parts is None:
        raise ModelError("stiffness_shares needs the second-order form and the stiffness by origin of "
                         "linearize(model, op, method='kane')")
    K = 0.5 * (so.K + so.K.T)
    M = 0.5 * (so.M + so.M.T)
    squared, shapes = scipy.linalg.eigh(K, M)
    shares = {o: np.einsum("ij,ik,kj->j", shapes, 0.5 * (Ko + Ko.T), shapes) for o, Ko in parts.items()}
    with np.errstate(invalid="ignore"):
        frequencies = np.sqrt(squared)
    return StiffnessShares(frozen_array(frequencies), frozen_array(squared),
                           MappingProxyType({o: frozen_array(v) for o, v in shares.items()}), frozen_array(shapes), so.dofs)
