"""Poles, invariant zeros, root gain and Bode form, all without polynomials.

Zeros come from the Rosenbrock system pencil after the structure-revealing reduction of
Emami-Naeini and Van Dooren (1982), which removes the infinite and singular part of the pencil by
orthogonal row and column compressions (Householder reflections, O(n^2) per output removed), so
that no infinite eigenvalue has to be recognised by a threshold afterwards: the zeros are the
eigenvalues of one standard problem ``A - B D^-1 C`` of the reduced system when it is as well
scaled as the system (the common case), else the generalized eigenvalues of the reduced pencil. The classic lambda-shift method of the
DISCOS report (reference notes, section 7.3) is kept as an independent SISO path and test oracle.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import ConvergenceError, ModelError, as_linear_system
from linflex.system import check_positive

__all__ = ["ZPK", "BodeForm", "poles", "zeros", "zpk", "lambda_shift_zpk", "bode_form"]

_EPS = np.finfo(float).eps


def _sort_roots(r: NDArray) -> NDArray[np.complex128]:
    r = np.asarray(r, dtype=complex)
    order = np.lexsort((r.imag, np.round(np.abs(r), 12)))
    out = r[order]
    out.setflags(write=False)
    return out


def poles(sys) -> NDArray[np.complex128]:
    """Poles of a linear system: the eigenvalues of ``A`` [1/s].

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
        Continuous or discrete (poles in ``z``, stable inside the unit circle), with or without
        delays: a continuous delay ``exp(-s tau)`` has no poles; a discrete delay of ``k``
        periods, ``z^-k``, adds ``k`` poles at ``z = 0``.

    Returns
    -------
    numpy.ndarray of complex, shape (n_states,)
        Eigenvalues [1/s] (dimensionless ``z`` for a discrete system) sorted by modulus, then
        imaginary part; read-only.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> poles(LinearSystem([[0, 1], [-4, 0]], [[0], [1]], [[1, 0]])).round(6).tolist()
    [-2j, 2j]
    """
    sys = _rational(as_linear_system(sys, "sys", discrete=True, delay=True))
    if sys.n_states == 0:
        return _sort_roots(np.zeros(0))
    return _sort_roots(scipy.linalg.eigvals(sys.A, check_finite=False))


def _rational(sys):
    """The rational part whose roots are the system's: a continuous delay has no poles or zeros,
    a discrete one is the exact shift register ``z^-k``."""
    if not sys.has_delay:
        return sys
    if sys.is_discrete:
        from linflex import pade

        return pade(sys, 1).sys
    return sys.with_(input_delay=None, output_delay=None)


def _balance(A, B, C, D):
    """Scale states (a diagonal similarity), inputs and outputs so that the system matrix is
    balanced; none of these changes the invariant zeros, and they make the rank decisions of the
    compressions meaningful for badly scaled states.

    LAPACK ``gebal`` (no permutation) is applied to the square padding of the system matrix::

        [A  B  0]   (n + q) x (n + q), q = max(m, p): the scale of index n + i acts on input i
        [C  D  0]   (columns) and on output i (rows), which is an admissible scaling of both.
        [0  0  0]
    """
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    q = max(m, p)
    if n + q == 0:
        return A, B, C, D
    S = np.zeros((n + q, n + q))
    S[:n, :n], S[:n, n:n + m], S[n:n + p, :n], S[n:n + p, n:n + m] = A, B, C, D
    _, (scale, _) = scipy.linalg.matrix_balance(S, permute=False, separate=True)
    ts, io = scale[:n], scale[n:]
    A = A * (1.0 / ts)[:, None] * ts[None, :]
    B = B * (1.0 / ts)[:, None] * io[None, :m]
    C = C * (1.0 / io[:p])[:, None] * ts[None, :]
    D = D * (1.0 / io[:p])[:, None] * io[None, :m]
    return A, B, C, D


def _reflect(h, tau, X, side: str):
    """``Q^T X`` (``side="L"``) or ``X Q`` (``side="R"``) for the Householder product
    ``Q = H_1 ... H_k`` stored by ``geqrf`` in ``(h, tau)`` (LAPACK ``dormqr``): O(n^2 k) for an
    n x n ``X``, no n x n orthogonal matrix formed."""
    X = np.asarray(X, dtype=float)
    if X.size == 0:
        return X.copy()
    trans = "T" if side == "L" else "N"
    dormqr = scipy.linalg.lapack.dormqr
    work = dormqr(side, trans, h, tau, X, -1)[1]
    out, _, info = dormqr(side, trans, h, tau, X, max(int(work[0]), 1))
    if info != 0:  # pragma: no cover - an argument error of the wrapper, not of the data
        raise ConvergenceError(f"zeros: LAPACK dormqr failed (info {info})")
    return out


def _reduce(A, B, C, D, tol):
    """One pass of the Emami-Naeini/Van Dooren reduction: returns a system with the same finite
    invariant zeros whose ``D`` has full row rank.

    Each step compresses the rows of ``D``; the rows of ``[C2 0]`` left over say that
    ``C2 x = 0`` on a zero direction. Rotating the state so that ``C2 V = [Cbar  0]`` with
    ``Cbar`` of full column rank forces ``x1 = 0``; the equation of ``x1`` then becomes an
    output constraint ``0 = A12 x2 + B1 u``::

        [A11 - sI  A12       B1]      new A = A22, new B = B2
        [A21       A22 - sI  B2]  ->  new C = [C12; A12]
        [0         C12       D1]      new D = [D1 ; B1 ]
        [Cbar      0         0 ]

    ``V`` is the product of ``nu = rank C2`` Householder reflections (``V^T A V`` costs
    O(n^2 nu), not a full n x n similarity), so a step of a system with few outputs costs a few
    matrix-vector products' worth of O(n^2) work.
    """
    while True:
        n = A.shape[0]
        p, m = D.shape
        if p == 0:
            return A, B, C, D
        if D.size:
            U, s, _ = np.linalg.svd(D)
        else:
            U, s = np.eye(p), np.zeros(0)
        rho = int(np.sum(s > tol))
        CD = U.T @ np.hstack([C, D])
        C1, D1, C2 = CD[:rho, :n], CD[:rho, n:], CD[rho:, :n]
        if rho == p or n == 0:
            return A, B, C1, D1
        _, s2, V2h = np.linalg.svd(C2, full_matrices=False)
        nu = int(np.sum(s2 > tol))
        if nu == 0:
            return A, B, C1, D1
        # V = H_1 ... H_nu: its first nu columns span the row space of C2, the others its kernel
        (h, tau), _ = scipy.linalg.qr(V2h[:nu].T, mode="raw", check_finite=False)
        At = _reflect(h, tau, _reflect(h, tau, A, "L"), "R")
        Bt, Ct = _reflect(h, tau, B, "L"), _reflect(h, tau, C1, "R")
        A, B, C, D = At[nu:, nu:], Bt[nu:], np.vstack([Ct[:, nu:], At[:nu, nu:]]), np.vstack([D1, Bt[:nu]])


#: The zeros of the reduced system with invertible feedthrough are the eigenvalues of the
#: standard problem ``A - B D^-1 C`` when that matrix is at most this times the system matrix in
#: norm: LAPACK's eigenvalues are exact for ``A - B D^-1 C + E``, ``||E|| <= c eps ||A - B D^-1 C||``,
#: which is a perturbation of ``A`` of the system (the orthogonal reduction maps it back unchanged
#: in norm), so the zeros keep the backward error of the generalized (QZ) path to within this
#: factor. Above it (a nearly singular ``D``: zeros escaping to infinity) the QZ path is used.
_STANDARD_GROWTH = 1e2


def _finite_pencil_zeros(A, B, C, D):
    """Finite zeros of a reduced square system with invertible ``D`` from the regular pencil of
    a column compression (QZ, LAPACK ``ggev``): ``[C D] W = [0 Dr]`` with ``Dr`` invertible; the
    leading n columns of ``[A - sI, B] W`` form a regular n x n pencil of the zeros."""
    n, p = A.shape[0], D.shape[0]
    _, _, Vh = np.linalg.svd(np.hstack([C, D]))
    W = np.hstack([Vh[p:].T, Vh[:p].T])
    Af = (np.hstack([A, B]) @ W)[:, :n]
    Ef = W[:n, :n]
    alpha, beta = scipy.linalg.eigvals(Af, Ef, homogeneous_eigvals=True, check_finite=False)
    finite = np.abs(beta) > _EPS * n * np.abs(alpha)
    return alpha[finite] / beta[finite]


def _invariant_zeros(A, B, C, D) -> NDArray[np.complex128]:
    A, B, C, D = _balance(A, B, C, D)
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    scale = max(np.linalg.norm(np.block([[A, B], [C, D]])) if (n + p) * (n + m) else 0.0, 1e-300)
    tol = _EPS * max(n + p, n + m, 1) * scale
    A, B, C, D = _reduce(A, B, C, D, tol)
    At, Bt, Ct, Dt = _reduce(A.T, C.T, B.T, D.T, tol)
    A, B, C, D = At.T, Ct.T, Bt.T, Dt.T
    n, (p, m) = A.shape[0], D.shape
    if p != m:
        raise ConvergenceError(
            f"zeros: the pencil reduction ended with a {p}x{m} feedthrough instead of a square one; "
            f"the rank decisions failed (tolerance {tol:.3g})"
        )
    if n == 0:
        return np.zeros(0, dtype=complex)
    if p == 0:
        return scipy.linalg.eigvals(A, check_finite=False)
    # a-posteriori: the standard problem is used only if the matrix actually formed is of the
    # system's size (its eigenvalues' backward error is eps times its norm)
    try:
        with np.errstate(all="ignore"):
            M = A - B @ np.linalg.solve(D, C)
        growth = np.linalg.norm(M) / scale
    except np.linalg.LinAlgError:  # D singular to working precision after all
        growth = np.inf
    if np.isfinite(growth) and growth <= _STANDARD_GROWTH:
        return scipy.linalg.eigvals(M, check_finite=False)
    return _finite_pencil_zeros(A, B, C, D)


def _lapack_hseqr():
    """LAPACK ``dhseqr`` (eigenvalues of a Hessenberg matrix, no reduction) from SciPy's own
    LAPACK (``scipy.linalg.cython_lapack``), or None where it cannot be reached; SciPy does not
    wrap it for Python, and ``eigvals`` of a Hessenberg matrix would reduce it once more."""
    import ctypes

    try:
        from scipy.linalg import cython_lapack

        capsule = cython_lapack.__pyx_capi__["dhseqr"]
        # private prototypes: the shared ctypes.pythonapi entries are left as they are
        name = ctypes.PYFUNCTYPE(ctypes.c_char_p, ctypes.py_object)(("PyCapsule_GetName", ctypes.pythonapi))
        pointer = ctypes.PYFUNCTYPE(ctypes.c_void_p, ctypes.py_object, ctypes.c_char_p)(
            ("PyCapsule_GetPointer", ctypes.pythonapi))
        address = pointer(capsule, name(capsule))
    except (ImportError, AttributeError, KeyError, TypeError, ValueError, OSError):
        return None
    i, d = ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_double)
    return ctypes.CFUNCTYPE(None, ctypes.c_char_p, ctypes.c_char_p, i, i, i, d, i, d, d, d, i, d, i, i)(address)


_HSEQR = _lapack_hseqr()


def _hessenberg_eigvals(H, scale: float) -> NDArray[np.complex128]:
    """Eigenvalues of an upper Hessenberg matrix by the QR algorithm on it directly (``dhseqr``),
    about a quarter of ``eigvals`` of a full matrix; diagonally balanced first (which keeps the
    form) only when its norm exceeds ``_STANDARD_GROWTH * scale``, the size of the system it
    comes from (balancing costs a few passes over the matrix)."""
    import ctypes

    n = H.shape[0]
    if n == 0:
        return np.zeros(0, dtype=complex)
    if not np.linalg.norm(H) <= _STANDARD_GROWTH * scale:
        H = scipy.linalg.matrix_balance(H, permute=False, separate=True)[0]
    if _HSEQR is None:
        return scipy.linalg.eigvals(H, check_finite=False)
    h = np.array(H, dtype=float, order="F")
    wr, wi, z, work = np.zeros(n), np.zeros(n), np.zeros(1), np.zeros(max(1, 11 * n))
    c_int, d = ctypes.c_int, ctypes.POINTER(ctypes.c_double)
    size, one, ldz, lwork, info = c_int(n), c_int(1), c_int(1), c_int(work.size), c_int(0)
    _HSEQR(b"E", b"N", ctypes.byref(size), ctypes.byref(one), ctypes.byref(size), h.ctypes.data_as(d),
           ctypes.byref(size), wr.ctypes.data_as(d), wi.ctypes.data_as(d), z.ctypes.data_as(d), ctypes.byref(ldz),
           work.ctypes.data_as(d), ctypes.byref(lwork), ctypes.byref(info))
    if info.value != 0:
        raise ConvergenceError(f"LAPACK dhseqr: the QR algorithm did not converge (info {info.value})")
    return wr + 1j * wi


def loop_roots(A, b, c, d) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Closed-loop poles (of ``1 / (1 + L)``) and invariant zeros of a single loop ``L = (A, b, c, d)``
    [1/s], from one orthogonal Hessenberg reduction.

    The balanced bordered matrix ``[[0, c], [b, A]]`` reduced to Hessenberg form by reflections
    that leave its first row and column in place gives ``Q^T b = beta e_1``, ``c Q`` and
    ``H = Q^T A Q`` upper Hessenberg (the controller-Hessenberg form). Then

    - the closed-loop matrix ``H - beta e_1 (c Q) / (1 + d)`` differs from ``H`` in its first row
      only: it is Hessenberg, and its eigenvalues come without a second reduction;
    - the zeros: with ``d != 0``, the eigenvalues of ``H - beta e_1 (c Q) / d`` (Hessenberg); with
      ``d = 0``, the first state equation only defines ``u``, the output row ``c Q x = 0`` then
      fixes ``x_1``, so that the zeros are the eigenvalues of the trailing Hessenberg block
      ``H[1:, 1:] - H[1, 0] e_1 (cQ)[1:] / (cQ)[0]``; while ``(cQ)[0]`` vanishes (relative degree
      above 1) ``x_1`` is the input of the trailing system ``(H[1:, 1:], H[1, 0] e_1, (cQ)[1:])``,
      one step per degree. The decisions are those of :func:`_invariant_zeros` (the Markov
      parameter against ``eps (n + 1) ||S||_F``), and that general reduction is used instead
      whenever the last matrix grows beyond ``_STANDARD_GROWTH`` times the system matrix or the
      input stops reaching the remaining states.

    Parameters
    ----------
    A, b, c, d : array_like
        The loop: ``(n, n)``, ``(n, 1)``, ``(1, n)``, ``(1, 1)``; ``1 + d`` must be invertible.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray) of complex
        The ``n`` eigenvalues of ``A - b c / (1 + d)`` [1/s] and the finite zeros [1/s].
    """
    A, B, C, D = (np.asarray(x, dtype=float) for x in (A, b, c, d))
    n = A.shape[0]
    if n == 0:
        return np.zeros(0, dtype=complex), np.zeros(0, dtype=complex)
    Ab, Bb, Cb, Db = _balance(A, B, C, D)
    scale = max(float(np.linalg.norm(np.block([[Ab, Bb], [Cb, Db]]))), 1e-300)
    tol = _EPS * (n + 1) * scale
    bordered = np.zeros((n + 1, n + 1))
    bordered[0, 1:], bordered[1:, 0], bordered[1:, 1:] = Cb[0], Bb[:, 0], Ab
    F = scipy.linalg.hessenberg(bordered, check_finite=False)
    beta, ct, H = F[1, 0], F[0, 1:], F[1:, 1:]
    dd = float(Db[0, 0])
    Hcl = H.copy()
    Hcl[0] -= beta * ct / (1.0 + dd)
    cl_poles = _hessenberg_eigvals(Hcl, scale)

    def general():
        return _invariant_zeros(A, B, C, D)

    if abs(dd) > tol:
        Z = H.copy()
        Z[0] -= beta * ct / dd
    else:
        while True:
            if abs(beta) <= tol:
                return cl_poles, general()
            nc = float(np.linalg.norm(ct))
            if nc <= tol:
                return cl_poles, general()
            if abs(ct[0] * beta) > tol * nc:
                break
            if H.shape[0] == 1:
                return cl_poles, general()
            beta, ct, H = H[1, 0], ct[1:], H[1:, 1:]
        if H.shape[0] == 1:
            return cl_poles, np.zeros(0, dtype=complex)
        Z = H[1:, 1:].copy()
        Z[0] -= H[1, 0] * ct[1:] / ct[0]
    if not np.linalg.norm(Z) <= _STANDARD_GROWTH * scale:
        return cl_poles, general()
    return cl_poles, _hessenberg_eigvals(Z, scale)


