"""Random feedback loops for the property corpus, and references independent of linflex's engine.

Generators (hypothesis strategies) build open loops ``L`` (negative feedback, square) of orders 1
to 60 from the parts a flexible spacecraft has: rigid-body double integrators, integrator chains,
undamped and lightly damped modes (damping 1e-4 .. 0.5, frequencies over five decades), unstable
real poles and pairs, stable lags, near pole-zero cancellations (modal residues down to 1e-8), a
feedthrough, a PD controller with a roll-off filter, and a loop gain chosen so that a gain
crossover lands exactly on a frequency-grid point or on the skirt of a resonance. The realization
is the one a user would hold: modal blocks, a random similarity transform of modest condition, or
the companion form of python-control's ``tf2ss``; optionally 1e-16 perturbations at random
positions of ``A`` (python-control realizations carry such round-off).

References (numpy, scipy and exact rational arithmetic only; nothing from linflex's engine):

- :func:`refined_response`: ``C (jwI - A)^-1 B + D`` by LAPACK solves with two steps of iterative
  refinement whose residuals are computed in extended precision (``numpy.longdouble``, 64-bit
  mantissa on x86-64), in balanced coordinates (an exact similarity by powers of 2);
- :func:`brute_margins`: every crossing of ``|L| = 1`` and of the negative real axis on a dense,
  adaptively refined grid of dense solves, each bracket refined by ``scipy.optimize.brentq``;
- :func:`closed_loop_poles`: ``numpy.linalg.eigvals`` of ``A - k B (I + k D)^-1 C``;
- :func:`refined_roots`: closed-loop poles by Newton's method on ``1 + k L(s)`` with
  extended-precision residuals;
- ``tests/hard/exact_zeros.py``: zeros in exact rational arithmetic.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import hypothesis
import numpy as np
import scipy.linalg
import scipy.optimize
from hypothesis import currently_in_test_context
from hypothesis import strategies as st

from linflex import LinearSystem

EPS = np.finfo(float).eps
# the extended precision of the reference residuals (x86-64: 64-bit mantissa, eps 1.1e-19); on a
# platform where longdouble is double the refinement gains nothing and the frequency-response
# tests skip (see has_extended_precision)
EPS_LD = float(np.finfo(np.longdouble).eps)


def assume(condition) -> bool:
    """``hypothesis.assume`` inside a property test; in a replayed example (a plain test calling
    the same checks) an assumption that does not hold fails the test, which must run whole."""
    if currently_in_test_context():
        return hypothesis.assume(condition)
    if not condition:
        import inspect

        caller = inspect.stack(context=1)[1]
        line = caller.code_context[0].strip() if caller.code_context else "?"
        raise AssertionError(f"a replayed example does not meet an assumption of its property test: {line} "
                             f"({Path(caller.filename).name}:{caller.lineno})")
    return True


def has_extended_precision() -> bool:
    return EPS_LD < 1e-3 * EPS


# ----------------------------------------------------------------------------------------------
# Loops


@dataclass(frozen=True)
class RandomLoop:
    """A generated open loop with what its construction knows exactly.

    ``sys`` is the realization handed to linflex; ``unperturbed`` the same realization before the
    1e-16 perturbations of ``A`` (identical when ``perturbed`` is False). ``rhp_poles`` counts the
    open-loop poles in the open right half-plane by construction (unstable lags and pairs; the
    rigid-body, integrator and undamped poles are on the axis and the Nyquist contour is indented
    to their right). ``crossover`` is the frequency [rad/s] the gain was set to cross at (``nan``
    when the gain is random), ``describe`` a one-line recipe for a reproducer.
    """

    sys: LinearSystem
    unperturbed: LinearSystem
    rhp_poles: int
    axis_poles: int
    perturbed: bool
    realization: str
    crossover: float
    describe: str
    draws: tuple = ()

    def __repr__(self) -> str:
        replay = f"; replayed_loop({list(self.draws)!r})" if self.draws else ""
        return f"RandomLoop({self.describe}{replay})"

    def _repr_pretty_(self, p, cycle) -> None:  # hypothesis prints falsifying examples with this
        p.text(repr(self))


def _part_blocks(kind: str, w: float, zeta: float, order: int):
    """(A, b, c) of one SISO modal part with transfer function 1/s^2, 1/s^k, 1/(s^2 + 2 z w s + w^2)
    or 1/(s - w)."""
    if kind == "rigid":
        return np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([0.0, 1.0]), np.array([1.0, 0.0])
    if kind == "chain":
        A = np.diag(np.ones(order - 1), 1)
        b, c = np.zeros(order), np.zeros(order)
        b[-1], c[0] = 1.0, 1.0
        return A, b, c
    if kind == "mode":
        return np.array([[0.0, 1.0], [-w * w, -2.0 * zeta * w]]), np.array([0.0, 1.0]), np.array([1.0, 0.0])
    if kind == "real":
        return np.array([[w]]), np.array([1.0]), np.array([1.0])
    raise ValueError(kind)


def assemble(parts, *, m: int, kp: float | None, kd: float, tau: float, dp: float) -> LinearSystem:
    """Plant = sum of the parts (each ``(kind, w, zeta, order, b_row, c_col)``) plus feedthrough
    ``dp I``, in series after a PD controller ``kp + kd s / (tau s + 1)`` per channel (none when
    ``kp`` is None): ``L = P K``, loop broken at the controller input.

    ::

        A = [ A_P   B_P C_K ]    B = [ B_P D_K ]    C = [ C_P   D_P C_K ]    D = D_P D_K
            [  0      A_K   ]        [   B_K   ]
    """
    blocks, Bs, Cs = [], [], []
    for kind, w, zeta, order, brow, ccol in parts:
        a, b, c = _part_blocks(kind, w, zeta, order)
        blocks.append(a)
        Bs.append(np.outer(b, brow))
        Cs.append(np.outer(ccol, c))
    Ap = scipy.linalg.block_diag(*blocks) if blocks else np.zeros((0, 0))
    Bp = np.vstack(Bs) if Bs else np.zeros((0, m))
    Cp = np.hstack(Cs) if Cs else np.zeros((m, 0))
    Dp = dp * np.eye(m)
    if kp is None:
        return LinearSystem(Ap, Bp, Cp, Dp)
    Ak, Bk = -np.eye(m) / tau, np.eye(m) / tau
    Ck, Dk = -(kd / tau) * np.eye(m), (kp + kd / tau) * np.eye(m)
    n, k = Ap.shape[0], m
    A = np.block([[Ap, Bp @ Ck], [np.zeros((k, n)), Ak]])
    B = np.vstack([Bp @ Dk, Bk])
    C = np.hstack([Cp, Dp @ Ck])
    return LinearSystem(A, B, C, Dp @ Dk)


def scale_output(sys: LinearSystem, g: float) -> LinearSystem:
    """``g L``: only ``C`` and ``D`` change, so ``A`` (and its eigenvalues) stay bit-identical."""
    return LinearSystem(sys.A, sys.B, g * sys.C, g * sys.D)


def similarity(sys: LinearSystem, rng: np.random.Generator, max_log10_cond: float = 1.5) -> LinearSystem:
    """``T A T^-1, T B, C T^-1`` with ``T = U diag(10^u) V`` (U, V random orthogonal): cond(T) up
    to ``10^max_log10_cond``."""
    n = sys.n_states
    if n == 0:
        return sys
    U, _ = np.linalg.qr(rng.standard_normal((n, n)))
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    s = 10.0 ** rng.uniform(0.0, max_log10_cond, n)
    T = U @ np.diag(s) @ V
    Tinv = V.T @ np.diag(1.0 / s) @ U.T
    return LinearSystem(T @ sys.A @ Tinv, T @ sys.B, sys.C @ Tinv, sys.D)


def companion(sys: LinearSystem) -> LinearSystem:
    """The realization python-control's ``tf2ss`` gives of this SISO system's transfer function."""
    import control

    try:
        tf = control.ss2tf(sys.to_control())
        return LinearSystem.from_control(control.tf2ss(tf))
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):
        assume(False)  # python-control cannot realize it (its minreal meets a non-finite root)
        raise


def perturb(A: np.ndarray, rng: np.random.Generator, count: int) -> np.ndarray:
    """``A`` with ``count`` entries at random positions changed by +-1e-16 of its largest entry."""
    A = np.array(A, dtype=float)
    n = A.shape[0]
    if n == 0:
        return A
    scale = max(float(np.max(np.abs(A))), 1.0)
    i, j = rng.integers(0, n, count), rng.integers(0, n, count)
    A[i, j] += rng.choice([-1.0, 1.0], count) * 1e-16 * scale
    return A


def dense_response(sys: LinearSystem, w) -> np.ndarray:
    """``C (jwI - A)^-1 B + D`` by batched dense solves in balanced coordinates, (n_w, p, m)."""
    w = np.atleast_1d(np.asarray(w, dtype=float))
    A, B, C = balanced(sys)
    n = A.shape[0]
    if n == 0:
        return np.broadcast_to(sys.D.astype(complex), (w.size,) + sys.D.shape).copy()
    M = 1j * w[:, None, None] * np.eye(n)[None] - A[None]
    with np.errstate(all="ignore"):
        try:
            X = np.linalg.solve(M, np.broadcast_to(B.astype(complex), (w.size,) + B.shape))
        except np.linalg.LinAlgError:
            X = np.stack([_solve_or_inf(Mi, B) for Mi in M])
        return C[None] @ X + sys.D[None]   # inf at a pole on the grid: nan where it meets a zero


def _norm2(X):
    """Spectral norms of a stack of matrices, ``inf`` where an entry is not finite."""
    good = np.all(np.isfinite(X), axis=(1, 2))
    out = np.full(X.shape[0], np.inf)
    if np.any(good):
        out[good] = np.linalg.norm(X[good], 2, axis=(1, 2))
    return out


def _solve_or_inf(M, B):
    try:
        return np.linalg.solve(M, B.astype(complex))
    except np.linalg.LinAlgError:
        return np.full(B.shape, np.inf + 0j)


def balanced(sys: LinearSystem):
    """``A, B, C`` after ``scipy.linalg.matrix_balance`` (exact diagonal similarity, powers of 2)."""
    if sys.n_states == 0:
        return sys.A, sys.B, sys.C
    _, (scale, _) = scipy.linalg.matrix_balance(sys.A, permute=False, separate=True)
    A = sys.A * (1.0 / scale)[:, None] * scale[None, :]
    return A, sys.B / scale[:, None], sys.C * scale[None, :]


@st.composite
def random_loops(draw, **options) -> RandomLoop:
    """A random loop (see the module docstring). ``mimo`` gives 2x2 loops (modal or similarity).

    Every value drawn is recorded in ``RandomLoop.draws``; :func:`replayed_loop` rebuilds the
    same loop from them (a failing example becomes an explicit ``@example``)."""
    drawn = []

    def recording(strategy):
        value = draw(strategy)
        drawn.append(value)
        return value

    return _build_loop(recording, drawn, assume, **options)


def replayed_loop(draws, **options) -> RandomLoop:
    """The loop :func:`random_loops` (same ``options``) builds from the recorded ``draws``: the
    same construction code, each ``draw`` answered by the next recorded value."""
    values = iter(draws)
    drawn = []

    def replay(strategy):
        drawn.append(next(values))
        return drawn[-1]

    def require(condition):
        assert condition, "the recorded draws no longer build a valid loop"

    lp = _build_loop(replay, drawn, require, **options)
    assert next(values, None) is None, "more draws recorded than the construction makes"
    return lp


def _build_loop(draw, drawn, require, *, max_order: int = 60, mimo: bool = False, gain_modes=("random", "grid", "resonance"),
                realizations=("modal", "similarity", "companion"), allow_unstable: bool = True,
                allow_perturbation: bool = True, allow_feedthrough: bool = True) -> RandomLoop:
    m = 2 if mimo else 1
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    controller = draw(st.booleans())
    budget = max_order - (m if controller else 0)
    parts, recipe = [], []
    rhp = axis = 0

    def gains():
        return rng.choice([-1.0, 1.0], m) * 10.0 ** rng.uniform(-0.5, 0.0, m)

    if budget >= 2 and draw(st.booleans()):
        parts.append(("rigid", 0.0, 0.0, 2, np.abs(gains()), np.abs(gains())))
        recipe.append("1/s^2")
        budget -= 2
        axis += 2
    chain = draw(st.integers(0, min(4, budget)))
    if chain:
        parts.append(("chain", 0.0, 0.0, chain, np.abs(gains()), np.abs(gains())))
        recipe.append(f"1/s^{chain}")
        budget -= chain
        axis += chain
    n_unstable = draw(st.integers(0, min(2, budget))) if allow_unstable else 0
    for _ in range(n_unstable):
        if budget >= 2 and draw(st.booleans()):
            w = 10.0 ** draw(st.floats(-1.0, 1.5))
            z = -(10.0 ** draw(st.floats(-3.0, -0.5)))
            parts.append(("mode", w, z, 2, gains(), gains()))
            recipe.append(f"1/(s^2{2 * z * w:+.3g}s+{w * w:.4g})")
            budget -= 2
            rhp += 2
        elif budget >= 1:
            a = 10.0 ** draw(st.floats(-1.0, 1.5))
            parts.append(("real", a, 0.0, 1, gains(), gains()))
            recipe.append(f"1/(s-{a:.4g})")
            budget -= 1
            rhp += 1
    n_lags = draw(st.integers(0, min(2, budget)))
    for _ in range(n_lags):
        a = -(10.0 ** draw(st.floats(-1.5, 2.5)))
        parts.append(("real", a, 0.0, 1, gains(), gains()))
        recipe.append(f"1/(s+{-a:.4g})")
        budget -= 1
    n_modes = draw(st.integers(0, budget // 2))
    for _ in range(n_modes):
        w = 10.0 ** draw(st.floats(-2.0, 3.0))
        kind = draw(st.sampled_from(["undamped", "light", "light", "moderate"]))
        z = {"undamped": 0.0, "light": 10.0 ** draw(st.floats(-4.0, -2.0)),
             "moderate": 10.0 ** draw(st.floats(-2.0, np.log10(0.5)))}[kind]
        b, c = gains(), gains()
        if draw(st.integers(0, 5)) == 0:  # near pole-zero cancellation: residue 1e-8 .. 1e-6
            b, c = b * 1e-4, c * 10.0 ** rng.uniform(-4.0, -2.0)
        parts.append(("mode", w, z, 2, b, c))
        recipe.append(f"{b[0] * c[0]:.3g}/(s^2+{2 * z * w:.3g}s+{w * w:.6g})")
        budget -= 2
        if z == 0.0:
            axis += 2
    if not parts:
        parts.append(("real", -1.0, 0.0, 1, np.ones(m), np.ones(m)))
        recipe.append("1/(s+1)")
    dp = draw(st.floats(-0.5, 0.5)) if allow_feedthrough and draw(st.integers(0, 3)) == 0 else 0.0
    kp, kd, tau = None, 0.0, 1.0
    if controller:
        kp = 10.0 ** draw(st.floats(-1.0, 1.0))
        kd = 10.0 ** draw(st.floats(-1.0, 1.0))
        tau = 10.0 ** draw(st.floats(-3.0, -1.0))
        recipe.append(f"PD({kp:.3g}+{kd:.3g}s/({tau:.3g}s+1))")
    if dp:
        recipe.append(f"D={dp:.3g}")
    L0 = assemble(parts, m=m, kp=kp, kd=kd, tau=tau, dp=dp)
    require(L0.n_states >= 1)

    real_choices = [r for r in realizations if not (r == "companion" and (mimo or L0.n_states > 10))]
    require(real_choices)
    realization = draw(st.sampled_from(real_choices))
    if realization == "similarity":
        L0 = similarity(L0, rng)
    elif realization == "companion":
        L0 = companion(L0)

    # the loop gain: set so that |L(j w_c)| = 1 (sigma_max for MIMO) at a chosen w_c
    mode = draw(st.sampled_from(gain_modes))
    w_c = np.nan
    if mode == "grid":
        from linflex.frequency import frequency_grid  # only to pick a point: the grid itself

        # the frequency itself is recorded (a replay does not depend on the grid of the day)
        w_c = draw(st.sampled_from([float(x) for x in frequency_grid(L0)]))
    elif mode == "resonance":
        # the skirt of a lightly damped pole on the margin search's vernier grid: w_d (1 + z x),
        # w_d = w_n sqrt(1 - 2 z^2) from numpy's eigenvalues of A (stability/_margins.py _base_grid)
        lam = np.linalg.eigvals(L0.A)
        light = lam[(lam.imag > 0) & (np.abs(lam.real) < 0.3 * np.abs(lam)) & (np.abs(lam.real) > 1e-9 * np.abs(lam))]
        require(light.size)
        p = draw(st.sampled_from([complex(x) for x in light]))
        wn, z = abs(p), abs(p.real) / abs(p)
        wd = wn * np.sqrt(max(1.0 - 2 * z**2, 0.0))
        x = draw(st.sampled_from([0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 8.0]))
        w_c = float(wd * (1 + z * x)) if draw(st.booleans()) or z * x >= 0.5 else float(wd * (1 - z * x))
    else:
        w_c_free = 10.0 ** draw(st.floats(-2.0, 3.0))
    target = w_c if np.isfinite(w_c) else w_c_free
    G = dense_response(L0, target)[0]
    require(np.all(np.isfinite(G)))
    s = np.linalg.norm(G, 2)
    require(1e-12 < s < 1e12)
    g = 1.0 / s
    # keep I + D well conditioned (a feedthrough near -1 makes the loop ill posed)
    require(np.min(np.abs(np.linalg.eigvals(np.eye(m) + g * L0.D))) > 1e-3)
    L = scale_output(L0, g)

    perturbed = allow_perturbation and draw(st.booleans())
    sys = L
    if perturbed:
        sys = LinearSystem(perturb(L.A, rng, max(1, L.n_states // 4)), L.B, L.C, L.D)
    describe = (f"{realization} {'2x2 ' if mimo else ''}order {L.n_states}, seed {seed}: gain {g:.6g} * ("
                + " + ".join(recipe) + ")" + (" perturbed 1e-16" if perturbed else "")
                + (f", crossover at {w_c:.10g} ({mode})" if np.isfinite(w_c) else ""))
    return RandomLoop(sys=sys, unperturbed=L, rhp_poles=rhp, axis_poles=axis, perturbed=perturbed,
                      realization=realization, crossover=w_c, describe=describe, draws=tuple(drawn))


# ----------------------------------------------------------------------------------------------
# Reference: frequency response with extended-precision refinement


def refined_response(sys: LinearSystem, w, steps: int = 3):
    """``G(jw)`` to about ``eps_ld * cond`` by iterative refinement with extended-precision residuals.

    Returns ``(G, converged, kappa)``: the response (n_w, p, m) rounded to double, a mask of the
    points where the last correction was below 1e-6 of ``eps`` relative to ``x`` (there ``G`` is
    exact to well below double precision; where the refinement does not converge, ``jwI - A`` is
    singular to working precision, say ``w`` on an undamped pole, and the point is not a
    reference), and ``kappa``: the normwise condition ``||M|| ||C M^-1|| ||M^-1 B|| / ||G||`` of
    the response at each point (``M = jwI - A`` balanced), so that ``eps * kappa`` is the error
    of a backward-stable evaluation.
    """
    w = np.atleast_1d(np.asarray(w, dtype=float))
    A, B, C = balanced(sys)
    n = A.shape[0]
    D = sys.D
    if n == 0:
        G = np.broadcast_to(D.astype(complex), (w.size,) + D.shape).copy()
        return G, np.ones(w.size, bool), np.ones(w.size)
    M = 1j * w[:, None, None] * np.eye(n)[None] - A[None]
    Bc = np.broadcast_to(B.astype(complex), (w.size,) + B.shape)
    with np.errstate(all="ignore"):
        good = np.ones(w.size, bool)
        try:
            x = np.linalg.solve(M, Bc)
            Minv = np.linalg.inv(M)
        except np.linalg.LinAlgError:  # exactly singular somewhere: per point
            x = np.stack([_solve_or_inf(Mi, B) for Mi in M])
            Minv = np.stack([_solve_or_inf(Mi, np.eye(n)) for Mi in M])
        good = np.all(np.isfinite(Minv), axis=(1, 2))
        x = x.astype(np.clongdouble)
        A_ld = A.astype(np.longdouble)
        jw = (1j * w).astype(np.clongdouble)[:, None, None]
        last = np.full(w.size, np.inf)
        for _ in range(steps):
            r = Bc.astype(np.clongdouble) - (jw * x - A_ld[None] @ x)
            # the correction through the inverse (the same LU's forward error as a solve)
            d = Minv @ r.astype(complex)
            x = x + d.astype(np.clongdouble)
            xn = np.max(np.abs(x.astype(complex)), axis=(1, 2))
            last = np.max(np.abs(d), axis=(1, 2)) / np.where(xn > 0, xn, 1.0)
        last = np.where(good, last, np.inf)
        G = (C.astype(np.longdouble)[None] @ x + D.astype(np.longdouble)[None]).astype(complex)
        normM = _norm2(M)
        cm = _norm2(C[None] @ Minv)
        mb = _norm2(Minv @ B[None])
        g = np.max(np.abs(G), axis=(1, 2))
        kappa = normM * cm * mb / np.where(g > 0, g, np.nan)
    converged = np.isfinite(last) & (last <= 1e-6 * EPS) & np.isfinite(kappa) & (kappa * EPS < 1e-2)
    return G, converged, kappa


# ----------------------------------------------------------------------------------------------
# Reference: brute-force margins of a SISO loop


@dataclass(frozen=True)
class Crossings:
    """Reference crossings of a SISO loop: frequencies [rad/s], the value of ``L`` there, the
    slopes ``d log|L| / d log w`` (gain) and ``d arg L / d log w`` [rad] (phase) that set their
    conditioning, and ``kappa`` (condition of ``L(jw)``, see :func:`refined_response`)."""

    wgc: np.ndarray
    Lgc: np.ndarray
    slope_gc: np.ndarray
    kappa_gc: np.ndarray
    wpc: np.ndarray
    Lpc: np.ndarray
    slope_pc: np.ndarray
    kappa_pc: np.ndarray

    @property
    def phase_margins(self):
        return np.degrees(np.angle(-self.Lgc))

    @property
    def delay_margins(self):
        return np.radians(np.mod(self.phase_margins, 360.0)) / self.wgc

    @property
    def gain_margins(self):
        return -1.0 / self.Lpc.real


def _features(sys: LinearSystem):
    """Poles, zeros and closed-loop poles (numpy/scipy eigenvalues), the places where L varies."""
    A, B, C, D = sys.A, sys.B, sys.C, sys.D
    n = A.shape[0]
    poles = np.linalg.eigvals(A)
    S = np.block([[A, B], [C, D]])
    E = np.zeros_like(S)
    E[:n, :n] = np.eye(n)
    with np.errstate(all="ignore"):
        z = scipy.linalg.eigvals(S, E)
    z = z[np.isfinite(z) & (np.abs(z) < 1e10 * max(1.0, np.linalg.norm(A, 1)))]
    cl = closed_loop_poles(sys, 1.0)
    return np.concatenate([poles, z, cl])


def brute_margins(sys: LinearSystem, *, per_decade: int = 60, max_rounds: int = 30,
                  max_points: int = 60_000) -> Crossings:
    """Every gain and phase crossover of a SISO loop by brute force (see the module docstring).

    Grid: ``per_decade`` points per decade from 1e-4 of the smallest to 1e4 times the largest
    feature (pole, zero, closed-loop pole; extended by decades while ``log|L|`` still moves
    towards 0), plus 25 points across +-100 half-bandwidths of every lightly damped feature and
    ``w (1 +- 10^-k)`` (k = 3..13) beside undamped ones; then every interval whose phase changes
    by more than 3 deg or whose magnitude changes by more than 0.25 dB is bisected (up to
    ``max_rounds`` rounds), and every extremum of ``|log|L||`` within 0.05 of zero without a sign
    change is sampled densely (twice 201 points: a pair of crossings between two grid points). Crossings outside ``1e-10 <= |L| <= 1e10`` are not reported (the
    documented window of :func:`linflex.stability.stability_margins`), and a sign change of
    ``Im L`` through a pole on the axis is not a phase crossover.
    """
    feats = _features(sys)
    scale = max(float(np.max(np.abs(feats))) if feats.size else 1.0, 1e-300)
    mags = np.abs(feats)
    big = mags > 1e-6 * scale
    lo = (np.min(mags[big]) if np.any(big) else 1.0) * 1e-4
    hi = (np.max(mags[big]) if np.any(big) else 1.0) * 1e4

    Ab, Bb, Cb = balanced(sys)
    I = np.eye(Ab.shape[0])
    d0 = complex(sys.D[0, 0])

    def L(w):
        w = np.atleast_1d(w)
        out = np.empty(w.size, dtype=complex)
        for k in range(0, w.size, 512):  # chunks: (512, n, n) complex at most
            M = 1j * w[k:k + 512, None, None] * I[None] - Ab[None]
            with np.errstate(all="ignore"):
                try:
                    X = np.linalg.solve(M, np.broadcast_to(Bb.astype(complex), (M.shape[0],) + Bb.shape))
                except np.linalg.LinAlgError:
                    X = np.stack([_solve_or_inf(Mi, Bb) for Mi in M])
                out[k:k + 512] = (Cb[None] @ X)[:, 0, 0] + d0
        return out

    def scalar(x):
        M = 1j * x * I - Ab
        with np.errstate(all="ignore"):
            try:
                return (Cb @ np.linalg.solve(M, Bb))[0, 0] + d0
            except np.linalg.LinAlgError:
                return complex(np.inf)

    def logmag(w):
        with np.errstate(divide="ignore"):
            return np.log(np.abs(L(w)))

    # extend while |L| approaches 1 (asymptotic regions are monotone in log-log)
    for direction in (-1, 1):
        edge = lo if direction < 0 else hi
        for _ in range(40):
            g0, g1 = logmag(np.array([edge, edge * 10.0**direction]))
            if not (np.isfinite(g0) and np.isfinite(g1)) or abs(g1) >= abs(g0) - 1e-9 or np.sign(g0) != np.sign(g1):
                if np.sign(g0) != np.sign(g1):
                    edge *= 10.0**direction
                break
            edge *= 10.0**direction
        if direction < 0:
            lo = edge / 10
        else:
            hi = edge * 10
    pts = [np.geomspace(lo, hi, int(np.ceil(np.log10(hi / lo) * per_decade)) + 1)]
    for f in feats[(feats.imag > 0)]:
        h = abs(f.real)
        if h < 0.7 * abs(f):
            hb = max(h, 1e-13 * abs(f))
            x = np.sinh(np.linspace(-np.arcsinh(100.0), np.arcsinh(100.0), 25))
            pts.append(f.imag + hb * x)
            pts.append(f.imag * (1 + np.concatenate([-(10.0 ** -np.arange(3, 14)), 10.0 ** -np.arange(3, 14)])))
    w = np.unique(np.concatenate(pts))
    w = w[(w > 0) & np.isfinite(w)]
    v = L(w)
    for _ in range(max_rounds):
        with np.errstate(all="ignore"):
            ratio = v[1:] / v[:-1]
            bad = (np.abs(np.angle(ratio)) > np.radians(3.0)) | (np.abs(np.log10(np.abs(ratio))) > 0.0125)
            bad |= ~np.isfinite(ratio)
            m = np.abs(v)
        bad &= w[1:] / w[:-1] > 1 + 1e-13
        bad &= ~((m[1:] < 1e-12) & (m[:-1] < 1e-12)) & ~((m[1:] > 1e12) & (m[:-1] > 1e12))
        if not bad.any():
            break
        # a reference that needs more than max_points is not resolved: the example is discarded
        # (hypothesis.assume), never silently truncated
        assume(w.size + np.count_nonzero(bad) <= max_points)
        i = np.flatnonzero(bad)
        mid = np.sqrt(w[i] * w[i + 1])
        w = np.insert(w, i + 1, mid)
        v = np.insert(v, i + 1, L(mid))

    # a pair of crossings between two grid points (|L| bulging across 1 by 4e-4 over 0.3 % of a
    # decade beside a resonance) changes neither sign nor magnitude enough to be refined above:
    # every interior extremum of |log|L|| within 0.05 of zero without a sign change is sampled
    # densely (201 points between its neighbours, twice; the 50 closest to zero)
    for _ in range(2):
        with np.errstate(all="ignore"):
            f = np.log(np.abs(v))
        a, sg = np.abs(f), np.sign(f)
        ext = (np.isfinite(f[:-2]) & np.isfinite(f[1:-1]) & np.isfinite(f[2:]) & (a[1:-1] <= a[:-2])
               & (a[1:-1] <= a[2:]) & (a[1:-1] < 0.05) & (sg[:-2] == sg[1:-1]) & (sg[1:-1] == sg[2:]))
        idx = np.flatnonzero(ext) + 1
        if not idx.size:
            break
        idx = idx[np.argsort(a[idx], kind="stable")[:50]]
        new = np.concatenate([np.geomspace(w[j - 1], w[j + 1], 201)[1:-1] for j in np.sort(idx)])
        assume(w.size + new.size <= max_points)
        w, k = np.unique(np.concatenate([w, new]), return_index=True)
        v = np.concatenate([v, L(new)])[k]

    def bracket(f, a, b):
        """Brent's method on [a, b] with the ends evaluated by the same scalar function (batched
        and single solves may round differently); None when f does not change sign."""
        fa, fb = f(a), f(b)
        if fa == 0:
            return a
        if not (np.isfinite(fa) and np.isfinite(fb)) or np.sign(fa) == np.sign(fb):
            return None
        return scipy.optimize.brentq(f, a, b, xtol=1e-300, rtol=1e-14)

    def f_gain(x):
        return float(np.log(abs(scalar(x))))

    def f_phase(x):
        z = scalar(x)
        return float(z.imag / abs(z))

    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.log(np.abs(v))
        hph = v.imag / np.abs(v)
    wgc, wpc = [], []
    for i in np.flatnonzero(np.isfinite(g[:-1]) & np.isfinite(g[1:]) & (np.sign(g[:-1]) != np.sign(g[1:]))):
        if g[i + 1] == 0:
            continue  # taken as the left end of the next interval
        x = bracket(f_gain, w[i], w[i + 1])
        if x is not None:
            wgc.append(x)
    inside = (np.abs(v) >= 1e-12) & (np.abs(v) <= 1e12)
    cand = (np.isfinite(hph[:-1]) & np.isfinite(hph[1:]) & (np.sign(hph[:-1]) != np.sign(hph[1:]))
            & ((v.real[:-1] < 0) | (v.real[1:] < 0)) & (inside[:-1] | inside[1:]))
    for i in np.flatnonzero(cand):
        if hph[i + 1] == 0:
            continue
        x = bracket(f_phase, w[i], w[i + 1])
        if x is None:
            continue
        z = scalar(x)
        if np.isfinite(z) and z.real < 0 and abs(z.imag) <= 1e-6 * abs(z) and 1e-10 <= abs(z) <= 1e10:
            wpc.append(x)
    # w = 0: a crossing when L(0) is finite and negative (no pole at the origin)
    lam = np.linalg.eigvals(sys.A)
    if not np.any(np.abs(lam) <= 1e-6 * max(1.0, scale)):
        L0 = L(np.array([0.0]))[0]
        if np.isfinite(L0) and L0.real < 0 and 1e-10 <= abs(L0) <= 1e10:
            wpc.append(0.0)
    wgc, wpc = np.array(sorted(set(wgc))), np.array(sorted(set(wpc)))

    def slopes(ws, kind):
        out = np.zeros(ws.size)
        for k, x in enumerate(ws):
            if x == 0:
                out[k] = np.inf
                continue
            d = 1e-6
            z1, z2 = scalar(x * np.exp(-d)), scalar(x * np.exp(d))
            out[k] = ((np.log(abs(z2)) - np.log(abs(z1))) if kind == "gain" else np.angle(z2 / z1)) / (2 * d)
        return out

    Lgc, Lpc = L(wgc), L(wpc)
    _, _, kgc = refined_response(sys, wgc) if wgc.size else (None, None, np.zeros(0))
    _, _, kpc = refined_response(sys, wpc) if wpc.size else (None, None, np.zeros(0))
    return Crossings(wgc=wgc, Lgc=Lgc, slope_gc=slopes(wgc, "gain"), kappa_gc=kgc,
                     wpc=wpc, Lpc=Lpc, slope_pc=slopes(wpc, "phase"), kappa_pc=kpc)


# ----------------------------------------------------------------------------------------------
# Reference: closed-loop poles


def closed_loop_poles(sys: LinearSystem, k: float = 1.0) -> np.ndarray:
    """Eigenvalues of ``A - k B (I + k D)^-1 C`` (the loop ``u = -k y``, feedthrough included)."""
    m = sys.n_inputs
    F = np.linalg.solve(np.eye(m) + k * sys.D, sys.C)
    return np.linalg.eigvals(sys.A - k * sys.B @ F)


def refined_roots(sys: LinearSystem, k: float, lam: np.ndarray, steps: int = 4):
    """Closed-loop poles of a SISO loop at gain ``k`` to about ``eps`` relative: Newton's method
    on ``1 + k L(s)`` from each eigenvalue ``lam``, with ``L`` by a solve whose residual is
    refined in extended precision (as :func:`refined_response`) and the iterate carried in
    extended precision. Returns ``(roots, ok, err)``: ``ok`` where the iteration converged
    (``err``, twice the larger of its last two steps, the noise of the extended-precision
    evaluation, below ``1e-8 max(1, |s|)``) without leaving a quarter of the distance to the
    nearest other eigenvalue (a multiple or clustered root is not refined)."""
    lam = np.asarray(lam, dtype=complex)
    out, ok, err = lam.copy(), np.zeros(lam.size, bool), np.full(lam.size, np.inf)
    A, B, C = balanced(sys)
    n = A.shape[0]
    if n == 0 or lam.size == 0:
        return out, ok, err
    b, c, d = B[:, 0], C[0], float(sys.D[0, 0])
    A_ld = A.astype(np.longdouble)
    gap = np.full(lam.size, np.inf)
    if lam.size > 1:
        Dm = np.abs(lam[:, None] - lam[None, :])
        np.fill_diagonal(Dm, np.inf)
        gap = Dm.min(axis=1)
    # the loop is real: a root below the axis is the conjugate of one above (refined once)
    lower = np.zeros(lam.size, bool)
    partner = np.zeros(lam.size, int)
    up = np.flatnonzero(lam.imag > 0)
    for i in np.flatnonzero(lam.imag < 0):
        if up.size:
            j = up[np.argmin(np.abs(lam[up] - lam[i].conj()))]
            if abs(lam[j] - lam[i].conj()) <= 1e-12 * abs(lam[i]):
                lower[i], partner[i] = True, j
    live = np.isfinite(lam) & ~lower
    s = lam[live].astype(np.clongdouble)
    last = prev = np.full(s.size, np.inf)
    good = np.ones(s.size, bool)
    eye = np.eye(n)[None]
    with np.errstate(all="ignore"):
        for _ in range(steps):
            sd = s.astype(complex)
            M = sd[:, None, None] * eye - A[None]
            try:
                Minv = np.linalg.inv(M)  # one LU for the solves and the corrections
            except np.linalg.LinAlgError:  # an iterate exactly on a pole: that one is not refined
                Minv = np.stack([_solve_or_inf(Mi, np.eye(n)) for Mi in M])
            x = Minv @ (b + 0j)
            y = c @ Minv
            x_ld = x.astype(np.clongdouble)
            for _ in range(6):  # until the corrections are below extended precision
                r = b.astype(np.clongdouble)[None] - (s[:, None] * x_ld - x_ld @ A_ld.T)
                dx = (Minv @ r.astype(complex)[..., None])[..., 0]
                x_ld = x_ld + dx.astype(np.clongdouble)
                if np.all(np.abs(dx) <= 1e-3 * EPS_LD * np.abs(x_ld.astype(complex)) + 1e-300):
                    break
            f = 1 + np.longdouble(k) * (x_ld @ c.astype(np.longdouble) + np.longdouble(d))
            fp = -k * np.sum(y * x, axis=1)
            step = f / fp.astype(np.clongdouble)
            fin = np.isfinite(step.astype(complex))
            good &= fin
            s = np.where(fin, s - step, s)
            prev, last = last, np.abs(step.astype(complex))
    sd = s.astype(complex)
    # the last steps are the noise of the extended-precision evaluation over |f'| once the
    # iteration has converged: twice the larger of the last two is the reference's own error
    ref = 2 * np.maximum(prev, last) + EPS * np.abs(sd)
    conv = good & (ref <= 1e-8 * np.maximum(1.0, np.abs(sd))) & (np.abs(sd - lam[live]) <= 0.25 * gap[live])
    idx = np.flatnonzero(live)
    out[idx[conv]], ok[idx[conv]] = sd[conv], True
    err[idx[conv]] = ref[conv]
    low = np.flatnonzero(lower)
    out[low], ok[low], err[low] = out[partner[low]].conj(), ok[partner[low]], err[partner[low]]
    return out, ok, err


def eigenvalue_conditions(M: np.ndarray):
    """Eigenvalues of ``M`` and their condition numbers ``1 / |y^H x|`` (unit left/right vectors)."""
    lam, vl, vr = scipy.linalg.eig(M, left=True, right=True)
    with np.errstate(divide="ignore"):
        c = 1.0 / np.abs(np.sum(vl.conj() * vr, axis=0))
    return lam, c
