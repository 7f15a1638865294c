"""Square-root balanced truncation with the unstable (rigid-body) part kept exactly."""

from __future__ import annotations

import ctypes
import time
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import AccuracyWarning, ConvergenceError, LinearSystem, ModelError, as_linear_system
from linflex.frequency import HinfNorm
from linflex.system import DENSE_STATES_MAX, apply_rotations, check_positive, complex_schur_from_real, schur_eigenvalues

from ._adi import adi_gramian_factor
from ._block_lyapunov import DENSE_PART_MAX, block_lyapunov_factors, modal_extent
from ._projection import project, project_split
from ._reduction_norm import checked_against_full, hinf_norm_stable, sparse_error_norm
from ._reduction_split import StableSplit, split_stable

__all__ = ["BalancedTruncation", "balanced_truncation"]

#: Relative Lyapunov residual above which a warning is issued, and above which the result is refused.
LYAPUNOV_WARN = 1e-8
LYAPUNOV_FAIL = 1e-4


@dataclass(frozen=True)
class BalancedTruncation:
    """Result of :func:`balanced_truncation` (the common shape of every reduction result:
    ``sys``, ``V``, ``W``, ``error_bound``, ``measured_error``, ``order``, ``seconds``).

    Attributes
    ----------
    sys : LinearSystem
        The reduced system; states ``xu0..`` (the unstable/rigid part, exact) then ``xb0..``
        (balanced states of the stable part).
    hsv : ndarray
        Hankel singular values of the stable part, descending (all of them; on the low-rank ADI
        path those the factors resolve, the rest below ``1e-10`` of the first's square)
        [output units per input unit].
    error_bound : float
        A-priori bound ``2 * sum(hsv[r:])`` on the H-infinity norm of the error [output units
        per input unit]. On the low-rank ADI path it is computed from the values of the
        low-rank gramians, which fall short of the exact ones by up to about the iteration's
        tolerance times ``hsv[0]`` (``P - Zc Zc^T`` is the positive semidefinite gramian of the
        final residual): where Glover's bound is attained (a relaxation system, symmetric ``A``
        with ``C = B^T``) the error can exceed it by that much (measured: 1e-10 of ``hsv[0]``).
    order : int
        Number of states of ``sys`` (unstable part plus kept balanced states).
    n_unstable : int
        Number of states of the unstable/marginal part, kept exactly.
    V, W : ndarray
        Projection bases ``(n, order)`` in the original coordinates: ``x ~ V xr``,
        ``xr = W.T x``, ``W.T @ V = I``; ``sys.A = W.T @ A @ V``.
    split : StableSplit or None
        The unstable/stable split used (with its conditioning); None on the low-rank ADI path
        (a sparse stable system, not split).
    lyapunov_residuals : tuple of float
        Relative residuals of the controllability and observability Lyapunov equations
        (Frobenius norm estimated with 8 random probes, relative to
        ``2 ||A||_F trace(P) + ||B||_F^2``; on the low-rank ADI path the exact 2-norm residual
        relative to ``||B B^T||_2``, the iteration's stopping test, below ``1e-10``).
    measured_error : HinfNorm or None
        H-infinity norm of ``G - G_r`` when ``measure_error=True`` was given, else None.
    tol : float or None
        The requested bound, if the order was chosen by ``tol``.
    method : str
        ``"square-root"``.
    lyapunov_solver : str
        Which solver computed the gramian factors: ``"modal"`` (linflex's real recursion on a
        block-diagonal Schur form), ``"SB03OD"`` (SLICOT's Hammarling solver on the real Schur
        form, through slycot), ``"hammarling"`` (linflex's own complex recursion) or ``"adi"``
        (low-rank factors of a sparse system, :mod:`linflex.linearize._adi`); where a
        recursion's residual exceeds ``LYAPUNOV_WARN``, the fall-back that replaced it:
        ``"SB03OD"``, or ``"bartels-stewart"`` (the gramians by
        ``scipy.linalg.solve_continuous_lyapunov``, factored by their eigendecompositions)
        without slycot.
    seconds : float
        Wall time [s] (including the error measurement).
    hsv_floor : float
        Round-off floor of the Hankel singular values: those at or below it count as zero (the
        numerical order) [output units per input unit]. ``n * eps * ||Zo||_F ||Zc||_F``, the
        bound on the rounding of ``Zo^T Zc`` (Weyl: it moves every singular value by at most
        that), with ``n`` the stable part's states; on the ADI path ``k * eps * hsv[0]``, ``k``
        the values resolved.
    """

    sys: LinearSystem
    hsv: NDArray[np.float64]
    error_bound: float
    order: int
    n_unstable: int
    V: NDArray[np.float64]
    W: NDArray[np.float64]
    split: StableSplit
    lyapunov_residuals: tuple[float, float]
    measured_error: HinfNorm | None
    tol: float | None
    method: str
    lyapunov_solver: str
    seconds: float
    hsv_floor: float