def zeros(sys) -> NDArray[np.complex128]:
    """Invariant zeros of a linear system (MIMO and non-square included) [1/s].

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
        Continuous or discrete (zeros in ``z``), with or without delays (a continuous delay has
        no zeros; a discrete one is realized exactly as ``z^-k``).

    Returns
    -------
    numpy.ndarray of complex
        The finite values ``s`` (or ``z``) at which the system matrix
        ``[[A - sI, B], [C, D]]`` loses rank below its normal rank, sorted by modulus; read-only.
        For a minimal system these are the transmission zeros; uncontrollable or unobservable
        modes appear as (decoupling) zeros too.

    Notes
    -----
    States are balanced (LAPACK ``gebal``) and inputs/outputs scaled to unit norm; then the
    reduction of Emami-Naeini and Van Dooren (Automatica 18, 1982, 415-430), applied to the
    system and to its dual, yields a system with invertible feedthrough ``D``: each step is a
    product of Householder reflections (O(n^2) work per output removed, so a relative degree
    ``r`` costs about ``r`` such steps, not ``r`` full similarities). The zeros are then the
    eigenvalues of the standard problem ``A - B D^-1 C`` of order ``n - (number of zeros at
    infinity)``, eigenvalues only, when that matrix, as formed, is at most
    ``_STANDARD_GROWTH = 100`` times the system matrix in norm (its eigenvalues' backward error,
    ``eps`` times its norm, is a perturbation of ``A``, so the zeros keep within that factor the
    backward error of the generalized problem); otherwise a final column compression gives a
    regular pencil whose generalized eigenvalues (QZ, ``scipy.linalg.eigvals(A, B)``) are the
    finite zeros. Rank decisions use ``eps * max(n+p, n+m) * ||S||_F``.
    A system whose transfer matrix has no full normal rank (for example a SISO system whose
    input does not reach its output) has no invariant zeros in this sense; the result then
    holds only the values where the rank drops further, often none.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> sys = LinearSystem([[-1, 0], [0, -2]], [[1], [1]], [[1, 1]])   # (2s+3)/((s+1)(s+2))
    >>> zeros(sys).real.round(6).tolist()
    [-1.5]
    """
    from ._checks import checked_system

    sys = _rational(checked_system(sys, "sys", discrete=True, delay=True))
    return _sort_roots(_invariant_zeros(sys.A, sys.B, sys.C, sys.D))


