"""Kane's direct linearization of a compiled scene, in second-order form with its stiffness by origin.

Kane's equations ``F_r + F_r* = 0`` are sums of loads and inertia forces projected on the
partial velocities ``V_r(q)``. Linearizing them directly (Banerjee 2016, section 1.4, Eqs.
1.63-1.65; reference notes section 3.1) keeps the first-order terms of both factors::

    d(V^T F) = V(q0)^T dF  +  (dV/dq dq)^T F(q0)
               '----------'   '--------------'
               premature       lost by premature linearization (motion-induced stiffness)

so the linear equations come straight from the partial velocities, velocities and
accelerations of the compiled scene, without differentiating its solved state derivative.
Each load keeps its origin (the effect that added it, ``"actuators"``, ``"structure"``, ...),
and the inertia forces theirs (``"inertia"``: centrifugal, Coriolis and gyroscopic terms;
``"geometric_stiffness"``), so the stiffness and damping matrices split by origin for free.
``premature=True`` evaluates every partial velocity at the nominal coordinates (partials of
the linearized velocities, Eqs. 1.66-1.67) to show the error.

Second-order form. With the kinematical equations linearized, ``dq' = Nq dq + Nu du``, the
degrees of freedom ``d`` are the coordinates, with each quaternion replaced by its small
rotation in body axes (``dq = 1/2 q0 (x) [0, d_theta]``), plus the integral of every speed that
no coordinate follows (a wheel's speed). ``du = G d' + H d`` then gives, premultiplied by
``G^T`` so that ``M`` stays symmetric::

    G^T M G d'' + G^T (M H - Ru G) d' - G^T (Rq T + Ru H) d = G^T [R_in  R_aux] [d_in; d_aux]

with ``R* = dR/d*`` the Jacobians of the generalized forces at the operating point. For joint
angles, positions and modal coordinates ``G = I`` and ``H = 0``.
"""

from __future__ import annotations

import time
import weakref
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
import scipy.linalg

from linflex import MethodUnavailableError, ModelError, NonlinearModel, SecondOrderSystem
from linflex.system import frozen_array

__all__ = ["DirectLinearization", "StiffnessShares", "direct_linearization", "stiffness_shares"]

_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class DirectLinearization:
    """What :func:`direct_linearization` computes (numpy arrays at the operating point)."""

    f0: np.ndarray
    y0: np.ndarray
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    second_order: SecondOrderSystem
    stiffness: MappingProxyType
    damping: MappingProxyType
    setup_seconds: float


def _functions(model: NonlinearModel, premature: bool):
    """The two CasADi functions of the direct linearization (cached per model and flag).

    With loop joints the multipliers ``lam`` of the independent constraint rows are unknowns
    beside ``u'``: the constraint forces ``A(q)^T lam`` are one more origin (``"constraints"``)
    and the constraints ``A u' + w(q, u) = 0`` (Baumgarte-stabilized, as compiled) close the
    system (Banerjee 2016, Eqs. 1.90-1.95).
    """
    per_model = _CACHE.setdefault(model, {})
    if premature in per_model:
        return per_model[premature], 0.0
    import casadi as ca

    start = time.perf_counter()
    eq = model.equations
    b = eq.builder
    nq = b.q.numel()
    qbar = ca.SX.sym("qbar", nq)
    # Premature: the partial velocities frozen at qbar (set to the nominal q when evaluated).
    parts = b.generalized_forces_by_origin(partials_at=qbar if premature else None)
    loop = eq.loop
    n_lam = 0 if loop is None else len(loop.selected)
    lam = ca.SX.sym("lam", n_lam)
    y = eq.y
    if loop is not None:
        A_c, w_c = loop.terms(eq.x, eq.params, b.t)
        A_c, w_c = ca.SX(A_c), ca.SX(w_c)
        if n_lam:
            A_p = ca.substitute(A_c, b.q, qbar) if premature else A_c
            parts["constraints"] = A_p.T @ lam
        y = ca.substitute(y, loop.multipliers, ca.mtimes(ca.SX(loop.selection), lam))
        constraint = A_c @ b.udot + w_c
    else:
        constraint = ca.SX(0, 1)
    origins = tuple(parts)
    R = ca.vertcat(*parts.values())
    total = sum(parts.values(), ca.SX.zeros(b.u.numel(), 1))
    args = [eq.x, eq.inputs, eq.params, b.t, qbar, b.udot, lam]
    # Kane's equations are affine in u' and lam: R = R(0, 0) - M u' + A^T lam, A u' + w = 0.
    force = ca.Function("kane_force", args, [total, -ca.jacobian(total, b.udot), ca.jacobian(constraint, b.udot),
                                             constraint])
    z = ca.vertcat(eq.x, eq.inputs, b.udot, lam)
    # Direct: the partial velocities vary with q like everything else (Eq. 1.65).
    jac = ca.Function("kane_jacobians", args,
                      [ca.jacobian(R, b.q), ca.jacobian(R, z), ca.jacobian(constraint, z), b.qdot,
                       ca.jacobian(b.qdot, eq.x), eq.auxdot, ca.jacobian(eq.auxdot, z), y, ca.jacobian(y, z)])
    per_model[premature] = (origins, n_lam, force, jac)
    return per_model[premature], time.perf_counter() - start


