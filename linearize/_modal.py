"""Modal truncation with static correction, on first-order and on second-order systems."""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import (
    LinearSystem,
    MethodUnavailableError,
    ModelError,
    SecondOrderSystem,
    as_linear_system,
)
from linflex.frequency import HinfNorm
from linflex.system import DENSE_STATES_MAX, real_matrix

from ._projection import project, project_second_order, project_split
from ._reduction_norm import (
    checked_against_full,
    hinf_norm_stable,
    sparse_error_norm,
    stable_parts_error,
)
from ._reduction_split import StableSplit, split_stable

__all__ = ["ModalTruncation", "modal_truncation"]

RANKINGS = ("frequency", "dominance", "effective_mass")


@dataclass(frozen=True)
class ModalTruncation:
    """Result of :func:`modal_truncation`.

    Attributes
    ----------
    sys : LinearSystem or SecondOrderSystem
        The reduced system, of the same kind as the input (a ``control.StateSpace`` input gives a
        :class:`LinearSystem`). First-order states: ``xu0..`` (unstable/rigid part, exact) then
        ``xm0..`` (two per kept oscillatory mode, one per real mode). Second-order dofs:
        ``rigid0..``, ``mode0..``, then ``mtv0..`` (modal truncation vectors).
    frequencies : ndarray
        Natural frequencies [rad/s] of all stable (flexible) modes, ascending (of a sparse
        system without block structure: of the lowest modes computed, a few beyond those kept).
    damping : ndarray
        Their damping ratios [-] (for a second-order system: from the diagonal of the modal damping
        matrix).
    measure : ndarray
        The ranking measure of each mode (same order as ``frequencies``): the frequency, the
        dominance ``||c_i|| ||b_i|| / |Re lambda_i|`` (peak gain of the modal term) or the modal
        effective-mass fraction (see ``influence``).
    kept : ndarray of int
        Indices into ``frequencies`` of the kept modes.
    rank_by : str
        The ranking used when ``keep`` is a count.
    n_rigid : int
        States (first order) or dofs (second order) of the rigid/unstable part, kept exactly.
    static_correction : bool
        Whether the static (DC) correction was applied.
    correction : ndarray
        First order: the feedthrough added to ``D`` (``p x m``), the DC gain of the discarded
        modes. Second order: the static deflection shapes of the discarded modes (``n_dofs x m``),
        from which the modal truncation vectors were built.
    n_correction_dofs : int
        Number of modal truncation vectors added (second order; 0 for first order).
    V, W : ndarray
        First order: projection bases in the original coordinates (``x ~ V xr``, ``xr = W.T x``).
        Second order: the Ritz basis ``Psi`` of the dofs (``q ~ Psi qr``) and ``W = M Psi``
        (``qr = W.T q`` for unit modal mass).
    split : StableSplit or None
        The unstable/stable split (first order) or None (second order).
    measured_error : HinfNorm or None
        H-infinity norm of the difference of the stable parts, when requested, checked against
        direct evaluations of ``G`` and ``G_r`` by the frequency engine (never ``certified``
        unless the check proves it: ``checked_against_full`` of ``linearize/_reduction_norm.py``);
        of a sparse system, ``sparse_error_norm`` of the same module.
    seconds : float
        Wall time [s].
    order : int
        Number of coordinates of ``sys`` (states or dofs); a property.
    error_bound : None
        Modal truncation has no a-priori bound (a property, for the common result shape).
    """

    sys: LinearSystem | SecondOrderSystem
    frequencies: NDArray[np.float64]
    damping: NDArray[np.float64]
    measure: NDArray[np.float64]
    kept: NDArray[np.int64]
    rank_by: str
    n_rigid: int
    static_correction: bool
    correction: NDArray[np.float64]
    n_correction_dofs: int
    V: NDArray[np.float64]
    W: NDArray[np.float64]
    split: StableSplit | None
    measured_error: HinfNorm | None
    seconds: float

    @property
    def order(self) -> int:
        """Number of coordinates of ``sys``: states (first order) or dofs (second order)."""
        return int(self.sys.n_states if isinstance(self.sys, LinearSystem) else self.sys.n_dofs)

    @property
    def error_bound(self) -> None:
        """None: modal truncation has no a-priori error bound (see ``measured_error``)."""
        return None