@dataclass(frozen=True)
class ZPK:
    """A SISO transfer function ``k * prod(s - z) / prod(s - p)``.

    Attributes
    ----------
    zeros, poles : numpy.ndarray of complex
        Finite zeros and poles [1/s].
    gain : float
        Root gain ``k`` (the leading coefficient of the numerator over a monic denominator)
        [output units per input unit times s^-relative_degree].
    relative_degree : int
        ``len(poles) - len(zeros)``.
    method : str
        ``"pencil"`` or ``"lambda_shift"``.
    gain_error : float
        Estimated absolute error of ``gain``, in its units (the imaginary part left when the gain is recovered
        from a complex evaluation point, or the spread between two estimates).
    output, input : str
        Names of the channel.
    """

    zeros: NDArray[np.complex128]
    poles: NDArray[np.complex128]
    gain: float
    relative_degree: int
    method: str
    gain_error: float
    output: str
    input: str

    def evaluate(self, s) -> NDArray[np.complex128]:
        """The factored form at complex ``s`` (array_like), summed in logarithms (notes 8.2).

        Parameters
        ----------
        s : array_like of complex
            Laplace variable [1/s]; ``s = 1j * omega`` with ``omega`` [rad/s] for the frequency
            response.

        Returns
        -------
        ndarray of complex, shape of ``s``
            ``k prod(s - z) / prod(s - p)`` [output units per input unit].
        """
        s = np.asarray(s, dtype=complex)
        if self.gain == 0:
            return np.zeros_like(s)
        logv = np.log(complex(self.gain)) + np.zeros_like(s)
        for z in self.zeros:
            logv = logv + np.log(s - z)
        for p in self.poles:
            logv = logv - np.log(s - p)
        return np.exp(logv)


