"""Order-n formulation: Kane's equations solved by an articulated-body recursion.

``compile_model(scene, formulation="order-n")`` builds the same scene (coordinates, speeds,
loads, outputs, monitors) as the dense formulation and differs only in how ``M u' = rhs`` is
solved:

* ``rhs = g - J^T c`` (generalized active forces minus the velocity terms of the generalized
  inertia forces) is formed without the partial-velocity matrix ``J``: ``J^T v`` is a
  reverse-mode directional derivative (``casadi.jtimes(..., tr=True)``), whose graph is a fixed
  multiple of the kinematics graph, which is linear in the number of bodies. Every effect that
  only adds loads (joint springs and dampers, gravity, actuators, disturbances, thrusters,
  surfaces, orbit gravity) therefore enters exactly as in the dense formulation.
* ``u' = M^{-1} rhs`` comes from the backward articulated-inertia pass and the forward
  acceleration pass of Banerjee's block-diagonal algorithm (reference notes, sections 8.4-8.5,
  Eqs. 8.28-8.33 and 8.49-8.51; 9.2 for the one-axis rigid case) with the generalized force
  ``rhs_i`` as the hinge load of the joint that owns speed ``i`` and no remainder accelerations
  (they are in ``rhs`` already). Each body costs a fixed number of 6x6 products and one scalar
  division (a k x k solve for a joint with k speeds), so the graph, built as SX, grows linearly
  (no dense ``n x n`` solve). The inertia part of the backward pass does not depend on the
  loads, so :func:`order_n_solver` forms it once and runs the load part and the forward pass on
  several columns of generalized forces at once: loop joints (Lagrange multipliers, reference
  notes 8.7) need ``M^-1 [rhs, A^T]``, one extra column per independent constraint row
  (Eq. 8.81), then a small solve for the multipliers.

Per body ``j`` (reference point: the origin of the body frame, body axes), with its parent ``p``,
the joint rotation ``C = C_pj`` and ``r_PQ`` the body origin from the parent origin (parent
axes)::

    V_j = W_j V_p + R_j u_j        W_j = [ C^T   -C^T skew(r_PQ) ]
                                         [ 0      C^T            ]
    revolute about a (child point cp):  R_j = [ -a x cp ; a ]
    prismatic along a:                  R_j = [ a ; 0 ]
    fixed, locked or prescribed:        no column (its motion is in rhs)
    free, spherical (speeds: translation rates in parent axes, the child's inertial angular
    velocity in child axes):            R_j = [ C^T e_x.. (moving translations)  skew(cp) ; 0  I3 ]
                                        and W_j without its rotational rows (the speed is absolute)

    backward (leaves first):  U = M R,  nu = R^T U  (k x k for k speeds),
                              Ma = M - U nu^-1 U^T,  Xa = X + U nu^-1 (tau - R^T X)
                              M_p += W^T Ma W,      X_p += W^T Xa
    forward (root first):     e = W A_p,  u_j' = nu^-1 (tau - U^T e - R^T X),  A_j = e + R u_j'

Flexible bodies: linflex hangs a flexible body's children on its frame (not on a node), so the
modal rates couple only into the body's own rows. Its modal-integral mass matrix in the speeds
``(v, w, eta')`` is split as ``[M1 M2; G E]`` (``G = M2^T`` unless ``geometric_stiffness`` adds
acceleration terms to the modal rows, which makes the articulated inertias unsymmetric: then
``R^T M`` is formed explicitly), and the modal accelerations are condensed before the hinge
(Eq. 8.28)::

    M3 = M1 - M2 E^-1 G,   X3 = X + M2 E^-1 tau_eta;   forward: eta'' = E^-1 (tau_eta - G A_j)

Parts that move relative to their body (the rotor of a wheel under ``wheel_gyroscopics``, a
wheel at a node of a flexible body, a ``slosh`` bob, a ``dampers`` mass) are sub-bodies:
children of their host body with ``k`` speeds of their own (``k = 0`` for a wheel at a constant
rate or locked, 1 for a torque-mode wheel or a damper, 2 for a pendulum). Their velocity terms
are in ``rhs`` like any element's. A part's partial velocities are those of its host's extended
speeds ``z_h = (V_h, eta_h')`` (with the modal rates of a flexible host: a wheel at a node moves
with ``Phi eta`` and turns with the node's exact rotation of :meth:`KaneBuilder.node_frame`)
transferred to the part, plus local columns in the host's modal rates and the part's own
speeds, read off the part's own velocity expressions by one Jacobian with respect to those
local speeds only (``_part_inertias``). Its kinetic energy ``1/2 z^T K z`` in
``z = (z_h, u_s)`` then gives a local condensation, the articulated-body step of a joint
(Eqs. 8.28-8.33 with ``R = [0; I_k]``)::

    K = [Khh Khs; Ksh Kss]   backward: M_h += Khh - Khs Kss^-1 Ksh,  X_h += Khs Kss^-1 tau_s
                             forward:  u_s' = Kss^-1 (tau_s - Ksh [A_h; eta_h''])

(the modal rows of a flexible host take their share before the modal condensation). Each part
costs a fixed number of operations and one k x k solve, so the graph stays linear in the
number of bodies and parts.

Supported: trees of every joint type (revolute, prismatic, fixed, free, spherical; locked and
prescribed coordinates included) of rigid and flexible bodies, with any effect that only adds
loads, geometric stiffness, and the moving parts of the built-in effects above (and massless
rotors at a constant rate relative to their body from any effect). Parts of other effects
(an element moving relative to its body, or a speed, that no built-in effect declared) raise
:class:`~linflex.ModelError`: their motion relative to the body is not known to the recursion.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from ..scene._values import profile_function, vector3
from ..system._errors import ModelError
from ._kane import KaneBuilder, composite_mass, quat_to_dcm, rot_axis, skew

__all__ = ["FORMULATIONS", "order_n_solver", "order_n_support"]

FORMULATIONS = ("dense", "order-n")

_JOINTS = ("revolute", "prismatic", "fixed", "spherical", "free")


def order_n_support(scene, b: KaneBuilder | None = None) -> list[str]:
    """What in ``scene`` (and in the builder's parts, once built) the order-n formulation does
    not support yet, one ``"path: reason"`` line per problem; empty when supported."""
    problems = []
    for i, j in enumerate(scene.joints):
        if j.type not in _JOINTS:
            problems.append(f"joints[{i}] ({j.name!r}): {j.type!r} joints are not supported by order-n yet "
                            f"(supported: {', '.join(_JOINTS)})")
    if b is not None:
        problems += _parts(scene, b)[1]
    return problems


@dataclass
class _Part:
    """A part that moves relative to its host body: a sub-body hanging off the host (off the
    host's modal motion too for a part at a node of a flexible body) with ``speeds`` of its own
    (indices into the builder's speeds; none for a wheel at a constant rate or a locked one)."""

    host: str
    elements: list
    speeds: list[int]


def _parts(scene, b: KaneBuilder) -> tuple[list[_Part], list[str]]:
    """The parts the built-in effects add (wheel rotors and node wheels of ``wheel_gyroscopics``
    and ``_add_node_wheels``, ``slosh`` bobs, ``dampers`` masses), massless rotors at a constant
    rate of any effect, and one problem line per element or speed that is none of these."""
    known: dict[str, tuple[str, list[str]]] = {}  # element name -> (host body, own speed names)
    for w in scene.wheels:
        speeds = [f"{w.name}.speed"] if f"{w.name}.speed" in b.u_names else []
        known[f"{w.name}.wheel" if w.node is not None else f"{w.name}.rotor"] = (w.body, speeds)
    for p in scene.pendulums:
        if p.name in b.pendulum_speeds:
            known[p.name] = (p.body, [f"{p.name}.rate1", f"{p.name}.rate2"])
    for d in scene.springs:
        if d.name in b.damper_coordinates:
            known[d.name] = (d.body, [f"{d.name}.speed"])
    bodies = set(b.frames)
    parts, problems = [], []
    for el in b.elements:
        if el.name in bodies and el.body == el.name:  # a body's composite
            continue
        host, speeds = known.get(el.name, (None, []))
        if host is not None and el.body == host and host in bodies:
            parts.append(_Part(host, [el], [b.u_names.index(n) for n in speeds]))
        elif _is_constant_rotor(b, el):
            parts.append(_Part(el.body, [el], []))
        else:
            problems.append(f"element {el.name!r}: a part moving relative to its body that no built-in effect "
                            "declared (order-n supports the parts of wheel_gyroscopics, slosh and dampers and "
                            "wheels at nodes) is not supported by order-n yet")
    for me in b.materials:
        problems.append(f"material {me.name!r}: material moving through its body (a deploying boom) is not "
                        "supported by order-n yet")
    joint_speeds = set(b.joint_speed_names.values())
    joint_speeds.update(n for j in scene.joints if j.type in ("free", "spherical") for n in _ball_speed_names(j))
    joint_speeds.update(f"{fe.name}.eta{k}_rate" for fe in b.flexible for k in range(fe.data.n_modes))
    joint_speeds.update(b.u_names[i] for p in parts for i in p.speeds)
    extra = [n for n in b.u_names if n not in joint_speeds]
    if extra:
        problems.append(f"speeds {extra}: only the speeds of joints, modes and the parts of built-in effects are "
                        "supported by order-n yet")
    return parts, problems


def _is_constant_rotor(b: KaneBuilder, el) -> bool:
    """A massless rotor spinning at a constant rate relative to its body: its angular velocity
    is the body's plus a constant, so its partial angular velocities are the body's."""
    frame = b.frames.get(el.body)
    if frame is None or el.C is not frame.C or el.has_mass:
        return False
    return not ca.depends_on(el.w - frame.w, b.u) if b.u.numel() else True


def _part_inertias(b: KaneBuilder, parts: list[_Part], modal: dict[str, list[int]]) -> list[Any]:
    """For each part, the matrix ``K`` of its kinetic energy ``1/2 z^T K z`` in the speeds
    ``z = (V_h, eta_h', u_s)``: its host's spatial velocity (body origin, body axes), the host's
    modal rates (flexible hosts only) and its own speeds.

    Each element ``e`` of the part moves with the host plus a local motion in the host's modal
    coordinates and the part's own coordinates, so its partial velocities are those of the
    host, transferred, plus local columns::

        v_e = [ U3  -skew(rho_e)  C_h^T dv_e/d(eta', u_s) ] z     rho_e = C_h^T (r_e - r_h)
        w_e = [ 0    C_eh^T       dw_e/d(eta', u_s)       ] z     C_eh = C_h^T C_e

        K = sum_e m_e Tv^T Tv + Tw^T I_e Tw

    The local columns are one Jacobian of all parts' velocities with respect to the local speeds
    only (each row depends on a few of them, so its graph is a fixed multiple of the parts').
    """
    masses = [(k, el) for k, p in enumerate(parts) for el in p.elements if el.has_mass]
    rotors = [(k, el) for k, p in enumerate(parts) for el in p.elements if el.has_inertia]
    local = sorted({i for p in parts for i in modal.get(p.host, []) + p.speeds})
    column = {i: c for c, i in enumerate(local)}
    rows = ([b.rate(ca.vertcat(*[el.r for _, el in masses]))] if masses else []) + [el.w for _, el in rotors]
    J = ca.jacobian(ca.vertcat(*rows), ca.vertcat(*[b.u[i] for i in local])) if rows and local else None

    def local_columns(k, r):
        cols = [column[i] for i in modal.get(parts[k].host, []) + parts[k].speeds]
        return J[r: r + 3, cols] if cols else ca.SX(3, 0)

    sizes = [6 + len(modal.get(p.host, [])) + len(p.speeds) for p in parts]
    K = [ca.SX(n, n) for n in sizes]
    for r, (k, el) in enumerate(masses):
        frame = b.frames[parts[k].host]
        Ct = frame.C.T
        rho = Ct @ (el.r - frame.r)
        Tv = ca.horzcat(ca.SX.eye(3), -skew(rho), Ct @ local_columns(k, 3 * r))
        K[k] = K[k] + el.mass * (Tv.T @ Tv)
    offset = 3 * len(masses)
    for r, (k, el) in enumerate(rotors):
        frame = b.frames[parts[k].host]
        C_eh = ca.SX.eye(3) if el.C is frame.C else frame.C.T @ el.C
        Tw = ca.horzcat(ca.SX(3, 3), C_eh.T, local_columns(k, offset + 3 * r))
        K[k] = K[k] + Tw.T @ (ca.SX(el.I) @ Tw)
    return K


def _composite(b: KaneBuilder, body: str):
    """Mass, mass centre (body axes) and central inertia of the body and its rigid attachments,
    as :meth:`KaneBuilder.finalize_kinematics` forms them, in SX."""
    data = composite_mass(list(b.attachments.get(body, {}).values()))
    if data is None:
        return None
    m, com, inertia = data
    return ca.SX(m), ca.SX(com), ca.SX(ca.DM(inertia)) if isinstance(inertia, np.ndarray) else inertia


def _spatial_inertia(b: KaneBuilder, body: str):
    """6x6 inertia about the body origin in body axes, ``(v; w)`` ordering (composite rigid
    body)."""
    data = _composite(b, body)
    if data is None:
        return ca.SX(6, 6)
    m, c, Ic = data
    ct = skew(c)
    return ca.blockcat([[m * ca.SX.eye(3), -m * ct], [m * ct, Ic - m * (ct @ ct)]])


def _rhs(b: KaneBuilder, terms: dict):
    """``g - J^T c`` of :meth:`KaneBuilder.assemble_parts`, with every ``J^T v`` a reverse-mode
    directional derivative instead of a product with the partial-velocity matrix."""
    n = b.u.numel()
    wF = ca.DM(b.w_F)
    masses = [el for el in b.elements if el.has_mass]
    rotors = [el for el in b.elements if el.has_inertia]
    rhs = ca.SX.zeros(n, 1)
    for extra in b.generalized:
        rhs += extra
    forces, torques = b._forces, b._torques
    points = [el.r for el in masses] + [r for r, _ in forces]
    if points:
        R = ca.vertcat(*points)
        Rdot = b.rate(R)
        k = len(masses)
        seeds = []
        if k:
            Rm3, Rdm3 = ca.reshape(R[: 3 * k], 3, k), ca.reshape(Rdot[: 3 * k], 3, k)
            a_t = b.rate(Rdot[: 3 * k]) + ca.vec(2 * skew(wF) @ Rdm3 + skew(wF) @ (skew(wF) @ Rm3))
            mvec = ca.vertcat(*[ca.repmat(ca.SX(el.mass), 3, 1) for el in masses])
            seeds.append(-mvec * a_t)
        seeds += [f for _, f in forces]
        rhs += ca.jtimes(Rdot, b.u, ca.vertcat(*seeds), True)
    rates = [el.w for el in rotors] + [w for w, _ in torques]
    if rates:
        W = ca.vertcat(*rates)
        k = len(rotors)
        seeds = []
        if k:
            alpha_t = b.rate(W[: 3 * k])
            gyro = [ca.cross(el.w if el.w_axes is None else el.w_axes, ca.SX(el.I) @ el.w) for el in rotors]
            Iw = ca.vertcat(*[ca.SX(el.I) @ alpha_t[3 * i: 3 * i + 3] for i, el in enumerate(rotors)])
            seeds.append(-(Iw + ca.vertcat(*gyro)))
        seeds += [t for _, t in torques]
        rhs += ca.jtimes(W, b.u, ca.vertcat(*seeds), True)
    if b.flexible:
        # J_f^T (M_f U_t + C_f) of the flexible bodies, U_t = dU/dt at u' = 0 (assemble_parts),
        # all bodies in one forward and one reverse sweep (per-body sweeps would each cover the
        # body's ancestors: a graph quadratic in the number of bodies).
        U = ca.vertcat(*[t[0] for t in terms.values()])
        Ut = b.rate(U)
        seeds, k = [], 0
        for U_f, M_f, C_f in terms.values():
            m = U_f.numel()
            seeds.append(M_f @ Ut[k: k + m] + C_f)
            k += m
        rhs -= ca.jtimes(U, b.u, ca.vertcat(*seeds), True)
    return rhs


def _flexible_terms(b: KaneBuilder) -> dict:
    """``{body: (U, M_f, C_f)}`` as :meth:`FlexibleElement.terms` forms them, with the frame
    velocities of all flexible bodies from one forward sweep."""
    from ._flexible import flexible_body_terms

    wF = ca.DM(b.w_F)
    r = ca.vertcat(*[fe.frame.r for fe in b.flexible])
    rdot = b.rate(r)
    out = {}
    for k, fe in enumerate(b.flexible):
        v_scene = rdot[3 * k: 3 * k + 3] + ca.cross(wF, fe.frame.r)
        U = ca.vertcat(fe.frame.C.T @ v_scene, fe.frame.w, fe.qd)
        M_f, C_f = flexible_body_terms(fe.data, fe.q, U[0:3], U[3:6], fe.qd, geometric_stiffness=fe.geometric)
        out[fe.name] = (U, M_f, C_f)
    return out


_XYZ = ("x", "y", "z")


def _ball_speed_names(j) -> list[str]:
    from ..scene._check import locked_translations

    moving = [c for c in _XYZ if c not in set(locked_translations(j))] if j.type == "free" else []
    return [f"{j.name}.v{c}" for c in moving] + [f"{j.name}.w{c}" for c in _XYZ]


def _ball_geometry(b: KaneBuilder, j):
    """``(W_j, R_j, speed indices)`` of a free or spherical joint (``_build_tree``'s speeds:
    translation rates in parent axes, then the child's inertial angular velocity in child
    axes). The angular velocity is absolute, so the parent's motion does not enter the child's
    (zero rotational rows of ``W``; reference notes 8.8)::

        v_j = C^T (v_p + w_p x d) + C^T d' + skew(cp) w_j,   d = parent_point + translation
    """
    names = _ball_speed_names(j)
    index = [b.u_names.index(n) for n in names]
    qi = {n: k for k, n in enumerate(b.q_names)}
    quat = ca.vertcat(*[b.q[qi[f"{j.name}.q{c}"]] for c in ("w", "x", "y", "z")])
    C = quat_to_dcm(quat)
    q0 = np.array([0, 0, 0, 1, 0, 0, 0.0]) if j.q0 is None else np.asarray(j.q0, float)
    trans = ca.SX.zeros(3, 1)
    moving = [n[len(j.name) + 2:] for n in names if n.startswith(f"{j.name}.v")]
    if j.type == "free":
        trans = ca.vertcat(*[b.q[qi[f"{j.name}.{c}"]] if c in moving else ca.SX(q0[i]) for i, c in enumerate(_XYZ)])
    d = ca.DM(vector3(j.parent_point)) + trans
    cp = ca.DM(vector3(j.child_point))
    Ct = C.T
    W = ca.blockcat([[Ct, -Ct @ skew(d)], [ca.SX(3, 3), ca.SX(3, 3)]])
    cols = [ca.vertcat(Ct[:, _XYZ.index(c)], ca.SX.zeros(3, 1)) for c in moving]
    R = ca.horzcat(*cols, ca.vertcat(ca.SX(skew(cp)), ca.SX.eye(3)))
    return W, R, index


def _joint_geometry(b: KaneBuilder, j):
    """``(C_pj, r_PQ, R_j or None, speed index or None)`` of a joint, as in ``_build_tree``."""
    axis = vector3(j.axis) / np.linalg.norm(vector3(j.axis))
    pp, cp = ca.DM(vector3(j.parent_point)), ca.DM(vector3(j.child_point))
    if j.type == "fixed":
        return ca.SX.eye(3), pp - cp, None, None
    index = None
    if j.name in b.joint_speeds:
        coord = b.joint_speeds[j.name][0]
        index = b.u_names.index(b.joint_speed_names[j.name])
    elif j.locked:
        coord = ca.SX(0.0 if j.q0 is None else float(np.ravel(j.q0)[0]))
    else:
        coord = ca.SX(profile_function(j.prescribed)(b.t))
    a = ca.DM(axis)
    if j.type == "revolute":
        C = rot_axis(axis, coord)
        R = ca.vertcat(-ca.cross(a, cp), a)
        r_PQ = pp - C @ cp
    else:
        C = ca.SX.eye(3)
        R = ca.vertcat(a, ca.DM.zeros(3, 1))
        r_PQ = pp + a * coord - cp
    return C, r_PQ, (R if index is not None else None), index


def order_n_solver(scene, b: KaneBuilder, joints):
    """``(rhs, solve)``: Kane's ``rhs = g - J^T c`` and ``solve(T) = M^-1 T`` for an SX matrix
    ``T`` (n x c) of generalized forces, by the articulated-body recursion; ``u' = solve(rhs)``.

    ``joints`` in the order of ``_build_tree`` (parents before children).

    The articulated inertias do not depend on the loads, so they are formed once (backward
    pass, inertia part); ``solve`` runs the load part of the backward pass and the forward pass
    on all ``c`` columns at once (loop closures solve ``M^-1 [rhs, A^T]`` this way, Eq. 8.81).
    Raises :class:`~linflex.ModelError` listing what order-n does not support in the scene.
    """
    parts, problems = _parts(scene, b)
    problems = order_n_support(scene) + problems
    if problems:
        raise ModelError(f"scene {scene.name!r}: formulation='order-n' does not support:\n  "
                         + "\n  ".join(problems) + "\n(use formulation='dense')")
    terms = _flexible_terms(b)
    rhs = _rhs(b, terms)
    n = b.u.numel()
    M = {j.child: _spatial_inertia(b, j.child) for j in joints}
    # Flexible bodies (frame-attached children, so no modal coupling N_j to them): the body's
    # modal-integral mass matrix about its frame origin, in the speeds (v, w, eta'), split as
    # [M1 M2; G E] (G = M2^T unless the geometric stiffness adds its acceleration terms).
    flexible = {}
    for fe in b.flexible:
        _, M_f, _ = terms[fe.name]
        m6 = M_f.shape[0] - 6
        M[fe.name] = M[fe.name] + M_f[:6, :6]
        index = [b.u_names.index(f"{fe.name}.eta{k}_rate") for k in range(m6)]
        flexible[fe.name] = [M_f[:6, 6:], M_f[6:, :6], M_f[6:, 6:], index]
    # Parts with speeds of their own (sub-bodies of their host, Eqs. 8.28-8.33 with the host's
    # extended speeds z_h = (V_h, eta_h') in place of the parent's V): their own accelerations
    # are condensed into the host, which then sees the articulated inertia and load
    #
    #     K = [Khh Khs; Ksh Kss]:  Ma = Khh - Khs Kss^-1 Ksh,  Xa = Khs Kss^-1 tau_s
    #     forward:                 u_s' = Kss^-1 (tau_s - Ksh [A_h; eta_h''])
    #
    # (a k x k solve, k <= 2). A part without own speeds adds K to its host.
    moving = []  # (part, Khs, Kss) of the parts with speeds
    modal = {name: f[3] for name, f in flexible.items()}
    for part, K in zip(parts, _part_inertias(b, parts, modal)):
        nh = K.shape[0] - len(part.speeds)
        Ma = K[:nh, :nh]
        if part.speeds:
            Khs, Kss = K[:nh, nh:], K[nh:, nh:]
            Ma = Ma - ((Khs @ Khs.T) / Kss if len(part.speeds) == 1 else Khs @ ca.solve(Kss, Khs.T))
            moving.append((part, Khs, Kss))
        M[part.host] = M[part.host] + Ma[:6, :6]
        if part.host in flexible:  # the modal rows: E etadd + G A = tau_eta - Xa_eta
            f = flexible[part.host]
            f[0], f[1], f[2] = f[0] + Ma[:6, 6:], f[1] + Ma[6:, :6], f[2] + Ma[6:, 6:]
    geometry = {}
    for j in joints:
        if j.type in ("free", "spherical"):
            geometry[j.name] = _ball_geometry(b, j)
            continue
        C, r_PQ, R, index = _joint_geometry(b, j)
        Ct = C.T
        W = ca.blockcat([[Ct, -Ct @ skew(r_PQ)], [ca.SX(3, 3), Ct]])
        geometry[j.name] = (W, R, index)
    # M is symmetric for rigid bodies; a flexible body with geometric stiffness makes its own
    # and its ancestors' articulated inertias unsymmetric (then R^T M is formed explicitly).
    symmetric = {j.child: True for j in joints}
    for fe in b.flexible:
        symmetric[fe.name] = not fe.geometric
    # Backward pass, inertia part: articulated inertias, children before parents (Eqs. 8.28-8.33).
    saved = {}
    for j in reversed(joints):
        W, R, index = geometry[j.name]
        Mj = M[j.child]
        if j.child in flexible:  # condense the modal accelerations (M3 of Eq. 8.28)
            M2, G, E, _ = flexible[j.child]
            Mj = Mj - M2 @ ca.solve(E, G)
        sym = symmetric[j.child]
        if R is not None:
            U = Mj @ R
            L = U.T if sym else R.T @ Mj
            nu = R.T @ U
            Ma = Mj - U @ ca.solve(nu, L) if isinstance(index, list) else Mj - (U @ L) / nu
            saved[j.name] = (U, L, nu)
        else:
            Ma = Mj
        if j.parent != "ground":
            M[j.parent] = M[j.parent] + W.T @ (Ma @ W)
            symmetric[j.parent] = symmetric[j.parent] and sym

    def rows(T, index):
        return ca.vertcat(*[T[i, :] for i in index])

    def solve(T):
        T = ca.SX(T)
        c = T.size2()
        X = {j.child: ca.SX.zeros(6, c) for j in joints}
        te = {name: rows(T, f[3]) for name, f in flexible.items()}
        for part, Khs, Kss in moving:  # the parts' loads, condensed into their hosts
            ts = rows(T, part.speeds)
            Xa = Khs @ (ts / Kss) if len(part.speeds) == 1 else Khs @ ca.solve(Kss, ts)
            X[part.host] = X[part.host] + Xa[:6, :]
            if part.host in flexible:
                te[part.host] = te[part.host] - Xa[6:, :]
        # Backward pass, load part (Eqs. 8.28-8.33).
        RX = {}
        for j in reversed(joints):
            W, R, index = geometry[j.name]
            Xj = X[j.child]
            if j.child in flexible:  # Y2 of Eq. 8.28
                M2, _, E, _ = flexible[j.child]
                Xj = Xj + M2 @ ca.solve(E, te[j.child])
            if R is not None:
                U, _, nu = saved[j.name]
                RX[j.name] = R.T @ Xj
                if isinstance(index, list):
                    Xa = Xj + U @ ca.solve(nu, rows(T, index) - RX[j.name])
                else:
                    Xa = Xj + U @ ((T[index, :] - RX[j.name]) / nu)
            else:
                Xa = Xj
            if j.parent != "ground":
                X[j.parent] = X[j.parent] + W.T @ Xa
        # Forward pass: accelerations, root first (Eqs. 8.49-8.51).
        A = {"ground": ca.SX.zeros(6, c)}
        udot = [ca.SX.zeros(1, c)] * n
        for j in joints:
            W, R, index = geometry[j.name]
            e = W @ A[j.parent]
            if isinstance(index, list):
                _, L, nu = saved[j.name]
                acc = ca.solve(nu, rows(T, index) - L @ e - RX[j.name])
                for k, i in enumerate(index):
                    udot[i] = acc[k, :]
                e = e + R @ acc
            elif R is not None:
                _, L, nu = saved[j.name]
                udot[index] = (T[index, :] - L @ e - RX[j.name]) / nu
                e = e + R @ udot[index]
            A[j.child] = e
            z = e
            if j.child in flexible:  # eta'' = E^-1 (tau_eta - G A)
                _, G, E, mi = flexible[j.child]
                eta = ca.solve(E, te[j.child] - G @ e)
                for k, i in enumerate(mi):
                    udot[i] = eta[k, :]
                z = ca.vertcat(e, eta)
        for part, Khs, Kss in moving:  # the parts' own accelerations, once their hosts' are known
            host = part.host
            z = ca.vertcat(A[host], *[udot[i] for i in flexible[host][3]]) if host in flexible else A[host]
            ts = rows(T, part.speeds)
            acc = (ts - Khs.T @ z) / Kss if len(part.speeds) == 1 else ca.solve(Kss, ts - Khs.T @ z)
            for k, i in enumerate(part.speeds):
                udot[i] = acc[k, :]
        return ca.vertcat(*udot)

    return rhs, solve
