"""Exponential integrator for oscillatory models: the linear part exact, the remainder by Runge-Kutta.

``x' = f(x, u, t)`` with ``u`` held on each piece is split about a frozen Jacobian ``J`` (the
model's exact ``df/dx`` at some point of the run): ``x' = J x + N(x, t)``, ``N = f - J x``.
The linear part is integrated exactly by matrix functions of ``h J``
(``phi_k(z) = sum_j z^j / (j + k)!``), the remainder by Krogstad's fourth-order exponential
Runge-Kutta scheme (S. Krogstad, "Generalized integrating factor methods for stiff PDEs",
J. Comput. Phys. 203 (2005) 72-88; its tableau as in M. Hochbruck and A. Ostermann,
"Exponential integrators", Acta Numerica 19 (2010) 209-286, section 2.3) with
``c = 0, 1/2, 1/2, 1``:

    a  = e^{hJ/2} x + (h/2) phi_1(hJ/2) N(x)
    b  = a + h phi_2(hJ/2) (N(a) - N(x))
    c  = e^{hJ} x + h phi_1(hJ) N(x) + 2 h phi_2(hJ) (N(b) - N(x))
    x+ = e^{hJ} x + h phi_1(hJ) N(x) + h (2 phi_2 - 4 phi_3)(N(a) + N(b) - 2 N(x))
         + h (4 phi_3 - phi_2)(N(c) - N(x))

Fast eigenvalues: where ``J`` has eigenvalues with ``|lambda| h > 10`` (:data:`_FAST`; an undamped
mode far above what the step resolves, as the axial modes of the solar arrays of
``benchmarks/simulation.py``, 278 rad/s at steps of 0.1 s), Krogstad's stages are poor on those
coordinates: ``a``'s fast part is the quasi-static response to ``N(x)`` of the step's start, and
``b``'s adds twice the response to the change ``N(a) - N(x)`` (``h phi_2(h lambda/2)`` is
``-2/lambda`` where the quasi-static response is ``-1/lambda``); through ``N`` the error reaches
the slow coordinates. With ``P_F = V_F V^-1_F`` the projector on the fast eigenvalues (an
eigendecomposition of each frozen ``J``, real as they come in conjugate pairs) and ``a0``, ``c0``
Krogstad's ``a`` and ``c``, the stages are then

    a  = a0 + P_F (h/2) phi_2(hJ/2) (N(a0) - N(x))
    b  = a0 + (h phi_2(hJ/2) - P_F (h/2) phi_2(hJ/2)) (N(a) - N(x))
    c  = c0 + P_F ((2 B2 - 2 h phi_2(hJ)) (N(b) - N(x)) + B3 (N(c0) - N(x)))

(``B2 = h (2 phi_2 - 4 phi_3)(hJ)``, ``B3 = h (4 phi_3 - phi_2)(hJ)``): on the fast part, ``a``
and ``b`` take ``N`` linear over ``[t, t + h/2]`` through ``N(a0)`` and ``N(a)``, ``c`` the quadratic
through ``N(x)``, ``N(b)``, ``N(c0)``, each integrated exactly; the slow part and ``x+`` are
Krogstad's. Two more evaluations of ``f`` per step, taken only where ``a``'s correction moves the
state by more than :data:`_FAST_NEGLIGIBLE` of the tolerance (fast modes the run forces); the
matrix functions on the fast eigenvalues are scalars, ``V_F diag(g(h lambda)) V^-1_F``. Measured
on those arrays (16 modes and the axial mode, tip error over its peak against DOP853 at rtol
1e-11, one frozen Jacobian): 3.2e-7 and 9.2e-8 at 300 and 600 steps become 5.7e-8 and 2.8e-8; the
16-mode arrays, whose fast modes are barely forced, are unchanged. What it leaves: the fast
coordinates' own quadrature (their part of ``N`` carries the slow modes' frequencies: products of
modal rates and the hub's rate, loads along the beams) is as Krogstad's, and at tight tolerances
the second estimate below keeps the steps near ``|lambda| h = 1`` on such models.

Two local error estimates: the difference to the embedded third-order solution that puts the
weight of ``N(c)`` on ``N(x+)`` instead (both stages sit at ``t + h`` with the same
``sum a_ij c_j``, so it meets every classical third-order condition),
``h (4 phi_3 - phi_2)(hJ) (N(c) - N(x+))``; and ``h (2 phi_2 - 4 phi_3)(hJ)`` times a third
divided difference of ``N`` over ``t - h_prev, t, t + h/2, t + h`` (``N`` at the previous
step's start, recomputed with the current ``J``): zero for ``N`` cubic in time, which the
scheme integrates exactly, and of the size of ``N``'s fast part where the frozen ``J`` leaves a
fast mode in it, which the first estimate does not see (``N(c)`` and ``N(x+)`` carry the same
fast part). On a first step, or after the inputs jump, the second difference
``N(a) + N(b) - N(x) - N(c)`` (the error of ETD2) stands in. ``N(x+)`` is the first stage of the
next step, so an accepted step costs four evaluations of ``f``.

For a linear model ``J`` is its matrix, ``N`` is the held input term, every difference of
``N`` vanishes and a step is the exact zero-order-hold recursion, whatever the frequencies.
Compiled flexible models are stepped in their momentum form (``linflex/simulation/_momentum.py``:
the state ``(q, M(q) u)``, where the stiffness's coefficient does not change along the run),
with the error estimates measured in the speeds.

Cost: the matrix functions of ``(J, h)`` come from a scaled Taylor series and doublings
(:func:`phi_matrices`: Skaflestad and Wright's scaling and modified squaring) at ``h / 16``,
then doubled on up to ``4 h`` (``Q_k(2h) = e^{hJ} Q_k(h) + sum_i h^(k-1-i) / (k-1-i)!
Q_(i+1)(h)`` for ``Q_k(h) = h^k phi_k(hJ)``). Steps are the sample interval over a power of two, so a few step sizes serve the
whole run; ``J`` stays frozen while the error test passes. Where the test rejects a step, or
steps stay below the sample interval, a new ``J`` (and its matrices) is tried at that point once
enough evaluations have passed since the last one, kept if it halves the error estimate of the
next step, else dropped for the old one with a longer wait before the next trial.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..system._errors import ConvergenceError

__all__ = ["exponential_stepper", "phi_matrices", "phi_matrices_augmented"]

# Below this many halvings of the sample interval a step is a failure of the method.
_MAX_LEVEL = 30
# A new Jacobian is tried (where a step is rejected, or steps are below the sample interval) only
# after this many evaluations of f per state since the last one (a Jacobian and its matrix
# functions cost a few n evaluations of f for the models of benchmarks/simulation.py), twice
# as many after each trial that did not halve the error estimate (measured on the solar-array
# model: 10 takes 20 to 40 % fewer steps than 100 at 4 to 16 modes per array).
_RELINEARIZE_PER_STATE = 10
# A step level goes up (h doubles) when the estimate is below this fraction of the tolerance
# (the estimates grow about 16-fold with h).
_UP = 0.05
# Step sizes below and above the one asked for that one phi_matrices serves (see _matrices).
_BELOW, _ABOVE = 4, 2
# Matrix functions kept per frozen Jacobian (step sizes); the oldest go first.
_CACHE_SIZE = 24
# Degree of the Taylor series of phi_3 at ||h J_b / 2^s||_1 <= 1 (phi_matrices): the first term
# left out is below 1 / 19! = 8.2e-18 of the identity's, below the rounding of the sum.
_TAYLOR_DEGREE = 15
# An eigenvalue of J is fast for a step h where |lambda| h is above this: the stage values' fast
# parts are then corrected (see the module's notes). Measured on the solar-array model with its
# axial mode (benchmarks/simulation.py): at 10 the tip error at 300 and 600 fixed steps falls
# 5.7- and 3.3-fold; at 3 (also correcting the 1200 steps of |lambda| h = 6.9) that row worsens
# from 9.1e-9 to 1.5e-8, and at 20 the 600 steps (|lambda| h = 13.9) keep their error.
_FAST = 10.0
# The fast correction is skipped (no extra evaluations) where the first one, of stage a, moves
# the state by less than this fraction of the tolerance (fast modes the run barely forces; its
# effect on the step is that times h and the fast modes' coupling). Measured (rms of a's shift
# over the tolerance at rtol 1e-6 to 1e-8): median 1e-5.5 to 1e-3.3 on the 16-mode arrays, whose
# correction changes nothing; 1e-0.9 to 1e1.3 with the axial mode.
_FAST_NEGLIGIBLE = 1e-2
# The eigendecomposition of J serves the fast correction only if the eigenvectors' condition
# number is below this and they reproduce J to _EIG_RESIDUAL (relative); else no correction.
_EIG_COND = 1e8
_EIG_RESIDUAL = 1e-9
# phi_matrices' check of the rounding: the largest relative residual of the series' identities it
# accepts (measured: 1e-15 to 4e-15 on the solar-array models of 16 to 48 modes per array).
_RESIDUAL_MAX = 1e-11


def phi_matrices(J: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(e^{hJ}, h phi_1(hJ), h^2 phi_2(hJ), h^3 phi_3(hJ))`` by scaling and modified squaring.

    ``J`` is balanced first (``J_b = D^-1 J D``, ``D`` a diagonal of powers of two: exact, and
    the norm of a flexible model's Jacobian drops by two to three orders, with it the number of
    squarings); at ``h / 2^s`` with ``||h J_b / 2^s||_1 <= 1`` the four functions are the
    Taylor series of ``phi_3`` to degree :data:`_TAYLOR_DEGREE` (Horner) and
    ``phi_k = I / k! + Z phi_(k+1)``; then ``s`` doublings (:func:`_doubled`, four products each)
    bring them to ``h`` (B. Skaflestad and W. M. Wright, "The scaling and modified squaring
    method for matrix functions related to the exponential", Appl. Numer. Math. 59 (2009)
    783-799). About 20 + 4 s products of ``n x n`` matrices: a tenth of the time of one ``expm``
    of Al-Mohy and Higham's ``4 n`` augmented matrix on the solar-array models of
    ``benchmarks/simulation.py`` (138 states: 5.5 ms against 64 ms).

    Truncation is bounded before the fact: ``e^Z`` is summed to degree ``_TAYLOR_DEGREE + 3 =
    18`` at ``||Z||_1 <= 1``, whose backward error is below the unit roundoff (Al-Mohy and
    Higham, SIAM J. Sci. Comput. 33 (2011) 488-511: ``theta_18`` is about 1.1), and a doubling
    is an exact identity of the functions. Rounding is checked after the fact: the residuals of
    ``e^{hJ} = I + J Q_1``, ``Q_1 = h I + J Q_2`` and ``Q_2 = h^2 I / 2 + J Q_3`` (identities the
    series keeps, so what they measure is the rounding the doublings gathered), relative to the
    matrices, must stay below :data:`_RESIDUAL_MAX`; else the ``expm`` of the augmented matrix is
    taken instead (:func:`phi_matrices_augmented`).

    Parameters
    ----------
    J : ndarray, shape (n, n)
        The linear part [1/s].
    h : float
        The step [s].

    Returns
    -------
    E, Q1, Q2, Q3 : ndarray, shape (n, n)
        ``Q_k = h^k phi_k(hJ)`` [s^k].

    Examples
    --------
    >>> import numpy as np
    >>> E, Q1, Q2, Q3 = phi_matrices(np.array([[0.0]]), 2.0)
    >>> float(E[0, 0]), float(Q1[0, 0]), float(Q2[0, 0]), float(Q3[0, 0])
    (1.0, 2.0, 2.0, 1.3333333333333333)
    """
    J = np.asarray(J, float)
    n = J.shape[0]
    Jb, (scale, _) = scipy.linalg.matrix_balance(J, permute=False, separate=True)
    norm = float(np.linalg.norm(Jb, 1)) * abs(h)
    s = max(0, int(np.ceil(np.log2(norm)))) if norm > 1.0 else 0
    hs = h / 2.0**s
    Z, eye = hs * Jb, np.eye(n)
    P = eye / math.factorial(_TAYLOR_DEGREE + 3)
    for j in range(_TAYLOR_DEGREE - 1, -1, -1):
        P = Z @ P + eye / math.factorial(j + 3)
    P2 = Z @ P + 0.5 * eye
    P1 = Z @ P2 + eye
    mats = (Z @ P1 + eye, hs * P1, hs * hs * P2, hs**3 * P)
    for _ in range(s):
        mats = _doubled(hs, *mats)
        hs *= 2.0
    E, Q1, Q2, Q3 = (scale[:, None] * M / scale[None, :] for M in mats)
    residual = max(float(np.max(np.abs(E - eye - J @ Q1))) / max(float(np.max(np.abs(E))), 1.0),
                   float(np.max(np.abs(Q1 - h * eye - J @ Q2))) / max(float(np.max(np.abs(Q1))), abs(h)),
                   float(np.max(np.abs(Q2 - 0.5 * h * h * eye - J @ Q3))) / max(float(np.max(np.abs(Q2))), h * h))
    if not residual <= _RESIDUAL_MAX:
        return phi_matrices_augmented(J, h)
    return E, Q1, Q2, Q3