def _siso(sys, output, input):
    sys = as_linear_system(sys, "sys")
    if output is None and input is None:
        if sys.shape != (1, 1):
            raise ModelError(
                f"sys has {sys.n_outputs} outputs and {sys.n_inputs} inputs; a SISO function needs "
                "one of each: pass output= and input= to choose a channel"
            )
        return sys
    for given, other, count, what in ((output, input, sys.n_inputs, "input"), (input, output, sys.n_outputs, "output")):
        if given is not None and other is None and count != 1:
            raise ModelError(f"sys has {count} {what}s: pass {what}= too to choose the channel (the "
                             f"{'output' if what == 'input' else 'input'} alone does not)")
    return sys.subsystem(
        inputs=[input if input is not None else 0] if sys.n_inputs != 1 or input is not None else None,
        outputs=[output if output is not None else 0] if sys.n_outputs != 1 or output is not None else None,
    )


def _evaluation_point(roots, A) -> complex:
    """A complex point of the spectral scale, away from every root."""
    scale = max(np.max(np.abs(roots)) if roots.size else 0.0, np.linalg.norm(A, 1) if A.size else 0.0, 1.0)
    s0 = scale * (0.73 + 0.41j)
    for factor in (1.0, 0.37, 2.9, 0.11, 7.3):
        cand = s0 * factor
        if not roots.size or np.min(np.abs(cand - roots)) > 1e-3 * abs(cand):
            return cand
    return s0