def balanced_truncation(
    sys, order: int | None = None, tol: float | None = None, *, rigid_tol: float | None = None,
    measure_error: bool = False, lyapunov_solver: str = "auto",
) -> BalancedTruncation:
    """Reduce a system by square-root balanced truncation of its stable part.

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
        The system. Rigid-body, marginally stable and unstable modes are split off first
        (:func:`split_stable`) and kept exactly.
    order : int, optional
        Number of states of the reduced system, including the unstable part.
    tol : float, optional
        Keep the smallest order whose bound ``2 * sum(discarded hsv)`` is ``<= tol`` (in the units
        of the outputs per unit input); a ``tol`` below round-off keeps the numerical order. Give at most one of ``order`` and ``tol``; with neither, the
        Hankel singular values at or below the round-off floor ``hsv_floor`` (see
        :class:`BalancedTruncation`) are discarded (a minimal balanced realization).
    rigid_tol : float, optional
        The spectrum policy's tolerance [1/s] for the split into the kept unstable/rigid part and
        the reduced stable part (eigenvalues with real part ``>= -rigid_tol`` are kept); default
        the policy of ``frequency/_spectrum.py``; see :func:`split_stable`. Given, it keeps a
        sparse system on the dense path, which splits (up to ``DENSE_STATES_MAX`` states);
        refused with ``lyapunov_solver="adi"``.
    measure_error : bool
        Also measure the H-infinity norm of the error (see :class:`~linflex.frequency.HinfNorm`); of a
        system with a sparse ``A`` on the ADI path by ``sparse_error_norm``: certified where the
        error system is block diagonal, else a sweep over the reduced poles, attained but not
        certified.
    lyapunov_solver : {"auto", "modal", "SB03OD", "hammarling", "adi"}
        How the gramian factors are computed. ``"modal"`` is linflex's Hammarling recursion in
        real arithmetic for a stable part whose Schur form is block diagonal beyond a leading
        block of at most 64 states (:mod:`linflex.linearize._block_lyapunov`: a modal model, a
        modal plant in series with a controller, any model up to 64 states): O(n^2 m) where the
        others cost O(n^3). ``"SB03OD"`` is SLICOT's Hammarling solver in real arithmetic (needs
        slycot, ``pip install slycot``); ``"hammarling"`` is linflex's own recursion on the complex
        Schur form (numpy and BLAS only). ``"auto"`` takes ``"modal"`` where the stable part has
        that shape and at least ``MODAL_STATES_MIN`` (400) states or slycot is missing, else
        SB03OD when slycot is installed (measured 1.7x to 4x faster than the
        complex recursion from 100 to 1000 states), else the recursion.
        All give the same factors to round-off. ``"adi"`` takes low-rank factors by the ADI
        iteration for a system with a ``scipy.sparse`` ``A`` (stable: rigid-body modes split off
        first), never forming an ``n x n`` matrix: one sparse LU per step, relative residual
        below ``1e-10``; ``"auto"`` takes it for sparse systems from ``ADI_STATES_MIN`` (3000)
        states, and the dense path where the ADI iteration refuses (rigid-body or unstable
        modes, which the dense path splits off), if the dense matrix may be formed.

    Returns
    -------
    BalancedTruncation

    Raises
    ------
    ModelError
        If ``lyapunov_solver`` is not one of the choices, or ``"SB03OD"`` is asked for without
        slycot installed.
        If ``rigid_tol`` is negative or not finite, or given with ``lyapunov_solver="adi"``.
        If both or invalid ``order``/``tol`` are given, or ``order`` is below the number of
        unstable states, above the number of states, or above the numerical order (Hankel
        singular values at round-off level cannot be balanced).
    ConvergenceError
        If a Lyapunov equation is solved with a relative residual above 1e-4 (a warning
        :class:`AccuracyWarning` is issued above 1e-8).

    Notes
    -----
    The gramian factors ``P = Zc Zc^T``, ``Q = Zo Zo^T`` of the stable part are computed directly
    (Hammarling's method, IMA J. Numer. Anal. 2, 1982) on the Schur form of the split, never
    forming the gramians, so small Hankel singular values keep their relative accuracy.
    Then ``Zo^T Zc = U1 S1 V1^T + U2 S2 V2^T`` and

    ::

        V = Zc V1 S1^-1/2,   W = Zo U1 S1^-1/2,   Ar = W^T A V,  Br = W^T B,  Cr = C V

    (Tombs and Postlethwaite, Int. J. Control 46, 1987; Laub, Heath, Paige and Ward, IEEE TAC 32,
    1987). The stable part of the error satisfies ``hsv[r] <= ||G - Gr||_inf <= 2 sum(hsv[r:])``
    (Glover, Int. J. Control 39, 1984); the unstable part contributes no error.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> import numpy as np
    >>> A = np.diag([-1.0, -2.0, -50.0])
    >>> res = balanced_truncation(LinearSystem(A, np.ones((3, 1)), np.ones((1, 3))), order=2)
    >>> bool(res.error_bound < 0.02)
    True
    """
    t0 = time.perf_counter()
    sys = as_linear_system(sys, "sys")
    if order is not None and tol is not None:
        raise ModelError(f"balanced_truncation: give order or tol, not both (got order={order!r}, tol={tol!r})")
    if order is not None:
        if isinstance(order, bool) or not isinstance(order, (int, np.integer)):
            raise ModelError(f"order must be an integer number of states, got {order!r}")
        order = int(order)
        if not 0 <= order <= sys.n_states:
            raise ModelError(f"order must lie between 0 and the {sys.n_states} states of sys, got {order}")
    if tol is not None:
        try:
            tol = float(tol)
        except (TypeError, ValueError) as err:
            raise ModelError(f"tol must be a positive real number, got {tol!r}") from err
        if not np.isfinite(tol) or tol <= 0:
            raise ModelError(f"tol must be a positive finite bound on the error, got {tol!r}")

    solver = _lyapunov_solver(lyapunov_solver)
    if rigid_tol is not None:
        check_positive(rigid_tol, "rigid_tol", allow_zero=True)
        if solver == "adi":
            raise ModelError(
                f"rigid_tol={rigid_tol!r} asks for a split, which the ADI path does not make (it reduces the whole "
                "stable system): omit rigid_tol, or use lyapunov_solver='auto' (the dense path splits)")
    if solver == "adi":
        return _balanced_truncation_adi(sys, order, tol, measure_error, t0)
    # a rigid_tol asks for the split, which only the dense path makes
    if solver == "auto" and sys.is_sparse and sys.n_states >= ADI_STATES_MIN and rigid_tol is None:
        try:
            return _balanced_truncation_adi(sys, order, tol, measure_error, t0)
        except ConvergenceError:
            # rigid-body or unstable modes, which the ADI path does not split off: the dense
            # path does, where the dense matrix may be formed (else the error stands)
            if sys.n_states > DENSE_STATES_MAX:
                raise

    split = split_stable(sys, rigid_tol=rigid_tol)
    n_u = split.n_unstable
    st = split.stable
    ns = st.n_states
    if order is not None and order < n_u:
        raise ModelError(
            f"order={order} is below the {n_u} states of the unstable/rigid-body part, which is kept exactly; "
            f"ask for order >= {n_u}"
        )

    if ns > 0 and st.n_inputs > 0 and st.n_outputs > 0:
        # st.A is already in real Schur form (from the split)
        if np.max(schur_eigenvalues(st.A).real) >= 0:
            raise ModelError("balanced_truncation: the stable part has an eigenvalue with real part >= 0")
        factors, solver = _gramian_factors(st.A, st.B, st.C, solver)
        Zc, Zo = factors
        residuals = (
            _lyapunov_residual(st.A, Zc, st.B),
            _lyapunov_residual(st.A.T, Zo, st.C.T),
        )
        worst = max(residuals)
        if worst > LYAPUNOV_WARN and solver in ("hammarling", "modal"):
            # the recursion lost accuracy (seen on strongly non-normal Schur forms: a long
            # mass-spring chain in first-order form from about 1000 states): SLICOT's solver
            # where slycot is there, else Bartels-Stewart, kept where its residual is smaller
            alt_solver = "SB03OD" if _slycot() is not None else "bartels-stewart"
            alt = (_gramian_factors_sb03od(st.A, st.B, st.C) if alt_solver == "SB03OD"
                   else _gramian_factors_bartels_stewart(st.A, st.B, st.C))
            if alt is not None:
                alt_residuals = (_lyapunov_residual(st.A, alt[0], st.B), _lyapunov_residual(st.A.T, alt[1], st.C.T))
                if max(alt_residuals) < worst:
                    (Zc, Zo), residuals, worst, solver = alt, alt_residuals, max(alt_residuals), alt_solver
        if worst > LYAPUNOV_FAIL:
            raise ConvergenceError(
                f"balanced_truncation: Lyapunov equation solved with relative residual {worst:.3g} "
                f"(> {LYAPUNOV_FAIL:g}); the stable part is too close to instability "
                f"(split condition {split.condition:.3g})"
            )
        if worst > LYAPUNOV_WARN:
            warnings.warn(
                f"balanced_truncation: Lyapunov relative residual {worst:.3g} exceeds {LYAPUNOV_WARN:g}; "
                "the Hankel singular values are correspondingly inaccurate",
                AccuracyWarning, stacklevel=2,
            )
        M = Zo.T @ Zc
        hsv = scipy.linalg.svdvals(M, check_finite=False)
        # forming M rounds it by up to n eps ||Zo||_F ||Zc||_F, which moves every singular value
        # as far (Weyl): an uncontrollable or unobservable state of a system whose gramians are
        # unbalanced (||P|| ||Q|| >> hsv[0]^2) keeps an hsv well above n eps hsv[0], and
        # balancing it would break W^T V = I
        noise = float(np.linalg.norm(Zo) * np.linalg.norm(Zc))
    else:
        solver = "none"
        hsv = np.zeros(ns)
        M = np.zeros((ns, ns))
        residuals = (0.0, 0.0)
        noise = 0.0

    floor = max(ns, 1) * np.finfo(float).eps * noise
    r = _choose_order(hsv, order, tol, n_u, ns, floor)
    if r > 0 and not hsv[r - 1] > floor:
        k = int(np.sum(hsv > floor))
        raise ModelError(
            f"order={n_u + r} asks for {r} balanced states but only {k} Hankel singular values of the stable part "
            f"exceed their round-off floor n*eps*||Zo||_F*||Zc||_F = {floor:.3g} (the rest are uncontrollable or "
            f"unobservable); ask for order <= {n_u + k}, or use minimal_realization"
        )
    if r > 0:
        U1, S1, V1 = leading_singular_vectors(M, hsv, r)
        s = 1.0 / np.sqrt(S1)
        Vs = Zc @ (V1 * s)
        Ws = Zo @ (U1 * s)
    else:
        Vs = np.zeros((ns, 0))
        Ws = np.zeros((ns, 0))
    proj = project_split(split, Vs, Ws, prefix="xb")
    red, V, W = proj.sys, proj.V, proj.W
    Ar, Br, Cr = proj.stable.A, proj.stable.B, proj.stable.C
    bound = float(2.0 * np.sum(hsv[r:]))

    measured = None
    if measure_error:
        Ae = scipy.linalg.block_diag(st.A, Ar)
        Be = np.vstack([st.B, Br])
        Ce = np.hstack([st.C, -Cr])
        De = np.zeros_like(sys.D)
        schur = None
        if solver != "none":
            T, rot = complex_schur_from_real(st.A)
            Trr, Urr = scipy.linalg.schur(Ar, output="complex") if r else (np.zeros((0, 0)), np.zeros((0, 0)))
            U = apply_rotations(rot, np.eye(ns, dtype=complex))
            schur = (scipy.linalg.block_diag(T, Trr), scipy.linalg.block_diag(U, Urr))
        measured = checked_against_full(sys, red, hinf_norm_stable(Ae, Be, Ce, De, schur=schur))

    hsv = np.array(hsv, dtype=float)
    for arr in (hsv, V, W):
        arr.setflags(write=False)
    return BalancedTruncation(
        sys=red, hsv=hsv, error_bound=bound, order=n_u + r, n_unstable=n_u, V=V, W=W, split=split,
        lyapunov_residuals=(float(residuals[0]), float(residuals[1])), measured_error=measured, tol=tol,
        method="square-root", lyapunov_solver=solver, seconds=time.perf_counter() - t0, hsv_floor=float(floor),
    )


