"""Kane's method on CasADi: the equation builder that scenes and effects contribute to.

The builder holds the generalized coordinates ``q``, the generalized speeds ``u``, the kinematical
equations ``q' = N(q, t) u + X(q, t)``, the frames of the scene's bodies and the mass elements.
Kane's equations are assembled in matrix form (Banerjee 2016, Eqs. 1.5-1.9 and the recipe of the
reference notes, section 1.2)::

    M = sum_j m_j V_j^T V_j + Omega_j^T I_j Omega_j
    C = -sum_j m_j V_j^T a_t,j + Omega_j^T (I_j alpha_t,j + w_j x I_j w_j)
    F = sum_loads V_P^T F + Omega_B^T T + (generalized forces)
    M u' = C + F

with partial velocities ``V_j = d(v_j)/du`` and partial angular velocities
``Omega_j = d(w_j)/du`` taken as CasADi Jacobians of the velocity expressions (so they are the
nonlinear partial velocities of Kane's direct method), and remainder accelerations
``a_t``, ``alpha_t`` (the accelerations at ``u' = 0``) from directional derivatives.

Frames. The scene frame ``F`` ("ground") rotates at the constant rate ``w_F`` (F axes) and its
origin follows the reference orbit in free fall, so the monopole of the Earth's gravity and the
origin's acceleration cancel and are left out; positions and their rates are relative to ``F``
in ``F`` axes, and the Coriolis and centripetal terms of ``F``'s rotation are part of ``a_t``.
Angular velocities are inertial, in body axes (efficient generalized speeds for free and
spherical joints).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

__all__ = ["KaneBuilder", "BodyFrame", "FlexibleElement", "MassElement", "MaterialElement", "skew",
           "quat_to_dcm", "rot_axis"]


def skew(v) -> Any:
    """Cross-product matrix of a 3-vector (CasADi or numpy)."""
    return ca.vertcat(ca.horzcat(0, -v[2], v[1]), ca.horzcat(v[2], 0, -v[0]), ca.horzcat(-v[1], v[0], 0))


def cross(a, b) -> Any:
    return ca.cross(ca.vec(a), ca.vec(b))


def quat_to_dcm(q) -> Any:
    """Rotation matrix of a unit quaternion ``[w, x, y, z]``: child axes to parent axes."""
    w, v = q[0], q[1:4]
    # Normalized form: exact rotation matrix even when |q| drifts slightly from 1.
    n2 = ca.dot(q, q)
    return ((w * w - ca.dot(v, v)) * ca.DM.eye(3) + 2 * (v @ v.T) + 2 * w * skew(v)) / n2


def quat_rate(q, w_rel) -> Any:
    """``q' = 1/2 q (x) [0, w_rel]`` with ``w_rel`` in child axes."""
    w, v = q[0], q[1:4]
    return 0.5 * ca.vertcat(-ca.dot(v, w_rel), w * w_rel + cross(v, w_rel))


def rot_axis(axis: np.ndarray, angle) -> Any:
    """Rotation matrix about a unit ``axis`` by ``angle`` (Rodrigues): child to parent axes."""
    a = ca.DM(axis)
    K = skew(a)
    return ca.DM.eye(3) + ca.sin(angle) * K + (1 - ca.cos(angle)) * (K @ K)


@dataclass
class BodyFrame:
    """A body frame: origin ``r`` and rotation ``C`` (body to scene axes), inertial angular
    velocity ``w`` in body axes; all CasADi expressions of ``(q, u, t)``."""

    name: str
    r: Any
    C: Any
    w: Any


@dataclass
class MassElement:
    """A rigid mass element (a body's composite, a rotor, a particle).

    ``r``: mass centre in scene axes; ``C``: element to scene axes; ``w``: inertial angular
    velocity in element axes; ``inertia`` about the mass centre in element axes (None for a
    particle); ``w_axes``: inertial angular velocity of the element axes when they do not turn
    with the element (a symmetric rotor described in its body's axes), else None.
    """

    name: str
    mass: Any
    inertia: Any
    r: Any
    C: Any
    w: Any
    body: str | None = None
    w_axes: Any = None

    @property
    def has_mass(self) -> bool:
        return _nonzero(self.mass)

    @property
    def has_inertia(self) -> bool:
        return self.inertia is not None and _nonzero(self.inertia)

    @property
    def I(self) -> Any:  # noqa: E743 - the inertia matrix as a CasADi matrix
        return self.inertia if isinstance(self.inertia, ca.SX) else ca.DM(np.asarray(self.inertia, float))


