"""Disk margins (stability/_disk.py): the peak search against dense references, Osborne's balance."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ModelError
from linflex.stability import stability_margins
from linflex.stability._disk import _osborne_log_scaling, disk_margin


def _type1_loop(k: float, a: float):
    """``L = k / (s (s + a))``: states (y, y'), closed-loop poles of ``s^2 + a s + k``."""
    return np.array([[0.0, 1.0], [0.0, -a]]), np.array([[0.0], [k]]), np.array([[1.0, 0.0]])


def _peak_reference(loops, skew: float) -> float:
    """max_w max_i |S_i(jw) + (skew - 1)/2| from the closed forms S_i = s (s + a) / (s^2 + a s + k):
    a dense grid (200 000 points over 1e-3..1e3 rad/s), then a bounded search around its best point."""
    c = (skew - 1.0) / 2.0

    def g(w):
        s = 1j * np.asarray(w, float)
        return np.max([np.abs(s * (s + a) / (s * s + a * s + k) + c) for k, a in loops], axis=0)

    w = np.geomspace(1e-3, 1e3, 200_001)
    j = int(np.argmax(g(w)))
    res = scipy.optimize.minimize_scalar(lambda t: -float(g(np.exp(t))), bounds=(np.log(w[j - 1]), np.log(w[j + 1])),
                                         method="bounded", options={"xatol": 1e-12})
    return max(float(g(w[j])), -float(res.fun))


@settings(derandomize=True, max_examples=20, deadline=None)
@given(w1=st.floats(0.05, 20.0), zeta1=st.floats(0.25, 0.6), ratio=st.floats(1.005, 1.06),
       dzeta=st.floats(2e-4, 2e-3), sign=st.sampled_from([1, -1]), skew=st.sampled_from([0.0, 0.5, -0.5]))
def test_two_close_peaks_multiloop_disk_margin(w1, zeta1, ratio, dzeta, sign, skew):
    # Two decoupled loops whose sensitivity peaks lie 0.5 to 6 per cent apart with heights 1e-4
    # to 1e-3 apart (two local maxima of the multi-loop peak function in one bracket of the
    # frequency grid; a local search from the bracket can end on the lower one; maxima closer
    # than the bracket's samples and within ~1e-7 in height can still be confused, the error
    # then being their difference). S is diagonal, so the
    # D-scaled mu bound and sigma_max are both max_i |S_i + (skew-1)/2| (exact, no scaling):
    # Reference: the closed forms of S_i on a dense grid, refined by a bounded scalar search;
    # the peak value agrees to round-off (1e-12) though its frequency is only known to ~1e-8.
    w2, zeta2 = w1 * ratio, zeta1 * (1 + sign * dzeta)
    loops = [(w1**2, 2 * zeta1 * w1), (w2**2, 2 * zeta2 * w2)]
    parts = [_type1_loop(k, a) for k, a in loops]
    L = LinearSystem(scipy.linalg.block_diag(*[p[0] for p in parts]), scipy.linalg.block_diag(*[p[1] for p in parts]),
                     scipy.linalg.block_diag(*[p[2] for p in parts]), np.zeros((2, 2)))
    m = stability_margins(L, skew=skew)
    peak = _peak_reference(loops, skew)
    for dm in (m.skewed_disk_margin, m.unstructured_skewed_disk_margin):
        assert 1 / dm.alpha <= peak * (1 + 1e-12)  # a value of the peak function, never above its max
        assert 1 / dm.alpha == pytest.approx(peak, rel=1e-12)


class _DiagonalSensitivity:
    """An evaluator of the diagonal ``S(jw) = diag(S_i)`` of the loops ``k / (s (s + a))``."""

    def __init__(self, loops):
        self.loops = loops
        self.D = np.eye(len(loops))  # S(inf)

    def __call__(self, w):
        s = 1j * np.asarray(w, float)
        out = np.zeros((s.size, len(self.loops), len(self.loops)), complex)
        for i, (k, a) in enumerate(self.loops):
            out[:, i, i] = s * (s + a) / (s * s + a * s + k)
        return out


@settings(derandomize=True, max_examples=60, deadline=None)
@given(w1=st.floats(0.1, 10.0), zeta1=st.floats(0.25, 0.6), ratio=st.floats(1.005, 1.06),
       dzeta=st.floats(2e-4, 2e-3), sign=st.sampled_from([1, -1]),
       structure=st.sampled_from(["diagonal", "unstructured"]))
def test_disk_margin_peak_search_on_a_coarse_grid(w1, zeta1, ratio, dzeta, sign, structure):
    # The peak search alone on a plain grid of 30 points per decade (no points at the poles):
    # two maxima as above share one grid bracket; the reported peak must be the higher one (the
    # single bounded search per bracket used before missed it by up to 1.5e-3 in 34 of 300 random
    # cases with the peaks 2 to 6 % apart). Reference: as above (closed forms, dense grid).
    w2, zeta2 = w1 * ratio, zeta1 * (1 + sign * dzeta)
    loops = [(w1**2, 2 * zeta1 * w1), (w2**2, 2 * zeta2 * w2)]
    dm = disk_margin([_DiagonalSensitivity(loops)], np.geomspace(1e-3, 1e3, 181), 0.0, True, structure, 400_000)
    peak = _peak_reference(loops, 0.0)
    assert 1 / dm.alpha <= peak * (1 + 1e-12)
    assert 1 / dm.alpha == pytest.approx(peak, rel=1e-12)
    assert abs(np.log(dm.frequency / np.sqrt(w1 * w2))) < 0.2  # the peak lies near the crossovers


@settings(derandomize=True, max_examples=30, deadline=None)
@given(n=st.integers(2, 5), seed=st.integers(0, 2**32 - 1), spread=st.floats(0.0, 4.0))
def test_osborne_scaling_balances_rows_and_columns(n, seed, spread):
    # Reference: Osborne's fixed point (Osborne 1960): every off-diagonal row and column of
    # D M D^-1 have the same 2-norm; the sweeps stop there (to 1e-12 in log d), not after a fixed
    # count. Matrices with entries spread over 10^(+-spread) need more sweeps than mild ones.
    rng = np.random.default_rng(seed)
    M = (rng.standard_normal((3, n, n)) + 1j * rng.standard_normal((3, n, n))) * 10.0 ** rng.uniform(-spread, spread,
                                                                                                    (3, n, n))
    logd = _osborne_log_scaling(M, sweeps=500)
    B = np.abs(M * np.exp(logd[:, :, None] - logd[:, None, :])) ** 2
    B[:, np.arange(n), np.arange(n)] = 0.0
    rows, cols = B.sum(axis=2), B.sum(axis=1)
    np.testing.assert_allclose(rows, cols, rtol=1e-9)
    assert np.all(logd[:, 0] == 0.0)


@settings(max_examples=25, deadline=None)
@given(n=st.integers(1, 3), seed=st.integers(0, 2**32 - 1), coupling=st.floats(0.0, 0.3),
       skew=st.sampled_from([0.0, 0.5]))
def test_multi_loop_only_disk_margins_equal_the_full_search(n, seed, coupling, skew):
    # disk_margins="multi-loop" searches the multi-loop (diagonal) disk margins only: they, and
    # every loop's crossings and margins, equal those of the full search (to rounding: the two
    # searches leave different points in the evaluator's memory); each loop's own disk margins and
    # the unstructured ones of a MIMO loop are nan; a single loop's own is its multi-loop one.
    rng = np.random.default_rng(seed)
    loops = [(rng.uniform(0.5, 20.0), rng.uniform(0.5, 8.0)) for _ in range(n)]
    parts = [_type1_loop(k, a) for k, a in loops]
    A = scipy.linalg.block_diag(*[p[0] for p in parts])
    B = scipy.linalg.block_diag(*[p[1] for p in parts])
    C = scipy.linalg.block_diag(*[p[2] for p in parts]) + coupling * rng.uniform(-1, 1, (n, 2 * n))
    L = LinearSystem(A, B, C, np.zeros((n, n)))
    full = stability_margins(L, skew=skew)
    fast = stability_margins(L, skew=skew, disk_margins="multi-loop")
    assert fast.closed_loop_stable == full.closed_loop_stable
    for got, want in ((fast.disk_margin, full.disk_margin), (fast.skewed_disk_margin, full.skewed_disk_margin)):
        assert got.alpha == pytest.approx(want.alpha, rel=1e-9, abs=1e-12)
    for got, want in zip(fast.loops, full.loops):
        np.testing.assert_allclose(got.gain_crossovers, want.gain_crossovers, rtol=1e-12)
        np.testing.assert_allclose(got.phase_margins, want.phase_margins, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(got.gain_margins, want.gain_margins, rtol=1e-12)
        if n == 1:
            assert got.disk_margin.alpha == pytest.approx(want.disk_margin.alpha, rel=1e-12)
        else:
            assert np.isnan(got.disk_margin.alpha) and np.isnan(got.skewed_disk_margin.phase_margin)
    if n > 1:
        assert np.isnan(fast.unstructured_disk_margin.alpha) and np.isnan(fast.unstructured_disk_margin.frequency)
        assert str(fast).count("disk margin not searched (disk_margins='multi-loop')") == n


def test_disk_margins_option_is_checked():
    L = LinearSystem(*_type1_loop(2.0, 3.0), np.zeros((1, 1)))
    with pytest.raises(ModelError, match="disk_margins must be 'all' or 'multi-loop', got 'some'"):
        stability_margins(L, disk_margins="some")


def _sensitivity_peak_reference(A_cl, B, C, c: float) -> float:
    """max_w |S(jw) + c| of ``S = 1 - C (sI - A_cl)^-1 B`` by dense complex solves: 20 001 log
    points over 1e-4..1e4 rad/s plus the closed-loop poles' magnitudes and imaginary parts, each of
    the eight largest local maxima refined by a bounded scalar search between its neighbours."""
    n = A_cl.shape[0]

    def g(w):
        w = np.atleast_1d(np.asarray(w, float))
        M = 1j * w[:, None, None] * np.eye(n) - A_cl[None]
        return np.abs(1.0 - (C[None] @ np.linalg.solve(M, np.broadcast_to(B, (w.size, n, 1))))[:, 0, 0] + c)

    lam = np.linalg.eigvals(A_cl)
    w = np.unique(np.concatenate([np.geomspace(1e-4, 1e4, 20_001), np.abs(lam), np.abs(lam.imag)]))
    w = w[w > 0]
    vals = g(w)
    best = max(float(np.max(vals)), float(g(0.0)[0]), abs(1.0 + c))
    interior = np.flatnonzero((vals[1:-1] >= vals[:-2]) & (vals[1:-1] >= vals[2:])) + 1
    for j in interior[np.argsort(-vals[interior])[:8]]:
        res = scipy.optimize.minimize_scalar(lambda t: -float(g(np.exp(t))[0]), method="bounded",
                                             bounds=(np.log(w[j - 1]), np.log(w[j + 1])), options={"xatol": 1e-13})
        best = max(best, -float(res.fun))
    return best


@settings(derandomize=True, max_examples=60, deadline=None)
@given(n_pairs=st.integers(0, 3), n_real=st.integers(0, 2), seed=st.integers(0, 2**32 - 1),
       zeta_exp=st.floats(-3.0, -0.1), skew=st.sampled_from([0.0, 0.5, -0.5, 1.0, -1.0]))
def test_hamiltonian_peak_of_small_loops_matches_dense_solves_and_the_grid_search(n_pairs, n_real, seed, zeta_exp,
                                                                                  skew):
    # Small continuous loops (1 to 8 states) take the disk margin's peak from the Hamiltonian
    # iteration (stability/_disk.py: _hamiltonian_candidates). The loop L = C (sI - A)^-1 B is
    # built around a chosen stable closed loop A_cl = A - B C (modes of damping ratio 0.001 to 0.8
    # and real poles, under a random similarity), so its sensitivity is S = 1 - C (sI - A_cl)^-1 B.
    # References: (1) dense complex solves of S on a 20 001-point grid with every local maximum
    # refined; (2) the grid search of the same function (HAMILTONIAN_MAX = 0). The problem as
    # given in floating point (A = A_cl + B C rounded) fixes the peak only to first order in
    # eps ||A|| ||X|| ||Y|| (X = (jw - A_cl)^-1 B, Y its adjoint with C, at the peak): reached,
    # relative to the peak, 1e-9 to 2e-7 on lightly damped sharp peaks, where (1) and linflex
    # differ by 0.01 to 0.4 of it. Against (1): the peak value is the function's value
    # attained at the reported frequency to 4 times that bound (at least 1e-12) and never below
    # (1) by more (a missed peak elsewhere would be far larger; (1) itself may stop below the
    # supremum); against (2), the same function and data: 1e-10.
    import linflex.stability._disk as disk

    if n_pairs + n_real == 0:
        n_real = 1
    rng = np.random.default_rng(seed)
    blocks = []
    for _ in range(n_pairs):
        wn, zeta = 10.0 ** rng.uniform(-1, 2), min(10.0 ** zeta_exp * rng.uniform(0.5, 2.0), 0.9)
        blocks.append(np.array([[-zeta * wn, wn * np.sqrt(1 - zeta**2)], [-wn * np.sqrt(1 - zeta**2), -zeta * wn]]))
    blocks += [np.array([[-(10.0 ** rng.uniform(-1, 2))]]) for _ in range(n_real)]
    Lam = scipy.linalg.block_diag(*blocks)
    n = Lam.shape[0]
    T = np.eye(n) + 0.3 * rng.standard_normal((n, n))
    A_cl = T @ Lam @ np.linalg.inv(T)
    B, C = rng.standard_normal((n, 1)), rng.standard_normal((1, n))
    L = LinearSystem(A_cl + B @ C, B, C, np.zeros((1, 1)))
    c = (skew - 1.0) / 2.0
    m = stability_margins(L, skew=skew)
    dm = m.skewed_disk_margin
    assert m.closed_loop_stable
    ref = _sensitivity_peak_reference(A_cl, B, C, c)
    tol = 1e-12
    if np.isfinite(dm.frequency):
        M = 1j * dm.frequency * np.eye(n) - A_cl
        X, Y = np.linalg.solve(M, B), np.linalg.solve(M.conj().T, C.T)
        tol = max(tol, 4 * np.finfo(float).eps * np.linalg.norm(L.A, 2) * np.linalg.norm(X) * np.linalg.norm(Y) / ref)
        assert abs(1.0 - (C @ X)[0, 0] + c) == pytest.approx(1 / dm.alpha, rel=tol)
    else:
        assert 1 / dm.alpha == abs(1.0 + c)
    assert 1 / dm.alpha >= ref * (1 - tol)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(disk, "HAMILTONIAN_MAX", 0)
        grid = stability_margins(L, skew=skew).skewed_disk_margin
    assert 1 / dm.alpha >= 1 / grid.alpha * (1 - 1e-10)
    assert dm.alpha == pytest.approx(grid.alpha, rel=1e-10)


@pytest.mark.parametrize("kind, hamiltonian", [("continuous", True), ("sampled", True), ("delayed", False),
                                                ("hidden undamped mode", False), ("large", False)])
def test_disk_peak_path_taken(kind, hamiltonian, monkeypatch):
    # Which search finds the disk margin's peak (stability/_disk.py): the Hamiltonian iteration on
    # a continuous loop and on a sampled one (its w-plane image is continuous and rational), the
    # grid search on a delayed loop (not rational in s), with a hidden undamped mode (the
    # Hamiltonian would have imaginary eigenvalues at every level), and above HAMILTONIAN_MAX
    # states. Both give the same margin (the property test above); this keeps the fast path on.
    import linflex.stability._disk as disk

    A, B, C = _type1_loop(2.0, 3.0)
    if kind == "sampled":
        import control

        L = control.c2d(control.ss(A, B, C, 0.0), 0.01)
    elif kind == "delayed":
        L = LinearSystem(A, B, C, np.zeros((1, 1)), input_delay=[0.05])
    elif kind == "hidden undamped mode":
        L = LinearSystem(scipy.linalg.block_diag(A, [[0.0, 2.0], [-2.0, 0.0]]), np.r_[B, [[0.0], [0.0]]],
                         np.c_[C, [[0.0, 0.0]]], np.zeros((1, 1)))
    elif kind == "large":
        n = disk.HAMILTONIAN_MAX + 1   # the loop and n - 2 uncoupled states at -100 (hidden, damped)
        A_big = np.zeros((n, n))
        A_big[:2, :2] = A
        A_big[2:, 2:] = -100.0 * np.eye(n - 2)
        L = LinearSystem(A_big, np.r_[B, np.zeros((n - 2, 1))], np.c_[C, np.zeros((1, n - 2))], np.zeros((1, 1)))
    else:
        L = LinearSystem(A, B, C, np.zeros((1, 1)))
    calls = []
    real = disk._hamiltonian_candidates
    monkeypatch.setattr(disk, "_hamiltonian_candidates", lambda *a: calls.append(1) or real(*a))
    m = stability_margins(L)
    assert (len(calls) > 0) == hamiltonian
    assert 0 < m.disk_margin.alpha < np.inf
