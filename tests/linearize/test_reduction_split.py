"""Tests of the unstable/stable split shared by the reductions."""

import numpy as np
import pytest

from linflex import LinearSystem, ModelError
from linflex.linearize import split_stable

from .models import spacecraft


def response(sys, w):
    """Reference: direct complex solve C (jwI - A)^-1 B + D."""
    n = sys.A.shape[0]
    return sys.C @ np.linalg.solve(1j * w * np.eye(n) - sys.A, sys.B) + sys.D


def test_spacecraft_split_rigid_part_and_response():
    sys = spacecraft().to_state_space()
    res = split_stable(sys)
    assert res.n_unstable == 2  # one rigid-body double integrator
    # the rigid part is a double integrator: both eigenvalues at 0 up to the round-off spread
    # sqrt(eps ||A||) ~ 1e-6 of a perturbed Jordan block
    assert np.max(np.abs(np.linalg.eigvals(res.unstable.A))) < 1e-5
    # eigenvalues of the stable part: those of A without the two near zero (scipy eigvals);
    # the relative 1e-9 tolerance is round-off for these well-separated modes
    ev = np.linalg.eigvals(sys.A)
    ev = np.sort_complex(ev[np.abs(ev) > 1e-5])
    ev_s = np.sort_complex(np.linalg.eigvals(res.stable.A))
    np.testing.assert_allclose(ev_s, ev, rtol=1e-9, atol=1e-10)
    # T^-1 A T is block diagonal and T^-1 T = I to round-off
    Ab = res.T_inv @ sys.A @ res.T
    assert np.max(np.abs(Ab[:2, 2:])) < 1e-10 * np.linalg.norm(sys.A, 1)
    np.testing.assert_allclose(res.T_inv @ res.T, np.eye(sys.n_states), atol=1e-12)
    # the two parts add up to the system: direct complex solve at several frequencies (rtol 1e-8:
    # both sides are round-off accurate; the lightest mode has damping 1e-4)
    for w in (0.3, 1.7, 12.0, 55.0):
        g = response(sys, w)
        np.testing.assert_allclose(response(res.unstable, w) + response(res.stable, w), g, rtol=1e-8)
    assert 1.0 <= res.condition < 1e3
    assert res.residual < 1e-13
    assert res.separation > 0.4  # lowest flexible mode at >= 0.5 rad/s, damping <= 5e-3


def test_badly_scaled_states_split():
    # orbit position in metres (1e6) next to modal coordinates (1e-3): diagonal scaling of a
    # rigid + flexible system; the split must still find the 2 rigid states and sum to the original
    base = spacecraft(n_modes=10, seed=3).to_state_space()
    s = np.logspace(-3, 6, base.n_states)
    sys = LinearSystem(base.A * s[:, None] / s[None, :], base.B * s[:, None], base.C / s[None, :])
    res = split_stable(sys)
    assert res.n_unstable == 2
    for w in (0.7, 9.0):
        np.testing.assert_allclose(response(res.unstable, w) + response(res.stable, w), response(sys, w), rtol=1e-7)


def test_all_stable_and_all_unstable():
    stable = LinearSystem(np.diag([-1.0, -2.0]), [[1.0], [1.0]], [[1.0, 1.0]], [[0.5]])
    res = split_stable(stable)
    assert res.n_unstable == 0 and res.condition == 1.0 and res.separation == np.inf
    np.testing.assert_allclose(res.stable.D, [[0.5]], rtol=0)  # D travels with the stable part
    unstable = LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]])
    res = split_stable(unstable)
    assert res.n_unstable == 2 and res.stable.n_states == 0
    # a double integrator: transfer 1/s^2, checked at s = 2j (closed form -1/4)
    np.testing.assert_allclose(response(res.unstable, 2.0), [[-0.25]], rtol=1e-14)


def test_near_threshold_rigid_tol_moves_a_mode():
    # poles at -1e-3 and -1: rigid_tol 1e-2 moves the slow pole into the "unstable" part
    sys = LinearSystem(np.diag([-1e-3, -1.0]), [[1.0], [1.0]], [[1.0, 1.0]])
    assert split_stable(sys).n_unstable == 0
    res = split_stable(sys, rigid_tol=1e-2)
    assert res.n_unstable == 1 and res.tol == 1e-2


@pytest.mark.parametrize("tol", [-1.0, np.nan, "x"])
def test_bad_rigid_tol(tol):
    with pytest.raises(ModelError, match="rigid_tol"):
        split_stable(LinearSystem([[-1.0]], [[1.0]], [[1.0]]), rigid_tol=tol)


def test_old_keyword_tol_is_gone():
    # one name for the spectrum policy's tolerance across linflex: rigid_tol
    with pytest.raises(TypeError, match="tol"):
        split_stable(LinearSystem([[-1.0]], [[1.0]], [[1.0]]), tol=1e-2)