def _balanced_truncation_adi(sys: LinearSystem, order, tol, measure_error: bool, t0: float) -> BalancedTruncation:
    """Square-root balanced truncation of a sparse stable system from low-rank ADI factors of its
    gramians (:func:`~linflex.linearize._adi.adi_gramian_factor`): no n x n matrix is formed."""
    if not sys.is_sparse:
        raise ModelError("lyapunov_solver='adi' takes a system whose A is a scipy.sparse matrix "
                         "(LinearSystem(A_sparse, B, C, D)); dense systems use 'auto'")
    A = sys.A_sparse
    rtol = 1e-10
    try:
        fc = adi_gramian_factor(A, sys.B, rtol=rtol)
        fo = adi_gramian_factor(A.T, sys.C.T, rtol=rtol)
    except ConvergenceError as err:
        raise ConvergenceError(f"balanced_truncation (ADI): {err}; balanced truncation of a sparse system needs a "
                               "stable A (its rigid-body modes split off)") from err
    Zc, Zo = fc.Z, fo.Z
    Uy, hsv, Vyt = scipy.linalg.svd(Zo.T @ Zc, full_matrices=False, lapack_driver="gesdd")
    ns = hsv.size
    floor = max(ns, 1) * np.finfo(float).eps * (hsv[0] if hsv.size else 0.0)
    r = _choose_order(hsv, order, tol, 0, ns, floor)
    if order is not None and order > ns:
        raise ModelError(f"order={order} is above the {ns} Hankel singular values the low-rank gramians resolve "
                         f"(the rest are below {rtol:g} of the largest); ask for order <= {ns}")
    s = 1.0 / np.sqrt(hsv[:r])
    V = Zc @ (Vyt[:r].T * s)
    W = Zo @ (Uy[:, :r] * s)
    red = project(sys, V, W, states=[f"xb{i}" for i in range(r)])
    measured = sparse_error_norm(sys, red) if measure_error else None
    hsv = np.array(hsv, dtype=float)
    for arr in (hsv, V, W):
        arr.setflags(write=False)
    return BalancedTruncation(
        sys=red, hsv=hsv, error_bound=float(2.0 * np.sum(hsv[r:])), order=r, n_unstable=0, V=V, W=W, split=None,
        lyapunov_residuals=(fc.residual, fo.residual), measured_error=measured, tol=tol, method="square-root",
        lyapunov_solver="adi", seconds=time.perf_counter() - t0, hsv_floor=float(floor),
    )


