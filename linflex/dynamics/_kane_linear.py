"""Kane's equations of a compiled scene and their direct linearization (arrays in, arrays out).

:class:`KaneEquations` holds what the builder (:mod:`._kane`) assembled; its
:meth:`~KaneEquations.linearization` linearizes Kane's equations directly (Banerjee 2016, section
1.4): the first-order and second-order forms and the stiffness and damping split by origin.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import casadi as ca
import numpy as np
import scipy.linalg

from ..system._errors import ModelError
from ..system._linear import SecondOrderSystem
from ..system._signals import frozen_array, real_vector

__all__ = ["KaneEquations", "KaneLinearization"]


@dataclass(frozen=True, eq=False)
class KaneEquations:
    """The symbolic equations of a compiled scene: what Kane's direct linearization works on.

    ``builder`` holds the coordinates ``q``, speeds ``u``, their rates ``udot`` (a symbol),
    the kinematical equations ``qdot`` and the loads; ``x`` is the state vector ``(q, u,
    auxiliary states)``, ``inputs`` and ``params`` the input and parameter vectors, ``y`` the
    outputs (with ``udot`` still symbolic) and ``auxdot`` the rates of the auxiliary states;
    ``loop`` the scene's loop closure (:class:`linflex.dynamics._constraints.LoopClosure`) or None.
    """

    builder: Any
    x: Any
    inputs: Any
    params: Any
    y: Any
    auxdot: Any
    loop: Any = None
    # The CasADi functions of the direct and of the premature linearization, built on first
    # use by :meth:`linearization` and kept with the equations they come from (a cache: it
    # never changes a result).
    _functions: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @property
    def state_names(self) -> tuple[str, ...]:
        """The names of ``x``: coordinates, speeds, then auxiliary states."""
        b = self.builder
        return tuple(b.q_names + b.u_names + b.aux_names)

    @property
    def quaternions(self) -> tuple[int, ...]:
        """Indices in ``x`` of the scalar part of each quaternion (the ``<joint>.qw`` coordinates)."""
        return tuple(k for k, name in enumerate(self.builder.q_names) if name.endswith(".qw"))

    def linearization(self, x, u, p, t: float, *, premature: bool = False) -> KaneLinearization:
        """Kane's direct linearization at ``(x, u, p, t)``: first- and second-order forms, by origin.

        Kane's equations ``F_r + F_r* = 0`` are sums of loads and inertia forces projected on
        the partial velocities ``V_r(q)``. Linearizing them directly (Banerjee 2016, section
        1.4, Eqs. 1.63-1.65; reference notes section 3.1) keeps the first-order terms of both
        factors::

            d(V^T F) = V(q0)^T dF  +  (dV/dq dq)^T F(q0)
                       '----------'   '--------------'
                       premature       lost by premature linearization (motion-induced stiffness)

        so the linear equations come straight from the partial velocities, velocities and
        accelerations, without differentiating the solved state derivative. Each load keeps
        its origin (the effect that added it, ``"actuators"``, ``"structure"``, ...), and the
        inertia forces theirs (``"inertia"``: centrifugal, Coriolis and gyroscopic terms;
        ``"geometric_stiffness"``), so stiffness and damping split by origin for free.

        Parameters
        ----------
        x : array_like, shape (n_states,)
            The state ``(q, u, auxiliary states)`` [state units].
        u : array_like, shape (n_inputs,)
            The inputs [input units].
        p : array_like, shape (n_params,)
            Values of the exposed parameters [parameter units].
        t : float
            Time [s].
        premature : bool
            Evaluate every partial velocity at the nominal coordinates (partials of the
            linearized velocities, Eqs. 1.66-1.67): premature linearization, which loses the
            motion-induced stiffness unless the scene has the ``geometric_stiffness`` effect;
            for showing that error.

        Returns
        -------
        KaneLinearization
            Numpy arrays at the point; built CasADi functions are kept on these equations
            (``setup_seconds`` is 0 from the second call on).

        Raises
        ------
        ShapeError
            For ``x``, ``u`` or ``p`` of the wrong length (or not finite).
        ModelError
            When the mass matrix (with loop joints: the saddle-point matrix of the mass matrix
            and the constraint rows) is singular at the point, or the kinematical equations do
            not map the speeds one to one onto degrees of freedom.

        Notes
        -----
        With loop joints the multipliers ``lam`` of the independent constraint rows are
        unknowns beside ``u'``: the constraint forces ``A(q)^T lam`` are one more origin
        (``"constraints"``) and the constraints ``A u' + w(q, u) = 0`` (Baumgarte-stabilized,
        as compiled) close the system (Banerjee 2016, Eqs. 1.90-1.95). Non-holonomic contacts
        (``scene.constraints``) are rows of the same kind (their ``A`` not the rate of a position
        Jacobian); ``linflex.linearize.constrained_linearization(model, method="kane")``
        restricts the result to the independent speeds, which is Kane's form with the dependent
        speeds eliminated (the multipliers drop out on the constraints' null space).

        Second-order form. With the kinematical equations linearized, ``dq' = Nq dq + Nu du``,
        the degrees of freedom ``d`` are the coordinates, with each quaternion replaced by its
        small rotation in body axes (``dq = 1/2 q0 (x) [0, d_theta]``), plus the integral of
        every speed that no coordinate follows (a wheel's speed). ``du = G d' + H d`` then
        gives, premultiplied by ``G^T`` so that ``M`` stays symmetric::

            G^T M G d'' + G^T (M H - Ru G) d' - G^T (Rq T + Ru H) d = G^T [R_in  R_aux] [d_in; d_aux]

        with ``R* = dR/d*`` the Jacobians of the generalized forces at the operating point.
        For joint angles, positions and modal coordinates ``G = I`` and ``H = 0``.

        Examples
        --------
        The spinning-table bar of the reference notes (section 3.3): spring 1 and centrifugal
        stiffness 4 [N m/rad], unit inertia [kg m^2].

        >>> import numpy as np
        >>> from linflex import Body, Joint, Scene, compile_model
        >>> bar = Scene("table", effects=["joint_springs"],
        ...             bodies=[Body("table", 10.0, (1, 1, 1)), Body("bar", 1.0, (0, 0, 0), com=[1.0, 0, 0])],
        ...             joints=[Joint("spin", "revolute", "table", prescribed={"profile": "ramp", "rate": 2.0}),
        ...                     Joint("hinge", "revolute", "bar", parent="table", parent_point=[1.0, 0, 0],
        ...                           stiffness=1.0)])
        >>> model = compile_model(bar)
        >>> lin = model.equations.linearization(model.x0, np.zeros(0), model.param_values, 0.0)
        >>> lin.second_order.M.tolist(), lin.second_order.K.tolist()
        ([[1.0]], [[5.0]])
        >>> {k: v.tolist() for k, v in lin.stiffness.items()}
        {'joint_springs': [[1.0]], 'inertia': [[4.0]]}
        """
        x = real_vector(x, "x", self.x.numel())
        u = real_vector(u, "u", self.inputs.numel())
        p = real_vector(p, "p", self.params.numel())
        if not np.isfinite(t):
            raise ModelError(f"t must be a finite time in seconds, got {t!r}")
        return _kane_linearization(self, x, u, p, float(t), bool(premature))


# -- Kane's direct linearization (KaneEquations.linearization) ----------------------------------


@dataclass(frozen=True)
class KaneLinearization:
    """Kane's direct linearization at a point (:meth:`KaneEquations.linearization`), numpy arrays.

    Deviation variables throughout: ``dx = x - x0`` and so on.

    Attributes
    ----------
    f0 : ndarray, shape (n_states,)
        The state derivative at the point [state units/s].
    y0 : ndarray, shape (n_outputs,)
        The outputs at the point [output units].
    A, B, C, D : ndarray
        The first-order Jacobians ``df/dx``, ``df/du``, ``dh/dx``, ``dh/du`` (read-only).
    second_order : SecondOrderSystem
        ``M d'' + D d' + K d = B [du; d_aux]`` with its outputs, in the degrees of freedom
        ``d`` (``second_order.dofs``: coordinates, ``<joint>.rx/ry/rz`` [rad] for each
        quaternion's small rotation in body axes, ``<speed>.integral`` for a speed that no
        coordinate follows); its inputs are the model's inputs then its auxiliary states.
    stiffness, damping : Mapping of str to ndarray, shape (n_dofs, n_dofs)
        ``second_order.K`` and ``.D`` split by origin (they sum to them): ``"inertia"``,
        ``"geometric_stiffness"``, ``"structure"``, each effect's name, ``"actuators"``,
        ``"disturbances"``, ``"constraints"`` (loop joints, contacts), ``"kinematics"`` (damping from the
        kinematical equations), in [generalized force per dof unit] and [generalized force per
        dof rate], e.g. [N m/rad] and [N m s/rad] for a rotation.
    setup_seconds : float
        Time spent building the CasADi functions for this call [s] (0 when they were built).
    """

    f0: np.ndarray
    y0: np.ndarray
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    second_order: SecondOrderSystem
    stiffness: Mapping[str, np.ndarray]
    damping: Mapping[str, np.ndarray]
    setup_seconds: float


def _kane_functions(eq: KaneEquations, premature: bool):
    """The two CasADi functions of the direct (or premature) linearization, and their build time [s]."""
    if premature in eq._functions:
        return eq._functions[premature], 0.0
    start = time.perf_counter()
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
    eq._functions[premature] = (origins, n_lam, force, jac)
    return eq._functions[premature], time.perf_counter() - start


def _kane_linearization(eq: KaneEquations, x, u, p, t: float, premature: bool) -> KaneLinearization:
    (origins, n_lam, force, jac), setup_seconds = _kane_functions(eq, premature)
    b = eq.builder
    nq, nu, nx, ni = b.q.numel(), b.u.numel(), eq.x.numel(), eq.inputs.numel()
    na, n_out = nx - nq - nu, eq.y.numel()
    qbar = x[:nq]
    args = [x, u, p, t, qbar]
    R0, M, Ac, w0 = (np.array(v, dtype=float) for v in force(*args, np.zeros(nu), np.zeros(n_lam)))
    R0, M, Ac, w0 = R0.reshape(nu), M.reshape(nu, nu), Ac.reshape(n_lam, nu), w0.reshape(n_lam)
    # M u' - A^T lam = R0, A u' = -w: the saddle-point matrix (M alone without constraints).
    KKT = np.block([[M, -Ac.T], [Ac, np.zeros((n_lam, n_lam))]])
    try:
        lu = scipy.linalg.lu_factor(KKT, check_finite=True)
    except (ValueError, np.linalg.LinAlgError) as err:
        raise ModelError(f"op: the mass matrix cannot be factored at t = {t} s: {err}") from err
    if np.min(np.abs(np.diag(lu[0])), initial=np.inf) <= np.finfo(float).eps * (nu + n_lam) * np.max(np.abs(KKT), initial=0.0):
        raise ModelError(f"op: the mass matrix (with the constraint rows) is singular at t = {t} s; a degenerate "
                         "configuration (a massless body, a singular loop position) has no linearization")
    sol0 = scipy.linalg.lu_solve(lu, np.concatenate([R0, -w0]))
    udot0, lam0 = sol0[:nu], sol0[nu:]
    Rq, Rz, Cz, qdot, Nx, auxdot, Fz, y, Yz = (np.array(v, dtype=float) for v in jac(*args, udot0, lam0))
    n_o, nz = len(origins), nx + ni + nu + n_lam
    Rq, Rz = Rq.reshape(n_o, nu, nq), Rz.reshape(n_o, nu, nz)
    Fz, Yz, Cz = Fz.reshape(na, nz), Yz.reshape(n_out, nz), Cz.reshape(n_lam, nz)
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
    Nx = Nx.reshape(nq, nx)
    A = np.vstack([Nx, Ux, Fz[:, :nx] + Fz[:, nx + ni:] @ Ux])
    B = np.vstack([np.zeros((nq, ni)), Uin, Fz[:, nx:nx + ni] + Fz[:, nx + ni:] @ Uin])
    C = Yz[:, :nx] + Yz[:, nx + ni:] @ Ux
    D = Yz[:, nx:nx + ni] + Yz[:, nx + ni:] @ Uin
    f0 = np.concatenate([qdot.reshape(nq), udot0, auxdot.reshape(na)])
    second, stiffness, damping = _kane_second_order(eq, x, Nx, M, Rq, Rz, Yz, origins)
    return KaneLinearization(frozen_array(f0), frozen_array(y.reshape(-1)), frozen_array(A), frozen_array(B),
                             frozen_array(C), frozen_array(D), second, stiffness, damping, setup_seconds)


def _tangent_basis(eq: KaneEquations, x):
    """``T`` with ``dq = T dd`` (quaternions by their small rotation), its left inverse ``P``
    and the degrees of freedom's names."""
    names = list(eq.builder.q_names)
    nq = len(names)
    T_cols, P_rows, dofs = [], [], []
    k = 0
    quats = set(eq.quaternions)
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


def _kane_second_order(eq: KaneEquations, x, Nx, M, Rq, Rz, Yz, origins):
    """The ``SecondOrderSystem`` and the stiffness and damping by origin (see ``linearization``)."""
    b = eq.builder
    nq, nu, nx, ni = b.q.numel(), b.u.numel(), eq.x.numel(), eq.inputs.numel()
    states = eq.state_names
    T, P, dofs = _tangent_basis(eq, x)
    Nq, Nu = Nx[:, :nq], Nx[:, nq:nq + nu]
    # Speeds that no coordinate follows get a coordinate of their own: their integral.
    free = [j for j in range(nu) if not np.any(Nu[:, j])]
    E = np.eye(nu)[free]
    dofs += [f"{states[nq + j]}.integral" for j in free]
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
    accel = (Yud @ G @ np.linalg.solve(M2, np.hstack([K2, D2, B2])) if Yud.size
             else np.zeros((Yz.shape[0], 2 * nd + B2.shape[1])))
    Cq = Yq @ Td + Yu @ H - accel[:, :nd]
    Cv = Yu @ G + Yud @ H - accel[:, nd:2 * nd]
    Du = np.hstack([Yin, Ya]) + accel[:, 2 * nd:]
    second = SecondOrderSystem(M2, D2, K2, B2, Cq, Cv, Du, dofs=dofs,
                               inputs=list(b.in_names) + list(states[nq + nu:]), outputs=list(b.out_names))
    return (second, MappingProxyType({k: frozen_array(v) for k, v in stiffness.items()}),
            MappingProxyType({k: frozen_array(v) for k, v in damping.items()}))
