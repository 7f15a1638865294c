"""Margins on everyday loops (issue 16): round-off in rigid and undamped poles, crossings on grid
points, one encirclement convention."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ShapeError
from linflex.frequency import nyquist_response
from linflex.stability import stability_margins

from .stab_models import bisect, direct_response

B2 = np.array([[0.0], [1.0]])


@pytest.mark.parametrize("A", [
    [[0, 1], [0, 0]], [[0, 1], [0, 1e-16]], [[0, 1], [0, -1e-16]], [[0, 1], [-1e-16, 0]], [[0, 1], [1e-16, 0]],
])
def test_double_integrator_with_round_off(A):
    # L = (8 s + 60) / s^2 (PD on a double integrator): closed form |L(j w)| = 1 at
    # w^4 = 64 w^2 + 3600, w = 10 rad/s; PM = angle(-L(10 j)) = atan2(80, 60) = 53.130102 deg;
    # delay margin 0.9272952 / 10 s. Before issue 16: 223 crossings and PM -0.0 for 1e-16 at
    # A[1, 1], a raw LinAlgError for -1e-16 at A[1, 0].
    m = stability_margins(LinearSystem(A, B2, [[60.0, 8.0]]))
    np.testing.assert_allclose(m.gain_crossovers, [10.0], rtol=1e-12)
    np.testing.assert_allclose(m.phase_margins, [np.degrees(np.arctan2(80, 60))], rtol=1e-12)
    assert m.delay_margin == pytest.approx(np.arctan2(80, 60) / 10, rel=1e-12)
    assert m.phase_crossovers.size == 0
    assert (m.open_loop_unstable_poles, m.open_loop_imaginary_poles, m.closed_loop_unstable_poles) == (0, 2, 0)
    assert m.nyquist_encirclements == 0 and m.closed_loop_stable


def test_python_control_transfer_function_of_a_double_integrator():
    # python-control's realization of (8 s + 60) / s^2 carries a 1e-16 entry (68 crossings before)
    m = stability_margins(control.tf([8, 60], [1, 0, 0]))
    np.testing.assert_allclose(m.gain_crossovers, [10.0], rtol=1e-12)
    assert m.min_phase_margin == pytest.approx(np.degrees(np.arctan2(80, 60)), rel=1e-12)
    assert m.nyquist_encirclements == 0


@pytest.mark.parametrize("k", [3, 5, 8, 10])
def test_gain_crossover_exactly_on_a_grid_point(k):
    # L = 1 / s^k (shift matrix): |L(j w)| = 1 at w = 1 rad/s exactly, a point of every decade grid;
    # PM = angle(-(j)^-k) in (-180, 180]: -90, 90, 180, 0 deg (closed form). Before: no crossing.
    A = np.eye(k, k=1)
    Bk = np.zeros((k, 1))
    Bk[-1] = 1.0
    Ck = np.zeros((1, k))
    Ck[0, 0] = 1.0
    m = stability_margins(LinearSystem(A, Bk, Ck))
    np.testing.assert_allclose(m.gain_crossovers, [1.0], rtol=1e-12)
    pm = np.degrees(np.angle(-(1j) ** (-k)))
    pm = pm + 360 if pm <= -180 else pm
    assert m.phase_margins[0] == pytest.approx(pm, abs=1e-9)
    # closed loop s^k + 1: Z poles in the right half-plane, N = Z - P clockwise (k = 10 has a
    # closed-loop pole at j on the contour: no count)
    Z = int(np.sum(np.roots([1] + [0] * (k - 1) + [1]).real > -1e-9))  # Re >= 0, as documented
    assert m.closed_loop_unstable_poles == Z
    assert m.nyquist_encirclements == (None if k == 10 else Z)


def undamped_loop(w0: float, kp: float, kd: float, eps: float = 0.0, where: int = 0) -> LinearSystem:
    """PD (kp + kd s) on an undamped mode 1 / (s^2 + w0^2), optionally with a round-off entry."""
    A = np.array([[0.0, 1.0], [-w0**2, 0.0]])
    A[[1, 1, 0][where], [1, 0, 0][where]] += eps
    return LinearSystem(A, B2, [[kp, kd]])


def test_undamped_pole_exactly_on_a_grid_point():
    # undamped mode at exactly 1 rad/s (a grid point of every decade grid; before issue 16 a
    # LinAlgError: singular matrix). Reference: brute force, dense numpy solves on a log sweep of
    # relative step 1e-4 plus bisection.
    L = undamped_loop(1.0, 2.0, 0.5)
    m = stability_margins(L)
    resp = lambda w: direct_response(L, w)[:, 0, 0]  # noqa: E731
    x = np.arange(np.log(1.2345e-3), np.log(1e3), 1e-4)  # the sweep avoids w = 1 itself
    g = np.log(np.abs(resp(np.exp(x))))
    wgc = np.array([np.exp(bisect(lambda t: float(np.log(np.abs(resp(np.exp(t))[0]))), x[i], x[i + 1]))
                    for i in np.flatnonzero(np.sign(g[:-1]) != np.sign(g[1:]))])
    assert wgc.size == 1
    np.testing.assert_allclose(m.gain_crossovers, wgc, rtol=1e-9)
    np.testing.assert_allclose(m.phase_margins, np.degrees(np.angle(-resp(wgc))), atol=1e-7)
    assert m.open_loop_imaginary_poles == 2 and m.open_loop_unstable_poles == 0
    # closed loop s^2 + 0.5 s + 3: stable, so N = Z - P = 0
    assert m.closed_loop_stable and m.nyquist_encirclements == 0


@pytest.mark.parametrize("flip", [-2e-11, 2e-11])
def test_crossing_on_a_grid_point_whose_sign_flips_when_evaluated_again(flip):
    # the scan saw log|L| = +-1e-11 at a grid point (a crossing on it, beside an undamped pole:
    # the long property run's 0.257 / (s^2 + 1e4) in a loop under a 1e-16 perturbation, its
    # crossing at 100.00156 rad/s missed); evaluated alone the point has the other sign, so the
    # bracket to its right (or left) has no sign change: the neighbours' bracket holds the root.
    # Reference: the root of the function as evaluated, t0 + flip (closed form of a line).
    from linflex.stability._crossings import crossings

    t0 = np.log(100.0015563)
    grid = np.exp(t0 + np.array([-3e-5, -1e-5, 0.0, 3e-5, 1e-4]))
    fg = t0 - np.log(grid)
    fg[2] = -np.sign(flip) * 1e-11         # what the scan saw there
    roots = crossings(grid, fg, lambda t: t0 + flip - t, 1e-12)
    assert len(roots) == 1
    assert np.log(roots[0]) == pytest.approx(t0 + flip, abs=1e-13)


def test_touching_unit_gain_is_found_once():
    # L = 2 k / (s^2 + 2 s + 2) ... peaks of |L| touching 1: |L(j w)| = c / |2 - w^2 + 2 j w| has its
    # maximum c / 2 at w = 0 (not interior); use a lightly damped mode instead:
    # |L(jw)| = 1 / |1 - w^2 + 2 zeta j w| peaks at 1 / (2 zeta sqrt(1 - zeta^2)) at
    # w = sqrt(1 - 2 zeta^2); scaled by that peak it touches 1 exactly there (closed form).
    zeta = 0.05
    peak = 1 / (2 * zeta * np.sqrt(1 - zeta**2))
    L = LinearSystem([[0, 1], [-1, -2 * zeta]], B2, [[1 / peak, 0]])
    m = stability_margins(L)
    assert m.gain_crossovers.size == 1
    assert m.gain_crossovers[0] == pytest.approx(np.sqrt(1 - 2 * zeta**2), rel=1e-6)


def test_one_encirclement_convention():
    # L = 2 / (s - 1): P = 1, closed loop s + 1 (Z = 0): N = Z - P = -1 clockwise in both APIs
    # (before issue 16: -1 from nyquist_response, +1 from stability_margins)
    L = LinearSystem([[1.0]], [[1.0]], [[2.0]])
    assert nyquist_response(L).encirclements == stability_margins(L).nyquist_encirclements == -1


def test_bad_loops_name_the_argument():
    with pytest.raises(ShapeError, match="L must be square"):
        stability_margins(LinearSystem(-np.eye(2), np.ones((2, 2)), np.ones((1, 2))))
    with pytest.raises(ShapeError, match="L has 1 outputs and 0 inputs"):
        stability_margins(LinearSystem([[-1.0]], np.zeros((1, 0)), [[1.0]]))


def _same_margins(m, m_ref):
    np.testing.assert_allclose(m.gain_crossovers, m_ref.gain_crossovers, rtol=1e-9)
    np.testing.assert_allclose(m.phase_margins, m_ref.phase_margins, atol=1e-7)
    np.testing.assert_allclose(m.phase_crossovers, m_ref.phase_crossovers, rtol=1e-9)
    np.testing.assert_allclose(m.gain_margins, m_ref.gain_margins, rtol=1e-9)
    assert m.nyquist_encirclements == m_ref.nyquist_encirclements
    assert (m.open_loop_unstable_poles, m.closed_loop_unstable_poles) == (m_ref.open_loop_unstable_poles, m_ref.closed_loop_unstable_poles)


@settings(derandomize=True, max_examples=25, deadline=None)
@given(kp=st.floats(0.01, 100.0), kd=st.floats(0.01, 30.0), eps=st.sampled_from([1e-16, -1e-16, 3e-17, -2e-16]),
       where=st.integers(0, 2))
def test_round_off_in_a_double_integrator_does_not_change_the_margins(kp, kd, eps, where):
    # PD on a double integrator, one entry of A perturbed by rounding: the same crossings, phase
    # margins and counts as the exact loop (reference: the exact loop, itself checked in closed
    # form above)
    exact = stability_margins(undamped_loop(0.0, kp, kd))
    _same_margins(stability_margins(undamped_loop(0.0, kp, kd, eps, where)), exact)
    assert exact.gain_crossovers.size == 1


@settings(derandomize=True, max_examples=25, deadline=None)
@given(w0=st.floats(0.05, 20.0), kp=st.floats(0.01, 100.0), kd=st.floats(0.01, 30.0),
       eps=st.sampled_from([1e-16, -1e-16, 2e-16]), where=st.integers(0, 1))
def test_round_off_in_an_undamped_mode_does_not_change_the_margins(w0, kp, kd, eps, where):
    # PD on an undamped mode, rounding in A: same margins as the exact loop
    exact = stability_margins(undamped_loop(w0, kp, kd))
    _same_margins(stability_margins(undamped_loop(w0, kp, kd, eps * max(w0**2, 1.0), where)), exact)


@settings(derandomize=True, max_examples=40, deadline=None)
@given(omega=st.floats(0.5, 40.0), phase=st.floats(0.0, 6.28), n_brackets=st.integers(1, 12),
       xtol=st.sampled_from([1e-12, 1e-9]))
def test_roots_of_every_bracket_together_match_the_closed_form(omega, phase, n_brackets, xtol):
    # stability/_crossings.py: _roots refines up to BRENT_MAX brackets one by one (brentq), more
    # all together (find_root, one vectorized call per step). f(t) = sin(omega t + phase) has its
    # roots at (k pi - phase) / omega (closed form); each bracket holds one at a random place
    # within it, plus a bracket without a sign change (nan) and one ending on a root (that end).
    from linflex.stability._crossings import _roots

    rng = np.random.default_rng(int(omega * 1e6) + n_brackets)
    k = np.arange(n_brackets) + 1
    roots = (k * np.pi - phase) / omega
    a = roots - rng.uniform(0.05, 0.9, n_brackets) * np.pi / omega
    b = roots + rng.uniform(0.05, 0.9, n_brackets) * np.pi / omega
    calls = []

    def f(t):
        calls.append(np.size(t))
        return np.sin(omega * t + phase)

    got = _roots(f, a, b, xtol)
    assert np.all(np.abs(got - roots) <= 3 * (xtol * 1e-3 + xtol * np.abs(roots))), got - roots
    if n_brackets > 2:
        assert len(calls) < 20 + n_brackets  # every bracket in each step's call
    none = _roots(f, np.array([roots[0] + 0.1 / omega]), np.array([roots[0] + 0.2 / omega]), xtol)
    assert np.isnan(none[0])
    end = _roots(f, np.array([roots[0]]), np.array([roots[0] + 0.5 / omega]), xtol)
    assert end[0] == roots[0]
