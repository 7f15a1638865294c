"""A flexible body in large overall motion from its modal integrals (Banerjee ch. 5 and 6).

With the body's generalized speeds ``U = (v, w, q')``: the inertial velocity of its reference
point O and its inertial angular velocity, both in body axes, and the modal rates, the
generalized inertia forces are ``-F* = M(q) U' + C(q, U)`` (component derivatives in body
axes), built from :class:`ModalIntegrals` so that the cost does not grow with the number of
finite-element nodes (reference notes section 6.2; the rotary-inertia terms are summed over the
points instead where that graph is the smaller: :func:`_rotary_velocity_terms`)::

        [ m U3     -s~       b      ]        s   = s0 + b q
    M = [ s~      I + W1    g + W4  ]        g_k = c_k + sum_l d_lk q_l
        [ b^T   (g + W4)^T  E + W9  ]        I   = I0 + sum (N_l + N_l^T) q_l + sum q_k q_l P_kl

    C_v = m w x v + w x (w x s) + 2 w x (b q')
    C_w = s x (w x v) + w x (I w) + 2 sum_k q'_k D_k^T w + C_w^rot
    C_k = b_k . (w x v) - w^T D_k w + 2 sum_l q'_l (w . d_lk) + C_k^rot,    D_k = N_k + sum_l q_l P_lk

The motion-induced geometric stiffness (section 5.4, corrected Eq. 5.25) adds
``sum_i S^(i) A_i q`` to the modal rows, with the inertia-load factors ``A_i`` of the
accelerations and rates (:func:`inertia_load_factors`); its acceleration part makes ``M``
unsymmetric.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from ..structures._modal_data import ModalData

__all__ = ["flexible_body_terms", "inertia_load_factors"]


def _skew(v):
    return ca.vertcat(ca.horzcat(0, -v[2], v[1]), ca.horzcat(v[2], 0, -v[0]), ca.horzcat(-v[1], v[0], 0))


def inertia_load_factors(v, w, vdot, wdot, *, rotary: bool = False):
    """The factors ``A_1..A_12`` (``A_1..A_21`` with ``rotary``) of the unit inertia loads.

    ``(A_1, A_2, A_3) = v' + w x v``; ``(A_4..A_12)`` the rows of ``w~ w~ + alpha~`` per the
    table of the reference notes (section 5.4), so that the inertia force on a point at ``x``
    is ``-m [U3, x1 U3, x2 U3, x3 U3] A``; with ``rotary``, ``A_13..A_21`` of the nodal
    inertia torques.
    """
    u1, u2, u3 = v[0], v[1], v[2]
    u4, u5, u6 = w[0], w[1], w[2]
    z1, z2, z3 = u5 * u3 - u6 * u2, u6 * u1 - u4 * u3, u4 * u2 - u5 * u1
    z4, z5, z6 = u4 * u5, u6 * u4, u5 * u6
    A = [vdot[0] + z1, vdot[1] + z2, vdot[2] + z3,
         -(u5**2 + u6**2), wdot[2] + z4, -wdot[1] + z5,
         -wdot[2] + z4, -(u6**2 + u4**2), wdot[0] + z6,
         wdot[1] + z5, -wdot[0] + z6, -(u4**2 + u5**2)]
    if rotary:
        A += [wdot[0], wdot[1], wdot[2], z4, z6, z5, u4**2 - u5**2, u5**2 - u6**2, u6**2 - u4**2]
    return ca.vertcat(*A)


def flexible_body_terms(data: ModalData, q, v, w, qd, *, geometric_stiffness: bool = False):
    """``(M, C)`` of the flexible body's generalized inertia forces ``-F* = M U' + C``.

    Parameters
    ----------
    data : ModalData
        The body's modal data (its integrals are computed once here).
    q, qd : casadi.SX (n_modes,)
        Modal coordinates and rates.
    v, w : casadi.SX (3,)
        Inertial velocity of the reference point and inertial angular velocity, body axes.
    geometric_stiffness : bool
        Add the motion-induced stiffness ``sum_i S^(i) A_i q`` to the modal rows (needs
        ``data.geometric_stiffness``: 12 unit loads, or 21 with the torques of nodal rotary
        inertia); its acceleration dependence goes into ``M``.

    Returns
    -------
    M : casadi.SX (6 + n_modes, 6 + n_modes)
    C : casadi.SX (6 + n_modes,)
    """
    I = data.integrals()
    n = data.n_modes
    q, qd, v, w = (ca.vec(x) for x in (q, qd, v, w))
    Ib, Ic, Id, IN, IP = (significant(a) for a in (I.b, I.c, I.d, I.N, I.P))
    b = ca.DM(Ib)
    s = ca.DM(I.s0) + b @ q
    d = [[ca.DM(Id[l, k]) for k in range(n)] for l in range(n)]
    g = ca.horzcat(*[ca.DM(Ic[:, k]) + sum((d[l][k] * q[l] for l in range(n)), ca.DM.zeros(3, 1))
                     for k in range(n)]) if n else ca.DM(3, 0)
    N = [ca.DM(IN[l]) for l in range(n)]
    P = [[ca.DM(IP[k, l]) for l in range(n)] for k in range(n)]
    # I(q) entry by entry: a linear part and one term per unordered pair (k, l).
    P_pairs = pair_tensor(IP.transpose(2, 3, 0, 1).reshape(9, n, n)) if n else np.zeros((9, 0))
    linear = np.stack([(IN[l] + IN[l].T).reshape(9) for l in range(n)], axis=1) if n else np.zeros((9, 0))
    inertia = ca.reshape(ca.DM(np.asarray(I.I0, float).reshape(9)) + ca.DM(linear) @ q
                         + ca.DM(P_pairs) @ pair_products(q), 3, 3).T
    D = [N[k] + sum((P[l][k] * q[l] for l in range(n)), ca.DM.zeros(3, 3)) for k in range(n)]
    gbar = g + ca.DM(I.W4)
    M = ca.vertcat(
        ca.horzcat(I.mass * ca.DM.eye(3), -_skew(s), b),
        ca.horzcat(_skew(s), inertia + ca.DM(I.W1), gbar),
        ca.horzcat(b.T, gbar.T, ca.sparsify(ca.DM(significant(I.e + I.W9)))),
    )
    wxv = ca.cross(w, v)
    C_v = I.mass * wxv + ca.cross(w, ca.cross(w, s)) + 2 * ca.cross(w, b @ qd)
    C_w = ca.cross(s, wxv) + ca.cross(w, inertia @ w)
    for k in range(n):
        C_w = C_w + 2 * qd[k] * (D[k].T @ w)
    C_q = [ca.dot(ca.DM(Ib[:, k]), wxv) - ca.dot(w, D[k] @ w)
           + 2 * sum((qd[l] * ca.dot(w, d[l][k]) for l in range(n)), ca.SX(0)) for k in range(n)]
    C = ca.vertcat(C_v, C_w, *C_q)
    C = C + _rotary_velocity_terms(data, w, qd)
    if geometric_stiffness:
        if data.geometric_stiffness is None:
            from ..system._errors import ModelError

            raise ModelError("geometric_stiffness: this body's modal data has no geometric-stiffness matrices")
        S = data.geometric_stiffness
        Udot = ca.SX.sym("Udot", 6 + n)
        A = inertia_load_factors(v, w, Udot[0:3], Udot[3:6], rotary=S.shape[0] == 21)
        force = sum((ca.DM(significant(S[i])) @ q * A[i] for i in range(S.shape[0])), ca.SX.zeros(n, 1))
        M_g = ca.jacobian(force, Udot)  # acceleration part: linear in U'
        C_g = ca.substitute(force, Udot, ca.SX.zeros(6 + n, 1))
        M = ca.vertcat(M[:6, :], M[6:, :] + M_g)
        C = ca.vertcat(C[:6], C[6:] + C_g)
    return M, C


# Entries of a modal tensor below this share of its largest entry are round-off of sums that
# vanish by symmetry (in-plane against out-of-plane bending, torsion against bending). Measured on
# beam_modal_data: they sit at 1e-20..1e-12 of the largest, the genuine entries at 1e-5 and above,
# and they are 80-93 % of the entries of P, d and the rotary tensors at 16 modes.
ROUNDOFF_SHARE = 1e-12


def significant(T):
    """``T`` with the entries below ``ROUNDOFF_SHARE`` of its largest entry set to exact zeros.

    An exact zero costs no instruction in the CasADi graph (``0 * x`` folds away); the dropped
    entries are below the accuracy of the modal data they come from (eigenvectors good to
    round-off times their condition), so the equations change by less than that data's own error.
    """
    T = np.asarray(T, dtype=float)
    if T.size == 0:
        return T
    return np.where(np.abs(T) > ROUNDOFF_SHARE * np.max(np.abs(T)), T, 0.0)


def pair_products(a):
    """``a_k a_l`` for ``k <= l`` (row-major upper triangle), the factors of :func:`pair_tensor`."""
    n = a.numel()
    return ca.vertcat(*[a[k] * a[l] for k in range(n) for l in range(k, n)]) if n else ca.SX(0, 1)


def pair_tensor(T):
    """``T[i, k, l]`` folded onto ``k <= l`` so that ``T(a (x) a) = pair_tensor(T) @ pair_products(a)``."""
    T = np.asarray(T, dtype=float)
    n = T.shape[1]
    k, l = np.triu_indices(n)
    return np.where(k == l, T[:, k, l], T[:, k, l] + T[:, l, k])


_EPS = np.zeros((3, 3, 3))
_EPS[0, 1, 2] = _EPS[1, 2, 0] = _EPS[2, 0, 1] = 1.0
_EPS[0, 2, 1] = _EPS[2, 1, 0] = _EPS[1, 0, 2] = -1.0


# What the rotary terms' two forms cost, in instructions of the graph, before either is built:
# the tensors between ROTARY_TENSOR_DENSITY[0] and [1] times the dense count of their modal
# tensors (their share of structural zeros grows with the modes; measured on beam_modal_data's
# 64-point arrays: 2.2 at 2 modes, where the fixed terms dominate, 1.14 at 8, 0.48 at 48), the
# point sum within ROTARY_POINT_SLACK of ROTARY_POINT_COST = (per nonzero of the stacked rotation
# shapes, per point) (measured 0.95 to 1.05 of that from 2 to 64 modes). Only a form that may be
# the smaller is built.
ROTARY_TENSOR_DENSITY = (0.4, 2.5)
ROTARY_POINT_COST = (5, 10)
ROTARY_POINT_SLACK = 1.2


def _rotary_velocity_terms(data: ModalData, w, qd):
    """``[0; C_w^rot; C_q^rot]``: the sum over points of ``[0; U3; Psi_G^T] t_G`` with
    ``t_G = J_G (w x Psi_G q') + w_G x J_G w_G``, ``w_G = w + Psi_G q'``.

    Two exact forms of the same sum, the one with the smaller graph taken: fixed modal tensors
    (:func:`_rotary_tensor_terms`: no loop over points, but ``O(n^3)`` terms in ``n`` modes) or
    the sum over the points with rotary inertia (:func:`_rotary_point_terms`: ``O(G n)`` for
    ``G`` points). On beam_modal_data's 64-point arrays the tensors are smaller to 32 modes, the
    points from 48 (48 modes: 32.5k against 18.9k instructions).
    """
    n = data.n_modes
    if not np.any(data.inertias):
        return ca.SX.zeros(6 + n, 1)
    dense = (3 + n) * 3 * n + 6 * n + (3 + n) * n * (n + 1) // 2
    keep = np.any(data.inertias != 0, axis=(1, 2))
    points = (ROTARY_POINT_COST[0] * np.count_nonzero(significant(data.rotations[keep]))
              + ROTARY_POINT_COST[1] * np.count_nonzero(keep))
    ws, qs = ca.SX.sym("w", 3), ca.SX.sym("qd", n)  # the forms are built and counted on symbols
    forms = [ca.Function("rotary", [ws, qs], [form(data, ws, qs)]) for form, cheaper in (
        (_rotary_point_terms, points / ROTARY_POINT_SLACK < ROTARY_TENSOR_DENSITY[1] * dense),
        (_rotary_tensor_terms, ROTARY_TENSOR_DENSITY[0] * dense < points * ROTARY_POINT_SLACK)) if cheaper]
    return min(forms, key=lambda f: f.n_instructions())(w, qd)


def _rotary_point_terms(data: ModalData, w, qd):
    """:func:`_rotary_velocity_terms` as the sum over the points with rotary inertia: ``Psi_G q'``
    for every point (one product with the stacked rotation shapes), ``t_G`` point by point, and
    the modal rows ``Psi^T t`` (one product with their transpose)."""
    n = data.n_modes
    keep = np.flatnonzero(np.any(data.inertias != 0, axis=(1, 2)))
    J = significant(data.inertias[keep])
    R = ca.sparsify(ca.DM(significant(data.rotations[keep]).reshape(3 * keep.size, n)))
    psi = R @ qd
    torques = []
    for g in range(keep.size):
        Jg, p = ca.sparsify(ca.DM(J[g])), psi[3 * g:3 * g + 3]
        wg = w + p
        torques.append(Jg @ ca.cross(w, p) + ca.cross(wg, Jg @ wg))
    t = ca.vertcat(*torques)
    torque = sum((t[3 * g:3 * g + 3] for g in range(keep.size)), ca.SX.zeros(3, 1))
    return ca.vertcat(ca.SX.zeros(3, 1), torque, R.T @ t)


def _rotary_tensor_terms(data: ModalData, w, qd):
    """:func:`_rotary_velocity_terms` from fixed tensors: expanded, ``t_G`` has five terms
    bilinear in ``(w, q')``; each sum over points is a fixed tensor computed once here, so
    evaluating the terms does not loop over points::

        t = T1 (w (x) q') + w x W1 w + w x W4 q' + T4 (q' (x) w) + T5 (q' (x) q')
    """
    n = data.n_modes
    J, Psi = data.inertias, data.rotations
    e = _EPS
    # Rows 'i' of the torque, and its projections 'm' on the modal rotations (Psi^T).
    T1 = np.einsum("gia,abc,gck->ibk", J, e, Psi)
    T4 = np.einsum("iab,gak,gbc->ikc", e, Psi, J)
    T5 = np.einsum("iab,gak,gbc,gcl->ikl", e, Psi, J, Psi)
    Q1 = np.einsum("gim,gia,abc,gck->mbk", Psi, J, e, Psi)
    Q2 = np.einsum("gim,iab,gbc->mac", Psi, e, J)
    Q3 = np.einsum("gim,iab,gbc,gck->mak", Psi, e, J, Psi)
    Q4 = np.einsum("gim,iab,gak,gbc->mkc", Psi, e, Psi, J)
    Q5 = np.einsum("gim,iab,gak,gbc,gcl->mkl", Psi, e, Psi, J, Psi)
    W1, W4 = J.sum(axis=0), np.einsum("gij,gjk->ik", J, Psi)
    T1, T4, T5, Q1, Q2, Q3, Q4, Q5, W4 = (significant(a) for a in (T1, T4, T5, Q1, Q2, Q3, Q4, Q5, W4))

    # Terms bilinear in (w, q') are gathered into one tensor (T4 and Q4 transposed), and the
    # symmetric products q'_k q'_l and w_a w_b taken once per unordered pair: about half the
    # instructions of contracting each tensor with a full Kronecker product (the modal rows
    # have O(n^3) terms: they dominate the graph from 8 modes on).
    wq = np.concatenate([T1 + T4.transpose(0, 2, 1), Q1 + Q3 + Q4.transpose(0, 2, 1)]).reshape(3 + n, -1)
    torque = (ca.DM(wq[:3]) @ ca.kron(w, qd) + ca.cross(w, ca.DM(W1) @ w) + ca.cross(w, ca.DM(W4) @ qd)
              + ca.DM(pair_tensor(T5)) @ pair_products(qd))
    modal = (ca.DM(wq[3:]) @ ca.kron(w, qd) + ca.DM(pair_tensor(Q2)) @ pair_products(w)
             + ca.DM(pair_tensor(Q5)) @ pair_products(qd))
    return ca.vertcat(ca.SX.zeros(3, 1), torque, modal)