def modal_truncation(
    sys, keep, *, rank_by: str = "frequency", static_correction: bool = True, rigid_tol: float | None = None,
    measure_error: bool = False, influence=None,
) -> ModalTruncation:
    """Keep selected modes of a system, with a static correction of the discarded ones.

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
        The system. A :class:`SecondOrderSystem` (symmetric ``M`` positive definite, symmetric
        ``K``) is reduced in its own structure by a Ritz basis of undamped modes; any other system
        through its eigenvalue decomposition: block by block where ``A`` (dense or
        ``scipy.sparse``) is block diagonal under a permutation with every eigenvalue stable
        (a modal model: O(sum k_j^3), no n x n matrix; ISS 12A in 0.02 s instead of 9 s); the
        lowest modes of any other ``scipy.sparse`` stable ``A`` by shift-invert (ARPACK, ranked
        by frequency; no n x n matrix); else of the whole matrix.
    keep : int or (float, float)
        A count of flexible modes (an oscillatory pair or a real pole counts as one mode), taken
        in the order of ``rank_by``; or a band ``(low, high)`` [rad/s] of natural frequencies.
        Rigid-body and unstable modes are always kept and not counted; undamped modes (poles on
        the axis away from the origin: a structural model without damping) are flexible modes
        like the others.
    rank_by : {"frequency", "dominance", "effective_mass"}
        Ranking when ``keep`` is a count: lowest natural frequency first; largest peak gain of the
        modal term first (a joint controllability/observability measure); or largest modal
        effective mass first (second-order systems, with ``influence``).
    static_correction : bool
        Make the low-frequency gain of the flexible part exact: first order by adding the DC
        gain of the discarded modes to ``D``; second order by appending modal truncation vectors
        (Dickens), the static deflections of the discarded modes under the input loads, which
        keeps the structure and needs no feedthrough.
    rigid_tol : float, optional
        The spectrum policy's tolerance [1/s] (``frequency/_spectrum.py``, the same parameter as
        :func:`split_stable` and :mod:`linflex.frequency`). First order: eigenvalues with real
        part ``>= -rigid_tol`` are kept exactly (:func:`split_stable`), except undamped
        oscillatory ones (``|Re| <= rigid_tol``, ``|lambda| > rigid_tol``), which are flexible
        modes (``split_stable(..., undamped="stable")``). Second order: a mode of
        natural frequency ``w`` (first-order poles ``+-j w``) is rigid when ``w <= rigid_tol``.
        Default: the policy's rounding rules (``rigid_mask`` of ``frequency/_spectrum.py`` on
        the poles ``+-sqrt(-w^2)`` with the scale of the first-order system); modes with
        ``w^2 < 0`` (static divergence) are always kept with the rigid part.
    measure_error : bool
        Also measure the H-infinity norm of the error of the stable parts (of a system with a
        sparse ``A``: certified by interval bounds where the error system is block diagonal, a
        modal model's; else a sweep over the reduced poles, attained but not certified). A
        discarded undamped mode makes it infinite, at that mode's frequency.
    influence : array_like, optional
        Rigid-body influence vectors ``(n_dofs, r)`` for ``rank_by="effective_mass"``: the dof
        motions produced by unit rigid motions of the boundary of a clamped (fixed-interface)
        model. The measure of mode ``i`` is ``sum_r (phi_i^T M R_r)^2 / (R_r^T M R_r)``, its
        effective mass as a fraction of the rigid-body mass, summed over the directions
        (Banerjee 2016, Eq. 7.22); over all modes it sums to ``r`` for a complete modal set.

    Returns
    -------
    ModalTruncation

    Raises
    ------
    ModelError
        On a bad ``keep``, an unknown ``rank_by``, ``influence`` without
        ``rank_by="effective_mass"``, a (nearly) defective stable part, or an ``M`` that is not
        symmetric positive definite.
    MethodUnavailableError
        For ``rank_by="effective_mass"`` on a first-order system, or a second-order system with non-symmetric ``K`` (reduce ``sys.to_state_space()``).

    Notes
    -----
    With rigid-body modes at the origin the DC gain is infinite; the correction then applies to
    the flexible part only, so ``G(jw) - Gr(jw) -> 0`` as ``w -> 0`` (the error is of order
    ``w^2 / w_i^4`` instead of ``1 / w_i^2``). Modal truncation vectors follow Banerjee,
    *Flexible Multibody Dynamics* (2016), Sec. 7.5 (Dickens, Nakagawa and Wittbrodt, 1997); the
    dominance measure is the peak gain ``|c_i||b_i| / |Re lambda_i|`` of each modal term
    (Varga, "Enhanced modal approach for model reduction", Math. Model. Syst. 1, 1995).

    Examples
    --------
    >>> import numpy as np
    >>> from linflex import SecondOrderSystem
    >>> K = np.array([[2.0, -1.0], [-1.0, 2.0]])
    >>> so = SecondOrderSystem(np.eye(2), 0.01 * K, K, [[1.0], [0.0]], Cq=[[1.0, 0.0]])
    >>> res = modal_truncation(so, keep=1)
    >>> res.sys.n_dofs  # one mode plus one modal truncation vector
    2
    """
    t0 = time.perf_counter()
    if rank_by not in RANKINGS:
        raise ModelError(f"rank_by must be one of {RANKINGS}, got {rank_by!r}")
    keep = _check_keep(keep)
    if influence is not None and rank_by != "effective_mass":
        raise ModelError(f"influence ranks the modes by effective mass only: pass rank_by='effective_mass' with it "
                         f"(got rank_by={rank_by!r}), or omit influence")
    if isinstance(sys, SecondOrderSystem):
        return _second_order(sys, keep, rank_by, bool(static_correction), rigid_tol, measure_error, influence, t0)
    if rank_by == "effective_mass":
        raise MethodUnavailableError(
            "rank_by='effective_mass' needs a SecondOrderSystem (mass matrix and rigid-body modes); "
            f"got a first-order {type(sys).__name__}"
        )
    return _first_order(as_linear_system(sys, "sys"), keep, rank_by, bool(static_correction), rigid_tol, measure_error, t0)