def phi_matrices_augmented(J: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`phi_matrices` from one ``expm`` of Al-Mohy and Higham's ``4 n`` augmented matrix
    ``[[hJ, I, 0, 0], [0, 0, I, 0], [0, 0, 0, I], 0]`` (its first block row is ``e^{hJ}, phi_1,
    phi_2, phi_3``): ten times the cost, the fall-back where the scaled Taylor series fails its
    check."""
    n = J.shape[0]
    M = np.zeros((4 * n, 4 * n))
    M[:n, :n] = h * J
    eye = np.eye(n)
    for k in range(3):
        M[k * n:(k + 1) * n, (k + 1) * n:(k + 2) * n] = eye
    W = scipy.linalg.expm(M)[:n]
    return W[:, :n], h * W[:, n:2 * n], h * h * W[:, 2 * n:3 * n], h ** 3 * W[:, 3 * n:]


def _rms(v: np.ndarray) -> float:
    """The root mean square of ``v``: the error norm of CVODES and scipy's integrators."""
    return float(np.sqrt(np.mean(v * v)))


def _doubled(h: float, E, Q1, Q2, Q3):
    """The matrix functions of ``2 h`` from those of ``h`` (see the module's docstring)."""
    return (E @ E, E @ Q1 + Q1, E @ Q2 + h * Q1 + Q2, E @ Q3 + (0.5 * h * h) * Q1 + h * Q2 + Q3)


def _phi123(z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``phi_1, phi_2, phi_3`` of complex scalars ``z`` by their recurrence ``phi_(k+1) = (phi_k
    - 1/k!) / z``: for ``|z|`` of a few and above (the fast eigenvalues: ``|z| >= _FAST / 2``),
    where the division loses nothing."""
    p1 = np.expm1(z) / z
    p2 = (p1 - 1.0) / z
    return p1, p2, (p2 - 0.5) / z


@dataclass
class _FastPart:
    """The fast eigenvalues of ``J`` for a step ``h`` (``|lambda| h > _FAST``, closed under
    conjugation) and the scalar functions of ``h lambda`` that correct the stages' fast parts
    (module docstring); each ``[s]``."""

    V: np.ndarray  # (n, m) their right eigenvectors
    W: np.ndarray  # (m, n) the matching rows of V^-1
    ga: np.ndarray  # (h/2) phi_2(h lambda / 2): a's fast part from N(a0) - N(x)
    gc2: np.ndarray  # 2 h (phi_2 - 4 phi_3): on N(b) - N(x), c's fast part from Krogstad's
    gc3: np.ndarray  # h (4 phi_3 - phi_2): on N(c0) - N(x)

    def apply(self, g: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``Re(V diag(g) W v)``: ``g(h J)`` on the fast invariant subspace, times ``v``."""
        return (self.V @ (g * (self.W @ v))).real


@dataclass
class _Coefficients:
    """The matrices one step of size ``h`` needs."""

    EQ_both: np.ndarray  # [[e^{hJ/2}, (h/2) phi_1(hJ/2)], [e^{hJ}, h phi_1(hJ)]], shape (2n, 2n)
    P2_half: np.ndarray  # h phi_2(hJ/2)
    P2: np.ndarray  # 2 h phi_2(hJ)
    B2: np.ndarray  # h (2 phi_2 - 4 phi_3)(hJ)
    B3: np.ndarray  # h (4 phi_3 - phi_2)(hJ)
    fast: _FastPart | None = None  # None: no eigenvalue of J is fast at this h


def _eigen(J: np.ndarray):
    """``(lambda, V, V^-1)`` of ``J``, or None where the eigenvectors are too ill-conditioned
    (or do not reproduce ``J``) to split off its fast part."""
    try:
        lam, V = np.linalg.eig(J)
        W = np.linalg.inv(V)
    except np.linalg.LinAlgError:
        return None
    if not (np.all(np.isfinite(lam)) and np.all(np.isfinite(W))):
        return None
    if float(np.linalg.norm(V, 1) * np.linalg.norm(W, 1)) > _EIG_COND:
        return None
    size = max(float(np.linalg.norm(J, 1)), np.finfo(float).tiny)
    if float(np.linalg.norm(J @ V - V * lam, 1)) > _EIG_RESIDUAL * size * float(np.linalg.norm(V, 1)):
        return None
    return lam, V, W


def _fast_part(eigen, h: float) -> _FastPart | None:
    """The :class:`_FastPart` of a step ``h`` [s] from :func:`_eigen`'s result; None where no
    eigenvalue is fast (or the eigendecomposition was refused)."""
    if eigen is None:
        return None
    lam, V, W = eigen
    mask = np.abs(lam) * h > _FAST
    if not mask.any():
        return None
    z = h * lam[mask]
    _, p2_half, _ = _phi123(0.5 * z)
    _, p2, p3 = _phi123(z)
    B2, B3 = h * (2.0 * p2 - 4.0 * p3), h * (4.0 * p3 - p2)
    return _FastPart(V=V[:, mask], W=W[mask], ga=0.5 * h * p2_half, gc2=2.0 * B2 - 2.0 * h * p2, gc3=B3)


def exponential_stepper(f, jacobian, rtol: float, atol, stats,
                        jacobian0: np.ndarray | None = None, momenta=None, fast_negligible: float = _FAST_NEGLIGIBLE):
    """A stepper ``step(times, x0, U) -> X[1:]`` of the exponential integrator (module docstring).

    Parameters
    ----------
    f : callable
        ``f(x, u, t) -> xdot`` [state units/s] as a flat float array.
    jacobian : callable
        ``jacobian(x, u, t) -> df/dx`` [1/s], shape (n, n).
    rtol : float
        Relative tolerance [-].
    atol : float or ndarray, shape (n,)
        Absolute tolerance [state units]: the root mean square over the states of the local
        error estimates, each over ``rtol max(|x_i|, |x+_i|) + atol_i``, is kept below 1 (the
        norm of CVODES and scipy).
    stats : IntegratorCounts
        Receives the counts (:class:`~linflex.simulation._steppers.IntegratorCounts`, accumulated
        over calls).
    jacobian0 : ndarray, shape (n, n), optional
        ``jacobian`` at the first call's start [1/s], where the caller has it already: the first
        frozen Jacobian, not taken again.
    momenta : (slice, callable), optional
        Where the state holds generalized momenta ``p = M(q) u`` instead of the speeds ``u``
        (:mod:`~linflex.simulation._momentum`), and ``(x, u, t) -> M(q)^-1``: the error
        estimates and the states are measured in speeds (``M^-1`` taken with each Jacobian), so
        ``rtol`` and ``atol`` keep their meaning for the model's own state.
    fast_negligible : float, optional
        The fast stages' correction is skipped where it moves the state by at most this fraction
        of the tolerance [-] (:data:`_FAST_NEGLIGIBLE`); 0 takes it wherever an eigenvalue is fast
        (fixed steps under a tolerance too loose to reject any, as ``benchmarks/simulation.py``
        runs them).

    Returns
    -------
    callable
        ``step(times, x0, U)``: the states at ``times[1:]`` [state units] from ``x0`` at
        ``times[0]``, with ``U[k]`` held on ``[times[k], times[k+1])``. The frozen Jacobian and
        its matrix functions carry over from one call to the next.
    """
    atol = np.asarray(atol, float)
    state: dict = {"J": None, "cache": {}, "raw": {}, "level": 0, "intervals": [], "since": 0, "trial": None,
                   "backoff": 1, "last": 1.0, "speeds": None, "eigen": False}

    def measured(v: np.ndarray) -> np.ndarray:
        """``v`` (a state or an error) with its momenta as speeds, ``M^-1 p``."""
        if momenta is None:
            return v
        w = v.copy()
        w[momenta[0]] = state["speeds"] @ v[momenta[0]]
        return w

    def linearize(x, u, t, reference: float | None = None, given: np.ndarray | None = None):
        """A new J at ``(x, u, t)`` (``given``: its value, known already); with ``reference``
        (the error ratio of the old J's last step) a trial, judged by :func:`judge` after the
        next step."""
        J = np.asarray(jacobian(x, u, t) if given is None else given, float)
        if not np.all(np.isfinite(J)):
            raise ConvergenceError(f"exponential: the Jacobian at t = {t} s is not finite")
        old = (state["J"], state["cache"], state["raw"], state["speeds"], state["eigen"])
        state["J"], state["cache"], state["raw"], state["since"] = J, {}, {}, stats.evaluations
        state["eigen"] = False  # not taken yet (False), refused (None) or (lambda, V, V^-1)
        state["speeds"] = None if momenta is None else momenta[1](x, u, t)
        state["trial"] = None if reference is None else (old, reference)
        stats.linearizations += 1

    def judge(ratio: float):
        """Keep a trial J if it halved the error ratio; else go back to the old one (its
        matrices are kept) and wait twice as long before the next trial."""
        trial, state["trial"] = state["trial"], None
        if trial is None:
            return
        old, reference = trial
        if ratio < 0.5 * reference:
            state["backoff"] = 1
        else:
            state["J"], state["cache"], state["raw"], state["speeds"], state["eigen"] = old
            state["since"], state["backoff"] = stats.evaluations, 2 * state["backoff"]

    def coefficients(h: float) -> _Coefficients:
        cache = state["cache"]
        key = float(h)
        if key not in cache:
            mats = _matrices(h)
            half = _matrices(0.5 * h)
            E, Q1, Q2, Q3 = mats
            if state["eigen"] is False:
                # One eigendecomposition per frozen J, where some step may have fast eigenvalues
                # (|lambda| <= ||J||_1: none can be fast at h below _FAST / ||J||_1).
                bound = float(np.linalg.norm(state["J"], 1)) * h
                state["eigen"] = _eigen(state["J"]) if bound > _FAST else False
            eigen = state["eigen"] if state["eigen"] is not False else None
            cache[key] = _Coefficients(
                EQ_both=np.block([[half[0], half[1]], [E, Q1]]), P2_half=(4.0 / h) * half[2], P2=(2.0 / h) * Q2,
                B2=(2.0 / h) * Q2 - (4.0 / h**2) * Q3, B3=(4.0 / h**2) * Q3 - Q2 / h, fast=_fast_part(eigen, h))
            while len(cache) > _CACHE_SIZE:
                cache.pop(next(iter(cache)))
        return cache[key]

    def _matrices(h: float):
        raw = state["raw"]
        key = float(h)
        if key not in raw:
            # One phi_matrices at h / 2^_BELOW, doubled up to h 2^_ABOVE: the step sizes a run
            # moves between for one series (a doubling costs four products of n x n matrices).
            fine = h / 2.0**_BELOW
            mats = phi_matrices(state["J"], fine)
            raw[float(fine)] = mats
            for _ in range(_BELOW + _ABOVE):
                mats = _doubled(fine, *mats)
                fine *= 2.0
                raw.setdefault(float(fine), mats)
        return raw[key]

    def evaluate(x, u, t):
        stats.evaluations += 1
        return np.asarray(f(x, u, t), float).reshape(-1)

    def base(t0: float, t1: float) -> float:
        # A sample interval equal to a known one up to the round-off of the times takes the
        # known one (and its matrices): a uniform grid has one interval, not a few dozen.
        dt = t1 - t0
        noise = 16.0 * np.finfo(float).eps * max(abs(t0), abs(t1))
        for known in state["intervals"]:
            if abs(known - dt) <= noise:
                return known
        state["intervals"].insert(0, dt)
        del state["intervals"][_CACHE_SIZE:]
        return dt

    def stale(n: int) -> bool:
        return stats.evaluations - state["since"] >= _RELINEARIZE_PER_STATE * n * state["backoff"]

    def step(times: np.ndarray, x0: np.ndarray, U: np.ndarray) -> np.ndarray:
        x = np.array(x0, float)
        out = np.zeros((times.size - 1, x.size))
        fx, u_prev, prev = None, None, None
        nx, nx_of = None, None  # the remainder f - J x at (x, fx) and the J it was taken with
        for k in range(times.size - 1):
            t0, t1, u = float(times[k]), float(times[k + 1]), U[k]
            if state["J"] is None:
                linearize(x, u, t0, given=jacobian0)
            if u_prev is None or not np.array_equal(u, u_prev):
                fx = prev = nx_of = None  # prev: (x, f, h) of the step before, with this u
            u_prev = u
            dt = base(t0, t1)
            level, done = state["level"], 0  # done: steps of dt / 2**level taken in this interval
            fresh = False  # J was taken at this step's start
            if level > 0 and stale(x.size):
                # Steps below the sample interval: a new J may let them grow again.
                linearize(x, u, t0, reference=state["last"])
                fresh = True
            while True:
                h = dt / 2**level
                t = t0 + done * h
                if fx is None:
                    fx = evaluate(x, u, t)
                J, C = state["J"], coefficients(h)
                if nx_of is not J:  # a new step start, or a new J: else the accepted step's own
                    nx, nx_of = fx - J @ x, J
                a, w = np.split(C.EQ_both @ np.concatenate([x, nx]), 2)
                na = evaluate(a, u, t + 0.5 * h) - J @ a
                F = C.fast
                if F is not None:
                    # Fast eigenvalues: a's fast part with N linear over [t, t + h/2] through
                    # N(a0), Krogstad's a (else the quasi-static response to N(x) alone); skipped
                    # where it would not move the state (fast modes the run leaves unforced).
                    shift = F.apply(F.ga, na - nx)
                    floor = rtol * np.abs(measured(x)) + atol
                    if _rms(measured(shift) / floor) <= fast_negligible:
                        F = None
                if F is None:
                    b = a + C.P2_half @ (na - nx)
                else:
                    a0, a = a, a + shift
                    na = evaluate(a, u, t + 0.5 * h) - J @ a
                    # b: Krogstad's on the slow part; on the fast part a0's with N linear
                    # through N(a) (Krogstad's would extrapolate the change of N twice).
                    b = a0 + C.P2_half @ (na - nx) - F.apply(F.ga, na - nx)
                nb = evaluate(b, u, t + 0.5 * h) - J @ b
                c = w + C.P2 @ (nb - nx)
                if F is not None:
                    # c's fast part with N quadratic through N(x), N(b) and N(c0), Krogstad's c.
                    nc0 = evaluate(c, u, t + h) - J @ c
                    c = c + F.apply(F.gc2, nb - nx) + F.apply(F.gc3, nc0 - nx)
                nc = evaluate(c, u, t + h) - J @ c
                x_new = w + C.B2 @ (na + nb - 2.0 * nx) + C.B3 @ (nc - nx)
                f_new = evaluate(x_new, u, t + h)
                ratio = np.inf
                if np.all(np.isfinite(x_new)) and np.all(np.isfinite(f_new)):
                    # The embedded third-order solution (N(c) weighed at x+) and the
                    # second-order one (ETD2 with c as predictor): the latter sees a remainder
                    # N that curves within the step (a fast mode the frozen J leaves in it).
                    scale = rtol * np.maximum(np.abs(measured(x)), np.abs(measured(x_new))) + atol
                    n_new = f_new - J @ x_new
                    third = C.B3 @ (nc - n_new)
                    if prev is None:
                        curve = na + nb - nx - nc  # ETD2's error: the first step, or after a jump of u
                    else:
                        # The third divided difference of N over t - h_prev, t, t + h/2, t + h
                        # (in units of h): zero for N cubic in time, which the scheme integrates
                        # exactly, of the size of N's fast part where a fast mode is left in it.
                        r = prev[2] / h
                        n_prev = prev[1] - J @ prev[0]
                        curve = (-n_prev / (r * (r + 0.5) * (r + 1.0)) + nx / (0.5 * r) - nb / (0.25 * (r + 0.5))
                                 + nc / (0.5 * (r + 1.0))) / 3.0
                    second = C.B2 @ curve
                    ratio = float(max(_rms(measured(third) / scale), _rms(measured(second) / scale)))
                judge(ratio)
                if ratio <= 1.0:
                    stats.steps += 1
                    state["last"] = ratio
                    prev = (x, fx, h)
                    x, fx, nx = x_new, f_new, n_new
                    done += 1
                    fresh = False
                    if done == 2**level:
                        break
                    # Up a level where the coarser grid lines up and the estimate leaves room.
                    if level > 0 and done % 2 == 0 and ratio < _UP:
                        level, done = level - 1, done // 2
                    continue
                stats.rejected += 1
                if not fresh and stale(x.size) and np.isfinite(ratio):
                    # The frozen J may no longer serve: take it anew here, once its
                    # matrices have paid for themselves (evaluations since the last one).
                    linearize(x, u, t, reference=ratio)
                    fresh = True
                    continue
                if level >= _MAX_LEVEL:
                    raise ConvergenceError(f"exponential: step size underflow at t = {t} s "
                                           f"(error estimate {ratio:.3g} times the tolerance)")
                level, done = level + 1, 2 * done
            out[k] = x
            state["level"] = level - 1 if (level > 0 and ratio < _UP) else level
        return out
    return step