#: The leading singular vectors come from the eigenvectors of ``M^T M`` (:func:`leading_singular_vectors`)
#: only while the last one kept is at least this fraction of the first: their error is then at
#: most ``1 / (2 SQUARED_RANGE)`` times that of a full SVD's.
SQUARED_RANGE = 1e-3


def leading_singular_vectors(M, hsv, r: int):
    """``(U1, S1, V1)``: ``r`` leading singular triplets of a square ``M`` whose singular values
    ``hsv`` are known, with ``U1^T M V1 = diag(S1)`` to rounding.

    A full SVD of ``M`` costs about three times its singular values alone (n = 1000). Where
    ``r`` is small and ``hsv[r-1] >= SQUARED_RANGE hsv[0]``, ``V1`` spans the eigenvectors of
    ``M^T M`` for its ``r`` largest eigenvalues (LAPACK syevr for those alone), whose error
    ``eps hsv[0]^2 / (hsv[r-1]^2 - hsv[r]^2)`` is at most ``hsv[0] / (2 hsv[r-1])`` times that of
    an SVD's vectors; a Rayleigh-Ritz step (the SVD of ``M V1``, n x r) makes the triplets exact
    for that subspace, so the balanced projection stays biorthogonal (``W^T V = I``) to
    rounding. Its singular values must then equal ``hsv[:r]`` to 1e-8; otherwise, and where the
    range is wider, the full SVD (LAPACK gesdd).
    """
    n = M.shape[0]
    if 4 * r <= n and hsv[r - 1] >= SQUARED_RANGE * hsv[0]:
        _, V = scipy.linalg.eigh(M.T @ M, subset_by_index=[n - r, n - 1], check_finite=False)
        U1, S1, Wt = scipy.linalg.svd(M @ V, full_matrices=False, check_finite=False)
        if np.allclose(S1, hsv[:r], rtol=1e-8, atol=0.0):
            return U1, S1, V @ Wt.T
    U, S, Vt = scipy.linalg.svd(M, lapack_driver="gesdd", check_finite=False)
    return U[:, :r], S[:r], Vt[:r].T