def _check_keep(keep):
    if isinstance(keep, bool):
        raise ModelError(f"keep must be a mode count or a band (low, high) in rad/s, got {keep!r}")
    if isinstance(keep, (int, np.integer)):
        if keep < 0:
            raise ModelError(f"keep must be a non-negative number of modes, got {keep}")
        return int(keep)
    try:
        lo, hi = (float(v) for v in keep)
    except (TypeError, ValueError):
        raise ModelError(f"keep must be a mode count or a band (low, high) in rad/s, got {keep!r}") from None
    if not (np.isfinite(lo) and 0 <= lo <= hi):
        raise ModelError(f"keep band must satisfy 0 <= low <= high [rad/s], got ({lo}, {hi})")
    return (lo, hi)


def _select(keep, frequencies, measure, rank_by) -> NDArray[np.int64]:
    if isinstance(keep, tuple):
        lo, hi = keep
        return np.nonzero((frequencies >= lo) & (frequencies <= hi))[0]
    if keep > frequencies.size:
        raise ModelError(f"keep={keep} modes requested but the system has {frequencies.size} flexible modes")
    order = np.argsort(measure, kind="stable") if rank_by == "frequency" else np.argsort(-measure, kind="stable")
    return np.sort(order[:keep])


def _mode_pairs(lam: NDArray[np.complex128]) -> list[tuple[int, bool]]:
    """``(index, pair)`` per mode of eigenvalues whose conjugate pairs are adjacent (LAPACK's
    order, or ARPACK's sorted by modulus): one per real eigenvalue, one per pair."""
    modes, i = [], 0
    while i < lam.size:
        pair = bool(lam[i].imag != 0.0 and i + 1 < lam.size
                    and np.isclose(lam[i + 1], np.conj(lam[i]), rtol=1e-8, atol=0))
        modes.append((i, pair))
        i += 2 if pair else 1
    return modes


def _real_mode(lam: complex, x: NDArray, y: NDArray, pair: bool):
    """One mode in real arithmetic: right basis columns, left basis columns (``W^T V = I``) and
    its real block (``W^T A V``): a real eigenvalue as it is, a conjugate pair (``x``, ``y`` of
    either member, ``y x = 1``) by ``[Re x, Im x]``, ``[2 Re y, -2 Im y]`` and
    ``[[Re lam, Im lam], [-Im lam, Re lam]]`` of the member with positive imaginary part."""
    if not pair:
        return x.real[:, None], y.real[:, None], np.array([[lam.real]])
    if lam.imag < 0:
        x, y, lam = x.conj(), y.conj(), np.conj(lam)
    return (np.column_stack([x.real, x.imag]), np.column_stack([2 * y.real, -2 * y.imag]),
            np.array([[lam.real, lam.imag], [-lam.imag, lam.real]]))


