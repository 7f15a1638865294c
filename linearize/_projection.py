"""The one projection base of every reduction: Petrov-Galerkin projection and the common result shape.

Every reduction of :mod:`linflex.linearize` chooses bases and hands them to this module, which
alone forms the reduced matrices (pyMOR's shape: reductors built on one projection):

- :func:`project`: ``x ~ V xr``, ``xr = W^T x`` with ``W^T V = I`` (Petrov-Galerkin; ``W = V``
  for an orthonormal Galerkin basis) gives ``(W^T A V, W^T B, C V, D)``;
- :func:`project_split`: the stable part of a :class:`~linflex.linearize.StableSplit` projected,
  reassembled with the unstable/rigid part kept exactly, with the bases in the original
  coordinates ``V = [T_u, T_s V_s]``, ``W = [T_inv_u^T, T_inv_s^T W_s]``;
- :func:`project_second_order`: the Ritz (Galerkin) projection of a second-order system,
  ``T^T M T``, ``T^T D T``, ``T^T K T``, ``T^T B``, ``Cq T``, ``Cv T``; its first-order form is
  :func:`project` of ``sys.to_state_space()`` with the bases of :func:`second_order_bases`.

:class:`ReductionResult` is the shape every result shares (balanced and modal truncation, minimal
realization, projected modes, and the core's component reductions ``guyan``/``craig_bampton``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import LinearSystem, SecondOrderSystem
from linflex.frequency import HinfNorm

from ._reduction_split import StableSplit

__all__ = ["ReductionResult", "SplitProjection", "project", "project_split", "project_second_order",
           "second_order_bases"]


@runtime_checkable
class ReductionResult(Protocol):
    """The fields every reduction result carries.

    Attributes
    ----------
    sys : LinearSystem or SecondOrderSystem
        The reduced system.
    V, W : ndarray
        The bases in the original coordinates: ``x ~ V xr``, ``xr = W^T x`` (second-order
        reductions: ``q ~ V qr`` with ``W`` the left basis; ``T`` of a component reduction).
    error_bound : float or None
        A-priori bound on the H-infinity norm of ``G - G_r`` [output units per input unit] where
        the method has one (Glover's ``2 sum(discarded hsv)`` for balanced truncation); None
        where it has none (modal truncation, the staircase minimal realization, projected modes,
        component modes).
    measured_error : HinfNorm or None
        The measured ``||G - G_r||`` (through the frequency engine, with its
        ``evaluation_error``) when asked for; None otherwise.
    order : int
        Number of coordinates of ``sys``: states (first order) or dofs (second order).
    seconds : float
        Wall time of the reduction [s].
    """

    sys: LinearSystem | SecondOrderSystem
    V: NDArray[np.float64]
    W: NDArray[np.float64]
    error_bound: float | None
    measured_error: HinfNorm | None
    order: int
    seconds: float


def project(sys: LinearSystem, V: NDArray, W: NDArray | None = None, *, states: Sequence[str],
            D: NDArray | None = None, A: NDArray | None = None) -> LinearSystem:
    """Petrov-Galerkin projection ``(W^T A V, W^T B, C V, D)`` of a first-order system (a sparse
    ``A`` is multiplied as it is, never formed densely).

    Parameters
    ----------
    sys : LinearSystem
        The system.
    V : ndarray, shape (n, r)
        Right basis, ``x ~ V xr``.
    W : ndarray, shape (n, r), optional
        Left basis with ``W^T V = I``; ``V`` (Galerkin) by default.
    states : sequence of str
        Names of the ``r`` reduced states.
    D : ndarray, optional
        Feedthrough of the reduced system; ``sys.D`` by default (a static correction passes its own).
    A : ndarray, shape (r, r), optional
        The projected state matrix when it is known in closed form (modal truncation: the real
        blocks of the kept eigenvalues, which equal ``W^T A V`` in exact arithmetic and are free
        of its round-off).

    Returns
    -------
    LinearSystem
        The reduced system, with the inputs and outputs of ``sys``.
    """
    W = V if W is None else W
    if A is None:
        Ar = W.T @ (sys.A_sparse @ V) if sys.is_sparse else W.T @ sys.A @ V   # a sparse A: O(nnz r)
    else:
        Ar = A
    return LinearSystem(Ar, W.T @ sys.B, sys.C @ V, sys.D if D is None else D, states=list(states),
                        inputs=sys.inputs, outputs=sys.outputs)


@dataclass(frozen=True)
class SplitProjection:
    """A reduced stable part reassembled with the exact unstable/rigid part.

    Attributes
    ----------
    sys : LinearSystem
        ``blockdiag(A_u, A_sr)`` etc.; states of the unstable part (``xu0..``) then the reduced
        stable part's.
    stable : LinearSystem
        The reduced stable part alone (for the error system ``G_s - G_sr``).
    V, W : ndarray
        Bases in the original coordinates, ``V = [T_u, T_s V_s]``, ``W = [T_inv_u^T, T_inv_s^T W_s]``.
    """

    sys: LinearSystem
    stable: LinearSystem
    V: NDArray[np.float64]
    W: NDArray[np.float64]


def project_split(split: StableSplit, Vs: NDArray, Ws: NDArray | None = None, *, prefix: str,
                  D: NDArray | None = None, A: NDArray | None = None) -> SplitProjection:
    """Project the stable part of ``split`` on ``(Vs, Ws)`` and keep the unstable part exactly.

    Parameters
    ----------
    split : StableSplit
        The additive decomposition (:func:`~linflex.linearize.split_stable`).
    Vs, Ws : ndarray, shape (n_stable, r)
        Bases of the stable part's coordinates (``Ws = Vs`` by default).
    prefix : str
        Reduced stable states are named ``prefix0, prefix1, ...``.
    D, A : ndarray, optional
        As in :func:`project` (``D`` defaults to the stable part's feedthrough, which is the system's).

    Returns
    -------
    SplitProjection
        The reassembled system, the reduced stable part and the bases in the original coordinates.
    """
    Ws = Vs if Ws is None else Ws
    stable = project(split.stable, Vs, Ws, states=[f"{prefix}{i}" for i in range(Vs.shape[1])], D=D, A=A)
    un = split.unstable
    n_u = split.n_unstable
    red = LinearSystem(
        scipy.linalg.block_diag(un.A, stable.A), np.vstack([un.B, stable.B]), np.hstack([un.C, stable.C]), stable.D,
        states=list(un.states) + list(stable.states), inputs=un.inputs, outputs=un.outputs,
    )
    V = np.hstack([split.T[:, :n_u], split.T[:, n_u:] @ Vs])
    W = np.hstack([split.T_inv[:n_u].T, split.T_inv[n_u:].T @ Ws])
    return SplitProjection(sys=red, stable=stable, V=V, W=W)


def project_second_order(sys: SecondOrderSystem, T: NDArray, *, dofs: Sequence[str]) -> SecondOrderSystem:
    """Ritz (Galerkin) projection ``q ~ T qr`` of a second-order system.

    Parameters
    ----------
    sys : SecondOrderSystem
        The system.
    T : ndarray, shape (n_dofs, r)
        The Ritz basis [dof units per reduced coordinate].
    dofs : sequence of str
        Names of the ``r`` reduced dofs.

    Returns
    -------
    SecondOrderSystem
        ``T^T M T``, ``T^T D T``, ``T^T K T`` (mass and stiffness symmetrized), ``T^T B``,
        ``Cq T``, ``Cv T``, ``Du``. Its state-space form equals :func:`project` of
        ``sys.to_state_space()`` on the bases of :func:`second_order_bases`.
    """
    Mr, Kr = T.T @ sys.M @ T, T.T @ sys.K @ T
    return SecondOrderSystem(
        (Mr + Mr.T) / 2, T.T @ sys.D @ T, (Kr + Kr.T) / 2, T.T @ sys.B, sys.Cq @ T, sys.Cv @ T, sys.Du,
        dofs=list(dofs), inputs=sys.inputs, outputs=sys.outputs,
    )


def second_order_bases(sys: SecondOrderSystem, T: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """First-order bases ``(V, W)`` of the Ritz projection ``q ~ T qr`` on the state ``x = [q; q']``.

    Parameters
    ----------
    sys : SecondOrderSystem
        The system (for ``M``).
    T : ndarray, shape (n_dofs, r)
        The Ritz basis, full column rank.

    Returns
    -------
    V, W : ndarray, shape (2 n_dofs, 2 r)
        ``V = blockdiag(T, T)``, ``W = blockdiag(T (T^T T)^-1, M T (T^T M T)^-1)``: ``W^T V = I``
        and ``W^T A V`` is the state matrix of :func:`project_second_order` (the velocity rows are
        weighted by ``M^-1`` in ``A``, hence the mass-weighted left basis).
    """
    Mr = T.T @ sys.M @ T
    W1 = np.linalg.solve(T.T @ T, T.T).T
    W2 = np.linalg.solve(Mr, T.T @ sys.M).T
    return scipy.linalg.block_diag(T, T), scipy.linalg.block_diag(W1, W2)
