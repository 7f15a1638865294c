"""Reference for the property corpus: zeros of small rational systems in exact arithmetic.

:func:`exact_zeros`: the numerator ``det [[sI - A, -B], [C, D]]`` in ``fractions.Fraction``
(Faddeev-LeVerrier), split into square-free factors (Yun), whose simple roots ``numpy.roots``
gives to the factors' conditioning, with exact multiplicities.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np


def _poly_mul(a, b):
    out = [Fraction(0)] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        if x:
            for j, y in enumerate(b):
                out[i + j] += x * y
    return out


def _poly_add(a, b):
    n = max(len(a), len(b))
    a, b = a + [Fraction(0)] * (n - len(a)), b + [Fraction(0)] * (n - len(b))
    return [x + y for x, y in zip(a, b)]


def _trim(a):
    a = list(a)
    while a and a[-1] == 0:
        a.pop()
    return a


def _poly_divmod(a, b):
    """Polynomials as coefficient lists, lowest degree first."""
    a, b = _trim(a), _trim(b)
    q = [Fraction(0)] * max(len(a) - len(b) + 1, 1)
    r = list(a)
    while len(_trim(r)) >= len(b) and _trim(r):
        r = _trim(r)
        c = r[-1] / b[-1]
        k = len(r) - len(b)
        q[k] = c
        for i, y in enumerate(b):
            r[i + k] -= c * y
        r = _trim(r)
    return _trim(q), _trim(r)


def _poly_gcd(a, b):
    a, b = _trim(a), _trim(b)
    while b:
        _, r = _poly_divmod(a, b)
        a, b = b, r
    return [x / a[-1] for x in a] if a else a


def _poly_deriv(a):
    return [i * x for i, x in enumerate(a)][1:]


def squarefree(f):
    """Yun's algorithm over Q: ``[(factor, multiplicity), ...]`` with ``f = c prod factor^k``."""
    f = _trim(f)
    out = []
    a = _poly_gcd(f, _poly_deriv(f))
    b, _ = _poly_divmod(f, a)
    c, _ = _poly_divmod(_poly_deriv(f), a)
    d = _poly_add(c, [-x for x in _poly_deriv(b)])
    k = 1
    while len(_trim(b)) > 1:
        a = _poly_gcd(b, d)
        if len(a) > 1:
            out.append((a, k))
        b, _ = _poly_divmod(b, a)
        c, _ = _poly_divmod(d, a)
        d = _poly_add(c, [-x for x in _poly_deriv(b)])
        k += 1
    return out


def exact_system_determinant(A, B, C, D):
    """``det [[sI - A, -B], [C, D]]`` of a square system with rational entries, as exact
    coefficients (lowest degree first), by Faddeev-LeVerrier (``adj(sI - A) = sum_k N_k s^(n-1-k)``)
    and ``det = det(C adj(sI - A) B + p(s) D) / p(s)^(m-1)``, ``p = det(sI - A)``."""
    A = [[Fraction(x) for x in row] for row in np.asarray(A).tolist()]
    B = [[Fraction(x) for x in row] for row in np.asarray(B).tolist()]
    C = [[Fraction(x) for x in row] for row in np.asarray(C).tolist()]
    D = [[Fraction(x) for x in row] for row in np.asarray(D).tolist()]
    n, m = len(A), len(B[0])

    def matmul(X, Y):
        return [[sum((X[i][k] * Y[k][j] for k in range(len(Y))), Fraction(0)) for j in range(len(Y[0]))]
                for i in range(len(X))]

    eye = [[Fraction(int(i == j)) for j in range(n)] for i in range(n)]
    # p(s) = s^n + c_{n-1} s^{n-1} + ... ; N_1 = I, N_{k+1} = A N_k + c_{n-k} I
    coeff = [Fraction(0)] * (n + 1)
    coeff[n] = Fraction(1)
    Ns = []
    N = eye
    for k in range(1, n + 1):
        Ns.append(N)
        AN = matmul(A, N)
        c = -sum((AN[i][i] for i in range(n)), Fraction(0)) / k
        coeff[n - k] = c
        N = [[AN[i][j] + (c if i == j else 0) for j in range(n)] for i in range(n)]
    # numerator matrix entries: sum_k (C N_k B) s^(n-k) + D p(s)
    Nmat = [[[Fraction(0)] * (n + 1) for _ in range(m)] for _ in range(m)]
    for k, Nk in enumerate(Ns, start=1):
        CNB = matmul(matmul(C, Nk), B)
        for i in range(m):
            for j in range(m):
                Nmat[i][j][n - k] += CNB[i][j]
    for i in range(m):
        for j in range(m):
            Nmat[i][j] = _poly_add(Nmat[i][j], [D[i][j] * x for x in coeff])
    if m == 1:
        return _trim(Nmat[0][0]), _trim(coeff)
    if m != 2:
        raise ValueError("exact determinant implemented for 1x1 and 2x2 systems")
    det = _poly_add(_poly_mul(Nmat[0][0], Nmat[1][1]), [-x for x in _poly_mul(Nmat[0][1], Nmat[1][0])])
    q, r = _poly_divmod(det, coeff)
    assert not _trim(r)  # p divides det(N) exactly (N = p G)
    return _trim(q), _trim(coeff)


def exact_zeros(A, B, C, D):
    """Roots of the exact numerator with multiplicities: ``[(root, multiplicity), ...]`` and the
    numerator degree; ``None`` when the numerator vanishes identically (no normal rank)."""
    num, _ = exact_system_determinant(A, B, C, D)
    if not num:
        return None
    out = []
    for factor, k in squarefree(num):
        if len(factor) < 2:
            continue
        r = np.roots([float(x) for x in reversed(factor)])
        out.extend((complex(z), k) for z in r)
    return out