def _dominance(CV, WB, lam: complex) -> float:
    """The peak gain ``||C v|| ||w^T B|| / |Re lambda|`` of a mode's term, from its output and
    input maps ``CV = C v``, ``WB = w^T B`` (:func:`_real_mode`'s columns): ``rank_by="dominance"``."""
    with np.errstate(divide="ignore"):   # an undamped mode's peak is infinite
        return float(np.linalg.norm(CV, 2) * np.linalg.norm(WB, 2) / abs(lam.real))


def _stacked(parts, n: int):
    """``(V, W, A)`` of the kept modes' ``(v, w, a)`` from :func:`_real_mode`, side by side."""
    if not parts:
        return np.zeros((n, 0)), np.zeros((n, 0)), np.zeros((0, 0))
    return (np.hstack([v for v, _, _ in parts]), np.hstack([w for _, w, _ in parts]),
            scipy.linalg.block_diag(*[a for _, _, a in parts]))


def _static_correction(dc_full, C, B, Vk, Wk, Ak):
    """The feedthrough that restores the DC gain ``dc_full = -C A^-1 B``: ``dc_full`` less the
    kept modes' own ``-(C V) A_k^-1 (W^T B)``."""
    return dc_full + ((C @ Vk) @ np.linalg.solve(Ak, Wk.T @ B) if Ak.size else 0.0)


def _first_order_blocks(sys: LinearSystem, keep, rank_by, correct, t0) -> ModalTruncation | None:
    """Modal truncation of a block-diagonal ``A`` (a modal model, dense or sparse) block by block:
    the eigendecompositions of the blocks (stacked by order), the bases filled only in each
    kept mode's own states, the static correction by the blocks' solves; O(sum k_j^3) and no
    n x n matrix. None (the caller takes the general path) where ``A`` is not block diagonal,
    a block is (nearly) defective, or an eigenvalue is near or right of the imaginary axis (the
    rigid part is split off by the general path)."""
    from linflex.frequency._modal_forms import _gather_blocks, block_components

    A = sys.A_sparse if sys.is_sparse else sys.A
    found = block_components(A)
    if found is None or found[2] is not None:
        return None
    label = found[1]
    n = sys.n_states
    sizes = np.bincount(label)
    order = np.argsort(label, kind="stable")
    starts = np.r_[0, np.cumsum(sizes)]
    lam_all, modes = [], []   # modes: (eigenvalue, state indices, x, y, pair)
    dc_full = np.zeros_like(sys.D)
    for k in np.unique(sizes):
        which = np.flatnonzero(sizes == k)
        idx = order[starts[which][:, None] + np.arange(k)[None, :]]
        Ab = _gather_blocks(A, idx)
        with np.errstate(all="ignore"):
            lam, X = np.linalg.eig(Ab)
            X = X / np.linalg.norm(X, axis=1, keepdims=True)
            if not np.all(np.isfinite(X)) or np.max(np.linalg.cond(X)) > 1e10:
                return None
            Y = np.linalg.inv(X)
        lam_all.append(lam.ravel())
        if correct:
            dc_full -= np.einsum("pqk,qkm->pm", sys.C[:, idx], np.linalg.solve(Ab, sys.B[idx]))
        for q in range(len(which)):
            modes += [(lam[q, i], idx[q], X[q, :, i], Y[q, i], pair) for i, pair in _mode_pairs(lam[q])]
    lam_all = np.concatenate(lam_all)
    scale = float(np.max(np.abs(lam_all), initial=0.0))
    if not np.all(-lam_all.real > 1e-6 * scale):
        return None
    modes.sort(key=lambda mode: abs(mode[0]))
    freq = np.array([abs(m[0]) for m in modes])
    zeta = np.array([-m[0].real / abs(m[0]) for m in modes])

    def local(mode):
        """The mode's real basis columns and left rows on its own states, and its real block."""
        return _real_mode(mode[0], mode[2], mode[3], mode[4])
    if rank_by == "frequency":
        measure = freq.copy()
    else:
        measure = np.empty(len(modes))
        for j, mode in enumerate(modes):
            v, w, _ = local(mode)
            measure[j] = _dominance(sys.C[:, mode[1]] @ v, w.T @ sys.B[mode[1]], mode[0])
    kept = _select(keep, freq, measure, rank_by)
    columns = sum(2 if modes[j][4] else 1 for j in kept)
    Vk, Wk = np.zeros((n, columns)), np.zeros((n, columns))
    blocks, c = [], 0
    for j in kept:
        v, w, a = local(modes[j])
        Vk[modes[j][1], c:c + v.shape[1]] = v
        Wk[modes[j][1], c:c + v.shape[1]] = w
        blocks.append(a)
        c += v.shape[1]
    Ak = scipy.linalg.block_diag(*blocks) if blocks else np.zeros((0, 0))
    correction = _static_correction(dc_full, sys.C, sys.B, Vk, Wk, Ak) if correct else np.zeros_like(sys.D)
    red = project(sys, Vk, Wk, states=[f"xm{i}" for i in range(columns)], D=sys.D + correction, A=Ak)
    return _result(red, freq, zeta, measure, kept, rank_by, 0, correct, correction, 0, Vk, Wk, None, None, t0)


