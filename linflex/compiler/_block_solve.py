"""The mass-matrix solve of a compiled scene by blocks: the speeds whose mass block is constant.

For modal coordinates of flexible bodies (mass-normalized: ``Phi^T m Phi = I``), and any other
speeds whose partial velocities do not depend on the state, the block ``D = M[F, F]`` of
``M = J^T Mb J`` is a constant. With ``M = [[A, B], [C, D]]`` (``R`` the other speeds)::

    (A - B D^-1 C) u'_R = r_R - B D^-1 r_F,     u'_F = D^-1 (r_F - C u'_R)

costs ``O(n_R^2 n_F + n_F^2 n_R)`` per right-hand side instead of the ``O(n^3)`` of one LU of
``M`` (``D^-1`` computed once; the identity for mass-normalized modes). Exact in exact
arithmetic; ``D`` is a principal block of a positive definite mass matrix, so the Schur
complement is as well conditioned as ``M`` (Golub and Van Loan, "Matrix Computations", 4th ed.,
section 3.4.6).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

#: The block solve is used from this many speeds with a constant block (measured on the hub with
#: two solar arrays: below it the one LU of the whole matrix is as cheap).
MIN_CONSTANT_SPEEDS = 8


def constant_block(J, Mb, depends) -> tuple[list[int], np.ndarray] | None:
    """``(F, D)``: the speeds whose block ``D = M[F, F]`` of ``M = J^T Mb J`` is constant, or None.

    ``J``, ``Mb`` are SX; ``depends`` the SX vector of every symbol (states, inputs, parameters,
    time). A speed is kept when its column of ``J`` is constant and its row and column of the
    block are; None when fewer than :data:`MIN_CONSTANT_SPEEDS` remain, when no other speed
    remains, or when ``D`` is not well conditioned.
    """
    n = J.size2()
    candidates = [j for j in range(n) if not ca.depends_on(J[:, j], depends)]
    if len(candidates) < MIN_CONSTANT_SPEEDS or len(candidates) == n:
        return None
    JF = J[:, candidates]
    D = JF.T @ (Mb @ JF)
    keep = [k for k in range(len(candidates))
            if not (ca.depends_on(D[k, :], depends) or ca.depends_on(D[:, k], depends))]
    if len(keep) < MIN_CONSTANT_SPEEDS or len(keep) == n:
        return None
    block = np.array(ca.evalf(D[keep, keep]), dtype=float)
    if not np.all(np.isfinite(block)) or np.linalg.cond(block) > 1e8:
        return None
    return [candidates[k] for k in keep], block


def block_solve(M, rhs, F: list[int], D: np.ndarray):
    """``M^-1 rhs`` with the constant block ``M[F, F] = D`` (see the module's notes): MX, the Schur
    complement's solve a LAPACK LU node; or SX, that solve expanded (for a few other speeds)."""
    n = M.size1()
    R = [j for j in range(n) if j not in set(F)]
    Dinv = ca.sparsify(ca.DM(np.linalg.inv(D)))
    A, B, C = M[R, R], M[R, F], M[F, R]
    rR, rF = rhs[R], rhs[F]
    DinvC = ca.mtimes(Dinv, C)
    schur, reduced = A - ca.mtimes(B, DinvC), rR - ca.mtimes(B, ca.mtimes(Dinv, rF))
    uR = ca.solve(schur, reduced, "lapacklu") if isinstance(M, ca.MX) else ca.solve(schur, reduced)
    uF = ca.mtimes(Dinv, rF) - ca.mtimes(DinvC, uR)
    order = np.argsort(np.array(R + F))
    return ca.vertcat(uR, uF)[order.tolist()]