def _gain_at(sys, z, p) -> tuple[float, float]:
    """Root gain from one evaluation of the transfer function at a complex point."""
    s0 = _evaluation_point(np.concatenate([z, p]), sys.A)
    n = sys.n_states
    g = sys.D[0, 0] + (sys.C @ np.linalg.solve(s0 * np.eye(n) - sys.A, sys.B))[0, 0] if n else sys.D[0, 0]
    if g == 0:
        return 0.0, 0.0
    logk = np.log(complex(g)) + np.sum(np.log(s0 - p)) - np.sum(np.log(s0 - z))
    k = np.exp(logk)
    return float(k.real), float(abs(k.imag))


def zpk(sys, *, output=None, input=None) -> ZPK:
    """Poles, zeros and root gain of a SISO channel, from pencils (no polynomial).

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
    output, input : str or int, optional
        The channel; required when ``sys`` is not SISO.

    Returns
    -------
    ZPK
        With ``method="pencil"``. Poles are the eigenvalues of ``A`` (all of them: no
        cancellation is performed, so uncontrollable or unobservable modes appear both as a pole
        and as a zero).

    Raises
    ------
    ModelError
        If the system is not SISO and no channel is given (or only ``output`` with several
        inputs, only ``input`` with several outputs), or a channel name is unknown.

    Notes
    -----
    The root gain comes from one evaluation of ``G(s0) = D + C (s0 I - A)^-1 B`` at a complex
    point ``s0`` of the spectral scale away from every root:
    ``k = G(s0) prod(s0 - p) / prod(s0 - z)``, in logarithms. The imaginary part of the result is
    reported as ``gain_error``; the first non-zero Markov parameter ``C A^(r-1) B`` is the
    classic cross-check used in the tests.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> z = zpk(LinearSystem([[-1, 0], [0, -2]], [[1], [1]], [[1, 1]]))
    >>> round(z.gain, 9), z.relative_degree
    (2.0, 1)
    """
    sys = _siso(sys, output, input)
    p = np.asarray(poles(sys))
    z = np.asarray(zeros(sys))
    k, kerr = _gain_at(sys, z, p)
    if k == 0:
        z = np.zeros(0, dtype=complex)
    return ZPK(
        zeros=_sort_roots(z), poles=_sort_roots(p), gain=k, relative_degree=len(p) - len(z),
        method="pencil", gain_error=kerr, output=sys.outputs[0], input=sys.inputs[0],
    )


