"""Compile once per structure: the scene numbers a sweep varies become parameters of one graph.

A sweep over a scene varies a few numbers (a hub inertia, a beam's bending stiffness) and runs
the same analysis on every variant. Compiling each variant rebuilds the same CasADi graph with
other constants; here each *structure* is compiled once, with the varied numbers as parameters
``p`` of the graph, and every case gets that model with its own parameter values
(:meth:`Model.with_params`): the linearization and everything after it run at the case's values.

What becomes a parameter (by the scene path a sweep varies):

- ``bodies.<b>.mass`` -> ``<b>.mass``; ``bodies.<b>.inertia...`` -> the body's inertia entries;
  ``joints.<j>.stiffness`` and ``.damping`` (revolute or prismatic) -> the joint's;
- any other number of a flexible body (``bodies.<b>.beam.EI``, ``.GJ``, ``.damping``, ...) ->
  the body's modal stiffness and damping matrices (``<b>.modal_stiffness[k,l]``,
  ``<b>.modal_damping[k,l]``), provided the case's modes span the same space as the group's
  (below).

Everything else changes the structure of the model (the number of modes, which effects, a
joint's type, a controller gain the plant does not contain but the scene does): cases are grouped
by the scene with the parametric numbers masked, and each group compiles once. A flexible body's
modes are compared per case: when the case's mode shapes are those of the group's reference
case in another basis, ``Phi_case = Phi_ref Q`` (same mass points, same geometric stiffness
``S_case = Q^T S_ref Q``, to ``MATCH_TOL`` of their size), the case is the reference model in the
coordinates ``eta_ref = Q eta_case`` with the modal stiffness ``Q^-T K_case Q^-1`` (and damping
alike): the same equations, so the same transfer functions, margins and modes to round-off. A
beam whose bending stiffness changes keeps its mode shapes and only scales its frequencies; when
the change moves another mode (a torsion mode) into the kept set, the shapes no longer match and
the case starts a group of its own.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import pickle
import re
import threading
from collections import OrderedDict
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..scene._scene import Scene
from ..scene._values import inertia_matrix

__all__ = ["MATCH_TOL", "compile_once", "elastic_loads", "modal_matrices", "sweep_compiler"]

#: Largest difference, relative to each array's largest entry, between a case's mode shapes (and
#: geometric stiffness) and those of its group's reference in the case's basis. Mode shapes of a
#: 16-element beam computed at two bending stiffnesses agree to 5e-12..2e-11 (the eigenvectors'
#: round-off); a mode moving in or out of the kept set differs at order 1.
MATCH_TOL = 1e-9

#: Structures kept per process (each a compiled model of a few MB).
MAX_GROUPS = 32

_INERTIA_KEYS = ("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")
_ACTIVE: contextvars.ContextVar[SweepCompiler | None] = contextvars.ContextVar("linflex_compile_once", default=None)
_COMPILERS: dict[tuple[str, ...], SweepCompiler] = {}
_COMPILERS_LOCK = threading.Lock()


def modal_matrices(data) -> tuple[np.ndarray, np.ndarray]:
    """Modal stiffness [N/m per modal coordinate] and damping matrices of a flexible body's data.

    With modal masses ``m_k = (e + W9)_kk`` (1 for mass-normalized modes): ``diag(m_k w_k^2)``
    and ``diag(2 zeta_k w_k m_k)``.
    """
    integrals = data.integrals()
    modal_mass = np.diagonal(integrals.e + integrals.W9)
    w, zeta = np.asarray(data.frequencies, float), np.asarray(data.damping, float)
    return np.diag(modal_mass * w**2), np.diag(2.0 * zeta * w * modal_mass)


def modal_parameter_names(body: str, n_modes: int) -> list[str]:
    """The parameter names of a flexible body's modal stiffness and damping (upper triangles)."""
    return [f"{body}.{kind}[{k},{l}]" for kind in ("modal_stiffness", "modal_damping")
            for k in range(n_modes) for l in range(k, n_modes)]


def modal_parameter_values(body: str, K: np.ndarray, C: np.ndarray) -> dict[str, float]:
    """``{name: value}`` of :func:`modal_parameter_names` for the symmetric matrices ``K``, ``C``."""
    n = K.shape[0]
    out = {}
    for kind, mat in (("modal_stiffness", K), ("modal_damping", C)):
        sym = 0.5 * (mat + mat.T)
        for k in range(n):
            for l in range(k, n):
                out[f"{body}.{kind}[{k},{l}]"] = float(sym[k, l])
    return out