def direct_linearization(model: NonlinearModel, x, u, p, t: float, *, premature: bool = False) -> DirectLinearization:
    """Kane's direct linearization of a compiled scene's model at ``(x, u, p, t)``.

    Parameters
    ----------
    model : Model
        A compiled scene (its ``equations`` are what is linearized).
    x, u, p : ndarray
        State, inputs and parameter values of the operating point.
    t : float
        Time [s].
    premature : bool
        Take the partial velocities at the nominal coordinates (premature linearization).

    Returns
    -------
    DirectLinearization

    Raises
    ------
    MethodUnavailableError
        For a model that is not a compiled scene.
    ModelError
        When the mass matrix (with the constraints: the saddle-point matrix of the mass matrix
        and the constraint rows) is singular at the point.
    """
    if getattr(model, "equations", None) is None:
        raise MethodUnavailableError(
            "method 'kane' needs a compiled scene (compile_model): it linearizes Kane's equations, "
            "which a NonlinearModel of plain functions does not have; use 'autodiff' or 'perturbation'"
        )
    (origins, n_lam, force, jac), setup_seconds = _functions(model, premature)
    b = model.equations.builder
    nq, nu, nx, ni = b.q.numel(), b.u.numel(), model.n_states, model.n_inputs
    na = nx - nq - nu
    qbar = np.asarray(x, float)[:nq]
    args = [x, u, p, t, qbar]
    R0, M, Ac, w0 = (np.array(v, dtype=float) for v in force(*args, np.zeros(nu), np.zeros(n_lam)))
    R0, M, Ac, w0 = R0.reshape(nu), M.reshape(nu, nu), Ac.reshape(n_lam, nu), w0.reshape(n_lam)
    # M u' - A^T lam = R0, A u' = -w: the saddle-point matrix (M alone without constraints).
    KKT = np.block([[M, -Ac.T], [Ac, np.zeros((n_lam, n_lam))]])
    try:
        lu = scipy.linalg.lu_factor(KKT, check_finite=True)
    except (ValueError, np.linalg.LinAlgError) as err:
        raise ModelError(f"op: the mass matrix cannot be factored at t = {t} s: {err}") from err
    if np.min(np.abs(np.diag(lu[0]))) <= np.finfo(float).eps * (nu + n_lam) * np.max(np.abs(KKT)):
        raise ModelError(f"op: the mass matrix (with the constraint rows) is singular at t = {t} s; a degenerate "
                         "configuration (a massless body, a singular loop position) has no linearization")
    sol0 = scipy.linalg.lu_solve(lu, np.concatenate([R0, -w0]))
    udot0, lam0 = sol0[:nu], sol0[nu:]
    Rq, Rz, Cz, qdot, Nx, auxdot, Fz, y, Yz = (np.array(v, dtype=float) for v in jac(*args, udot0, lam0))
    n_o, nz = len(origins), nx + ni + nu + n_lam
    Rq, Rz = Rq.reshape(n_o, nu, nq), Rz.reshape(n_o, nu, nz)
    Fz, Yz, Cz = Fz.reshape(na, nz), Yz.reshape(model.n_outputs, nz), Cz.reshape(n_lam, nz)
    Rx_sum = np.concatenate([Rq.sum(axis=0), Rz.sum(axis=0)[:, nq:nx]], axis=1)  # q from the direct Jacobian
    Rin_sum = Rz.sum(axis=0)[:, nx:nx + ni]
    # The rates of the speeds and the multipliers: [u'; lam] = KKT^-1 [Rx, Rin; -Cx, -Cin] [dx; din].
    rhs = np.vstack([np.hstack([Rx_sum, Rin_sum]), -Cz[:, :nx + ni]])
    sol = scipy.linalg.lu_solve(lu, rhs)
    Ux, Uin = sol[:nu, :nx], sol[:nu, nx:]
    Lx, Lin = sol[nu:, :nx], sol[nu:, nx:]
    if n_lam:
        # The multipliers' change is part of the constraint forces' stiffness and damping.
        k = origins.index("constraints")
        Rq[k] += Ac.T @ Lx[:, :nq]
        Rz[k, :, nq:nx + ni] += Ac.T @ np.hstack([Lx[:, nq:], Lin])
        for Z in (Fz, Yz):  # auxiliary rates and outputs through the multipliers
            Z[:, :nx + ni] += Z[:, nx + ni + nu:] @ np.hstack([Lx, Lin])
    Fz, Yz, Rz = Fz[:, :nx + ni + nu], Yz[:, :nx + ni + nu], Rz[:, :, :nx + ni + nu]
    A = np.vstack([Nx.reshape(nq, nx), Ux, Fz[:, :nx] + Fz[:, nx + ni:] @ Ux])
    B = np.vstack([np.zeros((nq, ni)), Uin, Fz[:, nx:nx + ni] + Fz[:, nx + ni:] @ Uin])
    C = Yz[:, :nx] + Yz[:, nx + ni:] @ Ux
    D = Yz[:, nx:nx + ni] + Yz[:, nx + ni:] @ Uin
    f0 = np.concatenate([qdot.reshape(nq), udot0, auxdot.reshape(na)])
    second, stiffness, damping = _second_order(model, np.asarray(x, float), Nx.reshape(nq, nx), M, Rq, Rz, Yz, origins)
    return DirectLinearization(f0, y.reshape(-1), A, B, C, D, second, stiffness, damping, setup_seconds)