def _relative_degree(A, b, c, d, tol_rel=1e3) -> int | None:
    """Smallest r with c A^(r-1) b != 0 (r = 0 when d != 0); None when the channel is zero.

    Each Markov parameter is compared with ``tol_rel * eps * ||c|| ||A||^(r-1) ||b||``, with the
    vector renormalised at each step so that nothing overflows (notes 7.3)."""
    n = A.shape[0]
    nb, nc = np.linalg.norm(b), np.linalg.norm(c)
    if abs(d) > tol_rel * _EPS * max(nb * nc, abs(d)):
        return 0
    if nb == 0 or nc == 0:
        return None
    normA = max(np.linalg.norm(A, 2), 1e-300)
    v = b / nb
    for r in range(1, n + 1):
        if abs(c @ v) > tol_rel * _EPS * n * nc * np.linalg.norm(v):
            return r
        v = (A @ v) / normA
        if not np.any(v):
            return None
    return None


def lambda_shift_zpk(sys, *, output=None, input=None, lam: complex | None = None) -> ZPK:
    """Zeros and root gain of a SISO channel by the lambda-shift method (DISCOS, III-39 to III-48).

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
    output, input : str or int, optional
        The channel; required when ``sys`` is not SISO.
    lam : complex, optional
        The shift [1/s]; default ``||A||_1 (0.73 + 0.41j)``. The zeros do not depend on it.

    Returns
    -------
    ZPK
        With ``method="lambda_shift"``.

    Raises
    ------
    ModelError
        If the system is not SISO and no channel is given, or ``lam`` is not a finite complex
        number.
    ConvergenceError
        If ``Ahat - lam Itilde`` is singular to working precision for every shift tried.

    Notes
    -----
    With the bordered numerator ``N(s) = det([[sI - A, b], [-c, d]]) = det(s Itilde - Ahat)``,
    ``Itilde = diag(I, 0)`` and ``Ahat = [[A, -b], [c, -d]]``, the eigenvalues ``mu`` of
    ``W = (Ahat - lam Itilde)^-1 Itilde`` give the zeros ``z = lam + 1/mu``. Exactly ``r + 1``
    of the ``n + 1`` values ``mu`` vanish (``r`` the relative degree); the ``n - r`` largest in
    modulus are kept (a structural count, not a threshold: reference notes 7.3), and
    ``k_R = (-1)^nz prod(mu) det(lam Itilde - Ahat)``.

    Examples
    --------
    ``1/(s + 1) + 1/(s + 2) = (2 s + 3) / ((s + 1)(s + 2))``: one zero at -1.5, root gain 2.

    >>> from linflex import LinearSystem
    >>> from linflex.frequency import lambda_shift_zpk
    >>> z = lambda_shift_zpk(LinearSystem([[-1, 0], [0, -2]], [[1], [1]], [[1, 1]]))
    >>> [round(float(s.real), 6) for s in z.zeros], round(z.gain, 9), z.method
    ([-1.5], 2.0, 'lambda_shift')
    """
    sys = _siso(sys, output, input)
    if lam is not None:
        try:
            shift = complex(lam)
        except (TypeError, ValueError) as err:
            raise ModelError(f"lam must be a complex number [1/s], got {lam!r}") from err
        if not np.isfinite(shift):
            raise ModelError(f"lam must be a finite complex number [1/s], got {lam!r}")
        lam = shift
    A, b, c, d = sys.A, sys.B[:, 0], sys.C[0], float(sys.D[0, 0])
    n = A.shape[0]
    p = np.asarray(poles(sys))
    r = _relative_degree(A, b, c, d)
    if r is None:
        return ZPK(_sort_roots(np.zeros(0)), _sort_roots(p), 0.0, n, "lambda_shift", 0.0,
                   sys.outputs[0], sys.inputs[0])
    nz = n - r
    Ahat = np.block([[A, -b[:, None]], [c[None, :], -np.array([[d]])]])
    Itilde = np.diag(np.r_[np.ones(n), 0.0])
    base = max(np.linalg.norm(A, 1), 1.0)
    shifts = [lam] if lam is not None else [base * f for f in (0.73 + 0.41j, -0.31 + 1.17j, 1.9 - 0.6j)]
    for lam_ in shifts:
        M = Ahat - lam_ * Itilde
        with warnings.catch_warnings():
            # an exactly singular M is detected from the pivots just below
            warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
            lu = scipy.linalg.lu_factor(M, check_finite=False)
        piv = np.abs(np.diag(lu[0]))
        if np.min(piv) <= 1e3 * _EPS * (n + 1) * np.max(piv):
            continue
        W = scipy.linalg.lu_solve(lu, Itilde.astype(complex), check_finite=False)
        mu = scipy.linalg.eigvals(W, check_finite=False)
        mu = mu[np.argsort(-np.abs(mu))][:nz]
        z = lam_ + 1.0 / mu
        # k = (-1)^nz prod(mu) det(lam I~ - A^), det(lam I~ - A^) = (-1)^(n+1) det(M), all in
        # logarithms because the products over- or underflow at orders in the hundreds.
        sign = (-1.0) ** (nz + n + 1 + int(np.sum(lu[1] != np.arange(n + 1))))
        k = sign * np.exp(np.sum(np.log(mu.astype(complex))) + np.sum(np.log(np.diag(lu[0]).astype(complex))))
        # Real system: conjugate zeros pair up exactly; symmetrise the round-off.
        z = np.where(np.abs(z.imag) <= 1e-12 * np.maximum(np.abs(z), 1e-300), z.real, z)
        return ZPK(_sort_roots(z), _sort_roots(p), float(k.real), r, "lambda_shift", float(abs(k.imag)),
                   sys.outputs[0], sys.inputs[0])
    raise ConvergenceError(f"lambda_shift_zpk: Ahat - lam Itilde is singular for every shift tried {shifts}")


