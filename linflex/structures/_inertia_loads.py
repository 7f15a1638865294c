"""Geometric stiffness of the unit inertia loads from a body's own stiffness and mass matrices.

:func:`beam_modal_data` computes the motion-induced stiffness of Banerjee's unit inertia loads
(docs/reference/multibody-formulations-banerjee.md, section 5.4) from its beam elements.
:func:`inertia_load_stiffness` does it for any frame model given only as assembled matrices (from
:func:`assemble_beams`, or a NASTRAN model of bars and beams): six freedoms per node (translations
x, y, z then rotations, body axes), node positions, and mass-normalized modes.

1. **Members from the stiffness.** Two nodes coupled by a nonzero block ``K_ab`` are joined by a
   two-node member (bar, beam, spring). Rigid-body invariance of a two-node member fixes its
   diagonal blocks from the coupling: ``K_aa^e = -K_ab T(x_b - x_a)`` with ``T(r) = [[U3, -r~],
   [0, U3]]``. The assembled diagonal blocks must equal the sum of these over the node's members;
   otherwise the model has elements joining more than two nodes (plates, solids) or grounded
   springs, and is refused (their stresses need the element formulation).
2. **Unit loads from the mass.** Load case ``i = 1..12`` is ``f_i = -M r_i`` with ``r_i`` the
   nodal values of the acceleration field ``[U3, x1 U3, x2 U3, x3 U3] e_i`` (Eq. 5.16): nodal
   translations are the field at the node, nodal rotations ``e x (A e)`` (the slope of the field
   along a member of direction ``e``, ``A`` the field's gradient), averaged over the node's beam
   members. This is exact (the consistent load of the field) when the members meeting at a node
   are collinear (straight members, any field) or the field is rigid; at a joint of members in
   different directions the members disagree on the slope, and the result carries an error
   estimate: twice the change of ``S`` when each joint takes its first member's slope instead of
   the average (on the frames of the tests the actual error against the element path of
   :func:`beam_modal_data` was 0.5 to 0.8 of it; an estimate, not a proven bound). With nodal rotary inertia (``rotary_inertias``) load cases 13..21 add the torques of
   Eqs. 5.19-5.21.
3. **Stresses and geometric stiffness.** The static solution of the restrained structure gives
   each member's axial force ``N = e . f_b`` (tension positive), with ``f_b = K_ba (u_a -
   T(x_a - x_b) u_b)`` the member's end force; a member that couples translations and rotations
   (a beam) contributes ``N`` times the consistent cubic-beam matrix per unit axial force, a bar
   ``N / L (U3 - e e^T)`` on its translations; ``S^(i) = Phi^T K_g^(i) Phi``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ..system._errors import ModelError
from ..system._signals import check_positive, frozen_array
from ._beam import GAUSS_W, GAUSS_XI, _shape_functions, _unit_inertia_torques
from ._components import _check_km, _indices

__all__ = ["InertiaLoadStiffness", "inertia_load_stiffness"]


@dataclass(frozen=True)
class InertiaLoadStiffness:
    """Projected geometric stiffness of the unit inertia loads, with its error estimate.

    Attributes
    ----------
    S : ndarray, shape (12 or 21, M, M)
        ``S^(i) = Phi^T K_g^(i) Phi`` [N/m per unit A_i in modal coordinates], as
        :attr:`linflex.ModalData.geometric_stiffness`.
    members : ndarray of int, shape (n_members, 2)
        Node pairs found in the stiffness matrix.
    axial_forces : ndarray, shape (n_members, 12 or 21)
        Axial force of each member per unit ``A_i`` [N per unit A_i], tension positive.
    error_estimate : float
        Twice the largest change of an entry of ``S`` when every joint of non-collinear beam
        members takes its first member's slope field instead of the average [N/m per unit A_i];
        0 when the unit loads are exact (collinear members at every node).
    """

    S: NDArray[np.float64]
    members: NDArray[np.int_]
    axial_forces: NDArray[np.float64]
    error_estimate: float


def _transfer(r: NDArray) -> NDArray:
    """``T(r)``: rigid motion (translation, rotation) of a point to a point at offset ``r``."""
    T = np.eye(6)
    T[:3, 3:] = -np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    return T


def _local_axes(e: NDArray) -> NDArray:
    ref = np.array([0.0, 1.0, 0.0]) if abs(e[1]) < 0.9 else np.array([0.0, 0.0, 1.0])
    ey = ref - e * (ref @ e)
    ey /= np.linalg.norm(ey)
    return np.vstack([e, ey, np.cross(e, ey)])


def _unit_geometric(e: NDArray, L: float, beam: bool) -> NDArray:
    """Member geometric stiffness per unit axial force in body axes (12 x 12)."""
    if not beam:
        g = (np.eye(3) - np.outer(e, e)) / L
        G = np.zeros((12, 12))
        G[np.ix_([0, 1, 2, 6, 7, 8], [0, 1, 2, 6, 7, 8])] = np.block([[g, -g], [-g, g]])
        return G
    G = np.zeros((12, 12))
    for xi, w in zip(GAUSS_XI, GAUSS_W):
        slope = _shape_functions(xi, L)[3]
        G += w * L * slope.T @ slope
    T = scipy.linalg.block_diag(*[_local_axes(e)] * 4)
    return T.T @ G @ T


def _field(i: int) -> tuple[NDArray, NDArray]:
    """Constant part and gradient of the acceleration field of unit load case i (0-based, < 12)."""
    a0, A = np.zeros(3), np.zeros((3, 3))
    if i < 3:
        a0[i] = 1.0
    else:
        j, k = divmod(i - 3, 3)  # field x_j e_k
        A[k, j] = 1.0
    return a0, A


def inertia_load_stiffness(K: ArrayLike, M: ArrayLike, nodes: ArrayLike, modes: ArrayLike, *,
                           fixed: ArrayLike = (), rotary_inertias: ArrayLike | None = None,
                           tol: float = 1e-8) -> InertiaLoadStiffness:
    """Geometric stiffness of the 12 (or 21) unit inertia loads of a frame model (module doc).

    Parameters
    ----------
    K, M : array_like, shape (6 n, 6 n)
        Assembled stiffness [N/m, N m/rad] and mass [kg, kg m^2] without boundary conditions;
        node ``j`` has freedoms ``6 j .. 6 j + 5`` (translations [m], rotations [rad], body axes).
    nodes : array_like, shape (n, 3)
        Node positions in the body frame [m].
    modes : array_like, shape (6 n, M)
        Mass-normalized modes of the restrained structure (zero at ``fixed``).
    fixed : array_like of int
        Restrained freedoms (those clamped for the modes; the loads are reacted there): indices or a boolean mask.
    rotary_inertias : array_like, shape (n, 3, 3), optional
        Nodal rotary inertia in body axes [kg m^2]; given, load cases 13..21 are added.
    tol : float
        Relative size under which a stiffness block or a member-sum mismatch is round-off [-].

    Returns
    -------
    InertiaLoadStiffness
        ``S`` (12 or 21, M, M), the members, their axial forces and the error estimate.

    Raises
    ------
    ModelError
        For inconsistent sizes, a stiffness that is not an assembly of two-node members, or a
        structure that ``fixed`` does not restrain.

    Examples
    --------
    Southwell's coefficient of a spinning cantilever (1.1932 for the flapwise mode; its lateral
    displacement makes the centrifugal softening negligible) from its assembled matrices:

    >>> import numpy as np
    >>> from linflex import Beam, assemble_beams, structural_modes
    >>> from linflex.structures import inertia_load_stiffness
    >>> beam = Beam((0, 0, 0), (1, 0, 0), EA=1e8, EIy=1.0, EIz=3.0, GJ=1.0, mass_per_length=1.0,
    ...             torsional_inertia_per_length=1e-3, elements=20)
    >>> s = assemble_beams(beam)
    >>> free = np.arange(6, s.K.shape[0])
    >>> modes = np.zeros((s.K.shape[0], 1))
    >>> modes[free] = structural_modes(s.K[np.ix_(free, free)], s.M[np.ix_(free, free)], 1).shapes
    >>> result = inertia_load_stiffness(s.K, s.M, s.nodes, modes, fixed=range(6))
    >>> round(float(-(result.S[3] + result.S[7])[0, 0]), 3), result.error_estimate  # 20 elements
    (1.194, 0.0)
    """
    K, M = _check_km(K, M)
    X = np.asarray(nodes, dtype=float)
    Phi = np.asarray(modes, dtype=float)
    n = X.shape[0] if X.ndim == 2 and X.shape[1:] == (3,) else -1
    if n < 2 or K.shape != (6 * n, 6 * n) or M.shape != K.shape:
        raise ModelError(f"inertia_load_stiffness: K {K.shape} and M {M.shape} must be (6 n, 6 n) for n nodes "
                         f"(nodes {X.shape})")
    if Phi.ndim != 2 or Phi.shape[0] != 6 * n:
        raise ModelError(f"inertia_load_stiffness: modes have shape {Phi.shape}; ({6 * n}, M) expected")
    for name, value in (("nodes", X), ("modes", Phi)):
        if not np.all(np.isfinite(value)):
            raise ModelError(f"inertia_load_stiffness: {name} have non-finite entries")
    fixed = _indices(fixed, 6 * n, "inertia_load_stiffness: fixed", allow_empty=True)
    tol = check_positive(tol, "tol")
    free = np.setdiff1d(np.arange(6 * n), fixed)
    blocks = K.reshape(n, 6, n, 6).transpose(0, 2, 1, 3)  # blocks[a, b] = K_ab
    size = np.abs(blocks).max(axis=(2, 3))
    scale = max(float(size.max()), 1e-300)
    pairs = np.argwhere(np.triu(size > tol * scale, k=1))
    reconstructed = np.zeros((n, 6, 6))
    for a, b in pairs:
        reconstructed[a] -= blocks[a, b] @ _transfer(X[b] - X[a])
        reconstructed[b] -= blocks[b, a] @ _transfer(X[a] - X[b])
    mismatch = np.abs(reconstructed - blocks[np.arange(n), np.arange(n)]).max(axis=(1, 2))
    worst = int(np.argmax(mismatch))
    if mismatch[worst] > 1e3 * tol * scale:
        raise ModelError(f"inertia_load_stiffness: the stiffness at node {worst} is not a sum of two-node members "
                         f"(relative mismatch {mismatch[worst] / scale:.2g}): elements joining more nodes (plates, "
                         "solids) or springs to ground need their element formulation")
    lengths = np.linalg.norm(X[pairs[:, 1]] - X[pairs[:, 0]], axis=1)
    members = pairs[lengths > tol * max(np.abs(X).max(), 1.0)]  # zero-length springs carry no axial force
    directions = [(X[b] - X[a]) / np.linalg.norm(X[b] - X[a]) for a, b in members]
    is_beam = [np.abs(blocks[a, b][:3, 3:]).max() + np.abs(blocks[a, b][3:, :3]).max() > tol * np.abs(blocks[a, b]).max()
               for a, b in members]
    attached: list[list[NDArray]] = [[] for _ in range(n)]
    for (a, b), e, beam in zip(members, directions, is_beam):
        if beam:
            attached[a].append(e)
            attached[b].append(e)

    J = None if rotary_inertias is None else np.asarray(rotary_inertias, dtype=float)
    if J is not None and J.shape != (n, 3, 3):
        raise ModelError(f"inertia_load_stiffness: rotary_inertias have shape {J.shape}; ({n}, 3, 3) expected")
    n_loads = 12 if J is None else 21

    def loads(first_only: bool) -> NDArray:
        F = np.zeros((6 * n, n_loads))
        for i in range(12):
            a0, A = _field(i)
            r = np.zeros((n, 6))
            r[:, :3] = a0 + X @ A.T
            for node, es in enumerate(attached):
                if es:
                    slopes = [np.cross(e, A @ e) for e in (es[:1] if first_only else es)]
                    r[node, 3:] = np.mean(slopes, axis=0)
            F[:, i] = -M @ r.reshape(-1)
        if J is not None:
            for node in range(n):
                F[6 * node + 3:6 * node + 6, 12:] += _unit_inertia_torques(J[node])
        return F

    Kff = K[np.ix_(free, free)]
    G = [_unit_geometric(e, float(np.linalg.norm(X[b] - X[a])), beam)
         for (a, b), e, beam in zip(members, directions, is_beam)]

    def stiffness(F: NDArray) -> tuple[NDArray, NDArray]:
        u = np.zeros_like(F)
        try:
            u[free] = scipy.linalg.solve(Kff, F[free], assume_a="sym")
        except (np.linalg.LinAlgError, scipy.linalg.LinAlgWarning) as err:
            raise ModelError(f"inertia_load_stiffness: the static problem cannot be solved ({err}): the fixed "
                             "freedoms do not restrain the structure") from err
        forces = np.zeros((len(members), n_loads))
        S = np.zeros((n_loads, Phi.shape[1], Phi.shape[1]))
        for k, ((a, b), e, g) in enumerate(zip(members, directions, G)):
            ua, ub = u[6 * a:6 * a + 6], u[6 * b:6 * b + 6]
            end_force = blocks[b, a] @ (ua - _transfer(X[a] - X[b]) @ ub)
            forces[k] = e @ end_force[:3]
            dofs = np.r_[6 * a:6 * a + 6, 6 * b:6 * b + 6]
            S += forces[k][:, None, None] * (Phi[dofs].T @ g @ Phi[dofs])[None]
        return S, forces

    S, forces = stiffness(loads(first_only=False))
    joints = any(len(es) > 1 and np.abs(np.cross(es[0], np.array(es))).max() > tol for es in attached)
    estimate = 2.0 * float(np.abs(stiffness(loads(first_only=True))[0] - S).max()) if joints else 0.0
    return InertiaLoadStiffness(frozen_array(S), frozen_array(members, dtype=None), frozen_array(forces), estimate)
