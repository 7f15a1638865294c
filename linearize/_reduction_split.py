"""The rigid/flexible split shared by every reduction: unstable and marginal part versus stable part.

A spacecraft model has rigid-body poles at the origin (double integrators) and possibly other
marginally stable or unstable poles; gramian-based reductions only make sense on the stable part.
:func:`split_stable` separates the two parts by an ordered real Schur form and a Sylvester
equation (the classic additive decomposition), keeps track of the transformation, and reports how
well conditioned the separation is.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import ConvergenceError, LinearSystem, ModelError, as_linear_system
from linflex.frequency._spectrum import rigid_mask, system_scale
from linflex.system import check_positive, schur_eigenvalues

__all__ = ["StableSplit", "split_stable"]


@dataclass(frozen=True)
class StableSplit:
    """The additive decomposition ``G(s) = G_unstable(s) + G_stable(s)`` of a linear system.

    Attributes
    ----------
    unstable : LinearSystem
        The part with every eigenvalue of real part ``>= -tol`` (rigid-body modes, marginal and
        unstable modes); its ``D`` is zero. States ``xu0, xu1, ...``.
    stable : LinearSystem
        The part with every eigenvalue of real part ``< -tol`` (and, split with
        ``undamped="stable"``, the undamped oscillatory ones); it carries the feedthrough ``D``.
        States ``xs0, xs1, ...``.
    T, T_inv : ndarray
        The similarity transformation ``x = T z``, ``z = T_inv x`` with ``z = [xu; xs]``:
        ``T_inv @ A @ T = blockdiag(A_unstable, A_stable)``.
    n_unstable : int
        Number of states of the unstable part.
    tol : float
        Threshold on the real part [1/s] used to classify eigenvalues: the ``rigid_tol`` given to
        :func:`split_stable`, or the spectrum policy's ``marginal_tol()`` by default.
    condition : float
        2-norm condition number of the decoupling part of ``T`` (``T`` also contains an exact
        balancing by powers of 2, which is not counted; for a modal ``A`` split block by block,
        a bound: see the Notes of :func:`split_stable`); large values (say above 1e8) mean the two parts are
        nearly inseparable (an unstable eigenvalue close to a stable one), and any reduction of the
        stable part loses accuracy accordingly.
    separation : float
        Smallest distance [1/s] between an eigenvalue of the unstable and of the stable part
        (``inf`` when one part is empty).
    residual : float
        Relative residual of the Sylvester equation that decouples the parts.
    seconds : float
        Wall time of the split [s].
    """

    unstable: LinearSystem
    stable: LinearSystem
    T: NDArray[np.float64]
    T_inv: NDArray[np.float64]
    n_unstable: int
    tol: float
    condition: float
    separation: float
    residual: float
    seconds: float


def default_split_tol(A: NDArray[np.float64], B=None, C=None, poles=None) -> float:
    """Default real-part threshold [1/s]: the spectrum policy's tolerance for "on the imaginary axis".

    ``Spectrum.marginal_tol()`` of :func:`linflex.frequency._spectrum.classify` (the one place
    where linflex decides which eigenvalues are rigid-body or undamped): the largest ``|Re lambda|``
    of an eigenvalue treated as rigid or on the axis, and at least ``100 eps scale`` with the
    scale of ``A`` balanced together with ``B`` and ``C``. A Jordan block at the origin split by
    round-off into ``+-sqrt(eps) scale`` therefore goes to the unstable (marginal) part whole.
    ``poles``: the eigenvalues of ``A`` when already known.
    """
    from linflex.frequency._spectrum import classify

    return classify(A, B=B, C=C, poles=poles).marginal_tol()


def split_stable(sys, *, rigid_tol: float | None = None, undamped: str = "unstable") -> StableSplit:
    """Split a system into its unstable/marginal part and its stable part.

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
        The system to split.
    rigid_tol : float, optional
        The spectrum policy's tolerance [1/s] (the ``rigid_tol`` of :mod:`linflex.frequency`, of
        :func:`modal_truncation` and :func:`balanced_truncation`): eigenvalues with real part
        ``>= -rigid_tol`` go to the unstable part. Default: the spectrum policy of
        ``frequency/_spectrum.py`` (``default_split_tol``): every eigenvalue that stability
        margins treat as rigid-body or undamped goes to the unstable part, including rigid-body
        double integrators perturbed by round-off.
    undamped : {"unstable", "stable"}
        The part that undamped oscillatory modes go to (poles on the axis to the threshold, away
        from the origin: a structural model without damping): the unstable part (default, as
        the stability margins treat them, and as gramians need), or the stable part, where
        :func:`modal_truncation` treats them as flexible modes like the others. Rigid-body poles
        (the policy's rigid group at the origin) and unstable ones stay in the unstable part.

    Returns
    -------
    StableSplit
        Both parts, the transformation and its conditioning.

    Raises
    ------
    ModelError
        If ``rigid_tol`` is negative or not finite, or ``undamped`` is not one of the two.
    ConvergenceError
        If the Schur reordering fails (eigenvalues too close to the threshold to be separated).

    Notes
    -----
    After balancing ``A`` by an exact diagonal similarity, with the real Schur form reordered so the unstable eigenvalues come first,

    ::

        Q^T A Q = [ A11  A12 ]        A11 X - X A22 = -A12          (Sylvester)
                  [  0   A22 ]

        T = Q [ I  X ]      T^-1 = [ I  -X ] Q^T      T^-1 A T = [ A11   0  ]
              [ 0  I ]             [ 0   I ]                     [  0   A22 ]

    The condition number of ``[[I, X], [0, I]]`` is ``((s + sqrt(s^2 + 4)) / 2)^2`` with
    ``s = ||X||_2`` (Q is orthogonal), so it is computed from the singular values of ``X`` alone.
    Reference: Kagstrom and Westin, "Generalized Schur methods with condition estimators for
    solving the generalized Sylvester equation", IEEE TAC 34 (1989); the same decomposition is
    SLICOT's TB01KD used by AB09ND.

    A block-diagonal (modal) ``A`` under a permutation of its states, possibly with a few hub
    states coupled to the blocks one way (a controller in series with a modal plant;
    :func:`~linflex.frequency._modal_forms.block_components`), is split block by block instead:
    each block's own real Schur form (blocks up to ``BLOCK_MAX`` states), the hub decoupled from
    the blocks by one Sylvester equation on those Schur forms, and the same decomposition as
    above inside a block whose eigenvalues lie on both sides. The stable part is then block
    diagonal (its complex pairs and real eigenvalues last, each its own block), which
    :func:`~linflex.linearize.balanced_truncation` uses for its gramians, and the split costs
    O(n^2) (the dense ``T``) instead of a dense Schur form's O(n^3). ``condition`` is then
    the product of the hub decoupling's and the worst block split's (a bound on the 2-norm
    condition of the non-orthogonal part of ``T``); a hub decoupling worse than
    ``HUB_CONDITION_MAX`` takes the dense path.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> sys = LinearSystem([[0, 1, 0], [0, 0, 1], [0, 0, -2]], [[0], [0], [1]], [[1, 0, 0]])
    >>> split_stable(sys).n_unstable
    2
    """
    t0 = time.perf_counter()
    sys = as_linear_system(sys, "sys")
    A = sys.A
    n = sys.n_states
    tol_given = rigid_tol
    if undamped not in ("unstable", "stable"):
        raise ModelError(f"undamped must be 'unstable' or 'stable', got {undamped!r}")
    if rigid_tol is not None:
        tol = check_positive(rigid_tol, "rigid_tol", allow_zero=True)
    if n == 0:
        T = np.eye(0)
        tol = default_split_tol(A, sys.B, sys.C) if tol_given is None else tol
        return _finish(sys, T, T, 0, np.zeros((0, 0)), np.zeros((0, 0)), tol, 1.0, np.inf, 0.0, t0)

    structured = _block_split(sys, tol_given, undamped)
    if structured is not None:
        return _finish(sys, *structured, t0)

    # exact diagonal similarity by powers of 2 (and a permutation) first: LAPACK's Schur routine
    # does not balance, and badly scaled states (metres beside modal coordinates) would otherwise
    # spread the eigenvalues by eps * ||A|| of the unbalanced matrix
    Ab, Tb = scipy.linalg.matrix_balance(A, permute=True, scale=True)
    # LAPACK's permutation step can isolate rows and then leave a badly scaled matrix unscaled
    # (states 1e9 apart kept ||A|| at 5e10 where scaling alone reaches 4e2): keep the smaller norm
    Ab_scaled, Tb_scaled = scipy.linalg.matrix_balance(A, permute=False, scale=True)
    if np.linalg.norm(Ab_scaled, 1) < np.linalg.norm(Ab, 1):
        Ab, Tb = Ab_scaled, Tb_scaled
    # one real Schur form: its eigenvalues feed the spectrum policy, then LAPACK trsen moves the
    # selected ones first (no second eigenvalue computation)
    S, Q = scipy.linalg.schur(Ab, output="real", check_finite=False)
    Bb, Cb = np.linalg.solve(Tb, sys.B), sys.C @ Tb
    tol, unstable_part = _policy(schur_eigenvalues(S), tol_given, undamped, Ab, Bb, Cb)
    A11, A22, QE, EiQt, n_u, residual, condition, separation = _schur_split(S, Q, unstable_part, tol)
    # T = Tb Q E: Tb (a scaled permutation) acts by row scaling and permutation
    rows, cols = np.nonzero(Tb)  # one entry per row and column
    t = Tb[rows, cols]
    T = np.empty_like(QE)
    T[rows] = t[:, None] * QE[cols]
    T_inv = np.empty_like(EiQt)
    T_inv[:, rows] = EiQt[:, cols] / t[None, :]
    return _finish(sys, T, T_inv, n_u, A11, A22, tol, condition, separation, residual, t0)


def _policy(poles, tol_given, undamped: str, A, B, C):
    """``(tol, unstable_part)``: the threshold (the spectrum policy's of :func:`default_split_tol`
    from the eigenvalues ``poles``, or the user's ``tol_given``) and which eigenvalues go to the
    unstable part (with ``undamped="stable"`` undamped oscillatory modes go to the stable part);
    the system's scale taken once for both."""
    from linflex.frequency._spectrum import classify

    scale = None
    if tol_given is None:
        spectrum = classify(A, B=B, C=C, poles=poles)
        tol, scale = spectrum.marginal_tol(), spectrum.scale
    else:
        tol = float(tol_given)
    if undamped == "stable" and scale is None:
        scale = system_scale(A, B, C)

    def unstable_part(ev):
        out = ev.real >= -tol
        if undamped == "stable":
            rigid, _ = rigid_mask(ev, A, tol_given, scale)
            out &= ~((np.abs(ev.real) <= tol) & (ev.imag != 0) & ~rigid)
        return out
    return tol, unstable_part


def _schur_split(S, Q, unstable_part, tol: float):
    """The additive decomposition of ``A = Q S Q^T`` (``S`` real Schur, ``Q`` orthogonal):
    ``(A11, A22, QE, EiQt, n_u, residual, condition, separation)`` with ``A QE = QE
    blockdiag(A11, A22)``, ``EiQt = QE^-1``, the eigenvalues ``unstable_part`` selects in
    ``A11`` (LAPACK trsen) and the Sylvester equation's residual and condition (Notes of
    :func:`split_stable`)."""
    n = S.shape[0]
    select = unstable_part(schur_eigenvalues(S))
    sdim = int(np.count_nonzero(select))
    if 0 < sdim < n and not np.all(select[:sdim]):
        S, Q, *_, info = scipy.linalg.lapack.dtrsen(select.astype(np.int32), S, Q, job="N")
        if info != 0:
            raise ConvergenceError(f"split_stable: LAPACK dtrsen could not reorder the Schur form (info {info})")
    ev = schur_eigenvalues(S)
    n_u = int(np.sum(unstable_part(ev)))
    if sdim != n_u or not np.all(unstable_part(ev)[:n_u]):
        raise ConvergenceError(
            f"split_stable: the Schur reordering put {sdim} eigenvalues first but {n_u} have real part "
            f">= -rigid_tol = {-tol:.3g}; eigenvalues lie too close to the threshold, choose another rigid_tol"
        )
    A11, A12, A22 = S[:n_u, :n_u], S[:n_u, n_u:], S[n_u:, n_u:]
    X, residual, condition = _decouple(A11, A12, A22)
    separation = float(np.min(np.abs(ev[:n_u, None] - ev[None, n_u:]))) if 0 < n_u < n else np.inf
    # Q E only changes the last columns by Q[:, :n_u] X
    QE = Q.copy()
    QE[:, n_u:] += Q[:, :n_u] @ X
    EiQt = Q.T.copy()
    EiQt[:n_u] -= X @ Q.T[n_u:]
    return A11, A22, QE, EiQt, n_u, residual, condition, separation


def _decouple(A11, A12, A22):
    """``X`` with ``A11 X - X A22 = -A12`` (both quasi-triangular: LAPACK trsyl directly,
    solve_sylvester would compute both Schur forms again), its relative residual and the
    2-norm condition of ``[[I, X], [0, I]]``."""
    if A12.size == 0:
        return np.zeros(A12.shape), 0.0, 1.0
    X, scale, info = scipy.linalg.lapack.dtrsyl(A11, A22, -A12, isgn=-1)
    if info < 0 or not scale > 0:
        X = scipy.linalg.solve_sylvester(A11, -A22, -A12)
    else:
        X = X / scale
    res = np.linalg.norm(A11 @ X - X @ A22 + A12, 1)
    scale = (np.linalg.norm(A11, 1) + np.linalg.norm(A22, 1)) * np.linalg.norm(X, 1) + np.linalg.norm(A12, 1)
    residual = float(res / scale) if scale > 0 else 0.0
    s = float(np.linalg.norm(X, 2))
    return X, residual, ((s + np.sqrt(s * s + 4.0)) / 2.0) ** 2


def _finish(sys, T, T_inv, n_u, A11, A22, tol, condition, separation, residual, t0) -> StableSplit:
    Bz = T_inv @ sys.B
    Cz = sys.C @ T
    n = sys.n_states
    unstable = LinearSystem(
        A11, Bz[:n_u], Cz[:, :n_u], np.zeros_like(sys.D),
        states=[f"xu{i}" for i in range(n_u)], inputs=sys.inputs, outputs=sys.outputs,
    )
    stable = LinearSystem(
        A22, Bz[n_u:], Cz[:, n_u:], sys.D,
        states=[f"xs{i}" for i in range(n - n_u)], inputs=sys.inputs, outputs=sys.outputs,
    )
    T = np.array(T, dtype=float)
    T_inv = np.array(T_inv, dtype=float)
    T.setflags(write=False)
    T_inv.setflags(write=False)
    return StableSplit(
        unstable=unstable, stable=stable, T=T, T_inv=T_inv, n_unstable=n_u, tol=float(tol),
        condition=float(condition), separation=float(separation), residual=float(residual),
        seconds=time.perf_counter() - t0,
    )


#: Largest diagonal block of a block-diagonal (modal) ``A`` that :func:`split_stable` splits
#: block by block; larger blocks take the dense path.
BLOCK_MAX = 8
#: Largest 2-norm condition of the transformation that decouples a hub (a controller in series
#: with a modal plant) from the blocks; beyond it the dense path's orthogonal Schur form is used.
HUB_CONDITION_MAX = 1e8


def _block_split(sys: LinearSystem, tol_given, undamped: str):
    """The split of a block-diagonal (modal) ``A``, possibly with a hub coupled one way
    (:func:`~linflex.frequency._modal_forms.block_components`), block by block:
    ``(T, T_inv, n_u, A11, A22, tol, condition, separation, residual)`` for :func:`_finish`, or
    None when ``A`` has no such structure.

    Each block's real Schur form (orthogonal, a few states); the hub decoupled from the blocks
    by one Sylvester equation on the Schur forms (its condition in ``condition``); a block with
    eigenvalues on both sides split by :func:`_schur_split`. The stable part is block diagonal:
    the blocks of a complex pair or a real eigenvalue last (the modal shape of
    :mod:`linflex.linearize._block_lyapunov`), the rest (the hub's stable part, larger blocks)
    first. O(n^2) for the dense ``T`` the split returns, where the dense path's Schur form
    costs O(n^3).
    """
    import scipy.sparse

    from linflex.frequency._modal_forms import _gather_blocks, _submatrix, block_components

    A = sys.A_sparse if sys.is_sparse else sys.A
    n = sys.n_states
    found = block_components(A)
    if found is None:
        return None
    _, label, hub = found
    in_hub = np.zeros(n, dtype=bool)
    if hub is not None:
        in_hub[hub[0]] = True
    body = np.flatnonzero(~in_hub)
    sizes = np.bincount(label)
    if np.max(sizes) > BLOCK_MAX:
        return None
    order = body[np.argsort(label, kind="stable")]        # the body's states, block by block
    starts = np.r_[0, np.cumsum(sizes)]
    S_list: list = [None] * sizes.size
    Q_list: list = [None] * sizes.size
    for k in np.unique(sizes):
        which = np.flatnonzero(sizes == k)
        for q, Aq in zip(which, _gather_blocks(A, order[starts[which][:, None] + np.arange(k)[None, :]])):
            S_list[q], Q_list[q] = (Aq, np.ones((1, 1))) if k == 1 else scipy.linalg.schur(Aq, output="real")
    coupling = (0.0, 1.0)
    X = None
    if hub is None:
        y = order
        full = _block_diagonal(S_list)
    else:
        hub_states, feeds = hub
        Sh, Qh = scipy.linalg.schur(_submatrix(A, hub_states, hub_states), output="real")
        # the blocks' and the hub's Schur forms in one dense matrix, the blocks' part a view of it
        nh = len(hub_states)
        full = _block_diagonal(S_list + [Sh] if feeds else [Sh] + S_list)
        Sb = full[:n - nh, :n - nh] if feeds else full[nh:, nh:]
        Qb = scipy.sparse.block_diag(Q_list, format="csr")
        if feeds:   # the hub drives the blocks: [[Sb, G], [0, Sh]]
            G = Qb.T @ (_submatrix(A, order, hub_states) @ Qh)
            X, res, cond = _decouple(Sb, G, Sh)
            y = np.r_[order, hub_states]
            S_list, Q_list = S_list + [Sh], Q_list + [Qh]
        else:       # the blocks drive the hub: [[Sh, G], [0, Sb]]
            G = (Qh.T @ _submatrix(A, hub_states, order)) @ Qb
            X, res, cond = _decouple(Sh, G, Sb)
            y = np.r_[hub_states, order]
            S_list, Q_list = [Sh] + S_list, [Qh] + Q_list
        if not (cond <= HUB_CONDITION_MAX):
            return None
        coupling = (res, cond)
    k_list = np.array([S.shape[0] for S in S_list])
    first = np.r_[0, np.cumsum(k_list)[:-1]]
    ev = schur_eigenvalues(full)
    tol, unstable_part = _policy(ev, tol_given, undamped, sys.A, sys.B, sys.C)
    count = np.add.reduceat(unstable_part(ev).astype(int), first)
    # pieces: (positions in the Schur coordinates, local basis columns, local inverse rows, matrix)
    unstable, dense, modal = [], [], []
    residual, worst = coupling[0], 1.0
    for S, k, f, c in zip(S_list, k_list, first, count):
        pos = f + np.arange(k)
        if c == k:
            unstable.append((pos, None, None, S))
            continue
        if c > 0:
            A11, A22, QE, EiQt, n_u, res, cond, _ = _schur_split(S, np.eye(k), unstable_part, tol)
            residual, worst = max(residual, res), max(worst, cond)
            unstable.append((pos, QE[:, :n_u], EiQt[:n_u], A11))
            piece = (pos, QE[:, n_u:], EiQt[n_u:], A22)
        else:
            piece = (pos, None, None, S)
        single = k - c == 1 or (k - c == 2 and piece[3][1, 0] != 0.0)
        (modal if single else dense).append(piece)
    pieces = unstable + dense + modal
    # T = P^T Q E F with P the permutation to y, Q the blocks' Schur vectors, E = [[I, X], [0, I]]
    # and F the pieces' local bases; T_inv = F^-1 E^-1 Q^T P
    zs = np.r_[0, np.cumsum([piece[3].shape[0] for piece in pieces])]
    pure = [i for i, piece in enumerate(pieces) if piece[1] is None]     # a whole block: a permutation
    rows = [np.concatenate([pieces[i][0] for i in pure] + [np.zeros(0, np.intp)])]
    cols = [np.concatenate([np.arange(zs[i], zs[i + 1]) for i in pure] + [np.zeros(0, np.intp)])]
    vals, irows, icols, ivals = [np.ones(rows[0].size)], [cols[0]], [rows[0]], [np.ones(rows[0].size)]
    for i, (pos, basis, inverse, S) in enumerate(pieces):
        if basis is not None:    # a piece of a split block: its local basis and inverse
            z = zs[i] + np.arange(S.shape[0])
            rows.append(np.repeat(pos, z.size))
            cols.append(np.tile(z, pos.size))
            vals.append(basis.ravel())
            irows.append(np.repeat(z, pos.size))
            icols.append(np.tile(pos, z.size))
            ivals.append(inverse.ravel())
    F = scipy.sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    F_inv = scipy.sparse.csr_matrix((np.concatenate(ivals), (np.concatenate(irows), np.concatenate(icols))),
                                    shape=(n, n))
    Q = scipy.sparse.block_diag(Q_list, format="csr")
    P = scipy.sparse.csr_matrix((np.ones(n), (np.arange(n), y)), shape=(n, n))
    E = scipy.sparse.identity(n, format="lil")
    E_inv = scipy.sparse.identity(n, format="lil")
    if X is not None:     # the first group's rows, the second group's columns
        E[:X.shape[0], X.shape[0]:] = X
        E_inv[:X.shape[0], X.shape[0]:] = -X
    T = (P.T @ (Q @ (E.tocsr() @ F))).toarray()
    T_inv = (F_inv @ (E_inv.tocsr() @ (Q.T @ P))).toarray()
    n_u = sum(p[3].shape[0] for p in unstable)
    A11 = _block_diagonal([p[3] for p in unstable])
    A22 = _block_diagonal([p[3] for p in dense + modal])
    ev_u, ev_s = schur_eigenvalues(A11), schur_eigenvalues(A22)
    separation = float(np.min(np.abs(ev_u[:, None] - ev_s[None, :]))) if ev_u.size and ev_s.size else np.inf
    return T, T_inv, n_u, A11, A22, tol, coupling[1] * worst, separation, residual


def _block_diagonal(blocks) -> NDArray[np.float64]:
    """The dense block-diagonal matrix of square ``blocks`` (scipy.linalg.block_diag, placed by
    one fancy-index assignment per block order instead of one slice per block)."""
    k = np.array([b.shape[0] for b in blocks], dtype=np.intp)
    n = int(np.sum(k))
    out = np.zeros((n, n))
    first = np.r_[0, np.cumsum(k)[:-1]] if k.size else k
    for size in np.unique(k):
        which = np.flatnonzero(k == size)
        idx = first[which][:, None] + np.arange(size)[None, :]
        out[idx[:, :, None], idx[:, None, :]] = np.stack([blocks[i] for i in which])
    return out