@dataclass(frozen=True)
class BodeForm:
    """A SISO transfer function in Bode form (reference notes 8.1)::

        T(s) = gain / s^n_integrators * prod(1 + tau s) prod(1 + 2 zeta s/w + s^2/w^2)
                                        / (same for the poles)

    Attributes
    ----------
    gain : float
        Bode gain ``k_B = k_R prod(-z) / prod(-p)`` over the non-zero roots (units of the output
        over the input times s^n_integrators).
    n_integrators : int
        Poles at the origin minus zeros at the origin (negative for differentiators).
    zero_time_constants, pole_time_constants : numpy.ndarray
        ``tau = -1/r`` [s] for each non-zero real root (negative for right-half-plane roots).
    zero_frequencies, pole_frequencies : numpy.ndarray
        ``omega = |r|`` [rad/s] of each complex pair.
    zero_damping, pole_damping : numpy.ndarray
        ``zeta = -Re(r)/|r|`` [-] of each complex pair, in the order of the frequencies.
    """

    gain: float
    n_integrators: int
    zero_time_constants: NDArray[np.float64]
    zero_frequencies: NDArray[np.float64]
    zero_damping: NDArray[np.float64]
    pole_time_constants: NDArray[np.float64]
    pole_frequencies: NDArray[np.float64]
    pole_damping: NDArray[np.float64]

    def evaluate(self, s) -> NDArray[np.complex128]:
        """The Bode form at complex ``s`` (array_like).

        Parameters
        ----------
        s : array_like of complex
            Laplace variable [1/s]; ``s = 1j * omega`` with ``omega`` [rad/s] for the frequency
            response.

        Returns
        -------
        ndarray of complex, shape of ``s``
            ``T(s)`` [output units per input unit].
        """
        s = np.asarray(s, dtype=complex)
        v = self.gain / s**self.n_integrators
        for tau in self.zero_time_constants:
            v = v * (1 + tau * s)
        for w, zeta in zip(self.zero_frequencies, self.zero_damping):
            v = v * (1 + 2 * zeta * s / w + (s / w) ** 2)
        for tau in self.pole_time_constants:
            v = v / (1 + tau * s)
        for w, zeta in zip(self.pole_frequencies, self.pole_damping):
            v = v / (1 + 2 * zeta * s / w + (s / w) ** 2)
        return v


