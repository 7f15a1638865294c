"""Single loops of order >= 200: closed-loop poles and zeros from the modal sums (O(n^2)) and the
grid scanned at a looser re-check tolerance give the margins of the dense path.

References: numpy's eigenvalues of ``A - b c / (1 + d)``; the same margins computed with the
modal path switched off (the Hessenberg form of ``frequency/_zeros.loop_roots``).
"""

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from linflex import LinearSystem
from linflex.frequency._evaluate import TransferEvaluator
from linflex.frequency._modal_roots import closed_loop_poles
from linflex.stability import _closed_loop, _margins, stability_margins


def random_loop(n: int, seed: int) -> LinearSystem:
    """A stable dense SISO loop: lightly to well damped pairs in a random non-orthogonal basis."""
    rng = np.random.default_rng(seed)
    pairs = n // 2
    wn = np.exp(rng.uniform(np.log(0.1), np.log(100.0), pairs))
    zeta = rng.uniform(0.01, 0.7, pairs)
    A = np.zeros((n, n))
    for i, (w, z) in enumerate(zip(wn, zeta)):
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[0.0, 1.0], [-w * w, -2 * z * w]]
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    T = Q * np.exp(rng.uniform(0, np.log(10.0), n))[None, :]
    A = T @ A @ np.linalg.inv(T)
    return LinearSystem(A, 3.0 * rng.normal(size=(n, 1)), rng.normal(size=(1, n)))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_closed_loop_poles_from_the_modal_sums_are_the_eigenvalues(seed):
    sys = random_loop(240, seed)
    modal = TransferEvaluator(sys).modal
    got = closed_loop_poles(modal, sys)
    assert got is not None and got.size == sys.n_states
    want = np.linalg.eigvals(sys.A - sys.B @ sys.C)
    cost = np.abs(got[:, None] - want[None, :])
    r, c = linear_sum_assignment(cost)
    # both are accurate to about eps ||A|| cond(lambda): 1e-9 of the spectral radius covers it
    assert np.max(cost[r, c]) <= 1e-9 * np.max(np.abs(want))


def test_closed_loop_poles_refuse_an_incomplete_set():
    # a gain so large that 1 + L has roots far beyond the poles: Aberth's start beside the poles
    # is then checked, and None (the dense path) is returned rather than a partial set
    sys = random_loop(220, 3)
    big = LinearSystem(sys.A, 1e12 * sys.B, sys.C)
    got = closed_loop_poles(TransferEvaluator(big).modal, big)
    if got is not None:  # converged after all: then it must be the full, right set
        want = np.linalg.eigvals(big.A - big.B @ big.C)
        cost = np.abs(got[:, None] - want[None, :])
        r, c = linear_sum_assignment(cost)
        assert np.max(cost[r, c]) <= 1e-8 * np.max(np.abs(want))


@pytest.mark.parametrize("seed", [0, 4])
def test_margins_of_large_loops_equal_the_dense_path(seed, monkeypatch):
    sys = random_loop(260, seed)
    fast = stability_margins(sys)
    monkeypatch.setattr(_closed_loop, "MODAL_ROOTS_MIN", 10**9)
    monkeypatch.setattr(_margins, "_RTOL_GRID", 0.0)
    dense = stability_margins(sys)
    assert fast.closed_loop_unstable_poles == dense.closed_loop_unstable_poles
    np.testing.assert_allclose(fast.gain_crossovers, dense.gain_crossovers, rtol=1e-10)
    np.testing.assert_allclose(fast.phase_margins, dense.phase_margins, rtol=0, atol=1e-8)
    np.testing.assert_allclose(fast.phase_crossovers, dense.phase_crossovers, rtol=1e-10)
    np.testing.assert_allclose(fast.gain_margins, dense.gain_margins, rtol=1e-9)