def elastic_loads(b) -> None:
    """Modal stiffness and damping of the flexible bodies as generalized forces.

    With modal masses ``m_k`` (1 for mass-normalized modes): ``-m_k (w_k^2 q_k + 2 zeta_k w_k q_k')``;
    the elastic energy ``1/2 sum m_k w_k^2 q_k^2`` joins the potential of the energy monitor. With
    the body's modal matrices exposed as parameters (``<body>.modal_stiffness[k,l]``, a sweep that
    compiles once): ``-(K q + C q')`` and ``1/2 q^T K q`` with ``K``, ``C`` symbolic.
    """
    import casadi as ca

    for fe in b.flexible:
        n = fe.data.n_modes
        K, C = modal_matrices(fe.data)
        names = modal_parameter_names(fe.name, n)
        if not any(name in b.params for name in names):
            for k in range(n):
                force = -(K[k, k] * fe.q[k] + C[k, k] * fe.qd[k])
                b.add_generalized_force(b.speed_index(f"{fe.name}.eta{k}_rate"), force)
                b.add_potential(0.5 * K[k, k] * fe.q[k] ** 2)
            continue
        Ks, Cs = ca.SX.zeros(n, n), ca.SX.zeros(n, n)
        for k in range(n):
            for l in range(k, n):
                for S, kind, M in ((Ks, "modal_stiffness", K), (Cs, "modal_damping", C)):
                    S[k, l] = S[l, k] = b.param(f"{fe.name}.{kind}[{k},{l}]", M[k, l])
        force = -(Ks @ fe.q + Cs @ fe.qd)
        for k in range(n):
            b.add_generalized_force(b.speed_index(f"{fe.name}.eta{k}_rate"), force[k])
        b.add_potential(0.5 * ca.dot(fe.q, Ks @ fe.q))


def modal_nominal(scene: Scene, requested: Sequence[str]) -> dict[str, float]:
    """Nominal values of the modal parameters among ``requested`` (the flexible bodies they name)."""
    out: dict[str, float] = {}
    for body in scene.bodies:
        if body.type == "flexible" and any(str(r).startswith(f"{body.name}.modal_") for r in requested):
            K, C = modal_matrices(body.resolved_modal_data())
            out.update(modal_parameter_values(body.name, K, C))
    return out


# -- matching a case's modes to a group's ----------------------------------------------------


def _shapes(data) -> np.ndarray:
    parts = [data.translations, data.rotations]
    if data.node_translations is not None:
        parts += [data.node_translations, data.node_rotations]
    return np.concatenate([np.reshape(p, (-1, data.n_modes)) for p in parts])


def _close(a, b, tol: float) -> bool:
    if a is None or b is None:
        return a is None and b is None
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape:
        return False
    scale = max(float(np.max(np.abs(b), initial=0.0)), np.finfo(float).tiny)
    return bool(np.max(np.abs(a - b), initial=0.0) <= tol * scale)


def basis_change(reference, case, tol: float = MATCH_TOL) -> np.ndarray | None:
    """``Q`` with ``Phi_case = Phi_ref Q`` when ``case`` is ``reference``'s structure in another
    modal basis (same mass points and nodes, shapes and geometric stiffness to ``tol``), else None."""
    n = case.n_modes
    if reference.n_modes != n or tuple(reference.node_names) != tuple(case.node_names):
        return None
    for field in ("positions", "masses", "inertias", "node_positions"):
        if not _close(getattr(case, field), getattr(reference, field), tol):
            return None
    ref, cas = _shapes(reference), _shapes(case)
    Q = np.linalg.lstsq(ref, cas, rcond=None)[0]
    if not _close(ref @ Q, cas, tol) or np.linalg.cond(Q) > 1e6:
        return None
    Sr, Sc = reference.geometric_stiffness, case.geometric_stiffness
    if (Sr is None) != (Sc is None):
        return None
    if Sc is not None and not _close(np.einsum("kl,ikm,mn->iln", Q, np.asarray(Sr), Q), Sc, tol):
        return None
    return Q


# -- the per-process cache of compiled structures -------------------------------------------


def _classify(scene: Scene, path: str) -> tuple[str, Any]:
    """``("param", names)``, ``("modal", body)`` or ``("structure", None)`` for a varied scene path."""
    tokens = path.split(".")
    if len(tokens) >= 3 and tokens[0] == "bodies":
        body = next((b for b in scene.bodies if b.name == tokens[1]), None)
        if body is None:
            return "structure", None
        field = re.sub(r"\[\d+\]", "", tokens[2])
        if len(tokens) == 3 and field == "mass":
            return "param", [f"{body.name}.mass"]
        if len(tokens) == 3 and field == "inertia":
            keys = _INERTIA_KEYS[:3] if np.shape(body.inertia) == (3,) else _INERTIA_KEYS
            return "param", [f"{body.name}.{k}" for k in keys]
        if body.type == "flexible" and field not in ("mass", "inertia", "com", "name", "type", "modes"):
            return "modal", body.name
    if len(tokens) == 3 and tokens[0] == "joints" and tokens[2] in ("stiffness", "damping"):
        joint = next((j for j in scene.joints if j.name == tokens[1]), None)
        if joint is not None and joint.type in ("revolute", "prismatic"):
            return "param", [f"{joint.name}.{tokens[2]}"]
    return "structure", None