def _choose_order(hsv, order, tol, n_u, ns, floor: float) -> int:
    """Number of balanced states to keep; ``floor``: the round-off floor of ``hsv``."""
    if order is not None:
        return min(order - n_u, ns)
    if ns == 0:
        return 0
    tail = 2.0 * np.concatenate([np.cumsum(hsv[::-1])[::-1], [0.0]])  # tail[r] = 2 sum(hsv[r:])
    numerical = int(np.sum(hsv > floor))
    if tol is not None:
        # a tol below the round-off level of the tail keeps the numerical order, no more
        return min(int(np.argmax(tail <= tol)), numerical)
    return numerical


LYAPUNOV_SOLVERS = ("auto", "modal", "SB03OD", "hammarling", "adi")
#: Smallest stable part for which ``lyapunov_solver="auto"`` takes the block recursion on a modal
#: Schur form when slycot is installed (the crossover measured in :func:`_gramian_factors`).
MODAL_STATES_MIN = 400
#: Smallest sparse system for which ``lyapunov_solver="auto"`` takes the low-rank ADI factors
#: (below, the dense solvers: exact, and a few seconds at most).
ADI_STATES_MIN = 3000


def _lyapunov_solver(choice) -> str:
    """Validate ``lyapunov_solver``; ``"SB03OD"`` needs slycot."""
    if choice not in LYAPUNOV_SOLVERS:
        raise ModelError(f"lyapunov_solver must be one of {LYAPUNOV_SOLVERS}, got {choice!r}")
    if choice == "SB03OD" and _slycot() is None:
        raise ModelError("lyapunov_solver='SB03OD' needs slycot (pip install slycot); "
                         "lyapunov_solver='hammarling' needs nothing more")
    return choice