def _arnoldi_start(n: int) -> NDArray[np.float64]:
    """The fixed starting vector of ARPACK's iterations (a seeded normal draw: no structure that a
    mode could be orthogonal to)."""
    return np.random.default_rng(0).standard_normal(n)


def _nearest_origin(M, k: int):
    """The ``k`` eigenvalues of the sparse ``M`` (CSC) nearest the origin with their eigenvectors,
    by shift-invert ARPACK from a fixed starting vector (ARPACK's own is drawn from a seed that
    advances with every call in the process, so a result would depend on what ran before). ARPACK
    sometimes stops at its iteration limit with all ``k`` pairs converged (it says so in the
    exception, which carries them): those are taken; with fewer, the Krylov space is enlarged once."""
    import scipy.sparse.linalg

    n = M.shape[0]
    v0 = _arnoldi_start(n)
    ncv = min(n, max(2 * k + 1, 20))
    for attempt in range(2):
        try:
            return scipy.sparse.linalg.eigs(M, k=k, sigma=0.0, which="LM", v0=v0, ncv=ncv)
        except scipy.sparse.linalg.ArpackNoConvergence as err:
            if err.eigenvalues.size >= k:
                return err.eigenvalues, err.eigenvectors
            if attempt or ncv == n:
                raise ModelError(f"modal_truncation: ARPACK did not converge on the {k} eigenvalues of the sparse A "
                                 f"nearest the origin ({err.eigenvalues.size} converged); give the dense matrix, "
                                 "or use balanced_truncation") from err
            ncv = min(n, 2 * ncv)
        except RuntimeError as err:   # SuperLU's "Factor is exactly singular", or another ARPACK error
            if "singular" not in str(err).lower():
                raise ModelError(f"modal_truncation: ARPACK failed on the sparse A ({err}); give the dense matrix, "
                                 "or use balanced_truncation") from err
            raise ModelError("modal_truncation: the sparse A is singular (a rigid-body mode); split it off, or give "
                             "the dense matrix") from err


def _lowest_modes(A, count: int | None, high: float | None):
    """The eigenvalues of the sparse ``A`` nearest the origin with right and left eigenvectors
    (shift-invert ARPACK on ``A`` and on ``A^T``, matched), enough for ``count`` modes or for all
    modes up to ``high`` [rad/s]: ``(lam, X, Y)`` with ``Y X = I`` on the pairs found."""
    import scipy.sparse
    from scipy.optimize import linear_sum_assignment

    n = A.shape[0]
    nev = min(n - 2, max(8, 2 * (count or 0) + 4))
    A = scipy.sparse.csc_matrix(A)
    while True:
        lam, X = _nearest_origin(A, nev)
        order = np.argsort(np.abs(lam), kind="stable")
        lam, X = lam[order], X[:, order]
        enough = (count is not None and nev >= 2 * count + 2) or (high is not None and np.abs(lam[-1]) > high)
        if enough or nev >= n - 2:
            break
        nev = min(n - 2, 2 * nev)
    # the far end of the range found may hold half a pair: drop the last value if its partner is missing
    if lam[-1].imag != 0 and not np.any(np.isclose(lam[:-1], np.conj(lam[-1]), rtol=1e-8, atol=0)):
        lam, X = lam[:-1], X[:, :-1]
    # ARPACK finds at most n - 2 eigenvalues: a band reaching past them, or more modes than they
    # hold, cannot be answered from them (the highest modes would be silently missing)
    short = (high is not None and not np.abs(lam[-1]) > high) or (count is not None and len(_mode_pairs(lam)) < count)
    if short:
        wanted = f"the {count} lowest modes" if count is not None else f"every mode up to {high:g} rad/s"
        raise ModelError(f"modal_truncation: the sparse path finds {lam.size} of the {n} eigenvalues of A (ARPACK, "
                         f"at most n - 2), short of {wanted}; keep fewer modes, or give the dense matrix")
    # the left ones, once, two more than the right (the far end of A^T's range may split another pair)
    mu, Z = _nearest_origin(scipy.sparse.csc_matrix(A.T), min(n - 2, lam.size + 2))
    _, match = linear_sum_assignment(np.abs(lam[:, None] - mu[None, :]))   # rows come back in order
    Z = Z[:, match]
    if np.max(np.abs(lam - mu[match]), initial=0.0) > 1e-6 * max(np.max(np.abs(lam)), 1e-300):
        raise ModelError("modal_truncation: the right and left eigenvalues of the sparse A do not match; "
                         "use balanced_truncation")
    Y = (Z / np.sum(Z * X, axis=0)).T          # rows y_i with y_i x_i = 1
    return lam, X / np.linalg.norm(X, axis=0), Y * np.linalg.norm(X, axis=0)[:, None]


