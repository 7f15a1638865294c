"""Minimal realization by orthogonal staircase forms or by balancing, with the rank decisions reported."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import LinearSystem, ModelError, as_linear_system
from linflex.frequency import HinfNorm

from ._projection import project
from ._reduction_norm import checked_against_full, stable_parts_error

__all__ = ["MinimalRealization", "minimal_realization"]


@dataclass(frozen=True)
class MinimalRealization:
    """Result of :func:`minimal_realization`.

    Attributes
    ----------
    sys : LinearSystem
        The minimal system; states ``xm0, xm1, ...``.
    order : int
        Its number of states.
    n_removed : int
        States removed.
    n_uncontrollable, n_unobservable : int or None
        States removed in the controllability step, then in the observability step
        (``"staircase"``); None for ``"balanced"``, which does not tell them apart.
    tol : float
        The threshold used: on the singular values of the staircase blocks (``"staircase"``) or
        on the Hankel singular values of the stable part (``"balanced"``); a value at or below it
        counts as zero.
    method : str
        ``"staircase"`` or ``"balanced"``.
    smallest_kept, largest_discarded : float
        Over all rank decisions (staircase blocks, or the Hankel singular values), the smallest
        singular value counted as non-zero and the largest counted as zero (0 when none was discarded or all were exactly zero). A wide gap between
        them, with ``tol`` inside it, means the order is well determined; a small gap means the
        system is close to one of lower order and the result depends on ``tol``.
    V, W : ndarray
        Projection bases ``(n, order)``: ``x ~ V xm``, ``xm = W.T x`` (orthonormal with
        ``W = V`` for ``"staircase"``; the balancing bases for ``"balanced"``).
    seconds : float
        Wall time [s].
    error_bound : float or None
        ``"balanced"``: Glover's a-priori bound ``2 * sum(discarded hsv)`` [output units per input
        unit] (round-off level by construction). ``"staircase"``: None, the rank decisions have
        no a-priori bound on the transfer function (judge them by ``largest_discarded`` and
        ``measured_error``).
    measured_error : HinfNorm or None
        ``||G - G_r||`` of the stable parts, checked against direct evaluations of both systems
        by the frequency engine, when ``measure_error=True``.
    """

    sys: LinearSystem
    order: int
    n_removed: int
    n_uncontrollable: int | None
    n_unobservable: int | None
    tol: float
    method: str
    smallest_kept: float
    largest_discarded: float
    V: NDArray[np.float64]
    W: NDArray[np.float64]
    seconds: float
    error_bound: float | None = None
    measured_error: HinfNorm | None = None


def minimal_realization(sys, tol: float | None = None, *, method: str = "staircase",
                        measure_error: bool = False) -> MinimalRealization:
    """Remove uncontrollable and unobservable states.

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
        The system.
    tol : float, optional
        ``"staircase"``: absolute threshold on the singular values of the staircase blocks,
        default ``n^2 * eps * max(||A||_F, ||B||_F, ||C||_F)`` (the default of SLICOT TB01PD).
        ``"balanced"``: absolute threshold on the Hankel singular values of the stable part,
        default and at least their round-off floor (``hsv_floor`` of
        :func:`~linflex.linearize.balanced_truncation`: values below it cannot be balanced).
    method : {"staircase", "balanced"}
        ``"staircase"``: orthogonal controllability then observability staircase forms, for any
        poles. ``"balanced"``: the stable part is replaced by its balanced truncation to the
        Hankel singular values above ``tol``; the unstable/rigid part (see
        :func:`split_stable`) is kept whole. The staircase decides ranks on Krylov-type blocks
        and can miss exactly uncontrollable modes of a high-order lightly damped system (Paige,
        IEEE TAC 26, 1981: the blocks of a nearby controllable system need not be small);
        balancing decides on Hankel singular values, which are robust to that.

    measure_error : bool
        Also measure ``||G - G_r||`` (see :class:`~linflex.frequency.HinfNorm`).

    Returns
    -------
    MinimalRealization

    Raises
    ------
    ModelError
        If ``tol`` is negative or not finite, or ``method`` is unknown.

    Notes
    -----
    Controllability staircase form (Van Dooren, "The generalized eigenstructure problem in linear
    system theory", IEEE TAC 26, 1981; SLICOT TB01PD): an SVD of ``B`` splits the state into its
    range and the rest; the block of ``A`` coupling the rest to the range is treated the same
    way, until a block has rank zero. The controllable states are the ones reached; the same on
    ``(A^T, C^T)`` of the controllable part removes the unobservable states. Orthogonal steps
    keep the rank decisions well conditioned; the gap of every decision is reported.
    Unlike a balanced truncation this works for any poles, including rigid-body modes.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> sys = LinearSystem([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [0.0]], [[1.0, 1.0]])
    >>> minimal_realization(sys).order
    1
    """
    t0 = time.perf_counter()
    sys = as_linear_system(sys, "sys")
    if method not in ("staircase", "balanced"):
        raise ModelError(f"method must be 'staircase' or 'balanced', got {method!r}")
    A, B, C = sys.A, sys.B, sys.C
    n = sys.n_states
    if tol is not None:
        try:
            tol = float(tol)
        except (TypeError, ValueError) as err:
            raise ModelError(f"tol must be a non-negative real number, got {tol!r}") from err
        if not np.isfinite(tol) or tol < 0:
            raise ModelError(f"tol must be a non-negative finite threshold, got {tol!r}")
    if method == "balanced":
        return _balanced_minimal(sys, tol, measure_error, t0)
    if tol is None:
        scale = max(np.linalg.norm(A), np.linalg.norm(B), np.linalg.norm(C), np.finfo(float).tiny)
        tol = max(n, 1) ** 2 * np.finfo(float).eps * scale
    kept: list[float] = []
    dropped: list[float] = []
    Qc, nc = _staircase(A, B, tol, kept, dropped)
    controllable = project(sys, Qc, states=[f"xc{i}" for i in range(nc)])
    Qo, no = _staircase(controllable.A.T, controllable.C.T, tol, kept, dropped)
    V = Qc @ Qo
    red = project(sys, V, states=[f"xm{i}" for i in range(no)])
    V = np.ascontiguousarray(V)
    V.setflags(write=False)
    return MinimalRealization(
        sys=red, order=no, n_removed=n - no, n_uncontrollable=n - nc, n_unobservable=nc - no, tol=float(tol),
        method="staircase",
        smallest_kept=float(min(kept)) if kept else 0.0, largest_discarded=float(max(dropped)) if dropped else 0.0,
        V=V, W=V, seconds=time.perf_counter() - t0, error_bound=None,
        measured_error=_measured(sys, red) if measure_error else None,
    )


def _measured(sys: LinearSystem, red: LinearSystem):
    """``||G - G_r||`` of the stable parts, checked against direct evaluations (the reductions' one check)."""
    return checked_against_full(sys, red, stable_parts_error(sys, red))


def _staircase(A, B, tol, kept, dropped) -> tuple[NDArray[np.float64], int]:
    """Orthonormal basis ``(n, k)`` of the controllable subspace of ``(A, B)`` and its dimension."""
    n = A.shape[0]
    Q = np.eye(n)
    At = np.array(A, dtype=float)
    k = 0
    block = B
    while k < n and block.size:
        U, s, _ = scipy.linalg.svd(block, full_matrices=True)
        r = int(np.sum(s > tol))
        if r < s.size:
            dropped.append(s[r])
        if r:
            kept.append(s[r - 1])
        if r == 0:
            break
        Q[:, k:] = Q[:, k:] @ U
        At[k:, :] = U.T @ At[k:, :]
        At[:, k:] = At[:, k:] @ U
        block = At[k + r:, k:k + r]
        k += r
    return Q[:, :k], k


def _balanced_minimal(sys: LinearSystem, tol, measure_error, t0) -> MinimalRealization:
    """Stable part by balanced truncation at the Hankel singular values above ``tol``."""
    from ._balanced import balanced_truncation

    probe = balanced_truncation(sys)  # the numerical order, and all Hankel singular values
    hsv = probe.hsv
    if tol is None:
        res = probe
        tol = probe.hsv_floor
    else:
        # values at or below the round-off floor are zero whatever tol says (they cannot be
        # balanced); as for balanced_truncation, a tol below round-off keeps the numerical order
        tol = max(tol, probe.hsv_floor)
        k = int(np.sum(hsv > tol))
        res = probe if k == probe.order - probe.n_unstable else balanced_truncation(sys, order=probe.n_unstable + k)
    r = res.order - res.n_unstable
    red = res.sys.with_(states=[f"xm{i}" for i in range(res.order)])
    return MinimalRealization(
        sys=red, order=res.order, n_removed=sys.n_states - res.order, n_uncontrollable=None, n_unobservable=None,
        tol=float(tol), method="balanced", smallest_kept=float(hsv[r - 1]) if r else 0.0,
        largest_discarded=float(hsv[r]) if r < hsv.size else 0.0, V=res.V, W=res.W,
        seconds=time.perf_counter() - t0, error_bound=res.error_bound,
        measured_error=_measured(sys, red) if measure_error else None,
    )