def _slycot():
    """The slycot module, or None when it is not installed."""
    try:
        import slycot
    except ImportError:
        return None
    return slycot


def _gramian_factors(S, B, C, solver: str):
    """``((Zc, Zo), name)``: real factors of both gramians of the stable Schur form ``S`` by the
    solver asked for (``lyapunov_solver`` of :func:`balanced_truncation`, validated), and the
    name of the one that computed them.

    ``"auto"`` takes the block recursion on the modal shape from ``MODAL_STATES_MIN`` states, or
    whenever slycot is missing; below, SB03OD's compiled loops beat the recursion's per-pivot
    overhead (measured, one BLAS thread, modal models with two inputs: the block recursion takes
    9.7x SB03OD's time at 50 states, 2.6x at 200, 1.0x at 400, 0.37x at 800; ISS 1R, 270 states
    and three inputs, 1.25x). Without the modal shape ``"auto"`` takes SB03OD whenever slycot
    is installed. Measured (one BLAS thread, the dense Schur forms of modal loops in random
    orthogonal coordinates, on the benchmark machine, an AMD EPYC): linflex's complex recursion
    takes 4.0x SB03OD's time at 100 states, 2.4x at 200, 1.9x at 400, 1.7x at 1000. (On the
    Intel Xeon of the first sessions the recursion was the faster above about 220 states; it
    stays for systems without slycot.)
    """
    if solver == "modal" or (solver == "auto" and (S.shape[0] >= MODAL_STATES_MIN or _slycot() is None)):
        factors = block_lyapunov_factors(S, B, C)
        if factors is not None:
            return factors, "modal"
        if solver == "modal":
            h = modal_extent(S)
            if h > DENSE_PART_MAX:
                raise ModelError(
                    f"balanced_truncation: lyapunov_solver='modal' needs a stable part whose Schur form is block "
                    f"diagonal beyond a leading block of at most {DENSE_PART_MAX} states (a modal model, or a "
                    f"small one); this one's leading block has {h} of {S.shape[0]} states: use 'auto'")
            raise ModelError(
                "balanced_truncation: lyapunov_solver='modal' refused the stable part: a 2x2 block's gramian is "
                "not positive definite to working precision (a mode the inputs or outputs reach along one "
                "direction only, to rounding); use 'auto'")
    if solver in ("SB03OD", "auto"):
        factors = _gramian_factors_sb03od(S, B, C)
        if factors is not None:
            return factors, "SB03OD"
        if solver == "SB03OD":
            raise ModelError("balanced_truncation: SLICOT's SB03OD refused the Schur form of the stable part; "
                             "use lyapunov_solver='hammarling'")
    return _gramian_factors_hammarling(S, B, C), "hammarling"


def _gramian_factors_sb03od(S, B, C):
    """Real factors ``(Zc, Zo)`` of both gramians by SLICOT's SB03OD on the real Schur form ``S``, or None.

    ``S P + P S^T + B B^T = 0`` is SB03OD's equation (1) with ``op(K) = K^T`` (``trans="T"``):
    ``P = U U^T / scale^2``; ``S^T Q + Q S + C^T C = 0`` is (1) with ``op(K) = K``:
    ``Q = U^T U / scale^2``. ``fact="F"`` hands SB03OD the Schur form with ``Q = I``, so it
    neither refactors nor back-transforms. SLICOT: Hammarling's method in real arithmetic with
    2x2 blocks (Varga's SB03OU/SB03OT, the same routines as AB09AD). Returns None when slycot is
    absent or refuses ``S`` (a non-standardized 2x2 block, which scipy's Schur form never has).
    """
    slycot = _slycot()
    if slycot is None:
        return None
    n = S.shape[0]
    # more inputs (outputs) than states: SB03OD (trans="T") needs B in an array of max(n, m)
    # columns, which slycot's wrapper does not give; B B^T = R^T R and C^T C = R^T R with the
    # triangular factors of QR decompositions of B^T and C, whose first n rows carry all of it
    if B.shape[1] > n:
        B = scipy.linalg.qr(B.T, mode="r", check_finite=False)[0][:n].T
    if C.shape[0] > n:
        C = scipy.linalg.qr(C, mode="r", check_finite=False)[0][:n]
    m, p = B.shape[1], C.shape[0]
    # slycot's wrapper wants B in an array with n columns and max(n, m) rows; it returns U there
    Bc = np.zeros((max(n, m), n), order="F")
    Bc[:n, :m] = B
    Co = np.zeros((max(n, p), n), order="F")
    Co[:p] = C
    try:
        Uc, sc, _ = slycot.sb03od(n, m, np.array(S, order="F"), np.eye(n, order="F"), Bc, "C", fact="F", trans="T")
        Uo, so, _ = slycot.sb03od(n, p, np.array(S, order="F"), np.eye(n, order="F"), Co, "C", fact="F", trans="N")
    except (ValueError, ArithmeticError):  # slycot's SlycotArithmeticError/SlycotParameterError
        return None
    if not (sc > 0 and so > 0):
        return None
    return np.triu(Uc[:n]) / sc, np.ascontiguousarray(np.triu(Uo[:n]).T) / so