@dataclass
class MaterialElement:
    """Particles of material moving through their body's frame (a deploying boom's material).

    The positions ``r`` are not fixed material points of the expressions the builder could
    differentiate (the material streams through them), so the effect gives each particle's
    velocity and acceleration: ``mass`` (k values [kg], may vary with time), ``r`` (3 k,
    positions relative to the scene frame, scene axes), ``v`` (3 k, their velocities relative to
    the scene frame), ``a_t`` (3 k, inertial accelerations at ``u' = 0``, the frame's Coriolis
    and centripetal terms included) and ``flux`` (3 k, the rate of momentum [N] that mass
    crossing into or out of the set adds at a particle, e.g. ``m' (v_in - v)``). Kane's
    generalized inertia forces are ``-sum V_k^T (m_k a_k + flux_k)`` with ``V_k = dv_k/du``.
    """

    name: str
    mass: Any
    r: Any
    v: Any
    a_t: Any
    flux: Any
    body: str | None = None

    def _mvec(self) -> Any:
        return ca.vec(ca.repmat(ca.vec(self.mass).T, 3, 1))


def _nonzero(value: Any) -> bool:
    """Structurally non-zero: a symbolic value counts as non-zero."""
    if isinstance(value, ca.SX):
        return not value.is_zero()
    return bool(np.any(np.asarray(value, float) != 0))


@dataclass
class FlexibleElement:
    """A flexible body: its frame, modal coordinates ``q`` and rates ``qd`` (SX), modal data, and
    whether the motion-induced geometric stiffness is included (the ``geometric_stiffness``
    effect switches it on)."""

    name: str
    frame: BodyFrame
    q: Any
    qd: Any
    data: Any
    geometric: bool = False
    _terms: dict = field(default_factory=dict, repr=False)  # built once per geometric setting

    def speeds(self, builder: KaneBuilder):
        """``U = (v, w, q')``: inertial velocity of the frame origin and inertial angular velocity,
        both in body axes, and the modal rates (the speeds of the modal-integral equations)."""
        r, C, w = self.frame.r, self.frame.C, self.frame.w
        v_scene = builder.rate(r) + cross(ca.DM(builder.w_F), r)
        return ca.vertcat(C.T @ v_scene, w, self.qd)

    def terms(self, builder: KaneBuilder, *, geometric: bool | None = None):
        """``(U, M, C)`` of ``-F* = M U' + C`` (see :func:`linflex.dynamics._flexible.flexible_body_terms`)."""
        from ._flexible import flexible_body_terms

        key = self.geometric if geometric is None else geometric
        if key not in self._terms:
            U = self.speeds(builder)
            M, C = flexible_body_terms(self.data, self.q, U[0:3], U[3:6], self.qd, geometric_stiffness=key)
            self._terms[key] = (U, M, C)
        return self._terms[key]


@dataclass
class _Attachment:
    mass: Any  # float or SX (an exposed parameter)
    point: np.ndarray
    inertia: Any  # about its own centre, body axes: 3x3 array or SX


def composite_mass(parts) -> tuple[Any, Any, Any] | None:
    """Mass, mass centre (body axes, 3x1) and central inertia of rigidly attached parts.

    Numeric (float, ``DM``, ndarray) unless a mass or inertia is an exposed parameter (then the
    same formulas in SX); None for no parts or a numeric total mass that is not positive.
    """
    if not parts:
        return None
    if any(isinstance(p.mass, ca.SX) or isinstance(p.inertia, ca.SX) for p in parts):
        mass = sum((p.mass for p in parts), ca.SX(0))
        com = sum((p.mass * ca.DM(p.point) for p in parts), ca.SX.zeros(3, 1)) / mass
        inertia = ca.SX.zeros(3, 3)
        for p in parts:
            d = ca.DM(p.point) - com
            inertia += p.inertia + p.mass * (ca.dot(d, d) * ca.DM.eye(3) - d @ d.T)
        return mass, com, inertia
    mass = sum(p.mass for p in parts)
    if mass <= 0:
        return None
    com = sum(p.mass * p.point for p in parts) / mass
    inertia = np.zeros((3, 3))
    for p in parts:
        d = p.point - com
        inertia += p.inertia + p.mass * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, ca.DM(com), inertia