def _first_order_sparse(sys: LinearSystem, keep, correct, t0) -> ModalTruncation:
    """Modal truncation of a sparse stable ``A`` without block structure, ranked by frequency:
    the lowest modes by shift-invert (:func:`_lowest_modes`), the static correction from one
    sparse LU of ``A``; no n x n matrix."""
    import scipy.sparse.linalg

    A = sys.A_sparse
    count, high = (keep, None) if isinstance(keep, int) else (None, keep[1])
    lam, X, Y = _lowest_modes(A, count, high)
    scale = float(np.max(np.abs(lam), initial=0.0))
    if np.any(-lam.real <= 1e-6 * scale):
        raise ModelError("modal_truncation: a sparse A with modes on or right of the imaginary axis (rigid-body or "
                         "unstable) is not reduced without forming it; split them off, or give the dense matrix")
    modes = _mode_pairs(lam)
    freq = np.array([abs(lam[i]) for i, _ in modes])
    zeta = np.array([-lam[i].real / abs(lam[i]) for i, _ in modes])
    kept = _select(keep, freq, freq, "frequency")
    Vk, Wk, Ak = _stacked([_real_mode(lam[i], X[:, i], Y[i], pair) for i, pair in (modes[j] for j in kept)],
                          sys.n_states)
    correction = np.zeros_like(sys.D)
    if correct:
        dc_full = -sys.C @ scipy.sparse.linalg.splu(scipy.sparse.csc_matrix(A)).solve(sys.B)
        correction = _static_correction(dc_full, sys.C, sys.B, Vk, Wk, Ak)
    red = project(sys, Vk, Wk, states=[f"xm{i}" for i in range(Vk.shape[1])], D=sys.D + correction, A=Ak)
    return _result(red, freq, zeta, freq, kept, "frequency", 0, correct, correction, 0, Vk, Wk, None, None, t0)