def _gramian_factors_bartels_stewart(S, B, C):
    """Real factors ``(Zc, Zo)`` from the gramians themselves (``scipy.linalg.solve_continuous_lyapunov``,
    Bartels-Stewart) and their symmetric eigendecompositions, negative round-off clipped: the
    fall-back of the recursion without slycot (small Hankel singular values lose relative accuracy)."""
    def factor(M):
        M = 0.5 * (M + M.T)
        lam, V = np.linalg.eigh(M)
        return V * np.sqrt(np.clip(lam, 0.0, None))
    P = scipy.linalg.solve_continuous_lyapunov(S, -B @ B.T)
    Q = scipy.linalg.solve_continuous_lyapunov(S.T, -C.T @ C)
    return factor(P), factor(Q)


def _gramian_factors_hammarling(S, B, C):
    """Real factors ``(Zc, Zo)`` of both gramians by :func:`_lyapunov_factor` on the complex Schur form."""
    # the complex Schur form of S follows by 2x2 rotations (U is block diagonal with 2x2 blocks,
    # applied as vectorized rotations)
    T, rot = complex_schur_from_real(S)
    Zc = apply_rotations(rot, _lyapunov_factor(T, apply_rotations(rot, B.astype(complex), adjoint=True)))
    # Q: A^T Q + Q A + C^T C = 0; A^T = A^H = (U J)(J T^H J)(U J)^H with J the reversal,
    # and J T^H J is upper triangular: one Schur form serves both equations.
    Tr = np.asfortranarray(T.conj().T[::-1, ::-1])
    Ro = _lyapunov_factor(Tr, apply_rotations(rot, C.T.astype(complex), adjoint=True)[::-1])
    Zo = apply_rotations(rot, Ro[::-1])
    return _real_factor(Zc), _real_factor(Zo)


def _column_start(R, Bw, sq, k: int):
    """The start of Hammarling's column ``k`` (:func:`_lyapunov_factor`): ``d = ||b|| / s``
    into ``R[k, k]`` and ``(s, d, u)``, or None when the column ends there (``k = 0``, ``b = 0``)."""
    s = sq[k]
    b = Bw[k]
    nb = np.sqrt(np.vdot(b, b).real)
    d = nb / s
    R[k, k] = d
    if k == 0 or nb == 0.0:
        return None
    return s, d, b.conj() / nb


def _column_end(R, Bw, k: int, s, r, u) -> None:
    """The end of Hammarling's column ``k``: ``r`` into ``R[:k, k]``, ``B1 <- B1 - s r u^H``."""
    R[:k, k] = r
    Bw[:k] -= (s * r)[:, None] * u.conj()[None, :]


def _lyapunov_factor(T: NDArray[np.complex128], B: NDArray[np.complex128]) -> NDArray[np.complex128]:
    """Upper triangular ``R`` with ``T P + P T^H + B B^H = 0``, ``P = R R^H``; ``T`` upper triangular, stable.

    Hammarling's column recursion, derived for a non-square ``B`` (n x m): partition from the
    bottom-right,

    ::

        T = [ T1  t ]   B = [ B1 ]   R = [ R1  r ]
            [  0  a ]       [ b  ]       [  0  d ]

        d = ||b|| / sqrt(-2 Re a),  u = b^H / ||b||,  s = sqrt(-2 Re a)
        (T1 + conj(a) I) r = -(t d + s B1 u)
        recurse on T1 with B1 <- B1 - s r u^H   (still m columns)

    The shifted solve works on the leading block of one Fortran-ordered copy of ``T`` (BLAS
    ``ztrsv`` with leading dimension ``n``) after shifting its diagonal, so no block is copied.
    """
    n = T.shape[0]
    R = np.zeros((n, n), dtype=complex, order="F")
    Bw = np.array(B, dtype=complex)
    Tw = np.array(T, dtype=complex, order="F")
    diag = np.diag(T).copy()
    dview = Tw.reshape(-1, order="F")[:: n + 1]  # writable view of Tw's diagonal
    sq = np.sqrt(-2.0 * diag.real)
    rhs = np.zeros(n, dtype=complex)
    solve = _leading_triangular_solver(Tw, rhs)
    for k in range(n - 1, -1, -1):
        column = _column_start(R, Bw, sq, k)
        if column is None:
            continue
        s, d, u = column
        np.multiply(Tw[:k, k], -d, out=rhs[:k])
        rhs[:k] -= s * (Bw[:k] @ u)
        dview[:k] = diag[:k] + np.conj(diag[k])
        _column_end(R, Bw, k, s, solve(k), u)
    return R