def _factor_roots(roots, tiny):
    """Split roots into (#at origin, time constants, (frequencies, damping)) of the Bode form."""
    roots = np.asarray(roots, dtype=complex)
    at_origin = np.abs(roots) <= tiny
    rest = roots[~at_origin]
    real = np.abs(rest.imag) <= 1e-9 * np.abs(rest)
    taus = np.sort(-1.0 / rest[real].real)
    upper = rest[~real & (rest.imag > 0)]
    lower = rest[~real & (rest.imag < 0)]
    if len(upper) != len(lower):
        raise ModelError("bode_form: complex roots do not come in conjugate pairs (a complex system?)")
    w = np.abs(upper)
    zeta = -upper.real / w
    order = np.argsort(w)
    return int(np.sum(at_origin)), taus, w[order], zeta[order]


def bode_form(sys, *, output=None, input=None, origin_tol: float = 1e-6) -> BodeForm:
    """Bode form (gain, integrators, time constants, natural frequencies, damping) of a SISO channel.

    Parameters
    ----------
    sys : ZPK, LinearSystem, SecondOrderSystem or control.StateSpace
        A :class:`ZPK` is used as is; a system goes through :func:`zpk` first.
    output, input : str or int, optional
        The channel of a system that is not SISO.
    origin_tol : float, optional
        Roots with modulus below ``origin_tol`` times the largest root modulus count as roots at
        the origin. A rigid-body double pole splits under round-off into a pair of modulus
        about ``sqrt(eps)`` times the spectral scale (a triple one into ``eps^(1/3)``), hence the
        default ``1e-6``.

    Returns
    -------
    BodeForm

    Raises
    ------
    ModelError
        If the system is not SISO and no channel is given, or ``origin_tol`` is not a
        non-negative finite number.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> bf = bode_form(LinearSystem([[0, 1], [0, -2]], [[0], [1]], [[1, 0]]))   # 1/(s(s+2))
    >>> bf.n_integrators, round(bf.gain, 9), bf.pole_time_constants.round(9).tolist()
    (1, 0.5, [0.5])
    """

    origin_tol = check_positive(origin_tol, "origin_tol", allow_zero=True)
    z = sys if isinstance(sys, ZPK) else zpk(sys, output=output, input=input)
    allr = np.concatenate([z.zeros, z.poles])
    scale = float(np.max(np.abs(allr))) if allr.size else 1.0
    tiny = origin_tol * max(scale, 1e-300)
    nz0, ztau, zw, zzeta = _factor_roots(z.zeros, tiny)
    np0, ptau, pw, pzeta = _factor_roots(z.poles, tiny)
    nzr = z.zeros[np.abs(z.zeros) > tiny]
    npr = z.poles[np.abs(z.poles) > tiny]
    # In logarithms: a product over hundreds of roots over- or underflows.
    logk = np.log(complex(z.gain)) + np.sum(np.log(-nzr)) - np.sum(np.log(-npr)) if z.gain else None
    gain = float(np.exp(logk).real) if logk is not None else 0.0
    arrays = [np.asarray(a, dtype=float) for a in (ztau, zw, zzeta, ptau, pw, pzeta)]
    for a in arrays:
        a.setflags(write=False)
    return BodeForm(gain, np0 - nz0, *arrays)