def _tangent_basis(model, nq: int, x):
    """``T`` with ``dq = T dd`` (quaternions by their small rotation), its left inverse ``P``
    and the degrees of freedom's names."""
    names = list(model.states[:nq])
    T_cols, P_rows, dofs = [], [], []
    k = 0
    quats = set(model.quaternions)
    while k < nq:
        if k in quats:
            w, v1, v2, v3 = x[k:k + 4]
            # dq = 1/2 q0 (x) [0, theta]: columns of the quaternion product's matrix.
            Xi = 0.5 * np.array([[-v1, -v2, -v3], [w, -v3, v2], [v3, w, -v1], [-v2, v1, w]])
            block = np.zeros((nq, 3))
            block[k:k + 4] = Xi
            T_cols.append(block)
            P_rows.append(block.T * (4.0 / float(np.dot(x[k:k + 4], x[k:k + 4]))))
            stem = names[k][: -len(".qw")]
            dofs += [f"{stem}.rx", f"{stem}.ry", f"{stem}.rz"]
            k += 4
        else:
            e = np.zeros((nq, 1))
            e[k] = 1.0
            T_cols.append(e)
            P_rows.append(e.T)
            dofs.append(names[k])
            k += 1
    T = np.hstack(T_cols) if T_cols else np.zeros((nq, 0))
    P = np.vstack(P_rows) if P_rows else np.zeros((0, nq))
    return T, P, dofs