def _first_order(sys: LinearSystem, keep, rank_by, correct, rigid_tol, measure_error, t0) -> ModalTruncation:
    # a sparse system's error is measured by sparse_error_norm (certified where the error system is
    # block diagonal, else a sweep); a dense one's by the general path's Hamiltonian-certified one
    if rigid_tol is None and (sys.is_sparse or not measure_error):
        fast = _first_order_blocks(sys, keep, rank_by, correct, t0)
        if fast is None and sys.is_sparse and rank_by == "frequency":
            try:
                fast = _first_order_sparse(sys, keep, correct, t0)
            except ModelError:
                # rigid-body or unstable modes: the general path splits them off, where the
                # dense matrix may be formed (else the reason stands)
                if sys.n_states > DENSE_STATES_MAX:
                    raise
        if fast is not None:
            if measure_error:
                fast = dataclasses.replace(fast, measured_error=sparse_error_norm(sys, fast.sys),
                                           seconds=time.perf_counter() - t0)
            return fast
    # undamped modes (on the axis, away from the origin) are flexible modes like the others
    split = split_stable(sys, rigid_tol=rigid_tol, undamped="stable")
    st = split.stable
    ns = st.n_states
    lam, X = scipy.linalg.eig(st.A) if ns else (np.zeros(0, complex), np.zeros((0, 0), complex))
    X = X / np.linalg.norm(X, axis=0) if ns else X
    if ns:
        cond = np.linalg.cond(X)
        if not np.isfinite(cond) or cond > 1e10:
            raise ModelError(
                f"modal_truncation: the stable part is (nearly) defective, eigenvector condition {cond:.3g}; "
                "use balanced_truncation instead"
            )
        Y = np.linalg.inv(X)
    # modes: one per real eigenvalue, one per conjugate pair (LAPACK returns the pair adjacent,
    # positive imaginary part first)
    modes = _mode_pairs(lam)
    modes.sort(key=lambda mode: abs(lam[mode[0]]))
    parts = [_real_mode(lam[i], X[:, i], Y[i], pair) for i, pair in modes]
    freq = np.array([abs(lam[i]) for i, _ in modes])
    zeta = np.array([-lam[i].real / abs(lam[i]) + 0.0 if lam[i] != 0 else 1.0 for i, _ in modes])
    if rank_by == "frequency":
        measure = freq.copy()
    else:
        measure = np.array([_dominance(st.C @ v, w.T @ st.B, lam[i]) for (i, _), (v, w, _) in zip(modes, parts)])
    kept = _select(keep, freq, measure, rank_by)
    Vk, Wk, Ak = _stacked([parts[k] for k in kept], ns)
    correction = np.zeros_like(st.D)
    if correct and ns:
        correction = _static_correction(-st.C @ np.linalg.solve(st.A, st.B), st.C, st.B, Vk, Wk, Ak)
    # the kept eigenvalue blocks are W^T A V in exact arithmetic: passed as A, free of its round-off
    proj = project_split(split, Vk, Wk, prefix="xm", D=st.D + correction, A=Ak)
    red, V, W = proj.sys, proj.V, proj.W
    n_u = split.n_unstable
    measured = None
    if measure_error:
        measured = _measured(sys, red, split, proj.stable, parts, freq, kept, np.abs(zeta) * freq <= split.tol,
                             correction, t0)
    return _result(red, freq, zeta, measure, kept, rank_by, n_u, correct, correction, 0, V, W, split, measured, t0)


def _measured(sys, red, split, sr, parts, freq, kept, undamped, correction, t0) -> HinfNorm:
    """``||G - G_r||_inf`` of a first-order modal truncation (``parts``: every mode of the stable
    part, ``undamped``: which are on the axis). A discarded undamped mode leaves its resonance, a
    pole on the axis, in the error: infinite, at that mode's frequency. Undamped modes all kept
    cancel between ``G`` and ``G_r`` but not in a stacked realization, whose poles would be on the
    axis: the error is then the discarded modes' terms less the correction; otherwise the stacked
    stable parts, ``G_s - G_r`` as computed."""
    st = split.stable
    dropped = np.setdiff1d(np.arange(freq.size), kept)
    lost = dropped[undamped[dropped]]
    if lost.size:
        w = float(np.min(freq[lost]))
        return HinfNorm(math.inf, w, True, 1e-6, 0, f"a discarded undamped mode at {w:.6g} rad/s: its resonance is a "
                        "pole of the error on the axis", time.perf_counter() - t0)
    if np.any(undamped):
        Vd, Wd, Ad = _stacked([parts[k] for k in dropped], st.n_states)
        norm = hinf_norm_stable(Ad, Wd.T @ st.B, st.C @ Vd, -correction)
    else:
        norm = hinf_norm_stable(scipy.linalg.block_diag(st.A, sr.A), np.vstack([st.B, sr.B]),
                                np.hstack([st.C, -sr.C]), -correction)
    return checked_against_full(sys, red, norm)


