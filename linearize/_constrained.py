"""Linearization of a constrained model (a scene with loop joints or contacts) onto independent coordinates and speeds."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from linflex import LinearSystem, ModelError, NonlinearModel, OperatingPoint
from linflex.dynamics import pivoted_columns
from linflex.system import check_positive

from ._linearization import _default_op, linearize
from ._result import Linearization

__all__ = ["ConstrainedLinearization", "constrained_linearization"]


@dataclass(frozen=True)
class ConstrainedLinearization:
    """A linearization restricted to the motions the loop constraints allow.

    The full-state deviations are ``dx = basis @ dz`` with ``dz`` the deviations of the
    independent states; ``sys`` is ``dz' = A dz + B du``, ``dy = C dz + D du`` (deviations from
    the operating point, as for :func:`linearize`).

    Attributes
    ----------
    sys : LinearSystem
        The linear system in the independent states (named after them).
    full : Linearization
        The linearization of all the tree's states (with the constraint-stabilization
        eigenvalues that ``sys`` does not have).
    basis : ndarray, shape (n_states, n_independent)
        The null-space basis of the linearized position and velocity constraints (read-only).
    independent, dependent : tuple of str
        The independent states and the coordinates and speeds the constraints determine.
    constraint_residual : float
        ``max(|phi|, |phi'|)`` at the operating point [m, m/s or -, 1/s].
    invariance_residual : float
        ``max(|A T - T A_r|, |B - T B_r|)`` relative to ``max(1, |A|, |B|)`` (largest entries) [-]:
        how far the full linearization is from leaving the constraint space invariant (round-off
        at a consistent equilibrium).
    seconds : float
        Wall time [s], the full linearization included.
    """

    sys: LinearSystem
    full: Linearization
    basis: NDArray[np.float64]
    independent: tuple[str, ...]
    dependent: tuple[str, ...]
    constraint_residual: float
    invariance_residual: float
    seconds: float


def constrained_linearization(
    model: NonlinearModel,
    op: OperatingPoint | None = None,
    *,
    method: Literal["auto", "perturbation", "central", "autodiff", "kane"] = "auto",
    independent: list[str] | tuple[str, ...] | None = None,
    constraint_tol: float = 1e-9,
    equilibrium_tol: float = 1e-8,
    allow_non_equilibrium: bool = False,
) -> ConstrainedLinearization:
    """Linearize a model with loop constraints onto independent coordinates and speeds.

    The full-state linearization of a compiled scene with loop joints has extra eigenvalues: the
    constraint stabilization's (``LoopJoint.baumgarte``) and zeros for the directions that break
    the constraints. Restricting it to the null space of the linearized position and velocity
    constraints removes them and leaves the mechanism's own dynamics. Non-holonomic contacts
    (``scene.constraints``: rolling wheels, knife edges) constrain speeds only: their rows have
    no position (``phi = 0``), so they remove speeds but no coordinates (Kane's independent
    speeds; ``examples/scene_bicycle.py``).

    Parameters
    ----------
    model : Model
        A compiled scene with ``loop_joints`` (``model.constraints`` is set).
    op : OperatingPoint, optional
        The point; default ``model.x0`` (consistent with the constraints) with zero inputs at
        t = 0. It must satisfy the constraints to ``constraint_tol``.
    method : {"auto", "perturbation", "central", "autodiff", "kane"}
        The method of the full linearization (:func:`linearize`).
    independent : sequence of str, optional
        The independent coordinates and speeds by state name (as many as the constraints leave
        free); default: the complement of the coordinates and speeds chosen by a QR
        factorization with column pivoting of the constraint Jacobians.
    constraint_tol : float
        Largest constraint residual accepted at ``op`` [m, m/s or -, 1/s].
    equilibrium_tol : float
        Largest scaled residual accepted as an equilibrium [1/s], as for :func:`linearize`.
    allow_non_equilibrium : bool
        Linearize about a non-equilibrium point too, as for :func:`linearize`.

    Returns
    -------
    ConstrainedLinearization
        The linear system in the independent states, the full linearization, the basis and
        the residuals.

    Raises
    ------
    ModelError
        For a model without loop constraints, an operating point that violates them, or an
        ``independent`` choice with the wrong number of states or that leaves the dependent
        ones undetermined.
    NotAnEquilibriumError
        As for :func:`linearize`.

    Notes
    -----
    Coordinate partitioning (Banerjee 2016, Eqs. 8.78-8.86; Wehage and Haug 1982) of the
    linearized constraints ``G_q dq = 0`` and ``Gv_q dq + Gv_u du = 0`` (``G_q = d(phi)/dq``,
    ``Gv = d(phi')/d(q, u)``)::

        dq_d = -G_qd^+ G_qi dq_i            du_d = -Gv_ud^+ (Gv_q dq + Gv_ui du_i)

        dx = T dz,   A_r = E A T,   B_r = E B,   C_r = C T,   D_r = D

    with ``E`` the rows of the independent states. The constraint space is invariant under the
    full linear dynamics (the stabilized constraint errors obey their own equations), so this
    restriction is exact; ``invariance_residual`` checks it.

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import compile_model, load_scene
    >>> from linflex.linearize import constrained_linearization
    >>> model = compile_model(load_scene("examples/four_bar.toml"))
    >>> lin = constrained_linearization(model, independent=["crank_hinge.angle", "crank_hinge.rate"])
    >>> lin.dependent
    ('rocker_hinge.angle', 'coupler_hinge.angle', 'rocker_hinge.rate', 'coupler_hinge.rate')
    >>> sorted(np.round(np.abs(np.linalg.eigvals(lin.full.sys.A)), 3).tolist())  # rad/s; 10: stabilization
    [4.448, 4.448, 10.0, 10.0, 10.0, 10.0]
    >>> np.round(np.abs(np.linalg.eigvals(lin.sys.A)), 3).tolist()  # the mechanism's own mode
    [4.448, 4.448]
    """
    start = time.perf_counter()
    constraints = getattr(model, "constraints", None)
    if constraints is None:
        raise ModelError("model has no loop constraints (compile a scene with loop_joints or constraints); use linearize")
    constraint_tol = check_positive(constraint_tol, "constraint_tol")
    op = _default_op(model, op)
    x = np.asarray(op.x, float)
    p = model.param_values
    phi, phidot = constraints.residual(x, op.t, p)
    residual = float(max(np.max(np.abs(phi), initial=0.0), np.max(np.abs(phidot), initial=0.0)))
    if residual > constraint_tol:
        rows = constraints.rows
        worst = int(np.argmax(np.maximum(np.abs(phi), np.abs(phidot))))
        raise ModelError(f"op: the operating point violates the loop constraints: row {rows[worst]!r} is off by "
                         f"{max(abs(phi[worst]), abs(phidot[worst])):.3g} (constraint_tol {constraint_tol:.3g}); "
                         "start from model.x0 or close the loop first")
    full = linearize(model, op, method=method, equilibrium_tol=equilibrium_tol,
                     allow_non_equilibrium=allow_non_equilibrium)

    nq, nu, n = constraints.n_coordinates, constraints.n_speeds, model.n_states
    Gp, Gv = constraints.jacobian_matrices(x, op.t, p)
    Gq, Gvq, Gvu = Gp[:, :nq], Gv[:, :nq], Gv[:, nq:nq + nu]
    dep_q, dep_u = _dependent(model, Gq, Gvu, nq, nu, independent)
    ind = [k for k in range(n) if k not in set(dep_q) | {nq + j for j in dep_u}]

    # dx = T dz: identity on the independent states, the dependent ones from the constraints.
    T = np.zeros((n, len(ind)))
    T[ind, range(len(ind))] = 1.0
    if dep_q:
        T[dep_q, :] = -np.linalg.lstsq(Gq[:, dep_q], Gq @ T[:nq, :], rcond=None)[0]
    if dep_u:
        T[[nq + j for j in dep_u], :] = -np.linalg.lstsq(Gvu[:, dep_u], Gvq @ T[:nq, :] + Gvu @ T[nq:nq + nu, :],
                                                          rcond=None)[0]
    A, B, C, D = full.sys.A, full.sys.B, full.sys.C, full.sys.D
    Ar, Br, Cr = A[ind, :] @ T, B[ind, :], C @ T
    scale = max(1.0, float(np.max(np.abs(A), initial=0.0)), float(np.max(np.abs(B), initial=0.0)))
    invariance = max(float(np.max(np.abs(A @ T - T @ Ar), initial=0.0)),
                     float(np.max(np.abs(B - T @ Br), initial=0.0))) / scale
    names = tuple(model.states[k] for k in ind)
    sys = LinearSystem(Ar, Br, Cr, D, states=names, inputs=model.inputs, outputs=model.outputs)
    T.setflags(write=False)
    return ConstrainedLinearization(
        sys=sys, full=full, basis=T, independent=names,
        dependent=tuple(model.states[k] for k in dep_q) + tuple(model.states[nq + j] for j in dep_u),
        constraint_residual=residual, invariance_residual=invariance, seconds=time.perf_counter() - start)


def _dependent(model, Gq, Gvu, nq: int, nu: int, independent) -> tuple[list[int], list[int]]:
    """Dependent coordinate and speed columns: pivoted QR, or the complement of ``independent``."""
    auto_q, auto_u = sorted(pivoted_columns(Gq)), sorted(pivoted_columns(Gvu))
    if independent is None:
        return auto_q, auto_u
    states = list(model.states)
    chosen = set()
    for k, name in enumerate([independent] if isinstance(independent, str) else independent):
        if name not in states[:nq + nu]:
            raise ModelError(f"independent[{k}]: {name!r} is not a coordinate or speed of the model; "
                             f"they are {', '.join(states[:nq + nu])}")
        chosen.add(states.index(name))
    dep_q = [k for k in range(nq) if k not in chosen]
    dep_u = [j for j in range(nu) if nq + j not in chosen]
    if len(dep_q) != len(auto_q) or len(dep_u) != len(auto_u):
        raise ModelError(f"independent: the constraints leave {nq - len(auto_q)} coordinates and {nu - len(auto_u)} "
                         f"speeds free; got {nq - len(dep_q)} coordinates and {nu - len(dep_u)} speeds")
    for G, dep, what in ((Gq, dep_q, "coordinates"), (Gvu, dep_u, "speeds")):
        if dep and len(pivoted_columns(G[:, dep])) < len(dep):
            raise ModelError(f"independent: the constraints do not determine the dependent {what} "
                             f"{', '.join(states[k if what == 'coordinates' else nq + k] for k in dep)}; "
                             "choose other independent states")
    return dep_q, dep_u
