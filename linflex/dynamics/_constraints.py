"""Loop-closing joints: constraints with undetermined multipliers on top of Kane's tree equations.

The joint tree gives Kane's equations ``M(q) u' = rhs(q, u, t)`` in the tree's coordinates. Each
:class:`~linflex.LoopJoint` adds position constraints ``phi(q, t) = 0`` between two bodies. Their
rates are linear in the speeds, ``phi' = A(q, t) u + a(q, t)``, and the constraint forces enter
as ``A^T lambda`` (Banerjee 2016, Eqs. 1.85-1.95; reference notes section 4)::

    M u' = rhs + A^T lambda                               (1.91)
    A u' + b + kd phi' + kp phi = 0                       (1.90 with Baumgarte's stabilization)

    lambda = -(A M^-1 A^T)^-1 (A M^-1 rhs + b + kd phi' + kp phi)
    u'     = M^-1 (rhs + A^T lambda)                      (1.95)

``b`` is the remainder of ``phi''`` at ``u' = 0``. Constraint rows (per joint, scene axes)::

    translation   p_A - p_B                         3 rows  (ball, revolute, weld)
    rotation      (C_A n_i) . (C_B m_i)             2 rows (revolute), 3 rows (weld)

so that ``lambda`` of a translation row is the force on ``body_a`` (scene axes) and ``lambda`` of
a rotation row the size of a torque ``(C_A n_i) x (C_B m_i)`` on ``body_a``; ``body_b`` receives
the opposite of both. The pairs ``(n_i, m_i)`` are chosen so that the torque directions are
``t1, t2`` (perpendicular to a revolute axis ``a``: ``(t2, a)`` and ``(-t1, a)``) or the three
axes (weld: ``(y, z)``, ``(z, x)``, ``(x, y)``).

Redundant constraints. A planar loop closed by a revolute joint constrains 5 components but
only 2 are independent (the tree's parallel hinges already keep the loop planar), so
``A M^-1 A^T`` is singular. The independent rows are chosen once, at the consistent initial
state, by a QR factorization with column pivoting of ``A^T`` (rank-revealing: the rows whose
remaining component is below ``RANK_TOL`` times the largest are dependent); the other rows get
no multiplier (zero force). The alternative, a least-squares (pseudo-inverse) or regularized
multiplier solve, needs a singular value decomposition inside every evaluation, or changes
the dynamics by the regularization. The fixed choice is exact and keeps the Schur complement
positive definite as long as the mechanism stays away from configurations where the chosen rows
become dependent (singular positions of the mechanism, where the constrained dynamics are
singular anyway).

Contacts. A scene's ``constraints`` (rolling wheels, knife edges; :mod:`._contacts`) add rows
of the same kind that restrict velocities only (non-holonomic, Banerjee 2016, Eq. 1.86): such a
row has no position (``phi = 0``, so no ``kp`` term) and its velocity ``A u + a`` is given
instead of being the rate of ``phi``; a rolling wheel's contact height is a holonomic row. Their
multipliers are the contact force's components, output as ``<constraint>.force.*``.

Consistent initial state. The scene's initial coordinates need only be close: the dependent
coordinates are those of the loop joints' ``solve_for`` joints, or else (as many as independent
constraints) the columns picked by a pivoted QR of the position Jacobian ``d(phi)/dq``; Newton's
method (least-squares steps) solves ``phi = 0`` for them (Banerjee 2016, Eqs. 8.78-8.86), and
the dependent speeds (likewise, or a pivoted QR of ``A``) are solved from ``phi' = 0``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ..scene._values import vector3
from ..system._errors import ModelError
from ._contacts import check_not_flat, contact_rows
from ._kane import KaneBuilder, cross

__all__ = ["LoopClosure", "LoopConstraints", "RANK_TOL", "pivoted_columns"]

#: Relative size of a pivot below which a constraint row (or column) counts as dependent.
RANK_TOL = 1e-9
#: Absolute tolerance of the consistent initial state: |phi| [m, -] and |phi'| [m/s, rad/s].
CLOSURE_TOL = 1e-12

_XYZ = ("x", "y", "z")


def pivoted_columns(G: NDArray[np.float64], tol: float = RANK_TOL) -> tuple[int, ...]:
    """The columns of ``G`` a QR factorization with column pivoting picks, up to its rank.

    The rank counts the pivots ``|R_kk|`` above ``tol`` times the largest.
    """
    if G.size == 0:
        return ()
    _, R, piv = scipy.linalg.qr(G, mode="economic", pivoting=True)
    diag = np.abs(np.diag(R))
    if diag.size == 0 or diag[0] == 0:
        return ()
    rank = int(np.sum(diag > tol * diag[0]))
    return tuple(int(k) for k in piv[:rank])


@dataclass(frozen=True, eq=False)
class LoopConstraints:
    """The loop-closing constraints of a compiled scene (``Model.constraints``).

    Attributes
    ----------
    joints : tuple of str
        The loop joints, then the contacts (``scene.constraints``), in scene order.
    rows : tuple of str
        One label per constraint row: ``<joint>.x``, ``.y``, ``.z`` (translation, scene axes) and
        ``<joint>.r1``, ``.r2`` (revolute) or ``.rx``, ``.ry``, ``.rz`` (weld) for rotation;
        ``<constraint>.normal``, ``.forward``, ``.lateral`` (rolling) and ``.lateral`` (knife
        edge) for contacts.
    independent_rows : tuple of int
        The rows that carry multipliers (chosen at the initial state, see the module notes).
    position, velocity : casadi.Function
        ``phi(x, p, t)`` [m or -] and ``phi'(x, p, t)`` [m/s or 1/s], one entry per row (a
        non-holonomic row: ``phi = 0`` and ``phi'`` its velocity ``A u + a``).
    jacobians : casadi.Function
        ``(x, p, t) -> (d(phi)/dx, d(phi')/dx)``, each ``(n_rows, n_states)``.
    n_coordinates, n_speeds : int
        Number of generalized coordinates and speeds of the tree.
    param_values : tuple of float
        The nominal values of the model's parameters (``p`` when not given).
    """

    joints: tuple[str, ...]
    rows: tuple[str, ...]
    independent_rows: tuple[int, ...]
    position: Any
    velocity: Any
    jacobians: Any
    n_coordinates: int
    n_speeds: int
    param_values: tuple[float, ...] = ()

    def residual(self, x: ArrayLike, t: float = 0.0, p: ArrayLike | None = None) -> tuple[NDArray, NDArray]:
        """``(phi, phi')`` at the state ``x`` (time ``t`` [s], parameters ``p``, default nominal)."""
        p = self.param_values if p is None else p
        phi, phidot = (np.asarray(self.position(x, p, t), float).reshape(-1),
                       np.asarray(self.velocity(x, p, t), float).reshape(-1))
        return phi, phidot

    def jacobian_matrices(self, x: ArrayLike, t: float = 0.0, p: ArrayLike | None = None) -> tuple[NDArray, NDArray]:
        """``(d(phi)/dx, d(phi')/dx)`` at ``x`` as arrays ``(n_rows, n_states)``."""
        p = self.param_values if p is None else p
        Gp, Gv = self.jacobians(x, p, t)
        return np.asarray(Gp, float), np.asarray(Gv, float)


def _point_and_axes(b: KaneBuilder, body: str, point, node: str | None):
    """Position (scene axes) of the joint point and the axes it turns with (to scene axes)."""
    if body == "ground":
        return ca.DM(vector3(point)), ca.SX(ca.DM.eye(3))
    if node is not None:  # moves with the structure at a node of a flexible body
        r, C, _ = b.node_frame(body, node)
        return r, C
    frame = b.frames[body]
    return frame.r + frame.C @ ca.DM(vector3(point)), frame.C


def _perpendiculars(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit ``t1, t2`` with ``t1 x t2 = a`` (``a`` a unit vector)."""
    helper = np.eye(3)[int(np.argmin(np.abs(a)))]
    t1 = np.cross(a, helper)
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(a, t1)


class LoopClosure:
    """The constraint terms of a scene's loop joints on a finalized :class:`KaneBuilder`.

    Built by :func:`linflex.compile_model` before the outputs are stacked: it registers the
    multiplier outputs with a placeholder symbol ``multipliers`` (replaced by the solved
    multipliers in each solve branch), computes the consistent initial state ``x0`` from
    ``x0_guess`` and chooses the independent rows there.
    """

    def __init__(self, scene: Any, b: KaneBuilder, x: Any, x0_guess: NDArray, param_values: ArrayLike) -> None:
        psym = ca.vertcat(*b.params.values()) if b.params else ca.SX(0, 1)
        t = b.t
        rows_phi, labels, gains_d, gains_p, torque_pairs = [], [], [], [], []
        for lj in scene.loop_joints:
            p_a, C_a = _point_and_axes(b, lj.body_a, lj.point_a, lj.node_a)
            p_b, C_b = _point_and_axes(b, lj.body_b, lj.point_b, lj.node_b)
            phi = [ca.SX(p_a) - p_b]
            names = [f"{lj.name}.{c}" for c in _XYZ]
            pairs = []
            if lj.type == "revolute":
                a = vector3(lj.axis) / np.linalg.norm(vector3(lj.axis))
                a_b = a if lj.axis_b is None else vector3(lj.axis_b) / np.linalg.norm(vector3(lj.axis_b))
                t1, t2 = _perpendiculars(a)
                pairs = [(t2, a_b), (-t1, a_b)]
                names += [f"{lj.name}.r1", f"{lj.name}.r2"]
            elif lj.type == "weld":
                e = np.eye(3)
                pairs = [(e[1], e[2]), (e[2], e[0]), (e[0], e[1])]
                names += [f"{lj.name}.r{c}" for c in _XYZ]
            start = sum(int(ca.vertcat(*r).numel()) for r in rows_phi)
            for n_i, m_i in pairs:
                phi.append(ca.dot(C_a @ ca.DM(n_i), C_b @ ca.DM(m_i)))
            rows_phi.append(phi)
            labels += names
            kd, kp = (float(v) for v in lj.baumgarte)
            gains_d += [kd] * len(names)
            gains_p += [kp] * len(names)
            torque_pairs.append((lj, start, C_a, C_b, pairs))
        # Non-holonomic contacts (linflex/dynamics/_contacts.py): a row without a position has
        # phi = 0 and its velocity given instead of the rate of phi.
        contacts = [contact_rows(b, c) for c in scene.constraints]
        given, k = {}, sum(int(ca.vertcat(*r).numel()) for r in rows_phi)
        for c, cr in zip(scene.constraints, contacts):
            torque_pairs.append((c, k, cr.directions, None, None))
            for velocity in cr.velocity:
                if velocity is not None:
                    given[k] = velocity
                k += 1
            rows_phi.append([ca.SX(0) if pos is None else pos for pos in cr.position])
            labels += cr.labels
            kd, kp = (float(v) for v in c.baumgarte)
            gains_d += [kd] * len(cr.labels)
            gains_p += [kp] * len(cr.labels)
        phi = ca.vertcat(*[ca.vertcat(*r) for r in rows_phi])
        phidot = b.rate(phi)
        if given:
            phidot = ca.vertcat(*[given.get(i, phidot[i]) for i in range(int(phi.numel()))])
        A = ca.jacobian(phidot, b.u)
        # phi'' = A u' + b.rate(phi') (the remainder: u held), stabilized (Baumgarte 1972).
        w = b.rate(phidot) + ca.DM(gains_d) * phidot + ca.DM(gains_p) * phi
        m = int(phi.numel())
        self.rows = tuple(labels)
        self.n_rows = m

        # Multiplier outputs: force and torque on body_a in scene axes, from a placeholder.
        self.multipliers = ca.SX.sym("lambda", m)
        for lj, start, C_a, C_b, pairs in torque_pairs:
            if C_b is None:  # a contact: its multipliers act along the directions C_a
                force = sum((self.multipliers[start + i] * e for i, e in enumerate(C_a)), ca.SX.zeros(3, 1))
                b.add_output([f"{lj.name}.force.{c}" for c in _XYZ], force)
                continue
            b.add_output([f"{lj.name}.force.{c}" for c in _XYZ], self.multipliers[start:start + 3])
            if pairs:
                torque = ca.SX.zeros(3, 1)
                for k, (n_i, m_i) in enumerate(pairs):
                    torque += self.multipliers[start + 3 + k] * cross(C_a @ ca.DM(n_i), C_b @ ca.DM(m_i))
                b.add_output([f"{lj.name}.torque.{c}" for c in _XYZ], torque)

        nq, nu = b.q.numel(), b.u.numel()
        position = ca.Function("loop_position", [x, psym, t], [phi], ["x", "p", "t"], ["phi"])
        velocity = ca.Function("loop_velocity", [x, psym, t], [phidot], ["x", "p", "t"], ["phidot"])
        jacobians = ca.Function("loop_jacobians", [x, psym, t], [ca.jacobian(phi, x), ca.jacobian(phidot, x)],
                                ["x", "p", "t"], ["dphi_dx", "dphidot_dx"])
        p0 = np.asarray(param_values, float).reshape(-1)
        chosen = [name for lj in scene.loop_joints if lj.solve_for is not None
                  for name in ([lj.solve_for] if isinstance(lj.solve_for, str) else lj.solve_for)]
        if chosen:
            owned = tuple(f"{name}." for name in chosen)
            chosen_q = [k for k, name in enumerate(b.q_names) if name.startswith(owned)]
            chosen_u = [k for k, name in enumerate(b.u_names) if name.startswith(owned)]
        else:
            chosen_q = chosen_u = None
        check_not_flat(scene, contacts, x, np.array(x0_guess, float), psym, p0, t)
        self.x0 = _consistent_state(scene, np.array(x0_guess, float), position, velocity, jacobians, p0, nq, nu,
                                    quaternions=[k for k, name in enumerate(b.q_names) if name.endswith(".qw")],
                                    chosen=(chosen_q, chosen_u), rows=self.rows)
        A0 = np.asarray(jacobians(self.x0, p0, 0.0)[1], float)[:, nq:nq + nu]
        selected = tuple(sorted(pivoted_columns(A0.T)))
        self.selected = selected
        # Selection matrix S (m x r): the full multiplier vector is S lambda_selected.
        S = np.zeros((m, len(selected)))
        S[list(selected), range(len(selected))] = 1.0
        self._S = ca.DM(S)
        rows = list(selected)
        self.terms = ca.Function("loop_terms", [x, psym, t],
                                 [A[rows, :] if rows else ca.SX(0, nu), w[rows] if rows else ca.SX(0, 1)])
        self.info = LoopConstraints(
            joints=tuple(e.name for e in (*scene.loop_joints, *scene.constraints)), rows=self.rows, independent_rows=selected,
            position=position, velocity=velocity, jacobians=jacobians, n_coordinates=nq, n_speeds=nu,
            param_values=tuple(float(v) for v in p0))

    @property
    def selection(self) -> Any:
        """``S`` (DM, rows x independent rows): the full multiplier vector is ``S lambda``."""
        return self._S

    @property
    def graph_size(self) -> int:
        return int(self.terms.n_instructions())

    def accelerations(self, M, rhs, x, p, t):
        """``(u', lambda)`` (SX or MX, like ``M``): Eq. 1.95 with the chosen rows; ``lambda`` full."""
        # One factorization of M for both right-hand sides: [M^-1 rhs, M^-1 A^T].
        return self.accelerations_by(lambda T: _solve(M, T), rhs, x, p, t)

    def accelerations_by(self, solve, rhs, x, p, t):
        """``(u', lambda)`` with ``solve(T) = M^-1 T`` given (a dense solve, or the order-n
        recursion on several columns at once): Eq. 1.95 with the chosen rows."""
        A, w = self.terms(x, p, t)
        if not self.selected:
            return solve(rhs), ca.mtimes(self._S, ca.MX(0, 1) if isinstance(rhs, ca.MX) else ca.SX(0, 1))
        sol = solve(ca.horzcat(rhs, A.T))
        Minv_rhs, Minv_At = sol[:, 0], sol[:, 1:]
        lam = _solve(ca.mtimes(A, Minv_At), -(ca.mtimes(A, Minv_rhs) + w))
        return Minv_rhs + ca.mtimes(Minv_At, lam), ca.mtimes(self._S, lam)


def _solve(M, T):
    """``M^-1 T``: symbolic for SX; for MX LAPACK's LU with partial pivoting, whose result is a
    smooth function of the entries (CasADi's default MX solve, a QR factorization, switches
    branches where entries vanish and gives finite differences jumps at such points)."""
    return ca.solve(M, T, "lapacklu") if isinstance(M, ca.MX) else ca.solve(M, T)


def _consistent_state(scene, x: NDArray, position, velocity, jacobians, p, nq: int, nu: int, *,
                      quaternions: list[int], chosen: tuple, rows: tuple[str, ...] = ()) -> NDArray:
    """Close the loops: Newton on the dependent coordinates, then the dependent speeds.

    The dependent coordinates and speeds are ``chosen`` (the ``solve_for`` joints'), or else
    picked by a pivoted QR of the Jacobians.
    """
    parts = [f"loop_joints ({', '.join(lj.name for lj in scene.loop_joints)})"] if scene.loop_joints else []
    names = ", ".join(parts + [f"constraints[{k}] ({c.name})" for k, c in enumerate(scene.constraints)])

    def phi(xx):
        return np.asarray(position(xx, p, 0.0), float).reshape(-1)

    G = np.asarray(jacobians(x, p, 0.0)[0], float)[:, :nq]
    dependent = list(pivoted_columns(G)) if chosen[0] is None else chosen[0]
    r = phi(x)
    for _ in range(50):
        size = np.max(np.abs(r), initial=0.0)
        if size <= 0.01 * CLOSURE_TOL or not dependent:
            break
        G = np.asarray(jacobians(x, p, 0.0)[0], float)[:, dependent]
        x[dependent] += np.linalg.lstsq(G, -r, rcond=None)[0]
        r = phi(x)
        if size <= CLOSURE_TOL and np.max(np.abs(r)) >= size:
            break  # at round-off
    for k in quaternions:  # the attitude matrix is normalized, so phi does not change
        x[k:k + 4] /= np.linalg.norm(x[k:k + 4])
    r = phi(x)
    if np.max(np.abs(r), initial=0.0) > CLOSURE_TOL:
        worst = int(np.argmax(np.abs(r)))
        raise ModelError(f"{names}: the initial coordinates do not close the loop: constraint "
                         f"row {rows[worst] if rows else worst!r} is off by {r[worst]:.3g} after Newton's method on the dependent coordinates; "
                         "give initial joint coordinates (q0) closer to a closed configuration, or other "
                         "joints to solve_for")
    A = np.asarray(jacobians(x, p, 0.0)[1], float)[:, nq:nq + nu]
    dependent_u = list(pivoted_columns(A)) if chosen[1] is None else chosen[1]
    for _ in range(2):  # linear in the speeds: one step, one to polish round-off
        v = np.asarray(velocity(x, p, 0.0), float).reshape(-1)
        if not dependent_u or np.max(np.abs(v), initial=0.0) == 0:
            break
        x[nq + np.array(dependent_u)] += np.linalg.lstsq(A[:, dependent_u], -v, rcond=None)[0]
    v = np.asarray(velocity(x, p, 0.0), float).reshape(-1)
    if np.max(np.abs(v), initial=0.0) > CLOSURE_TOL:
        raise ModelError(f"{names}: could not make the initial speeds consistent with the loop "
                         f"constraints (velocity residual {np.max(np.abs(v)):.3g})")
    return x