def _leading_triangular_solver(Tw, rhs):
    """``solve(k)``: overwrite ``rhs[:k]`` with the solution of ``Tw[:k, :k] x = rhs[:k]`` and return it.

    ``Tw`` is upper triangular and Fortran-ordered. Uses BLAS ``ztrsv`` from scipy's own BLAS on
    the leading block in place (``lda = n``); falls back to a solve with the full matrix and a
    right-hand side that is zero below row ``k`` (which returns zeros there and the
    leading-block solution above) if the BLAS entry point is not reachable.
    """
    n = Tw.shape[0]
    ztrsv = _blas_ztrsv()
    if ztrsv is None:
        def solve_full(k):
            rhs[k:] = 0.0
            rhs[:] = scipy.linalg.solve_triangular(Tw, rhs, check_finite=False)
            return rhs[:k]

        return solve_full
    up, no, nonunit = ctypes.c_char(b"U"), ctypes.c_char(b"N"), ctypes.c_char(b"N")
    args = [ctypes.byref(up), ctypes.byref(no), ctypes.byref(nonunit)]
    order = ctypes.c_int(0)
    lda, inc = ctypes.c_int(n), ctypes.c_int(1)
    tail = [Tw.ctypes.data, ctypes.byref(lda), rhs.ctypes.data, ctypes.byref(inc)]
    k_ref = ctypes.byref(order)

    def solve_blas(k):
        order.value = k
        ztrsv(*args, k_ref, *tail)
        return rhs[:k]

    return solve_blas


def _blas_ztrsv():
    """The ``ztrsv`` function pointer exported by :mod:`scipy.linalg.cython_blas`, or None."""
    try:
        from scipy.linalg import cython_blas

        capsule = cython_blas.__pyx_capi__["ztrsv"]
        get_name = ctypes.pythonapi.PyCapsule_GetName
        get_name.restype, get_name.argtypes = ctypes.c_char_p, [ctypes.py_object]
        get_pointer = ctypes.pythonapi.PyCapsule_GetPointer
        get_pointer.restype, get_pointer.argtypes = ctypes.c_void_p, [ctypes.py_object, ctypes.c_char_p]
        address = get_pointer(capsule, get_name(capsule))
        proto = ctypes.CFUNCTYPE(
            None, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
            ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
        )
        return proto(address)
    except (AttributeError, KeyError, ValueError, TypeError, ImportError):
        return None


def _real_factor(Z: NDArray[np.complex128]) -> NDArray[np.float64]:
    """A real square factor ``F`` with ``F F^T = Z Z^H`` (which is real).

    ``Z Z^H = Re Z Re Z^T + Im Z Im Z^T`` when the product is real, so ``[Re Z, Im Z]`` is a real
    factor; its QR compression gives an ``n x n`` one.
    """
    stacked = np.hstack([Z.real, Z.imag])
    Rq = scipy.linalg.qr(stacked.T, mode="r", check_finite=False)[0]
    return np.ascontiguousarray(Rq[: Z.shape[0]].T)


def _lyapunov_residual(A, Z, B, probes: int = 8) -> float:
    """Relative residual of ``A P + P A^T + B B^T = 0`` with ``P = Z Z^T``, never forming ``P``.

    ``||Res||_F`` is estimated from ``probes`` fixed pseudo-random Gaussian vectors ``g``
    (``E ||Res g||^2 = ||Res||_F^2``; Hutchinson), each costing a few matrix-vector products,
    and divided by ``2 ||A||_F trace(P) + ||B||_F^2`` (``trace(P) = ||Z||_F^2 >= ||P||_F``).
    """
    n = A.shape[0]
    G = np.random.default_rng(12345).standard_normal((n, probes))
    ZtG = Z.T @ G
    res = A @ (Z @ ZtG) + Z @ (Z.T @ (A.T @ G)) + B @ (B.T @ G)
    estimate = np.sqrt(np.sum(res * res) / probes)
    scale = 2 * np.linalg.norm(A) * np.sum(Z * Z) + np.sum(B * B)
    return float(estimate / scale) if scale > 0 else 0.0