def _second_order(so: SecondOrderSystem, keep, rank_by, correct, rigid_tol, measure_error, influence, t0) -> ModalTruncation:
    M, K, D = so.M, so.K, so.D
    scale_k = max(np.max(np.abs(K)), 1e-300)
    if np.max(np.abs(K - K.T)) > 1e-10 * scale_k:
        raise MethodUnavailableError(
            "modal_truncation of a SecondOrderSystem needs a symmetric K (no circulatory terms); "
            "reduce sys.to_state_space() instead"
        )
    if np.max(np.abs(M - M.T)) > 1e-10 * np.max(np.abs(M)):
        raise ModelError("modal_truncation: M must be symmetric")
    try:
        w2, Phi = scipy.linalg.eigh((K + K.T) / 2, (M + M.T) / 2)
    except np.linalg.LinAlgError as err:
        raise ModelError(f"modal_truncation: M must be symmetric positive definite ({err})") from err
    rigid = _rigid_modes(so, w2, rigid_tol)
    Phi_r, Phi_f = Phi[:, rigid], Phi[:, ~rigid]
    wf = np.sqrt(w2[~rigid])
    Dm = Phi_f.T @ D @ Phi_f
    zeta = np.diag(Dm) / (2 * wf)
    if rank_by == "frequency":
        measure = wf.copy()
    elif rank_by == "dominance":
        c = np.linalg.norm(so.Cq @ Phi_f, axis=0) + wf * np.linalg.norm(so.Cv @ Phi_f, axis=0)
        b = np.linalg.norm(Phi_f.T @ so.B, axis=1)
        with np.errstate(divide="ignore"):
            measure = np.where(zeta > 0, c * b / (2 * np.abs(zeta) * wf**2), np.inf)
    else:
        if influence is None:
            raise ModelError(
                "rank_by='effective_mass' needs influence=: the rigid-body influence vectors (n_dofs x r, the "
                "unit base motions of a clamped/fixed-interface model)"
            )
        R = real_matrix(influence, "influence", (so.n_dofs, None))
        mr = np.einsum("ir,ij,jr->r", R, M, R)
        if np.any(mr <= 0):
            raise ModelError("influence: every column must have positive rigid-body mass r^T M r")
        measure = np.sum((Phi_f.T @ M @ R) ** 2 / mr[None, :], axis=1)
    kept = _select(keep, wf, measure, rank_by)
    discarded = np.setdiff1d(np.arange(wf.size), kept)
    # static deflection of the discarded flexible modes under the input loads:
    # u = Phi_d Omega_d^-2 Phi_d^T B  (= K^-1 F_res restricted to the flexible part)
    Pd = Phi_f[:, discarded]
    u_res = Pd @ ((Pd.T @ so.B) / wf[discarded, None] ** 2)
    basis = [Phi_r, Phi_f[:, kept]]
    n_mtv = 0
    if correct and discarded.size and u_res.size:
        L = scipy.linalg.cholesky((M + M.T) / 2, lower=True)
        Us, s, Vt = scipy.linalg.svd(L.T @ u_res, full_matrices=False)
        k = int(np.sum(s > 1e-10 * s[0])) if s.size and s[0] > 0 else 0
        if k:
            u = u_res @ Vt[:k].T
            Ks, Ms = u.T @ K @ u, u.T @ M @ u
            _, phi = scipy.linalg.eigh((Ks + Ks.T) / 2, (Ms + Ms.T) / 2)
            basis.append(u @ phi)
            n_mtv = k
    Psi = np.hstack(basis)
    n_r, n_k = Phi_r.shape[1], kept.size
    names = [f"rigid{i}" for i in range(n_r)] + [f"mode{i}" for i in range(n_k)] + [f"mtv{i}" for i in range(n_mtv)]
    red = project_second_order(so, Psi, dofs=names)
    measured = None
    if measure_error:
        full, reduced = so.to_state_space(), red.to_state_space()
        measured = checked_against_full(full, reduced, stable_parts_error(full, reduced))
    return _result(
        red, wf, zeta, measure, kept, rank_by, n_r, correct, u_res, n_mtv, Psi, M @ Psi, None, measured, t0,
    )


def _rigid_modes(so: SecondOrderSystem, w2, rigid_tol) -> NDArray[np.bool_]:
    """Rigid (and statically divergent) modes by the spectrum policy, from their poles ``+-sqrt(-w^2)``."""
    from linflex.frequency._spectrum import rigid_mask, system_scale

    poles = np.sqrt(-np.asarray(w2, dtype=complex))
    scale = None
    if rigid_tol is None:
        ss = so.to_state_space()
        scale = system_scale(ss.A, ss.B, ss.C)
    mask, _ = rigid_mask(np.concatenate([poles, -poles]), np.zeros((0, 0)), rigid_tol, scale)
    return mask[: poles.size] | mask[poles.size:] | (np.asarray(w2) < 0)


def _result(red, freq, zeta, measure, kept, rank_by, n_rigid, correct, correction, n_mtv, V, W, split, measured, t0):
    arrays = [np.array(a, dtype=float) for a in (freq, zeta, measure, correction, V, W)]
    kept = np.array(kept, dtype=np.int64)
    for a in [*arrays, kept]:
        a.setflags(write=False)
    freq, zeta, measure, correction, V, W = arrays
    return ModalTruncation(
        sys=red, frequencies=freq, damping=zeta, measure=measure, kept=kept, rank_by=rank_by, n_rigid=int(n_rigid),
        static_correction=correct, correction=correction, n_correction_dofs=int(n_mtv), V=V, W=W, split=split,
        measured_error=measured, seconds=time.perf_counter() - t0,
    )