@dataclass
class KaneBuilder:
    """Collects coordinates, speeds, elements and loads, then assembles Kane's equations.

    Effects talk to it through these methods (see :class:`linflex.Effect`):

    * structure stage: :meth:`add_coordinates`, :meth:`set_kinematics`, :meth:`add_element`,
      :meth:`detach` (remove a rigidly attached part so that the effect can make it move),
      :meth:`add_input`;
    * signals stage: :meth:`add_state`, :meth:`add_output`, ``commands`` (actuator commands);
    * loads stage: :meth:`add_force`, :meth:`add_torque`, :meth:`add_generalized_force`,
      :meth:`add_potential`, and the kinematics: :meth:`point_kinematics`, ``frames``.
    """

    scene: Any
    t: Any = field(default_factory=lambda: ca.SX.sym("t"))
    w_F: np.ndarray = field(default_factory=lambda: np.zeros(3))
    C_NF: Any = None
    R_O: Any = None  # orbit position of the frame origin, scene axes (None without an orbit)
    V_O: Any = None
    n_orbit: float = 0.0
    mu: float = 0.0

    def __post_init__(self) -> None:
        self.q_parts: list[Any] = []
        self.u_parts: list[Any] = []
        self.q_names: list[str] = []
        self.u_names: list[str] = []
        self.qdot_parts: list[Any] = []
        self.aux_parts: list[Any] = []
        self.aux_names: list[str] = []
        self.auxdot_parts: list[Any] = []
        self.in_parts: list[Any] = []
        self.in_names: list[str] = []
        self.out_parts: list[Any] = []
        self.out_names: list[str] = []
        self.frames: dict[str, BodyFrame] = {}
        self.elements: list[MassElement] = []
        self.flexible: list[FlexibleElement] = []
        self.materials: list[MaterialElement] = []  # material moving through its body (deployment)
        self.attachments: dict[str, dict[tuple[str, str], _Attachment]] = {}
        self.joint_speeds: dict[str, tuple[Any, Any]] = {}
        self.commands: dict[str, Any] = {}
        self.sensor_signals: dict[str, Any] = {}
        self.potential: Any = ca.SX(0)
        self.generalized: list[Any] = []
        self._forces: list[tuple[Any, Any]] = []
        self._torques: list[tuple[Any, Any]] = []
        # What each load comes from (an effect's name, "actuators", "structure", ...): loads are
        # tagged with ``origin`` when added, so a linearization can split its stiffness by origin.
        self.origin = "applied"
        self._force_origins: list[str] = []
        self._torque_origins: list[str] = []
        self._generalized_origins: list[str] = []
        self.params: dict[str, Any] = {}  # exposed parameter name -> SX symbol
        self.wheel_speeds: dict[str, Any] = {}
        self.node_wheels: dict[str, MassElement] = {}  # wheels at nodes of flexible bodies
        self.pendulum_speeds: dict[str, Any] = {}
        self.damper_coordinates: dict[str, Any] = {}
        self.joint_speed_names: dict[str, str] = {}
        self.udot = None
        self.q = self.u = self.qdot = None

    def param(self, name: str, nominal: float) -> Any:
        """The SX symbol of an exposed parameter ``name``, else the float ``nominal``."""
        return self.params.get(name, float(nominal))

    # -- structure -----------------------------------------------------------------------------

    def add_coordinates(self, q_names: list[str], u_names: list[str]):
        """New coordinates and speeds (SX column symbols); their kinematics via set_kinematics."""
        q = ca.SX.sym("q_" + "_".join(q_names) if q_names else "q", len(q_names))
        u = ca.SX.sym("u_" + "_".join(u_names) if u_names else "u", len(u_names))
        if q_names:
            self.q_parts.append(q)
            self.q_names.extend(q_names)
            self.qdot_parts.append(None)
        if u_names:
            self.u_parts.append(u)
            self.u_names.extend(u_names)
        return q, u

    def set_kinematics(self, q, qdot) -> None:
        """Set ``q' = qdot`` for coordinates returned by :meth:`add_coordinates`."""
        for k, part in enumerate(self.q_parts):
            if part is q:
                self.qdot_parts[k] = qdot
                return
        raise KeyError("set_kinematics: unknown coordinate block")

    def attach(self, body: str, key: tuple[str, str], mass: float, point, inertia=None) -> None:
        """Attach a rigid part (mass [kg] at ``point`` [m], central inertia) to ``body``."""
        if not isinstance(mass, ca.SX):
            mass = float(mass)
        if inertia is None:
            inertia = np.zeros((3, 3))
        elif not isinstance(inertia, ca.SX):
            inertia = np.asarray(inertia, float)
        self.attachments.setdefault(body, {})[key] = _Attachment(mass, np.asarray(point, float).reshape(3), inertia)

    def detach(self, body: str, key: tuple[str, str]) -> None:
        """Remove a rigidly attached part from ``body`` (an effect will model its motion)."""
        del self.attachments[body][key]

    def add_element(self, element: MassElement) -> None:
        self.elements.append(element)

    def add_input(self, names: list[str]):
        sym = ca.SX.sym("in_" + "_".join(names), len(names))
        self.in_parts.append(sym)
        self.in_names.extend(names)
        return sym

    def add_state(self, names: list[str]):
        """Auxiliary first-order states (e.g. controller states); set their rate with set_rate."""
        sym = ca.SX.sym("aux_" + "_".join(names), len(names))
        self.aux_parts.append(sym)
        self.aux_names.extend(names)
        self.auxdot_parts.append(None)
        return sym

    def set_rate(self, sym, xdot) -> None:
        for k, part in enumerate(self.aux_parts):
            if part is sym:
                self.auxdot_parts[k] = xdot
                return
        raise KeyError("set_rate: unknown state block")

    def add_output(self, names: list[str], expr) -> None:
        self.out_parts.append(ca.vec(expr))
        self.out_names.extend(names)

    # -- finalize kinematics (after the structure stage) -----------------------------------------

    def finalize_kinematics(self) -> None:
        self.q = ca.vertcat(*self.q_parts) if self.q_parts else ca.SX(0, 1)
        self.u = ca.vertcat(*self.u_parts) if self.u_parts else ca.SX(0, 1)
        missing = [k for k, v in enumerate(self.qdot_parts) if v is None]
        if missing:
            raise RuntimeError("kinematics missing for a coordinate block")
        self.qdot = ca.vertcat(*self.qdot_parts) if self.qdot_parts else ca.SX(0, 1)
        self.udot = ca.SX.sym("udot", self.u.numel())
        # Composite rigid bodies (body + everything rigidly attached to it), numeric unless a
        # mass or inertia is an exposed parameter (then the same formulas in SX).
        for name, frame in self.frames.items():
            composite = composite_mass(list(self.attachments.get(name, {}).values()))
            if composite is None:
                continue
            mass, com, inertia = composite
            self.elements.insert(0, MassElement(name, mass, inertia, frame.r + frame.C @ com,
                                                frame.C, frame.w, body=name))

    def rate(self, expr) -> Any:
        """Time derivative of an expression of ``(q, t)`` (and of ``u``: then only at ``u' = 0``)."""
        expr = ca.vec(expr)
        out = ca.jtimes(expr, self.q, self.qdot) if self.q.numel() else ca.SX.zeros(expr.shape)
        return out + ca.jacobian(expr, self.t)

    def point_kinematics(self, body: str, point=None):
        """``(r, v, V, a_t)`` of a point fixed in ``body``: position and velocity relative to the
        scene frame, partial velocities ``d(v_inertial)/du`` (3 x n_u) and the inertial
        acceleration at ``u' = 0`` (without the orbit's free fall), all in scene axes."""
        frame = self.frames[body]
        r = frame.r if point is None else frame.r + frame.C @ ca.DM(np.asarray(point, float).reshape(3))
        return self.kinematics_of(r)

    def kinematics_of(self, r):
        rdot = self.rate(r)
        V = ca.jacobian(rdot, self.u)
        wF = ca.DM(self.w_F)
        a_t = self.rate(rdot) + 2 * cross(wF, rdot) + cross(wF, cross(wF, r))
        return r, rdot, V, a_t

    def inertial_velocity(self, r, rdot) -> Any:
        """Inertial velocity (scene axes) of a point at ``r`` moving at ``rdot`` in the scene frame."""
        v = rdot + cross(ca.DM(self.w_F), r)
        return v if self.V_O is None else v + self.V_O

    # -- loads ---------------------------------------------------------------------------------

    def add_force(self, body: str, point, F) -> None:
        """A force ``F`` [N] (scene axes) at ``point`` [m] of ``body`` (body axes)."""
        frame = self.frames[body]
        r = frame.r if point is None else frame.r + frame.C @ ca.DM(np.asarray(point, float).reshape(3))
        self.add_force_at(r, F)

    def add_force_at(self, r, F) -> None:
        """A force ``F`` (scene axes) at the point whose position expression is ``r``."""
        # Collected and projected on the partial velocities of all points at once in assemble().
        self._forces.append((ca.vec(r), ca.vec(F)))
        self._force_origins.append(self.origin)

    def add_torque(self, body: str, T) -> None:
        """A torque ``T`` [N m] on ``body`` in body axes."""
        self.add_torque_at(self.frames[body].w, T)

    def add_torque_at(self, w, T) -> None:
        """A torque ``T`` on whatever turns at the angular velocity expression ``w`` (same axes)."""
        self._torques.append((ca.vec(w), ca.vec(T)))
        self._torque_origins.append(self.origin)

    def _flexible_element(self, body: str) -> FlexibleElement:
        fe = next((f for f in self.flexible if f.name == body), None)
        if fe is None:
            raise KeyError(f"{body!r} is not a flexible body")
        return fe

    def node_motion(self, body: str, node: str):
        """``(r, C, w)`` of a node of a flexible body: position (scene axes), the node's axes to
        scene axes to first order in its small rotation ``Psi q``, inertial angular velocity."""
        fe = self._flexible_element(body)
        position, Phi, Psi = fe.data.node(node)
        frame = fe.frame
        r = frame.r + frame.C @ (ca.DM(position) + ca.DM(Phi) @ fe.q)
        C = frame.C @ (ca.DM.eye(3) + skew(ca.DM(Psi) @ fe.q))
        return r, C, frame.w + ca.DM(Psi) @ fe.qd

    def node_frame(self, body: str, node: str):
        """``(r, C, w)`` of the axes of a node of a flexible body as a proper rotation.

        ``r``: the node's position (scene axes, translation ``Phi q`` included); ``C``: node axes
        to scene axes; ``w``: their inertial angular velocity in node axes. The node's small
        rotation ``theta = Psi q`` (body axes) is taken as the rotation of Gibbs vector
        ``g = theta / 2`` (the normalized quaternion ``[1, theta / 2]``), which equals
        ``U3 + skew(theta)`` to first order like :meth:`node_motion` but is orthogonal at every
        ``q``, with the exact angular velocity (Shuster 1993, *A survey of attitude
        representations*, section 7; child axes)::

            w_rel = 2 (g' - g x g') / (1 + g . g)

        so a rigid part carried there (a wheel) has consistent kinematics: the model conserves
        energy and angular momentum exactly.
        """
        fe = self._flexible_element(body)
        position, Phi, Psi = fe.data.node(node)
        frame = fe.frame
        g, gdot = 0.5 * ca.DM(Psi) @ fe.q, 0.5 * ca.DM(Psi) @ fe.qd
        R = quat_to_dcm(ca.vertcat(1, g))  # node axes to body axes
        w_rel = 2 * (gdot - cross(g, gdot)) / (1 + ca.dot(g, g))
        r = frame.r + frame.C @ (ca.DM(position) + ca.DM(Phi) @ fe.q)
        return r, frame.C @ R, R.T @ frame.w + w_rel

    def add_element_torque(self, element: MassElement, T) -> None:
        """A torque ``T`` on a mass element, in its axes."""
        self.add_torque_at(element.w, T)

    def add_generalized_force(self, index: int, value) -> None:
        """A generalized active force on speed ``index``."""
        e = np.zeros(self.u.numel())
        e[index] = 1.0
        self.generalized.append(ca.DM(e) * value)
        self._generalized_origins.append(self.origin)

    def add_potential(self, expr) -> None:
        """Add to the potential energy used by the energy monitor [J]."""
        self.potential = self.potential + expr

    def speed_index(self, name: str) -> int:
        return self.u_names.index(name)

    # -- assembly ------------------------------------------------------------------------------

    def assemble_parts(self, *, geometric: bool | None = None):
        """``(J, Mb, c, g)`` with ``M = J^T Mb J`` and ``rhs = g - J^T c``.

        All mass centres and element angular velocities are stacked so that one Jacobian and
        one directional derivative serve every element and load (CasADi shares the
        subexpressions)::

            J  = [V_1; ...; V_k; Om_1; ...; Om_l]               (3 (k + l) x n, partial velocities)
            Mb = blkdiag(m_1 I3, ..., m_k I3, I_1, ..., I_l)     (constant)
            c  = [m_j a_t,j ; I_j alpha_t,j + w_axes,j x I_j w_j]
            g  = sum V_P^T F + Om_B^T T + generalized forces
        """
        n = self.u.numel()
        wF = ca.DM(self.w_F)
        masses = [el for el in self.elements if el.has_mass]
        rotors = [el for el in self.elements if el.has_inertia]
        blocks_J, blocks_c, blocks_M = [], [], []
        g = ca.SX.zeros(n, 1)
        points = [el.r for el in masses] + [r for r, _ in self._forces]
        if points:
            R = ca.vertcat(*points)
            Rdot = self.rate(R)
            V = ca.jacobian(Rdot, self.u)
            k = len(masses)
            if k:
                Rm3, Rdm3 = ca.reshape(R[: 3 * k], 3, k), ca.reshape(Rdot[: 3 * k], 3, k)
                # Remainder acceleration, plus the Coriolis and centripetal terms of the frame.
                a_t = self.rate(Rdot[: 3 * k]) + ca.vec(2 * skew(wF) @ Rdm3 + skew(wF) @ (skew(wF) @ Rm3))
                mvec = ca.vertcat(*[ca.repmat(ca.SX(el.mass), 3, 1) for el in masses])
                blocks_J.append(V[: 3 * k, :])
                blocks_c.append(mvec * a_t)
                blocks_M.append(ca.diag(mvec))
            if self._forces:
                g += V[3 * k:, :].T @ ca.vertcat(*[f for _, f in self._forces])
        rates = [el.w for el in rotors] + [w for w, _ in self._torques]
        if rates:
            W = ca.vertcat(*rates)
            Om = ca.jacobian(W, self.u)
            k = len(rotors)
            if k:
                alpha_t = self.rate(W[: 3 * k])
                Iblk = ca.diagcat(*[ca.SX(el.I) for el in rotors])
                # dH/dt in element axes: I (component rate of w) + w_axes x (I w).
                gyro = ca.vertcat(*[cross(el.w if el.w_axes is None else el.w_axes, el.I @ el.w)
                                    for el in rotors])
                blocks_J.append(Om[: 3 * k, :])
                blocks_c.append(Iblk @ alpha_t + gyro)
                blocks_M.append(Iblk)
            if self._torques:
                g += Om[3 * k:, :].T @ ca.vertcat(*[t for _, t in self._torques])
        for fe in self.flexible:
            # Kane's generalized inertia forces of a flexible body from its modal integrals:
            # J_f^T (M_f U' + C_f) with U' = J_f u' + U_t (component derivatives, body axes).
            U, M_f, C_f = fe.terms(self, geometric=geometric)
            blocks_J.append(ca.jacobian(U, self.u))
            blocks_c.append(M_f @ self.rate(U) + C_f)
            blocks_M.append(M_f)
        for me in self.materials:
            mvec = me._mvec()
            blocks_J.append(ca.jacobian(me.v, self.u))
            blocks_c.append(mvec * me.a_t + me.flux)
            blocks_M.append(ca.diag(mvec))
        for extra in self.generalized:
            g += extra
        J = ca.vertcat(*blocks_J) if blocks_J else ca.SX(0, n)
        c = ca.vertcat(*blocks_c) if blocks_c else ca.SX(0, 1)
        Mb = ca.diagcat(*blocks_M) if blocks_M else ca.SX(0, 0)
        return J, Mb, c, g

    def generalized_forces_by_origin(self, partials_at=None) -> dict[str, Any]:
        """Kane's generalized forces ``F_r + F_r*`` (SX, n_u) grouped by where they come from.

        The keys are the loads' origins (an effect's name, ``"actuators"``, ``"structure"``,
        ``"disturbances"``), ``"inertia"`` for the generalized inertia forces
        ``-J^T (Mb J u' + c)`` (they depend on ``udot``), and ``"geometric_stiffness"`` for what
        the flexible bodies' geometric stiffness adds to them. The sum over the keys is zero
        along a motion (Kane's equations).

        ``partials_at``: an SX vector like ``q``; when given, the partial velocities and partial
        angular velocities that project loads and inertia forces are evaluated there instead of
        at ``q``, while velocities and accelerations keep ``q``. Differentiating with respect
        to ``q`` alone then gives the prematurely linearized equations (partials of the
        linearized velocities, Banerjee 2016, Eqs. 1.66-1.67), and with respect to both, Kane's
        direct linearization (Eqs. 1.63-1.65).
        """

        n = self.u.numel()
        out: dict[str, Any] = {}

        def add(origin, value):
            out[origin] = out.get(origin, ca.SX.zeros(n, 1)) + value

        # Each load with the velocity it does work on: a force with its point's, a torque with
        # its body's angular velocity; one partial-velocity matrix per origin projects them.
        loads = ([(self.rate(r), F, o) for (r, F), o in zip(self._forces, self._force_origins)]
                 + [(w, T, o) for (w, T), o in zip(self._torques, self._torque_origins)])
        for origin in dict.fromkeys(o for _, _, o in loads):
            mine = [(v, f) for v, f, o in loads if o == origin]
            P = ca.jacobian(ca.vertcat(*[v for v, _ in mine]), self.u)
            if partials_at is not None:
                P = ca.substitute(P, self.q, partials_at)
            add(origin, P.T @ ca.vertcat(*[f for _, f in mine]))
        for value, origin in zip(self.generalized, self._generalized_origins):
            add(origin, value)

        def inertia(geometric):
            J, Mb, c, _ = self.assemble_parts(geometric=geometric)
            Jp = J if partials_at is None else ca.substitute(J, self.q, partials_at)
            return -Jp.T @ (Mb @ (J @ self.udot) + c)

        out["inertia"] = inertia(False)
        if any(fe.geometric for fe in self.flexible):
            out["geometric_stiffness"] = inertia(None) - out["inertia"]
        return out

    def assemble(self):
        """``(M, rhs)`` of ``M u' = rhs`` as SX expressions (see :meth:`assemble_parts`)."""
        J, Mb, c, g = self.assemble_parts()
        return J.T @ (Mb @ J), g - J.T @ c

    def _mass_points(self):
        masses = [el for el in self.elements if el.has_mass]
        if not masses:
            return masses, None, None
        R = ca.vertcat(*[el.r for el in masses])
        R3 = ca.reshape(R, 3, len(masses))
        V3 = ca.reshape(self.rate(R), 3, len(masses)) + skew(ca.DM(self.w_F)) @ R3
        return masses, R3, V3

    def kinetic_energy(self) -> Any:
        """Kinetic energy relative to the inertial frame (origin at rest) [J]."""
        T = ca.SX(0)
        masses, _, V3 = self._mass_points()
        for k, el in enumerate(masses):
            T += 0.5 * el.mass * ca.sumsqr(V3[:, k])
        for el in self.elements:
            if el.has_inertia:
                T += 0.5 * ca.dot(el.w, el.I @ el.w)
        for fe in self.flexible:
            U, M_f, _ = fe.terms(self, geometric=False)
            T += 0.5 * ca.dot(U, M_f @ U)
        for me, _, V3 in self._material_points():
            T += 0.5 * ca.dot(me._mvec(), ca.vec(V3) ** 2)
        return T

    def _material_points(self):
        """``(element, positions 3 x k, inertial velocities 3 x k)`` of the material elements."""
        out = []
        for me in self.materials:
            k = me.mass.numel()
            R3 = ca.reshape(me.r, 3, k)
            out.append((me, R3, ca.reshape(me.v, 3, k) + skew(ca.DM(self.w_F)) @ R3))
        return out

    def angular_momentum(self) -> Any:
        """Angular momentum about the scene origin in inertial axes [N m s]."""
        H = ca.SX.zeros(3, 1)
        masses, R3, V3 = self._mass_points()
        for k, el in enumerate(masses):
            H += el.mass * cross(R3[:, k], V3[:, k])
        for el in self.elements:
            if el.has_inertia:
                H += el.C @ (el.I @ el.w)
        for fe in self.flexible:
            # dT/dv is the linear momentum and dT/dw the angular momentum about O (body axes).
            U, M_f, _ = fe.terms(self, geometric=False)
            p_body, h_O = M_f[0:3, :] @ U, M_f[3:6, :] @ U
            H += fe.frame.C @ h_O + cross(fe.frame.r, fe.frame.C @ p_body)
        for me, R3, V3 in self._material_points():
            for k in range(R3.shape[1]):
                H += me.mass[k] * cross(R3[:, k], V3[:, k])
        return self.C_NF @ H
