"""Modal forms of a linear system for :class:`~._evaluate.TransferEvaluator` (see that module's
docstring for the paths and their error estimates): the dense modal form with its split-off
ill-conditioned block (:class:`_Modal`), the block-diagonal one (:class:`_BlockModal`, also with
a few hub states coupled one way to the blocks, such as a controller in series with a modal
plant: :func:`block_components`) and the undamped modes of a classically damped second-order
system (:class:`_SecondOrderModal`).
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import LinearSystem
from linflex.system import complex_schur

from ._spectrum import EPS, joint_balance

#: Largest eigenvector condition number of an eigenvalue kept in the diagonal part of the modal
#: form; the others are split off into a dense block.
MODAL_KAPPA_MAX = 1e5
#: The scale [-] a vanishing response's error estimate is relative to (:func:`_relative`): the
#: smallest normal number, exact (a power of two), so that a caller measuring against a floor of
#: its own recovers the absolute bound (``frequency/_response.py: _warn_if_inaccurate``).
ZERO_SCALE = np.finfo(float).tiny
class _Unstructured(Exception):
    pass


def balance_system(A, B, C):
    """``(A_bal, B_bal, C_bal)``: an exact diagonal state similarity (powers of 2) that balances
    ``A`` together with ``B`` and ``C`` (:func:`~._spectrum.joint_balance`), so that
    ``||(sI - A)^-1 B||`` and ``||C (sI - A)^-1||`` measure the system and not the units of its
    states. The transfer function is unchanged."""
    ts = joint_balance(A, B, C)
    return A * (1.0 / ts)[:, None] * ts[None, :], B / ts[:, None], C * ts[None, :]


def _relative(abs_bound: NDArray, G: NDArray) -> NDArray[np.float64]:
    """Normwise relative error ``abs_bound / max|G|`` per point; where ``G`` vanishes, relative to
    :data:`ZERO_SCALE` (astronomically large; inf only where ``abs_bound >= 4``); inf where ``G``
    is not finite."""
    with np.errstate(over="ignore", invalid="ignore"):
        scale = np.max(np.abs(G), axis=(1, 2)) if G.size else np.zeros(len(G))
        rel = abs_bound / np.maximum(scale, ZERO_SCALE)
    return np.where(np.isfinite(G).all(axis=(1, 2)), rel, np.inf)


class _Modal:
    """Block-diagonal modal form of a system, computed once, evaluated at many points.

    ::

        A ~ Z Y diag(T11, Lambda) Y^-1 Z^H      Z: ordered complex Schur vectors
        Y = [I  X]   T11 X - X T22 = -T12       (Sylvester, decouples the ill-conditioned block)
            [0  I]   T22 = V Lambda V^-1        (diagonalizable, well conditioned)
    """

    # weights of the adjoint inherent estimate (:meth:`_setup_adjoint`), when the eigenvector
    # norms are known, and ``1 + ||X||`` of the decoupling of a split-off block
    _P: NDArray | None = None
    _Q: NDArray | None = None
    _decoupling = 1.0

    def __init__(self, sys: LinearSystem, *, kappa_max: float = MODAL_KAPPA_MAX) -> None:
        A, B, C = sys.A, sys.B, sys.C
        n = A.shape[0]
        self.D = np.asarray(sys.D, dtype=complex)
        self.k = 0
        self.Kinh = None
        self._dense = None
        self.schur_form = None
        if n == 0:
            self.lam = np.zeros(0, dtype=complex)
            self.poles = self.lam
            self.cond = 1.0
            self.normA = 0.0
            self._setup_diag(np.zeros((sys.n_outputs, 0)), np.zeros((0, sys.n_inputs)), 1.0)
            return
        A, B, C = balance_system(A, B, C)
        self.normA = float(np.linalg.norm(A, 1))
        lam, V = scipy.linalg.eig(A, check_finite=False)
        self.poles = lam
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            # a defective eigenvalue makes V (numerically) singular: kappa = inf flags it
            warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
            lu = scipy.linalg.lu_factor(V, check_finite=False)
            normV = np.linalg.norm(V, 1)
            rcond, info = scipy.linalg.lapack.zgecon(lu[0], normV)
            cond = 1.0 / rcond if info == 0 and rcond > 0 else np.inf
            if cond <= kappa_max:
                # well conditioned as a whole (LAPACK 1-norm estimate): no inverse needed
                self.lam = lam
                self.cond = float(cond)
                self._setup_diag(C @ V, scipy.linalg.lu_solve(lu, B.astype(complex), check_finite=False), self.cond)
                self._dense = (A, B, C, V, lu, None)
                return
            Vinv = scipy.linalg.lu_solve(lu, np.eye(n, dtype=complex), check_finite=False)
            kappa = np.linalg.norm(V, axis=0) * np.linalg.norm(Vinv, axis=1)
        bad = ~np.isfinite(kappa) | (kappa > kappa_max)
        if not np.any(bad):
            self.lam = lam
            self.cond = float(np.linalg.norm(V, 1) * np.linalg.norm(Vinv, 1))
            CV, WB = C @ V, Vinv @ B
            self._setup_diag(CV, WB, self.cond)
            self._setup_adjoint(CV, WB, np.linalg.norm(V, axis=0), np.linalg.norm(Vinv, axis=1))
            self._dense = (A, B, C, V, None, Vinv)
            return
        # Ordered complex Schur form with the ill-conditioned eigenvalues first.
        targets = lam[bad]
        radius = 1e-6 * max(np.max(np.abs(lam)), 1.0)

        def select(x):
            return bool(np.min(np.abs(targets - x)) <= radius)

        T, Z, k = complex_schur(A, sort=select)
        if k == 0 or k == n:
            raise _Unstructured("no separation of the ill-conditioned eigenvalues")
        T11, T12, T22 = T[:k, :k], T[:k, k:], T[k:, k:]
        # T11 X - X T22 = -T12 on the triangular blocks themselves (LAPACK trsyl; solve_sylvester
        # would compute Schur forms of both once more)
        X, scale, info = scipy.linalg.lapack.ztrsyl(T11, T22, -T12, isgn=-1)
        if info < 0 or not scale > 0:
            raise _Unstructured("the ill-conditioned block does not decouple")
        X = X / scale
        normX = np.linalg.norm(X, 1)
        Zb = Z.conj().T @ B
        CZ = C @ Z
        B1 = Zb[:k] - X @ Zb[k:]
        B2 = Zb[k:]
        C1 = CZ[:, :k]
        C2 = CZ[:, :k] @ X + CZ[:, k:]
        lam2, V2 = scipy.linalg.eig(T22, check_finite=False)
        V2inv = scipy.linalg.inv(V2, check_finite=False)
        cond2 = float(np.linalg.norm(V2, 1) * np.linalg.norm(V2inv, 1))
        self.k = k
        # the ordered Schur form itself, for backward-stable re-checks (as _evaluate._schur_form)
        self.schur_form = (T.copy(), Zb, CZ, float(np.linalg.norm(T, 1)))
        self.T11, self.B1, self.C1 = T11, B1, C1
        self.lam = lam2
        self.cond = cond2 * (1 + normX) ** 2
        CV, WB = C2 @ V2, V2inv @ B2
        self._setup_diag(CV, WB, self.cond)
        # the eigenvectors in the coordinates of A: v_i = Z [X; I] V2 e_i, w_i^H = e_i^H V2^-1 [0, I] Z^H
        self._setup_adjoint(CV, WB, np.sqrt(np.linalg.norm(X @ V2, axis=0) ** 2 + np.linalg.norm(V2, axis=0) ** 2),
                            np.linalg.norm(V2inv, axis=1))
        self._decoupling = 1.0 + float(np.linalg.norm(X, 2))

    def _setup_adjoint(self, CV, WB, v_norms, w_norms) -> None:
        """Per-term weights of the inherent estimate of :meth:`evaluate`: ``|C v_i| ||w_i||``
        (one column per output) and ``||v_i|| |w_i^H B|`` (one per input)."""
        self._P = np.abs(CV).T * w_norms[:, None]
        self._Q = v_norms[:, None] * np.abs(WB)

    def _setup_diag(self, CV, WB, cond) -> None:
        p, m = self.D.shape
        # K[i, (o, j)] = CV[o, i] * WB[i, j]: one matrix product evaluates every channel.
        self.K = (CV.T[:, :, None] * WB[:, None, :]).reshape(CV.shape[1], p * m)
        self.Kabs = (np.abs(CV).T[:, :, None] * np.abs(WB)[:, None, :]).reshape(CV.shape[1], p * m)
        self.shape = (p, m)

    def evaluate(self, s: NDArray[np.complex128]) -> tuple[NDArray, NDArray, NDArray]:
        """Response at the points ``s``, the relative rounding error of the modal evaluation
        itself (what a backward-stable solve would avoid) and the inherent relative error (the
        first-order effect of the backward error ``eps ||A||`` of the decomposition, which every
        backward-stable path shares)."""
        p, m = self.shape
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            R = 1.0 / (s[:, None] - self.lam[None, :])
            absR = np.abs(R)
            G = (R @ self.K).reshape(len(s), p, m) + self.D[None]
            # rounding of the modal sum, eps cond(V) sum_i |K_i| / |s - lambda_i|; first-order
            # eigenvalue errors eps ||A|| cond(V) sum_i |K_i| / |s - lambda_i|^2, bounded by the
            # same sum times max_i 1 / |s - lambda_i| (one product instead of two)
            c = EPS * max(self.cond, 1.0)
            total = np.max(absR @ self.Kabs, axis=1) if self.lam.size else np.zeros(len(s))
            rounding = total * (c * (4 + np.sqrt(len(self.lam) + self.k)))
            if self._P is not None:
                # the adjoint bound of a backward-stable path, eps ||A|| ||Y|| ||X||, with
                # ||X|| <= sum_i ||v_i|| |w_i^H B| / |s - lambda_i| (and ||Y|| likewise): the
                # first-order effect of a perturbation eps ||A|| of A on G, eigenvalues and
                # eigenvectors alike; near a resonance it is cond(lambda_i) |K_i| / |s - lambda_i|^2,
                # not cond(V) times that
                xs = np.max(absR @ self._Q, axis=1) if self.lam.size else np.zeros(len(s))
                ys = np.max(absR @ self._P, axis=1) if self.lam.size else np.zeros(len(s))
                if self.k:
                    Gd, rd, _, xb, yb = self._dense_part(s)
                    G, rounding = G + Gd, rounding + rd
                    # the block's share: X_1 = Z [I; 0] M^-1 B_1, Y_1^H = C_1 M^-1 [I, -X] Z^H
                    xs, ys = xs + xb, ys + yb * self._decoupling
                inherent = xs * ys * (EPS * (4 + np.sqrt(len(self.lam) + self.k)) * self.normA)
            elif self.Kinh is None:
                inherent = total * np.max(absR, axis=1, initial=0.0) * (c * self.normA)
            else:
                # per-term norms of the (decoupled) blocks the eigenvalues come from
                inherent = (np.max(absR @ self.Kinh, axis=1) if self.lam.size else np.zeros(len(s))) * (
                    np.max(absR, axis=1, initial=0.0) * c)
            if self.k and self._P is None:
                Gd, rd, idd, _, _ = self._dense_part(s)
                G, rounding, inherent = G + Gd, rounding + rd, inherent + idd
        return G, _relative(rounding, G), _relative(inherent, G)

    def residual_checked(self, s: NDArray[np.complex128], chunk: int = 32) -> tuple[NDArray, NDArray] | None:
        """``G(s)`` from the modal solutions with a residual-based error bound, for a diagonal
        modal form (``None`` otherwise): where the modal rounding estimate is pessimistic, this
        certifies the modal value at the cost of a few matrix products instead of a
        backward-stable re-solve.

        For the points in one block (all at once, as matrix products)::

            X = V (R W B)            Y = V^-H R^H (C V)^H        (modal solution and adjoint)
            Res = B - (sI - A) X     G - C X = C (sI - A)^-1 Res = Y^H Res + (Y_exact - Y)^H Res

        and ``|G - C X - D| <= 2 ||Y|| ||Res||`` while the modal adjoint is good to a relative
        error below 1 (its own estimate is far below), plus the rounding of ``Res`` itself and of
        ``C X`` (``c eps ((||A|| + |s|) ||X|| ||Y|| + max |C| |X|)``, the bound of a
        backward-stable solve).
        """
        if self._dense is None or self.k:
            return None
        A, B, C, V, lu, Vinv = self._dense
        n, m = B.shape
        # eigenvalues moved by the spectrum policy (snap_axis): the residual is taken against
        # A + V diag(dlam) V^-1, the matrix the policy evaluates
        dlam = self.lam - self.poles
        moved = np.flatnonzero(dlam)
        p = C.shape[0]
        CVh = np.conj(C @ V).T                                       # (n, p)
        WB = scipy.linalg.lu_solve(lu, B.astype(complex), check_finite=False) if Vinv is None else Vinv @ B
        G = np.empty((len(s), p, m), dtype=complex)
        bound = np.empty(len(s))
        c = EPS * (4 + np.sqrt(n))
        absC = np.abs(C)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            for a in range(0, len(s), chunk):
                sc = s[a:a + chunk]
                q = len(sc)
                R = 1.0 / (sc[None, :] - self.lam[:, None])                # (n, q)
                M = (R[:, :, None] * WB[:, None, :]).reshape(n, q * m)
                X = V @ M
                # real A times complex X as two real products (no complex copy of A)
                Res = np.tile(B, (1, q)) - np.repeat(sc, m)[None, :] * X + (A @ X.real + 1j * (A @ X.imag))
                if moved.size:
                    Res += V[:, moved] @ (dlam[moved, None] * M[moved])
                Z = (np.conj(R)[:, :, None] * CVh[:, None, :]).reshape(n, q * p)
                Y = (scipy.linalg.lu_solve(lu, Z, trans=2, check_finite=False) if Vinv is None
                     else np.conj(Vinv).T @ Z)
                G[a:a + chunk] = (C @ X).reshape(p, q, m).transpose(1, 0, 2) + self.D[None]
                nx = np.linalg.norm(X.reshape(n, q, m), axis=(0, 2))
                ny = np.linalg.norm(Y.reshape(n, q, p), axis=(0, 2))
                nr = np.linalg.norm(Res.reshape(n, q, m), axis=(0, 2))
                cx = np.max((absC @ np.abs(X)).reshape(p, q, m), axis=(0, 2))
                bound[a:a + chunk] = 2 * ny * nr + c * ((self.normA + np.abs(sc)) * nx * ny + cx)
            return G, _relative(bound, G)

    def _dense_part(self, s: NDArray[np.complex128]) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
        """The split-off block's term ``C1 (sI - T11)^-1 B1``, its absolute rounding and
        inherent error bounds (adjoint bound of a backward-stable small solve), and the norms
        ``||(sI - T11)^-1 B1||`` and ``||C1 (sI - T11)^-1||`` that bound give."""
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            M = s[:, None, None] * np.eye(self.k)[None] - self.T11[None]
            try:
                # the small block's inverse gives X = M^-1 B1 and the adjoint Y^H = C1 M^-1
                Minv = np.linalg.inv(M)
            except np.linalg.LinAlgError:
                Minv = np.stack([_solve_or_inf(Mi, np.eye(self.k, dtype=complex)) for Mi in M])
            X = Minv @ self.B1
            nx = np.linalg.norm(X.reshape(len(s), -1), axis=1)
            ny = np.linalg.norm((self.C1[None] @ Minv).reshape(len(s), -1), axis=1)
            rounding = EPS * (4 + self.k) * np.max((np.abs(self.C1)[None] @ np.abs(X)).reshape(len(s), -1), axis=1)
            inherent = EPS * (4 + self.k) * getattr(self, "normT11", self.normA) * ny * nx
            return self.C1[None] @ X, rounding, inherent, nx, ny


#: Largest total order of the ill-conditioned blocks of a block-diagonal state matrix that
#: :class:`_BlockModal` keeps as one dense block (evaluated by a small solve per point).
BLOCK_DENSE_MAX = 64
#: Largest number of hub states (:func:`block_components`): states coupled to more than
#: ``HUB_DEGREE`` others, such as a controller's states in series with a modal plant.
HUB_MAX = 16
HUB_DEGREE = 8


def _components(i: NDArray[np.intp], j: NDArray[np.intp], n: int) -> tuple[int, NDArray[np.intp]] | None:
    """Connected components of the graph of the pairs ``(i, j)`` over ``n`` nodes (undirected);
    None unless there are at least two, none larger than half the order."""
    import scipy.sparse
    import scipy.sparse.csgraph

    graph = scipy.sparse.coo_matrix((np.ones(i.size, dtype=np.int8), (i, j)), shape=(n, n)).tocsr()
    n_blocks, label = scipy.sparse.csgraph.connected_components(graph, directed=False)
    if n_blocks < 2 or np.max(np.bincount(label)) > n // 2:
        return None
    return int(n_blocks), label


def nonzero_pattern(A, most: int | None = None) -> tuple[NDArray[np.intp], NDArray[np.intp]] | None:
    """Row and column indices of the non-zero entries of ``A`` (dense or ``scipy.sparse``); None
    when there are more than ``most`` (counted before any index array is built)."""
    import scipy.sparse

    if scipy.sparse.issparse(A):
        coo = scipy.sparse.coo_matrix(A)
        keep = coo.data != 0
        if most is not None and np.count_nonzero(keep) > most:
            return None
        return coo.row[keep].astype(np.intp), coo.col[keep].astype(np.intp)
    mask = A != 0
    if most is not None and np.count_nonzero(mask) > most:
        return None
    flat = np.flatnonzero(mask)   # much faster than np.nonzero(A) on a float matrix
    return np.divmod(flat, A.shape[0])


def block_components(A):
    """The diagonal blocks of ``A`` (dense or ``scipy.sparse``) under a symmetric permutation,
    possibly with a few hub states coupled to them one way: ``(n_blocks, label, hub)``, or
    ``None`` when there is no such structure.

    ``label[i]`` is the block of state ``i`` (connected components of the graph of ``A + A^T``);
    ``hub`` is ``None`` when ``A`` is block diagonal with at least two blocks of at most half the
    order. Otherwise, when removing at most ``HUB_MAX`` states of more than ``HUB_DEGREE``
    couplings leaves such blocks (``label`` over the remaining states, in increasing order) and
    the hub is coupled to them one way only, ``hub = (states, feeds)``: ``feeds`` is False when
    the blocks feed the hub (``A[blocks, hub] = 0``: a modal plant followed by a controller,
    ``A`` block lower triangular) and True when the hub feeds the blocks (``A[hub, blocks] = 0``).
    Such an ``A`` has the blocks' eigenvalues and the hub's; :class:`_BlockModal` decouples them
    by a Sylvester equation that is diagonal in the blocks' eigenvectors. A two-way coupling
    (a closed loop) moves the eigenvalues: ``None``.

    One pass over ``A``'s non-zero pattern (no factorization): a modal or block-diagonal model
    (ISS 12A: 706 blocks of order 2) is found in milliseconds, a dense one is rejected by its
    non-zero count before any graph is built.
    """
    n = A.shape[0]
    if n < 4:
        return None
    pattern = nonzero_pattern(A, most=16 * n)
    if pattern is None:
        return None
    i, j = pattern
    found = _components(i, j, n)
    if found is not None:
        return found[0], found[1], None
    off = i != j
    i, j = i[off], j[off]
    degree = np.bincount(i, minlength=n) + np.bincount(j, minlength=n)
    hub = np.flatnonzero(degree > HUB_DEGREE)
    if hub.size == 0 or hub.size > HUB_MAX:
        return None
    in_hub = np.zeros(n, dtype=bool)
    in_hub[hub] = True
    body = np.flatnonzero(~in_hub)
    position = np.cumsum(~in_hub) - 1          # a body state's index among the body states
    inside = ~in_hub[i] & ~in_hub[j]
    found = _components(position[i[inside]], position[j[inside]], body.size)
    if found is None:
        return None
    into_body = bool(np.any(~in_hub[i] & in_hub[j]))   # A[body, hub] != 0: the hub feeds the blocks
    into_hub = bool(np.any(in_hub[i] & ~in_hub[j]))
    if into_body and into_hub:
        return None
    return found[0], found[1], (hub, into_body)


def _submatrix(A, rows, cols) -> NDArray[np.float64]:
    """``A[rows][:, cols]`` as a dense array, ``A`` dense or ``scipy.sparse``."""
    import scipy.sparse

    if scipy.sparse.issparse(A):
        return scipy.sparse.csr_matrix(A)[rows][:, cols].toarray()
    return A[np.ix_(rows, cols)]


def _principal(A, idx: NDArray[np.intp]):
    """The principal submatrix ``A[idx][:, idx]``, sparse where ``A`` is."""
    import scipy.sparse

    if scipy.sparse.issparse(A):
        return scipy.sparse.csr_matrix(A)[idx][:, idx]
    return A[np.ix_(idx, idx)]


def _gather_blocks(A, idx: NDArray[np.intp]) -> NDArray[np.float64]:
    """The stack of diagonal blocks ``A[idx[q]][:, idx[q]]``, shape ``(N, k, k)``, of ``A`` dense
    or ``scipy.sparse`` (there: from its non-zeros, never a dense n x n matrix)."""
    import scipy.sparse

    if not scipy.sparse.issparse(A):
        return A[idx[:, :, None], idx[:, None, :]]
    N, k = idx.shape
    n = A.shape[0]
    block = np.full(n, -1)
    block[idx.ravel()] = np.repeat(np.arange(N), k)
    slot = np.zeros(n, dtype=np.intp)
    slot[idx.ravel()] = np.tile(np.arange(k), N)
    coo = scipy.sparse.coo_matrix(A)
    keep = (block[coo.row] >= 0) & (block[coo.row] == block[coo.col])
    out = np.zeros((N, k, k))
    np.add.at(out, (block[coo.row[keep]], slot[coo.row[keep]], slot[coo.col[keep]]), coo.data[keep])
    return out


def _balance_stack(A, B, C, sweeps: int = 8):
    """Balance a stack of small blocks ``A[q]`` (Osborne's rule in powers of 2, as LAPACK
    ``gebal`` without permutation, all blocks at once) together with ``B[q]`` and ``C[q]`` (rows
    ``[A B]``, columns ``[A; C]``), and apply the same exact state scaling to them. A state whose
    row or column is zero is not scaled."""
    k = A.shape[1]
    if k < 2 or A.shape[0] == 0:
        return A, B, C
    A, B, C = A.copy(), B.copy(), C.copy()
    off = ~np.eye(k, dtype=bool)
    for _ in range(sweeps):
        changed = False
        for i in range(k):
            # column i of [A; C] and row i of [A, B] without the diagonal (the states are balanced
            # with the signals that give them their meaning, as joint_balance does)
            c = np.sum(np.abs(A[:, :, i]) * off[i], axis=1) + np.sum(np.abs(C[:, :, i]), axis=1)
            r = np.sum(np.abs(A[:, i, :]) * off[i], axis=1) + np.sum(np.abs(B[:, i, :]), axis=1)
            with np.errstate(divide="ignore", invalid="ignore"):
                f = np.exp2(np.round(0.5 * np.log2(r / c)))
            f = np.where(np.isfinite(f) & (c > 0) & (r > 0) & (f > 0), f, 1.0)
            # D^-1 A D with D_ii = f: column i times f, row i over f
            if np.any(f != 1.0):
                changed = True
                A[:, :, i] *= f[:, None]
                A[:, i, :] /= f[:, None]
                B[:, i, :] /= f[:, None]
                C[:, :, i] *= f[:, None]
        if not changed:
            break
    return A, B, C


def _block_forms(A, B, C, label, kappa_max: float):
    """Eigendecomposition of a block-diagonal ``A`` (blocks ``label``), block by block: the
    well-conditioned blocks' modal data ``(lam, CV, WB, cond, norm)`` per eigenvalue (``cond``
    and ``norm`` of its own block), their balanced ``(A_j, B_j, C_j)`` stacks by order, the
    ill-conditioned blocks ``(A_j, B_j, C_j)`` and the largest block norm."""
    p, m = C.shape[0], B.shape[1]
    order = np.argsort(label, kind="stable")
    sizes = np.bincount(label)
    starts = np.r_[0, np.cumsum(sizes)]
    lams, CVs, WBs, conds, groups, norm_i, bad, norms = [], [], [], [], [], [], [], []
    for k in np.unique(sizes):
        which = np.flatnonzero(sizes == k)
        idx = order[starts[which][:, None] + np.arange(k)[None, :]]      # (N, k) state indices
        Ab = _gather_blocks(A, idx)                                     # (N, k, k)
        Bb, Cb = B[idx], np.moveaxis(C[:, idx], 0, 1)                   # (N, k, m), (N, p, k)
        Ab, Bb, Cb = _balance_stack(Ab, Bb, Cb)
        norms.append(np.max(np.sum(np.abs(Ab), axis=1), axis=1))
        with np.errstate(all="ignore"):
            lam, V = np.linalg.eig(Ab)
            lam, V = lam.astype(complex), V.astype(complex)
            sv = np.linalg.svd(V, compute_uv=False)
            ok = np.isfinite(sv).all(axis=1) & (sv[:, -1] > sv[:, 0] / kappa_max)
            W = np.zeros_like(V)
            if np.any(ok):
                W[ok] = np.linalg.inv(V[ok])
            cond = np.max(np.sum(np.abs(V), axis=1), axis=1) * np.max(np.sum(np.abs(W), axis=1), axis=1)
            ok &= np.isfinite(cond) & (cond <= kappa_max)
        bad.extend(zip(Ab[~ok], Bb[~ok], Cb[~ok]))
        if np.any(ok):
            groups.append((Ab[ok], Bb[ok], Cb[ok]))
        lams.append(lam[ok].ravel())
        CVs.append((Cb[ok] @ V[ok]).transpose(1, 0, 2).reshape(p, -1))
        WBs.append((W[ok] @ Bb[ok]).reshape(-1, m))
        conds.append(np.repeat(np.maximum(cond[ok], 1.0), k))
        norm_i.append(np.repeat(norms[-1][ok], k))
    return (np.concatenate(lams), np.concatenate(CVs, axis=1), np.concatenate(WBs, axis=0),
            np.concatenate(conds), np.concatenate(norm_i), groups, bad, float(np.max(np.concatenate(norms))))


class _BlockModal(_Modal):
    """Modal form of a block-diagonal ``A`` (after a permutation), computed block by block.

    Blocks of equal order are stacked and eigendecomposed together (``numpy.linalg.eig`` on a
    stack): O(sum k_j^3) instead of O(n^3), and no n x n matrix is formed. Each eigenvalue's term
    of the modal sum carries its own block's eigenvector condition ``||V_j||_1 ||V_j^-1||_1``
    (a defective rigid-body block no longer spoils the estimate of the others); blocks whose
    condition exceeds ``MODAL_KAPPA_MAX`` form the dense block of :class:`_Modal` as they are
    (they are small; their solve is backward stable). The backward-stable re-evaluation
    (:meth:`stable`) is block by block too: one small triangular solve per block in the block's
    complex Schur form.

    With hub states fed by the blocks (:func:`block_components`; a controller after a modal
    plant), ``A = [[A_G, 0], [A_HG, A_H]]`` (``G``: the well-conditioned blocks; the hub and
    the ill-conditioned blocks form ``H``) is block diagonalized by ``[[I, 0], [X, I]]`` with
    ``X A_G - A_H X = A_HG``; in the eigenvectors ``A_G = V Lambda W`` each column of
    ``Y = X V`` is one small solve ``(lambda_i I - A_H) y_i = A_HG v_i``, so the modal terms
    become ``(C_G v_i + C_H y_i) (w_i B_G)`` and the dense block gets ``B_H - Y W B_G``: still
    O(n) per point. A hub that feeds the blocks is the transpose of that case (the form of
    ``(A^T, C^T, B^T)``, transposed back).
    """

    def __init__(self, sys: LinearSystem, blocks, *, kappa_max: float = MODAL_KAPPA_MAX) -> None:
        n_blocks, label, hub = blocks
        self.n_blocks = n_blocks
        self._schur = None
        self._dense = None  # no dense factors: re-checks go through the block Schur forms
        self._hub = None
        A, B, C, D = sys.A_sparse if sys.is_sparse else sys.A, sys.B, sys.C, np.asarray(sys.D, dtype=float)
        dual = hub is not None and hub[1]
        if dual:
            A, B, C, D = A.T, C.T, B.T, D.T
        p, m = D.shape
        self.D = D.astype(complex)
        if hub is None:
            lam, CV, WB, conds, norm_i, self.groups, bad, self.normA = _block_forms(A, B, C, label, kappa_max)
            Kabs_cv = np.abs(CV)
        else:
            h = hub[0]
            r = h.size
            body = np.setdiff1d(np.arange(A.shape[0]), h)
            # the blocks with the coupling rows A_HG as extra outputs: A_HG V comes out of the same
            # (balanced) eigenvectors as C_G V
            Cx = np.vstack([C[:, body], _submatrix(A, h, body)])
            lam, CVx, WB, conds, norm_i, self.groups, bad, normG = _block_forms(
                _principal(A, body), B[body], Cx, label, kappa_max)
            AH, BH, CH = _submatrix(A, h, h), B[h], C[:, h]
            with np.errstate(all="ignore"):
                Y = np.linalg.solve(lam[:, None, None] * np.eye(r)[None] - AH[None], CVx[p:].T[:, :, None])[:, :, 0].T
            if not np.all(np.isfinite(Y)):
                raise _Unstructured("an eigenvalue of the blocks is one of the hub's")
            CV = CVx[:p] + CH @ Y
            Kabs_cv = np.abs(CVx[:p]) + np.abs(CH) @ np.abs(Y)
            self.normA = max(normG, float(np.max(np.sum(np.abs(_submatrix(A, h, np.arange(A.shape[0]))), axis=1))))
            # the dense block: the ill-conditioned blocks, then the hub with its coupling to them
            kb = int(sum(len(Ab) for Ab, _, _ in bad))
            T = np.zeros((kb + r, kb + r))
            if kb:
                T[:kb, :kb] = scipy.linalg.block_diag(*[Ab for Ab, _, _ in bad])
                T[kb:, :kb] = np.concatenate([Cb[p:] for _, _, Cb in bad], axis=1)
            T[kb:, kb:] = AH
            Bd = np.concatenate([Bb for _, Bb, _ in bad] + [BH])
            Cd = np.concatenate([Cb[:p] for _, _, Cb in bad] + [CH], axis=1)
            B1 = Bd.astype(complex)
            B1[kb:] -= Y @ WB
            bad = [(T, B1, Cd)]
            # for the backward-stable path: the dense block in the original coordinates of the
            # blocks (input B_H, driven by A_HG x_G)
            self._hub = (dual, T.astype(complex), Bd.astype(complex), Cd.astype(complex), kb, p)
        self.k = int(sum(len(Ab) for Ab, _, _ in bad))
        if self.k > BLOCK_DENSE_MAX:
            raise _Unstructured(f"{self.k} states in ill-conditioned blocks and hubs")
        if self.k:
            self.T11 = scipy.linalg.block_diag(*[Ab for Ab, _, _ in bad]).astype(complex)
            self.B1 = np.concatenate([Bb for _, Bb, _ in bad]).astype(complex)
            self.C1 = np.concatenate([Cb for _, _, Cb in bad], axis=1).astype(complex)
            self.normT11 = float(np.linalg.norm(self.T11, 1))
        self.lam = lam
        self.cond = 1.0
        self._setup_diag(CV, WB, 1.0)
        # each term's rounding scales with its own block's eigenvector condition (and the
        # rounding of the hub's share C_H y_i)
        self.Kabs = (Kabs_cv.T[:, :, None] * np.abs(WB)[:, None, :]).reshape(len(lam), p * m) * conds[:, None]
        self.Kinh = self.Kabs * norm_i[:, None]
        # the first-order error of each pole, n eps ||A|| cond(lambda): the block's eigenvector
        # condition, times 1 + ||y_i|| through a hub; the dense block's eigenvalue conditions
        # times the decoupling's 1 + ||Y|| max cond (a defective eigenvalue: sqrt(n eps) ||A||)
        n_all = A.shape[0]
        growth = 1.0 if hub is None else 1.0 + np.linalg.norm(Y, axis=0)
        est = n_all * EPS * self.normA * conds * growth
        self.poles = self.lam
        if self.k:
            mu, vl, vr = scipy.linalg.eig(self.T11, left=True, right=True, check_finite=False)
            with np.errstate(divide="ignore"):
                cmu = 1.0 / np.abs(np.sum(vl.conj() * vr, axis=0))
            spread = 1.0 if hub is None else 1.0 + float(np.linalg.norm(Y)) * float(np.max(conds, initial=1.0))
            norm = max(self.normA, self.normT11)
            e_mu = n_all * EPS * norm * cmu * spread
            e_mu = np.where(np.isfinite(e_mu) & (cmu < 1 / np.sqrt(EPS)), e_mu, np.sqrt(n_all * EPS) * norm)
            self.poles = np.concatenate([self.lam, mu])
            est = np.concatenate([est, e_mu])
        self.pole_estimate = est
        if dual:
            self._transpose()

    def _transpose(self) -> None:
        """The form of ``G^T`` becomes the form of ``G`` (the hub-feeds-blocks case)."""
        p, m = self.shape
        n = len(self.lam)
        for name in ("K", "Kabs", "Kinh"):
            setattr(self, name, getattr(self, name).reshape(n, p, m).transpose(0, 2, 1).reshape(n, m * p))
        self.D = self.D.T
        self.shape = (m, p)
        if self.k:
            self.T11, self.B1, self.C1 = self.T11.T.copy(), self.C1.T.copy(), self.B1.T.copy()

    def _blockwise(self, s, snap, p_out: int, m_in: int) -> tuple[NDArray, NDArray, NDArray]:
        """``sum_j C_j (sI - A_j)^-1 B_j`` over the well-conditioned blocks by triangular solves
        in their complex Schur forms, with ``sum_j ||T_j|| ||Y_j|| ||X_j||`` and
        ``sum_j |C_j| |X_j|`` per point (the adjoint bound's parts)."""
        if self._schur is None:
            forms = []
            for Ab, Bb, Cb in self.groups:
                T = np.empty(Ab.shape, dtype=complex)
                Z = np.empty(Ab.shape, dtype=complex)
                for q, Aq in enumerate(Ab):
                    T[q], Z[q] = scipy.linalg.schur(Aq.astype(complex), output="complex", check_finite=False)
                Zh = np.conj(np.swapaxes(Z, 1, 2))
                forms.append((T, Zh @ Bb, Cb @ Z, np.max(np.sum(np.abs(T), axis=1), axis=1)))
            self._schur = forms
        G = np.zeros((len(s), p_out, m_in), dtype=complex)
        bound = np.zeros(len(s))
        absG = np.zeros((len(s), p_out, m_in))
        for T, ZB, CZ, nT in self._schur:
            N, k = T.shape[:2]
            d = np.diagonal(T, axis1=1, axis2=2)
            if snap is not None:
                move = snap(d.ravel()).reshape(d.shape)
                d = np.where(move, 1j * d.imag, d)
            M = -T.copy()
            ii = np.arange(k)
            with np.errstate(all="ignore"):
                for q, sq in enumerate(s):
                    M[:, ii, ii] = sq - d
                    if not np.all(M[:, ii, ii] != 0):
                        G[q], bound[q] = np.inf, np.inf
                        continue
                    X = np.linalg.solve(M, ZB)
                    Y = np.linalg.solve(np.conj(np.swapaxes(M, 1, 2)), np.conj(np.swapaxes(CZ, 1, 2)))
                    G[q] += np.sum(CZ @ X, axis=0)
                    absG[q] += np.sum(np.abs(CZ) @ np.abs(X), axis=0)
                    bound[q] += np.sum(nT * np.linalg.norm(X, axis=(1, 2)) * np.linalg.norm(Y, axis=(1, 2)))
        c = EPS * (4 + np.sqrt(max([T.shape[1] for T, *_ in self._schur], default=1)))
        return G, bound, c * absG.reshape(len(s), -1).max(axis=1, initial=0.0)

    def stable(self, s: NDArray[np.complex128], snap=None) -> tuple[NDArray, NDArray]:
        """``G(s)`` and its relative error estimate by backward-stable solves block by block: in
        each block's complex Schur form ``A_j = Z_j T_j Z_j^H`` one triangular solve with
        ``sI - T_j`` and one with its adjoint per point; the adjoint bound of the module docstring
        summed over the blocks, ``c eps sum_j ||T_j|| ||Y_j|| ||X_j||``. ``snap(lam)``: a mask of
        Schur diagonal entries to move onto the imaginary axis (the evaluator's spectrum policy).

        With a hub, the blocks' solves give ``C_G x_G`` and ``A_HG x_G``; the dense block (hub
        and ill-conditioned blocks) is then solved with the input ``B_H + A_HG x_G`` (block
        forward substitution), and the blocks' error bound is carried through
        ``1 + ||C_H (sI - A_H)^-1||``.
        """
        if self._hub is not None:
            return self._stable_hub(s, snap)
        p, m = self.shape
        Gb, nb, rb = self._blockwise(s, snap, p, m)
        c = EPS * (4 + np.sqrt(max([T.shape[1] for T, *_ in self._schur], default=1)))
        G = Gb + self.D[None]
        bound = c * nb + rb
        if self.k:
            Gd, rd, idd, _, _ = self._dense_part(s)
            G, bound = G + Gd, bound + rd + idd
        with np.errstate(invalid="ignore", over="ignore"):
            return G, _relative(bound, G)

    def _stable_hub(self, s, snap):
        dual, T, Bd, Cd, kb, p = self._hub
        m = Bd.shape[1]
        r = T.shape[0] - kb
        Gx, nb, rb = self._blockwise(s, snap, p + r, m)
        c = EPS * (4 + np.sqrt(max([Tj.shape[1] for Tj, *_ in self._schur], default=1)))
        body = c * nb + rb                  # absolute bound on [C_G x_G; A_HG x_G]
        k = T.shape[0]
        G = Gx[:, :p] + (self.D.T if dual else self.D)[None]
        bound = np.empty(len(s))
        cd = EPS * (4 + k)
        nT = float(np.linalg.norm(T, 1))
        with np.errstate(all="ignore"):
            M = s[:, None, None] * np.eye(k)[None] - T[None]
            try:
                Minv = np.linalg.inv(M)
            except np.linalg.LinAlgError:
                Minv = np.stack([_solve_or_inf(Mi, np.eye(k, dtype=complex)) for Mi in M])
            U = np.broadcast_to(Bd, (len(s), k, m)).copy()
            U[:, kb:] += Gx[:, p:]
            X = Minv @ U
            CM = Cd[None] @ Minv
            G += Cd[None] @ X
            nx = np.linalg.norm(X.reshape(len(s), -1), axis=1)
            ny = np.linalg.norm(CM.reshape(len(s), -1), axis=1)
            gain = 1.0 + np.linalg.norm(CM[:, :, kb:].reshape(len(s), -1), axis=1)
            bound = (body * gain + cd * (nT * nx * ny
                                         + np.max((np.abs(Cd)[None] @ np.abs(X)).reshape(len(s), -1), axis=1)))
            if dual:
                G = G.transpose(0, 2, 1)
            return G, _relative(bound, G)


def _solve_or_inf(M, B):
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", scipy.linalg.LinAlgWarning)
            return scipy.linalg.solve(M, B, check_finite=False)
    except (np.linalg.LinAlgError, scipy.linalg.LinAlgWarning):
        return np.full(B.shape, np.inf + 0j)


class _SecondOrderModal:
    """Undamped modes of a classically damped ``M q'' + D q' + K q = B u``, evaluated per mode.

    With ``K Phi = M Phi diag(k)`` and ``Phi^T M Phi = I`` (``scipy.linalg.eigh(K, M)``, half
    the order of the first-order form and symmetric), and ``Phi^T D Phi = diag(d)`` (checked)::

        G(s) = Du + sum_i (Cq phi_i + s Cv phi_i) (phi_i^T B) / (s^2 + d_i s + k_i)

    Rigid-body modes (``k_i = 0``) are plain ``1/(s^2 + d_i s)`` terms: no defective block.
    """

    def __init__(self, so, *, offdiag_tol: float = 1e-10) -> None:
        M, D, K = so.M, so.D, so.K
        for name, X in (("M", M), ("D", D), ("K", K)):
            if not np.allclose(X, X.T, rtol=1e-12, atol=1e-14 * max(np.max(np.abs(X)), 1e-300)):
                raise _Unstructured(f"{name} is not symmetric")
        try:
            k, Phi = scipy.linalg.eigh(K, M, check_finite=False)
        except (np.linalg.LinAlgError, ValueError) as err:
            raise _Unstructured(f"M is not positive definite ({err})") from err
        Dm = Phi.T @ D @ Phi
        d = np.diag(Dm).copy()
        off = Dm - np.diag(d)
        if np.linalg.norm(off) > offdiag_tol * max(np.linalg.norm(Dm), 1e-300) and np.any(off):
            raise _Unstructured("damping is not diagonal in the undamped modes")
        k = np.where(np.abs(k) <= 1e-12 * max(np.max(np.abs(k)), 1e-300), 0.0, k)
        self.d, self.k = d, k
        Bm = Phi.T @ so.B
        CqP, CvP = so.Cq @ Phi, so.Cv @ Phi
        p, m = so.Du.shape
        n = len(k)
        self.Kq = (CqP.T[:, :, None] * Bm[:, None, :]).reshape(n, p * m)
        self.Kv = (CvP.T[:, :, None] * Bm[:, None, :]).reshape(n, p * m)
        self.Kabs = np.abs(self.Kq) + np.abs(self.Kv)
        self.D = np.asarray(so.Du, dtype=complex)
        self.shape = (p, m)
        self.n = n
        # cond(M)^(1/2) bounds the growth of the M-orthonormal modes
        ev = scipy.linalg.eigvalsh(M, check_finite=False)
        self.cond = float(np.sqrt(ev[-1] / ev[0])) if ev[0] > 0 else np.inf
        disc = np.sqrt((d / 2).astype(complex) ** 2 - k)
        self.poles = np.concatenate([-d / 2 + disc, -d / 2 - disc])

    def evaluate(self, s: NDArray[np.complex128]) -> tuple[NDArray, NDArray, NDArray]:
        """As :meth:`_Modal.evaluate`: response, rounding and inherent relative errors."""
        p, m = self.shape
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            den = s[:, None] ** 2 + s[:, None] * self.d[None, :] + self.k[None, :]
            Q = 1.0 / den
            G = (Q @ self.Kq + s[:, None] * (Q @ self.Kv)).reshape(len(s), p, m) + self.D[None]
            absQ = np.abs(Q) * np.maximum(1.0, np.abs(s))[:, None]
            rounding = np.max(absQ @ self.Kabs, axis=1) * (EPS * max(self.cond, 1.0) * (4 + np.sqrt(self.n)))
            # the modal stiffness and damping are known to about eps cond(M) (|k| + |d s|) (eigh is
            # backward stable): first order |K_i| |Q_i|^2 times that
            size = np.abs(s[:, None] * self.d[None]) + np.abs(self.k[None])
            inherent = np.max((absQ * np.abs(Q) * size) @ self.Kabs, axis=1) * (4 * EPS * max(self.cond, 1.0))
        return G, _relative(rounding, G), _relative(inherent, G)
