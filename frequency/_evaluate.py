"""The one transfer evaluator of linflex: ``G(s) = D + C (sI - A)^-1 B`` at many points.

Used by :func:`~linflex.frequency.frequency_response`, :func:`~linflex.frequency.nyquist_response`,
:func:`~linflex.stability.stability_margins` and the norms of :mod:`linflex.linearize`.

Paths (all after an exact diagonal state scaling by powers of 2 that balances
``A`` with ``B`` and ``C``, :func:`balance_system`):

- ``"modal"``: a block-diagonal modal form computed once (:class:`_Modal`); eigenvalues whose
  eigenvector condition exceeds ``MODAL_KAPPA_MAX`` (defective rigid-body blocks, near-repeated
  clusters) are split off from an ordered complex Schur form by a Sylvester equation and solved
  as one small dense block; O(n) per point for the rest.
- ``"second_order_modal"``: undamped modes of a classically damped second-order system.
- ``"hessenberg"``: ``A = Q H Q^T`` once, one banded LU (LAPACK ``gbtrf``) of ``sI - H`` per
  point, backward stable, O(n^2) per point (Laub, IEEE TAC 26, 1981).
- ``"direct"``: dense LU of ``sI - A`` per point, O(n^3), the reference.
- ``"sparse"``: a system given a ``scipy.sparse`` ``A`` without block-diagonal structure: one
  sparse LU of ``sI - A`` per point (SuperLU through ``scipy.sparse.linalg.splu``), O(nnz) per
  point for the banded or tree-like patterns of structural models; its estimate is the exact
  residual's ``|G - C X - D| <= ||Y|| ||B - (sI - A) X||`` (``Y`` the adjoint solution from
  the same LU) plus the rounding of that residual and of ``C X`` (no dense matrix is formed).
  A sparse ``A`` that is block diagonal (a modal model) takes the block-modal path as a dense
  one does, its blocks read from the non-zeros.

Every point gets an **a-posteriori error estimate** (normwise relative to ``max |G(s)|``):

- backward-stable solves (Hessenberg, direct): the computed ``X = (sI - A)^-1 B`` is exact for
  ``A + dA`` with ``||dA|| <= c eps ||A||``; to first order ``dG = Y^H dA X`` with the adjoint
  solution ``Y = (sI - A)^-H C^H`` from the same LU, so the estimate is
  ``c eps ||A|| ||Y|| ||X|| / max|G|`` -- the conditioning of ``G`` itself, not of the solve;
- modal: rounding of the modal sum ``eps cond(V) sum_i |c_i| |w_i b| / |s - lambda_i|``, plus the
  first-order effect of the decomposition's backward error ``eps ||A||`` (a pole at ``-1e-8``
  beside one at ``-1e6`` is only known to ``2e-10``): where the eigenvector norms are at hand
  (the inverse of ``V`` formed, or a split-off block), the adjoint bound of a backward-stable
  path ``eps ||A|| ||Y|| ||X||`` with ``||X|| <= sum_i ||v_i|| |w_i b| / |s - lambda_i|`` and
  ``||Y||`` likewise (eigenvalue and eigenvector errors alike; near a resonance the eigenvalue's
  own condition, not ``cond(V)``), the split-off block's solutions added; otherwise the eigenvalue
  errors ``eps ||A|| cond(V) sum_i |c_i| |w_i b| / |s - lambda_i|^2``, bounded by the first sum
  times ``eps ||A|| cond(V) max_i 1 / |s - lambda_i|``, plus the adjoint bound of the block.
- Hessenberg: where ``A`` is Hessenberg already (a companion form), no reduction, and the
  smaller of the adjoint bound and a componentwise bound from the residual
  (:func:`_hessenberg_eval`).

``"auto"`` uses the modal form (its re-checks by the banded LU where ``A`` is Hessenberg
already, for every point above ``rtol``) and re-checks every point whose modal rounding estimate exceeds
both ``rtol`` and the point's inherent estimate (the inherent part, shared in form by every
backward-stable path, is not a reason to switch), keeping per point the value with the smaller
total estimate:

- a diagonal dense modal form (no split-off block): the modal solution ``X = V R W B`` and its
  adjoint ``Y``, then the residual ``Res = B - (sI - A) X`` (all points at once, matrix
  products), ``|G - C X - D| <= 2 ||Y|| ||Res||`` plus the rounding of ``Res`` and ``C X``
  (:meth:`_Modal.residual_checked`): the modal value certified at O(n^2) per point without any
  further O(n^3) form (the spectrum policy's moved eigenvalues enter the residual);
- a block-diagonal ``A`` (:func:`block_components`, say a modal structural model: its modal
  form is built block by block, :class:`_BlockModal`, O(sum k_j^3) once and O(n) per point, no
  n x n matrix formed): triangular solves in each block's complex Schur form;
- otherwise (a split-off block): the complex Schur form ``A = Z T Z^H`` that the modal form
  already ordered to split the block off (``"schur"``: one triangular solve with ``sI - T`` per
  point and its adjoint, O(n^2), no copy of the matrix per point, no further O(n^3) form: 1.8 ms
  per point against 9.5 ms for a banded LU of the Hessenberg form at order 1000); up to
  ``SCHUR_BATCH_MAX`` states the points of a call are solved together in one batched LAPACK
  call, where one call per point would cost ten times the arithmetic.

A point where ``sI - A`` is singular (a pole exactly on a grid point) gets an infinite estimate.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import AccuracyWarning, LinearSystem, ModelError
from linflex.system import complex_schur

from ._modal_forms import (
    MODAL_KAPPA_MAX,
    _BlockModal,
    _Modal,
    _relative,
    _SecondOrderModal,
    _solve_or_inf,
    _Unstructured,
    balance_system,
    block_components,
)
from ._spectrum import EPS

__all__ = ["TransferEvaluator", "METHODS", "MODAL_KAPPA_MAX", "WARN_RTOL"]

METHODS = ("auto", "modal", "hessenberg", "direct", "sparse")
#: The largest sparse ``A`` without block structure whose poles :attr:`TransferEvaluator.poles`
#: computes (dense ``eigvals``: about 3 s at 2000 states, 25 s at 4000): an automatic grid,
#: the spectrum policy and the margins' stability count need them; beyond, give the frequencies.
SPARSE_POLES_MAX = 4000
#: An :class:`~linflex.AccuracyWarning` is issued when the estimated relative error of an
#: evaluation that a caller reports exceeds this. The estimates are first-order normwise bounds,
#: pessimistic by up to 1e4 on stiff models (a 10-segment spring chain: estimate 6e-6 where dense
#: solves in balanced coordinates agree to 1e-11), hence a level well above the typical error.
WARN_RTOL = 1e-4
#: Points whose value and estimate an evaluator remembers (:meth:`TransferEvaluator.at`), and
#: the largest call that is remembered and looked up (a dense sweep of more points than this is
#: evaluated as it is: its points are rarely asked for again and the look-ups would cost more).
MEMO_POINTS = 2**16
MEMO_CALL = 4096
#: ``"auto"`` re-checks a modal point whose total estimate exceeds this even where the inherent
#: part dominates it (see :meth:`TransferEvaluator._at`).
RECHECK_RTOL = 1e-2 * WARN_RTOL
#: Up to this many states the Schur path solves all points of a call in one batched LAPACK call
#: (:func:`_schur_eval_batched`); above, one ``trsm`` per point, whose O(n^2) wins near 40 states.
SCHUR_BATCH_MAX = 32


def is_hessenberg(A: NDArray) -> str | None:
    """``"upper"`` or ``"lower"`` when ``A`` is already an (upper or lower) Hessenberg matrix
    (a companion or canonical form, as ``tf2ss`` gives), else ``None``."""
    if A.shape[0] < 3 or not np.any(np.tril(A, -2)):
        return "upper"
    if not np.any(np.triu(A, 2)):
        return "lower"
    return None


def _hessenberg_form(sys: LinearSystem):
    """Balanced Hessenberg form of ``sys`` for :func:`_hessenberg_eval`: ``(band storage of -H,
    Q^T B, C Q, ||H||_1, H or None, transposed)``.

    A state matrix that already is Hessenberg is used as it is (``Q = I``: no reduction and its
    rounding; a lower Hessenberg one through the transposed system ``G^T = B^T (sI - A^T)^-1
    C^T``); then ``H`` is kept for the componentwise error estimate of :func:`_hessenberg_eval`.
    """
    # diagonal balancing first (an exact similarity by powers of 2): the Hessenberg reduction's
    # backward error is eps ||A||, which on a stiff or badly scaled model is far above eps ||A_bal||
    # (a 10-segment spring chain: 5e-9 relative error unbalanced, 1e-12 balanced); with B and C
    # in the balance, the adjoint error estimate measures the system, not its state units
    A, B, C = balance_system(sys.A, sys.B, sys.C)
    shape = is_hessenberg(A)
    transposed = shape == "lower"
    if transposed:
        A, B, C = A.T, C.T, B.T
    if shape is None:
        H, Q = scipy.linalg.hessenberg(A, calc_q=True, check_finite=False)
        Bh, Ch, kept = Q.T @ B, C @ Q, None
    else:
        H, Bh, Ch = np.ascontiguousarray(A), B, C
        kept = H
    n = A.shape[0]
    u = n - 1
    # LAPACK band storage for gbtrf with kl = 1 subdiagonal and ku = n - 1 superdiagonals, plus
    # kl rows of fill-in: ab[kl + ku + i - j, j] = (-H)[i, j]
    ab = np.zeros((2 + u + 1, n), dtype=complex, order="F")  # LAPACK's order: no copy per point
    i, j = np.nonzero(np.triu(np.ones((n, n), dtype=bool), -1))
    ab[1 + u + i - j, j] = -H[i, j]
    return ab, Bh.astype(complex), Ch.astype(complex), float(np.linalg.norm(H, 1)), kept, transposed


def _hessenberg_eval(form, D, s: NDArray[np.complex128]) -> tuple[NDArray, NDArray]:
    """``G(s)`` and its relative error estimate from one banded LU of ``sI - H`` per point.

    The estimate is the adjoint bound of a backward-stable solve, ``c eps ||H|| ||X|| ||Y||``
    (normwise: the reduction ``A = Q H Q^T`` and the LU perturb ``H`` by ``eps ||H||``). Where
    ``A`` was already Hessenberg (no reduction) the smaller of that and a componentwise
    a-posteriori bound from the residual ``r = B - (sI - H) X`` is taken::

        |G - C X - D| <= |Y|^T (|r| + c eps (|sI - H| |X| + |B|)) + c eps |C| |X|

    (the error of the computed residual included, Higham, *Accuracy and Stability of Numerical
    Algorithms*, 2nd ed., section 7.2): it sees that an LU of a companion matrix with partial
    pivoting keeps its zeros and tiny entries, where a quadruple pole at the origin makes the
    normwise bound 1e12 times too large at 1e-3 rad/s.
    """
    ab, Bh, Ch, normH, H, transposed = form
    if transposed:
        D = D.T
    n = ab.shape[1]
    u = n - 1
    out = np.empty((len(s),) + D.shape, dtype=complex)
    bound = np.empty(len(s))
    gbtrf, gbtrs = scipy.linalg.lapack.zgbtrf, scipy.linalg.lapack.zgbtrs
    ChH = np.ascontiguousarray(Ch.conj().T)
    c = EPS * (4 + np.sqrt(n))
    absC = np.abs(Ch)
    if H is not None:
        absH, absB, dH = np.abs(H), np.abs(Bh), np.diag(H)
        absdH = np.abs(dH)
    for q, sq in enumerate(s):
        work = ab.copy(order="F")
        work[1 + u, :] += sq
        lu, piv, info = gbtrf(work, 1, u, overwrite_ab=1)
        if info != 0:
            out[q] = np.inf
            bound[q] = np.inf
            continue
        X, _ = gbtrs(lu, 1, u, Bh, piv)
        Y, _ = gbtrs(lu, 1, u, ChH, piv, trans=2)
        out[q] = Ch @ X + D
        absX = np.abs(X)
        cx = absC @ absX
        bound[q] = c * (normH * np.linalg.norm(X) * np.linalg.norm(Y) + np.max(cx, initial=0.0))
        if H is not None:
            r = Bh - sq * X + (H @ X.real + 1j * (H @ X.imag))
            MX = absH @ absX + (np.abs(sq - dH) - absdH)[:, None] * absX
            comp = np.abs(Y).T @ (np.abs(r) + c * (MX + absB)) + c * cx
            bound[q] = min(bound[q], float(np.max(comp, initial=0.0)))
    if transposed:
        out = out.transpose(0, 2, 1)
    with np.errstate(invalid="ignore", over="ignore"):
        return out, _relative(bound, out)


def _schur_form(sys: LinearSystem):
    """Balanced complex Schur form ``(T, Z^H B, C Z, ||T||_1)`` (``A = Z T Z^H``, T upper triangular)."""
    A, B, C = balance_system(sys.A, sys.B, sys.C)
    T, Z, _ = complex_schur(A)
    return T, Z.conj().T @ B, C @ Z, float(np.linalg.norm(T, 1))


def _schur_eval(form, D, s: NDArray[np.complex128]) -> tuple[NDArray, NDArray]:
    """``G(s)`` and its relative error estimate from one triangular solve with ``sI - T`` per point
    (O(n^2), backward stable; only the diagonal changes with ``s``), and one with its adjoint.
    Up to :data:`SCHUR_BATCH_MAX` states the points are solved together (:func:`_schur_eval_batched`)."""
    T, Bt, Ct, normT = form
    n = T.shape[0]
    if n <= SCHUR_BATCH_MAX:
        return _schur_eval_batched(form, D, s)
    out = np.empty((len(s),) + D.shape, dtype=complex)
    bound = np.empty(len(s))
    M = -T.copy()
    d0 = -np.diag(T)
    idx = np.arange(n)
    CtHc = np.ascontiguousarray(Ct.T)  # conj(C^H)
    MT = M.T
    absCt = np.abs(Ct)
    trsm = scipy.linalg.solve_triangular
    with np.errstate(all="ignore"):
        for q, sq in enumerate(s):
            M[idx, idx] = d0 + sq
            if not np.all(M[idx, idx] != 0):
                out[q], bound[q] = np.inf, np.inf
                continue
            # through the transposed view (Fortran order: LAPACK takes it without a copy): the
            # adjoint as conj(M^-T conj(c)), 20 times faster at n = 2001 than trans="C" on M
            X = trsm(MT, Bt, lower=True, trans="T", check_finite=False)
            Y = np.conj(trsm(MT, CtHc, lower=True, check_finite=False))
            out[q] = Ct @ X + D
            bound[q] = _solve_bound(X[None], Y[None], absCt, normT)[0]
        return out, _relative(bound, out)


def _solve_bound(X: NDArray, Y: NDArray, absC: NDArray, normF: float) -> NDArray[np.float64]:
    """The absolute error bound of ``C X + D`` at each point, ``X = (sI - F)^-1 B`` by a backward
    stable solve (the Schur path's ``F = T``, the direct path's balanced ``A``): ``c (||F|| ||X||
    ||Y|| + max |C| |X|)`` with ``Y = (sI - F)^-H C^H`` and ``c = eps (4 + sqrt(n))``; ``X`` of shape
    (k, n, m), ``Y`` (k, n, p) for ``k`` points, ``absC = |C|``, ``normF = ||F||_1``."""
    k, n = X.shape[0], X.shape[1]
    c = EPS * (4 + np.sqrt(n))
    return c * (normF * np.linalg.norm(X.reshape(k, -1), axis=1) * np.linalg.norm(Y.reshape(k, -1), axis=1)
                + np.max((absC[None] @ np.abs(X)).reshape(k, -1), axis=1, initial=0.0))


def _schur_eval_batched(form, D, s: NDArray[np.complex128], chunk: int = 256) -> tuple[NDArray, NDArray]:
    """:func:`_schur_eval` for small ``T``: the triangular systems of all points stacked and solved
    by one batched LAPACK call (``getrf``/``getrs``: on a triangular matrix partial pivoting makes
    no exchange, so the factorization is ``sI - T`` itself and the solve its back substitution, as
    backward stable as ``trsm``), with the same error estimate. At 2 to 16 states the per-point
    calls of ``trsm`` cost 10 to 30 times more than the arithmetic (measured: 30 points at 8
    states, 1.6 ms looped, 0.15 ms stacked; equal near 40 states)."""
    T, Bt, Ct, normT = form
    n = T.shape[0]
    out = np.empty((len(s),) + D.shape, dtype=complex)
    bound = np.empty(len(s))
    absCt, diag, eye = np.abs(Ct), np.diag(T), np.eye(n)
    with np.errstate(all="ignore"):
        for a in range(0, len(s), chunk):
            sc = s[a:a + chunk]
            ok = np.all(sc[:, None] != diag[None, :], axis=1)  # else a pole on the point: sI - T is singular
            block_out, block_bound = out[a:a + chunk], bound[a:a + chunk]
            block_out[~ok], block_bound[~ok] = np.inf, np.inf
            if not ok.any():
                continue
            M = sc[ok, None, None] * eye - T[None]
            X = np.linalg.solve(M, Bt)
            Y = np.conj(np.linalg.solve(np.swapaxes(M, 1, 2), Ct.T))
            block_out[ok] = Ct[None] @ X + D
            block_bound[ok] = _solve_bound(X, Y, absCt, normT)
        return out, _relative(bound, out)


def _direct_eval(sys: LinearSystem, s: NDArray[np.complex128], chunk: int = 64) -> tuple[NDArray, NDArray]:
    """``G(s)`` by dense complex solves (LAPACK ``gesv``) and the adjoint error estimate."""
    n = sys.n_states
    out = np.empty((len(s),) + sys.D.shape, dtype=complex)
    bound = np.zeros(len(s))
    if n == 0:
        out[:] = sys.D
        return out, bound
    eye = np.eye(n)
    A, B, C = balance_system(sys.A, sys.B, sys.C)
    normA, absC = float(np.linalg.norm(A, 1)), np.abs(C)
    for a in range(0, len(s), chunk):
        sc = s[a:a + chunk]
        M = sc[:, None, None] * eye[None] - A[None]
        with np.errstate(all="ignore"):
            try:
                X = np.linalg.solve(M, np.broadcast_to(B, (len(sc),) + B.shape).astype(complex))
                Y = np.linalg.solve(np.conj(np.swapaxes(M, 1, 2)),
                                    np.broadcast_to(C.T, (len(sc),) + C.T.shape).astype(complex))
            except np.linalg.LinAlgError:
                X = np.stack([_solve_or_inf(Mi, B.astype(complex)) for Mi in M])
                Y = np.stack([_solve_or_inf(Mi.conj().T, C.T.astype(complex)) for Mi in M])
            out[a:a + chunk] = C[None] @ X + sys.D
            bound[a:a + chunk] = _solve_bound(X, Y, absC, normA)
    with np.errstate(invalid="ignore", over="ignore"):
        return out, _relative(bound, out)


def _sparse_form(sys: LinearSystem):
    """What every call of :func:`_sparse_eval` needs of ``sys``, formed once per evaluator:
    ``A`` as CSC, the identity, ``||A||_1``, ``B``, ``C^H`` and ``|C|``."""
    import scipy.sparse
    import scipy.sparse.linalg

    A = sys.A_sparse.tocsc()
    return (A, scipy.sparse.identity(A.shape[0], dtype=complex, format="csc"), float(scipy.sparse.linalg.norm(A, 1)),
            sys.B.astype(complex), np.ascontiguousarray(sys.C.T.astype(complex)), np.abs(sys.C))


def _sparse_eval(sys: LinearSystem, form, s: NDArray[np.complex128]) -> tuple[NDArray, NDArray]:
    """``G(s)`` by one sparse LU of ``sI - A`` per point (``form``: :func:`_sparse_form`), with
    the residual and adjoint estimate (module docstring); a point where ``sI - A`` is exactly
    singular gets ``inf``."""
    import scipy.sparse.linalg

    n, (p, m) = sys.n_states, sys.D.shape
    out = np.empty((len(s), p, m), dtype=complex)
    bound = np.zeros(len(s))
    if n == 0 or p == 0 or m == 0:
        out[:] = sys.D
        return out, bound
    A, eye, normA, B, CH, absC = form
    C = sys.C
    c = EPS * (4 + np.sqrt(n))
    for q, sq in enumerate(s):
        M = (sq * eye - A).tocsc()
        try:
            lu = scipy.sparse.linalg.splu(M)
        except RuntimeError:   # exactly singular: a pole on the point
            out[q], bound[q] = np.inf, np.inf
            continue
        X = lu.solve(B)
        Y = lu.solve(CH, trans="H")
        R = B - M @ X
        out[q] = C @ X + sys.D
        nx, ny = np.linalg.norm(X), np.linalg.norm(Y)
        bound[q] = ny * np.linalg.norm(R) + c * ((normA + abs(sq)) * nx * ny + np.max(absC @ np.abs(X)))
    with np.errstate(invalid="ignore", over="ignore"):
        return out, _relative(bound, out)


class TransferEvaluator:
    """``G(s)`` of a linear system at any points, with an a-posteriori error estimate per point.

    Parameters
    ----------
    sys : LinearSystem
        The system.
    method : {"auto", "modal", "hessenberg", "direct", "sparse"}
        Evaluation path (see the module docstring).
    rtol : float
        Relative error [-] above which ``"auto"`` re-evaluates a modal point from the Schur form.
    second_order : SecondOrderSystem, optional
        The second-order form of ``sys``, for the ``"second_order_modal"`` path.

    Attributes
    ----------
    error : float
        Largest estimated relative error [-] of every point evaluated so far.
    worst : complex
        The point [1/s] where ``error`` was reached.
    last_error : ndarray
        Estimated relative errors [-] of the last call.
    n_evaluations : int
        Points evaluated so far (a point asked for again is remembered, not evaluated again).
    """

    def __init__(self, sys: LinearSystem, method: str = "auto", rtol: float = 1e-11, second_order=None) -> None:
        if method not in METHODS:
            raise ModelError(f"method must be one of {list(METHODS)}, got {method!r}")
        self.sys, self.method, self.rtol = sys, method, rtol
        self.D = np.asarray(sys.D, dtype=float)
        self.shape = self.D.shape
        self.modal = None
        self.modal_name = "modal"
        self.used: set[str] = set()
        self.error = 0.0
        self.worst = complex("nan")
        self.last_error = np.zeros(0)
        self.n_evaluations = 0
        self._hess = None
        self._schur = None
        self._sparse = None   # the sparse path's form (_sparse_form), once
        self._snap = None
        self._memo: dict[complex, tuple[NDArray[np.complex128], float]] = {}
        if second_order is not None and method in ("auto", "modal"):
            try:
                self.modal = _SecondOrderModal(second_order)
                self.modal_name = "second_order_modal"
            except (_Unstructured, np.linalg.LinAlgError, ValueError):
                self.modal = None
        if method in ("auto", "modal") and self.modal is None:
            blocks = block_components(sys.A_sparse if sys.is_sparse else sys.A)
            if blocks is not None:
                try:
                    self.modal = _BlockModal(sys, blocks)
                except (_Unstructured, np.linalg.LinAlgError, ValueError):
                    self.modal = None
        if method == "sparse" and not sys.is_sparse:
            raise ModelError("method='sparse' needs a system whose A is a scipy.sparse matrix")
        if (method == "modal" or (method == "auto" and not sys.is_sparse)) and self.modal is None:
            try:
                self.modal = _Modal(sys)
            except (_Unstructured, np.linalg.LinAlgError, ValueError) as err:
                if method == "modal":
                    raise ModelError(f"method='modal': the system has no usable modal form ({err})") from err
        self._poles = getattr(self.modal, "poles", None)
        # a state matrix that is Hessenberg already (a companion or canonical form) is re-checked
        # by its own banded LU; a block-diagonal one (2x2 modal blocks are Hessenberg too) by its
        # blocks' Schur forms, O(n) per point
        self._given_hessenberg = (method == "auto" and sys.n_states > 0 and not sys.is_sparse
                                  and not isinstance(self.modal, _BlockModal)
                                  and is_hessenberg(np.asarray(sys.A)) is not None)

    @property
    def _own_hessenberg(self) -> bool:
        """Whether points are (re-)evaluated by the banded LU of ``A`` as given: a Hessenberg
        ``A`` under ``"auto"``, unless the spectrum policy moved poles (the Schur form holds them)."""
        return self._given_hessenberg and self._snap is None

    def snap_axis(self, spec) -> int:
        """Evaluate from now on with every non-rigid on-axis pole of the spectrum policy exactly
        on the axis, ``lambda -> j Im(lambda)``, as the policy says it is.

        A ``1e-16`` perturbation leaves an undamped pole at ``sigma + j w_p`` with ``|sigma|``
        below ``axis_tol``; within about ``sqrt(|sigma| / |Im G|)`` of ``w_p`` that ``sigma``
        alone decides the sign of ``Im G(j w)`` (it adds ``-R sigma / (w - w_p)^2``), so the loop
        and its perturbation would have different phase crossovers. The modal eigenvalues and the
        diagonal of the Schur form are moved; both are the evaluator's own values, so the change
        is exactly the policy's and nothing else of ``G`` changes.

        Parameters
        ----------
        spec : Spectrum
            The classified poles (:func:`~linflex.frequency._spectrum.classify`).

        Returns
        -------
        int
            The number of eigenvalues of the modal form moved.
        """
        self._snap = spec
        self._memo.clear()
        modal = self.modal
        if isinstance(modal, _Modal) and modal.lam.size:
            lam = modal.lam
            move = self._snap_mask(lam)
            if np.any(move):
                modal.lam = np.where(move, 1j * lam.imag, lam)
            return int(np.count_nonzero(move))
        return 0

    def _snap_mask(self, lam) -> NDArray[np.bool_]:
        spec = self._snap
        if spec is None:
            return np.zeros(np.shape(lam), dtype=bool)
        return ((lam.real != 0) & (np.abs(lam.real) <= spec.axis_tol(lam))
                & (np.abs(lam) > 10 * spec.rigid_radius) & (np.abs(lam) > 0))

    @property
    def poles(self) -> NDArray[np.complex128]:
        """Eigenvalues of ``A`` [1/s] (from the modal form when there is one)."""
        if self._poles is None:
            if self.sys.is_sparse and self.sys.n_states > SPARSE_POLES_MAX:
                raise ModelError(
                    f"the poles of a sparse system of {self.sys.n_states} states without block-diagonal structure "
                    f"take a dense eigendecomposition (above SPARSE_POLES_MAX = {SPARSE_POLES_MAX} states), which an "
                    "automatic grid, the margins and the Nyquist count need: give frequency_response the frequencies "
                    "(omega), or give the system in modal (block-diagonal) form, whose poles come from its blocks")
            A = self.sys.A
            self._poles = scipy.linalg.eigvals(A, check_finite=False) if A.shape[0] else np.zeros(0, complex)
        return self._poles

    def _hessenberg(self, s):
        if self.sys.n_states == 0:
            out = np.broadcast_to(self.D.astype(complex), (len(s),) + self.shape).copy()
            return out, np.zeros(len(s))
        if self._hess is None:
            self._hess = _hessenberg_form(self.sys)
        return _hessenberg_eval(self._hess, self.D, s)

    def _triangular(self, s):
        if self.sys.n_states == 0:
            out = np.broadcast_to(self.D.astype(complex), (len(s),) + self.shape).copy()
            return out, np.zeros(len(s))
        if self._schur is None:
            reuse = getattr(self.modal, "schur_form", None)  # the modal form's own, when it split a block off
            self._schur = (reuse[0].copy(), *reuse[1:]) if reuse is not None else _schur_form(self.sys)
            move = self._snap_mask(np.diag(self._schur[0]))
            if np.any(move):
                i = np.flatnonzero(move)
                self._schur[0][i, i] = 1j * self._schur[0][i, i].imag
        return _schur_eval(self._schur, self.D, s)

    def __call__(self, omega) -> NDArray[np.complex128]:
        """``G(j omega)``, shape ``(n_omega, p, m)``, for frequencies ``omega`` [rad/s]."""
        return self.at(1j * np.atleast_1d(np.asarray(omega, dtype=float)))

    def siso(self, omega) -> NDArray[np.complex128]:
        """``G(j omega)`` of a 1x1 system as a 1-D array (``omega`` in [rad/s])."""
        return self(omega)[:, 0, 0]

    def at(self, s) -> NDArray[np.complex128]:
        """``G(s)`` at complex points ``s`` [1/s], shape ``(n_s, p, m)``.

        A point evaluated before is not evaluated again: its value and estimate are remembered
        (up to ``MEMO_POINTS`` points, from calls of at most ``MEMO_CALL`` points), so the
        analyses that come back to the same frequencies (the sensitivity ``1 / (1 + L)`` on the
        grid of ``L``, the Nyquist count on that grid, the checks at the crossings) cost nothing
        there, and every part of an analysis sees the same value at the same point."""
        s = np.atleast_1d(np.asarray(s, dtype=complex))
        if s.size > MEMO_CALL:
            G, self.last_error = self._blocks(s)
            self._record(s, s.size)
            return G
        keys = s.tolist()
        memo = self._memo
        known = [memo.get(k) for k in keys] if memo else [None] * len(keys)
        new = np.array([v is None for v in known], dtype=bool)
        if np.all(new):
            G, rel = self._blocks(s)
        else:
            G = np.empty((s.size,) + self.shape, dtype=complex)
            rel = np.empty(s.size)
            if np.any(new):
                G[new], rel[new] = self._blocks(s[new])
            for i in np.flatnonzero(~new):
                G[i], rel[i] = known[i]
        if len(memo) < MEMO_POINTS:
            for i in np.flatnonzero(new)[:MEMO_POINTS - len(memo)]:
                memo[keys[i]] = (G[i].copy(), float(rel[i]))
        self.last_error = rel
        self._record(s, int(np.count_nonzero(new)))
        return G

    def _blocks(self, s):
        # blocks of points keep the (n_points, n) work arrays of the modal form in cache
        block = max(256, 2**20 // max(self.sys.n_states, 1))
        if s.size > block:
            parts = [self._at(s[i:i + block]) for i in range(0, s.size, block)]
            return np.concatenate([G for G, _ in parts]), np.concatenate([e for _, e in parts])
        return self._at(s)

    def _record(self, s, n_new: int) -> None:
        self.n_evaluations += n_new
        rel = self.last_error
        if rel.size:
            j = int(np.argmax(np.where(np.isnan(rel), np.inf, rel)))
            if not rel[j] <= self.error:
                self.error, self.worst = float(rel[j]) if not np.isnan(rel[j]) else np.inf, complex(s[j])

    def _at(self, s):
        if self.method == "sparse" or (self.method == "auto" and self.modal is None and self.sys.is_sparse):
            self.used.add("sparse")
            if self._sparse is None and self.sys.n_states:
                self._sparse = _sparse_form(self.sys)
            G, rel = _sparse_eval(self.sys, self._sparse, s)
        elif self.method == "direct":
            self.used.add("direct")
            G, rel = _direct_eval(self.sys, s)
        elif self.method == "hessenberg":
            self.used.add("hessenberg")
            G, rel = self._hessenberg(s)
        elif self.modal is None and self._own_hessenberg:
            self.used.add("hessenberg")
            G, rel = self._hessenberg(s)
        elif self.modal is None:
            self.used.add("schur")
            G, rel = self._triangular(s)
        else:
            G, rounding, inherent = self.modal.evaluate(s)
            rel = rounding + inherent
            self.used.add(self.modal_name)
            # only the modal rounding is what a backward-stable solve can improve on, and only
            # where it dominates the modal estimate: elsewhere the total is at most twice the
            # inherent part, a first-order conditioning bound of the same form as a backward-stable
            # path's (which is often tighter: ||X|| ||Y|| instead of cond(V) sum |K_i| |R_i|^2),
            # and the re-evaluation would cost O(n^2) per point after an O(n^3) form; a point whose
            # modal estimate approaches the warning level is re-checked all the same, so that a
            # warning is issued only when a backward-stable evaluation cannot do better
            # (a state matrix that is Hessenberg already shares no inherent part with its
            # Hessenberg solve, whose componentwise estimate is often far below: every point
            # above rtol is re-checked)
            redo = (np.zeros(len(s), dtype=bool) if self.method != "auto"
                    else ~(rel <= self.rtol) if self._own_hessenberg
                    else ~(rounding <= self.rtol) & (~(rounding <= inherent) | ~(rel <= RECHECK_RTOL)))
            if np.any(redo):
                if self._own_hessenberg:
                    # a state matrix that is Hessenberg already needs no reduction: one banded LU
                    # per point and a componentwise estimate
                    Gh, relh = self._hessenberg(s[redo])
                    self.used.add("hessenberg")
                elif isinstance(self.modal, _BlockModal):
                    Gh, relh = self.modal.stable(s[redo], self._snap_mask if self._snap is not None else None)
                    self.used.add("schur")
                elif isinstance(self.modal, _Modal) and (checked := self.modal.residual_checked(s[redo])) is not None:
                    # the modal value with a residual bound: a few matrix products
                    Gh, relh = checked
                elif self._snap is None and self._schur is None and getattr(self.modal, "schur_form", None) is None:
                    # a Hessenberg reduction costs a fraction of the complex Schur form
                    Gh, relh = self._hessenberg(s[redo])
                    self.used.add("hessenberg")
                else:
                    Gh, relh = self._triangular(s[redo])
                    self.used.add("schur")
                # keep, point by point, the value whose estimate is smaller
                better = ~(relh >= rel[redo])
                idx = np.flatnonzero(redo)[better]
                G[idx], rel[idx] = Gh[better], relh[better]
        return G, rel

    @property
    def label(self) -> str:
        """The paths actually used, joined by ``+``."""
        names = ("second_order_modal", "modal", "schur", "hessenberg", "direct", "sparse")
        return "+".join(m for m in names if m in self.used) or self.method

    def cause(self, s: complex) -> str:
        """Why the evaluation at ``s`` [1/s] is inaccurate, in words."""
        try:
            p = self.poles
        except ModelError:   # a large sparse system: its poles are not computed for a message
            p = np.zeros(0, complex)
        if p.size:
            d = np.abs(p - s)
            i = int(np.argmin(d))
            if d[i] <= 1e-6 * max(abs(s), abs(p[i]), np.finfo(float).tiny):
                return (f"a pole at {complex(p[i]):.6g} lies {d[i]:.2g} from s = {s:.6g}: "
                        f"sI - A is singular to working precision there")
            lo, hi = float(np.min(np.abs(p))), float(np.max(np.abs(p)))
            if hi > 1e8 * max(lo, abs(s)) and lo < 1e3 * abs(s) + hi * 1e-8:
                return (f"the poles span {lo:.2g} to {hi:.2g} rad/s: a slow pole is only known to "
                        f"eps * {hi:.2g} and s = {s:.6g} is close to it")
        return "sI - A is ill conditioned there (non-normal A or nearly cancelling pole and zero)"

    def warn_if_inaccurate(self, what: str, threshold: float = WARN_RTOL, stacklevel: int = 3) -> None:
        """Issue an :class:`~linflex.AccuracyWarning` when ``error`` exceeds ``threshold``."""
        if self.error > threshold:
            w = self.worst
            where = f"omega = {w.imag:.6g} rad/s" if w.real == 0 else f"s = {w:.6g}"
            warnings.warn(
                f"{what}: the evaluation at {where} has an estimated relative error of {self.error:.2g} "
                f"(cause: {self.cause(w)})",
                AccuracyWarning, stacklevel=stacklevel,
            )