def _param_values(scene: Scene, names: Sequence[str]) -> dict[str, float]:
    bodies = {b.name: b for b in scene.bodies}
    joints = {j.name: j for j in scene.joints}
    out = {}
    for name in names:
        owner, key = name.rsplit(".", 1)
        if key == "mass":
            out[name] = float(bodies[owner].mass)
        elif key in _INERTIA_KEYS:
            i = _INERTIA_KEYS.index(key)
            row, col = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))[i]
            out[name] = float(inertia_matrix(bodies[owner].inertia)[row, col])
        else:
            out[name] = float(getattr(joints[owner], key))
    return out


@dataclasses.dataclass
class _Group:
    model: Any
    references: dict[str, Any]  # flexible body -> the modal data the graph was compiled with


class SweepCompiler:
    """The compiled structures of one sweep's varied paths, in one process (thread-safe).

    Attributes
    ----------
    paths : tuple of str
        The scene paths the sweep varies.
    compilations : int
        Structures compiled so far in this process.
    """

    def __init__(self, paths: Sequence[str]) -> None:
        self.paths = tuple(paths)
        self.compilations = 0
        self._groups: OrderedDict[bytes, list[_Group]] = OrderedDict()
        self._lock = threading.Lock()

    def model(self, scene: Scene, symbolic: str, formulation: str, compile: Callable[..., Any]):
        """The compiled model of ``scene``: its group's graph at the case's parameter values."""
        param_names: list[str] = []
        modal: list[str] = []
        data = scene.to_dict()
        data["bodies"] = [dict(b) for b in data.get("bodies", [])]
        data["joints"] = [dict(j) for j in data.get("joints", [])]
        for path in self.paths:
            kind, what = _classify(scene, path)
            if kind == "param":
                param_names += [n for n in what if n not in param_names]
                owner, key = what[0].rsplit(".", 1)
                table = "joints" if key in ("stiffness", "damping") else "bodies"
                entry = next(e for e in data[table] if e.get("name") == owner)
                entry["inertia" if key in _INERTIA_KEYS else key] = None
            elif kind == "modal" and what not in modal:
                modal.append(what)
                entry = next(e for e in data["bodies"] if e.get("name") == what)
                for key in ("beam", "modal_data"):
                    entry.pop(key, None)
        key = pickle.dumps((data, symbolic, formulation), protocol=pickle.HIGHEST_PROTOCOL)
        values = _param_values(scene, param_names)
        case_data = {b.name: b.resolved_modal_data() for b in scene.bodies if b.name in modal}
        with self._lock:
            for group in self._groups.get(key, []):
                changes = {name: basis_change(group.references[name], case_data[name]) for name in modal}
                if all(Q is not None for Q in changes.values()):
                    self._groups.move_to_end(key)
                    break
            else:
                group, changes = None, {name: None for name in modal}
        if group is None:
            names = param_names + [n for body in modal for n in modal_parameter_names(body, case_data[body].n_modes)]
            token = _ACTIVE.set(None)  # the group's own compilation is a plain one
            try:
                group = _Group(compile(scene, params=names, symbolic=symbolic, formulation=formulation), case_data)
            finally:
                _ACTIVE.reset(token)
            with self._lock:
                self.compilations += 1
                self._groups.setdefault(key, []).append(group)
                self._groups.move_to_end(key)
                while sum(len(groups) for groups in self._groups.values()) > MAX_GROUPS:
                    oldest = next(iter(self._groups))
                    if len(self._groups[oldest]) > 1:
                        self._groups[oldest].pop(0)
                    else:
                        del self._groups[oldest]
        for name in modal:
            K, C = modal_matrices(case_data[name])
            Q = changes[name]
            if Q is not None:  # eta_ref = Q eta_case: forces transform with Q^-T
                Qi = np.linalg.inv(Q)
                K, C = Qi.T @ K @ Qi, Qi.T @ C @ Qi
            values.update(modal_parameter_values(name, K, C))
        base = group.model
        params = {**dict(zip(base.params, base.param_values)), **values}
        return type(base)(base.f, base.h, states=base.states, inputs=base.inputs, outputs=base.outputs,
                          params=params or None,
                          compiled=dataclasses.replace(base.compiled, scene=scene), equations=base._graphs)


def sweep_compiler() -> SweepCompiler | None:
    """The compiler of the sweep running in this context (see :func:`compile_once`), or None."""
    return _ACTIVE.get()


@contextlib.contextmanager
def compile_once(paths: Sequence[str]):
    """Within this block, :func:`compile_model` compiles each structure once per process.

    Parameters
    ----------
    paths : sequence of str
        The scene paths the sweep varies (``"bodies.hub.inertia[0]"``, ...); the cache of
        compiled structures is shared by every block with the same paths in this process (a
        worker runs many cases of one sweep).

    Yields
    ------
    SweepCompiler
        The cache, with its count of ``compilations``.
    """
    paths = tuple(str(p) for p in paths)
    with _COMPILERS_LOCK:
        compiler = _COMPILERS.get(paths)
        if compiler is None:
            _COMPILERS.clear()  # one sweep's structures at a time per process
            compiler = _COMPILERS[paths] = SweepCompiler(paths)
    token = _ACTIVE.set(compiler)
    try:
        yield compiler
    finally:
        _ACTIVE.reset(token)