def _second_order(model, x, Nx, M, Rq, Rz, Yz, origins):
    """The ``SecondOrderSystem`` and the stiffness and damping by origin (module docstring)."""
    b = model.equations.builder
    nq, nu, nx, ni = b.q.numel(), b.u.numel(), model.n_states, model.n_inputs
    T, P, dofs = _tangent_basis(model, nq, x)
    Nq, Nu = Nx[:, :nq], Nx[:, nq:nq + nu]
    # Speeds that no coordinate follows get a coordinate of their own: their integral.
    free = [j for j in range(nu) if not np.any(Nu[:, j])]
    E = np.eye(nu)[free]
    dofs += [f"{model.states[nq + j]}.integral" for j in free]
    Q = np.vstack([P @ Nu, E])
    if Q.shape != (nu, nu) or np.linalg.matrix_rank(Q) < nu:
        raise ModelError(f"the kinematical equations do not map the {nu} speeds one to one onto "
                         f"{Q.shape[0]} degrees of freedom; no second-order form")
    nd = nu
    S = np.zeros((nd, nd))
    S[: T.shape[1], : T.shape[1]] = P @ Nq @ T
    G = np.linalg.solve(Q, np.eye(nu))
    H = -G @ S
    Td = np.zeros((nq, nd))
    Td[:, : T.shape[1]] = T
    Rd = Rq @ Td  # (origins, nu, nd)
    Ru, Ra, Rin = Rz[:, :, nq:nq + nu], Rz[:, :, nq + nu:nx], Rz[:, :, nx:nx + ni]
    stiffness = {o: -G.T @ (Rd[k] + Ru[k] @ H) for k, o in enumerate(origins)}
    damping = {o: -G.T @ Ru[k] @ G for k, o in enumerate(origins)}
    kinematic = G.T @ M @ H
    if np.any(kinematic):
        damping["kinematics"] = kinematic
    M2 = G.T @ M @ G
    D2 = sum(damping.values(), np.zeros((nd, nd)))
    K2 = sum(stiffness.values(), np.zeros((nd, nd)))
    B2 = G.T @ np.hstack([Rin.sum(axis=0), Ra.sum(axis=0)])
    # Outputs: dy = Yq dq + Yu du + Y_aux d_aux + Y_in d_in + Y_udot du', with du' = G d'' + H d'
    # and d'' from the equations of motion.
    Yq, Yu, Ya = Yz[:, :nq], Yz[:, nq:nq + nu], Yz[:, nq + nu:nx]
    Yin, Yud = Yz[:, nx:nx + ni], Yz[:, nx + ni:]
    accel = Yud @ G @ np.linalg.solve(M2, np.hstack([K2, D2, B2])) if Yud.size else np.zeros((Yz.shape[0], 2 * nd + B2.shape[1]))
    Cq = Yq @ Td + Yu @ H - accel[:, :nd]
    Cv = Yu @ G + Yud @ H - accel[:, nd:2 * nd]
    Du = np.hstack([Yin, Ya]) + accel[:, 2 * nd:]
    second = SecondOrderSystem(M2, D2, K2, B2, Cq, Cv, Du, dofs=dofs,
                               inputs=list(model.inputs) + list(model.states[nq + nu:]), outputs=model.outputs)
    return second, MappingProxyType({k: frozen_array(v) for k, v in stiffness.items()}), \
        MappingProxyType({k: frozen_array(v) for k, v in damping.items()})




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
    dofs: tuple


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
