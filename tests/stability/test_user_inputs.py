"""What a hurried user types into linflex.stability: the options at their edges, odd inputs.

Each test names its reference (a closed form, python-control 0.10.2, a direct complex evaluation
with scipy's brentq) and the tolerance beside each assertion.
"""

from __future__ import annotations

import control
import numpy as np
import pytest
import scipy.linalg
import scipy.optimize
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ModelError
from linflex.stability import modes, stability_margins

# (2 s + 1) / s^2: a PD loop on a unit rigid body
PD_RIGID = LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 2.0]])
# closed form: |1 + 2 j w| = w^2 gives w^4 = 4 w^2 + 1, w^2 = 2 + sqrt(5); PM = atan(2 w)
PD_RIGID_WGC = np.sqrt(2.0 + np.sqrt(5.0))
PD_RIGID_PM = np.degrees(np.arctan(2.0 * PD_RIGID_WGC))


def _pd_with_mode(zeta: float, wn: float, gain: float = 1.0) -> LinearSystem:
    """``gain (0.1 s + 0.01) / s^2 / (s^2 / wn^2 + 2 zeta s / wn + 1)``: a PD on a rigid body, then the mode."""
    A = np.array([[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0],
                  [0.0, 0.0, 0.0, 1.0], [0.0, 0.0, -wn**2, -2 * zeta * wn]])
    # series: the mode's input is the PD output y1 = 0.01 x0 + 0.1 x1, its output gain wn^2
    A[3, 0], A[3, 1] = 0.01 * wn**2, 0.1 * wn**2
    B = np.array([[0.0], [1.0], [0.0], [0.0]])
    C = np.array([[0.0, 0.0, gain, 0.0]])
    return LinearSystem(A, B, C)


def _pd_with_mode_response(w, zeta: float, wn: float, gain: float = 1.0):
    s = 1j * np.asarray(w, dtype=float)
    return gain * (0.1 * s + 0.01) / s**2 / (s**2 / wn**2 + 2 * zeta * s / wn + 1)


def test_crossing_tol_below_brents_limit_still_finds_the_crossover():
    # scipy's brentq refuses rtol < 4 eps; the refusal read as "no root in the bracket" and a
    # crossing_tol of 1e-20 returned no gain crossover at all
    m = stability_margins(PD_RIGID, crossing_tol=1e-20)
    # reference: closed form above; 1e-13 relative, the rounding of the refined root
    np.testing.assert_allclose(m.gain_crossovers, [PD_RIGID_WGC], rtol=1e-13)
    np.testing.assert_allclose(m.phase_margins, [PD_RIGID_PM], rtol=1e-12)


def test_loose_crossing_tol_does_not_merge_distinct_crossovers():
    # (2 s + 1) / s^2 (s^2/4 + 1) / (s^2/25 + 1): three gain crossovers, at 1.31, 2.79 and 14.0 rad/s
    # (python-control 0.10.2 stability_margins(returnall=True): 1.31096149, 2.78967282, 14.03518183);
    # the duplicate filter merged roots within 10 crossing_tol of each other: with 0.1 only the
    # first was left, and the worst phase margin (-100 deg) was lost
    s = control.tf("s")
    loop = (2 * s + 1) / s**2 * (s**2 / 4 + 1) / (s**2 / 25 + 1)
    ref = [1.31096149, 2.78967282, 14.03518183]
    tight = stability_margins(loop)
    np.testing.assert_allclose(tight.gain_crossovers, ref, rtol=1e-8)  # python-control, printed to 9 digits
    loose = stability_margins(loop, crossing_tol=0.1)
    assert loose.gain_crossovers.size == 3
    # each root to its tolerance in log w: |dt| <= xtol (1e-3 + |log w|), 0.1 * 2.7 at 14 rad/s
    np.testing.assert_allclose(np.log(loose.gain_crossovers), np.log(ref), atol=0.1 * (1e-3 + np.log(14.1)))
    # python-control: -100.16137289 deg; the crossover is off by up to 30 % in w, the phase by 1 deg
    assert loose.phase_margins[1] == pytest.approx(-100.16, abs=1.0)


@pytest.mark.parametrize("crossing_tol", [1e-9, 1e-6])
def test_phase_crossover_beside_a_light_mode_survives_a_loose_crossing_tol(crossing_tol):
    # a PD loop with a mode of damping 1e-3 at 1000 rad/s: phase crossover just below the mode,
    # gain margin 20 (26 dB). With crossing_tol=1e-9 the root left |Im L| / |L| at 1e-4 and the
    # test for a sign change through a pole (|Im L| / |L| <= 1e-6) dropped the crossing
    zeta, wn = 1e-3, 1000.0
    loop = _pd_with_mode(zeta, wn)
    # reference: Im L(jw) = 0 of the direct complex evaluation, by scipy's brentq to rounding
    w_ref = scipy.optimize.brentq(lambda w: _pd_with_mode_response(w, zeta, wn).imag, 990.0, 1000.0 - 1e-9,
                                  xtol=1e-13, rtol=4 * np.finfo(float).eps)
    gm_ref = -1.0 / _pd_with_mode_response(w_ref, zeta, wn).real
    assert gm_ref == pytest.approx(20.0, rel=1e-5)  # python-control 0.10.2: 19.999996 at 999.9999 rad/s
    m = stability_margins(loop, crossing_tol=crossing_tol)
    np.testing.assert_allclose(m.phase_crossovers, [w_ref], rtol=10 * crossing_tol)  # crossing_tol in log w, |log w| ~ 7
    np.testing.assert_allclose(m.gain_margins, [gm_ref], rtol=1e-6)


@pytest.mark.parametrize("max_points", [np.inf, float("nan"), 150.7, "500"])
def test_max_points_that_is_not_an_integer_is_refused(max_points):
    # int(inf) raised a bare OverflowError; 150.7 was truncated to 150 and "500" parsed silently
    with pytest.raises(ModelError, match=r"max_points must be an integer, got"):
        stability_margins(PD_RIGID, max_points=max_points)


def test_max_points_given_as_a_whole_float_is_accepted():
    m = stability_margins(PD_RIGID, max_points=1e6)
    np.testing.assert_allclose(m.gain_crossovers, [PD_RIGID_WGC], rtol=1e-12)  # closed form above


def test_disk_margins_not_searched_keep_their_skew():
    # disk_margins="multi-loop": each loop's balanced disk margin and the unstructured balanced one
    # are not searched (nan), but they are balanced (skew 0), as documented; they carried the skew
    L = control.ss(control.tf([[[1, 2], [0.5]], [[0.2], [1, 1]]], [[[1, 0, 0], [1, 1]], [[1, 3], [1, 0, 0]]]))
    m = stability_margins(L, skew=0.5, disk_margins="multi-loop")
    assert [lp.disk_margin.skew for lp in m.loops] == [0.0, 0.0]
    assert [lp.skewed_disk_margin.skew for lp in m.loops] == [0.5, 0.5]
    assert m.unstructured_disk_margin.skew == 0.0 and m.unstructured_skewed_disk_margin.skew == 0.5
    assert np.isnan(m.loops[0].disk_margin.alpha) and np.isnan(m.unstructured_disk_margin.alpha)
    # the searched multi-loop margin: python-control 0.10.2 disk_margins(L, logspace(-1, 1, 4001))
    # gives 0.62291698 (its grid: 1e-6 relative here); D-scaled bound, exact for two channels
    assert m.disk_margin.alpha == pytest.approx(0.62291698, rel=1e-6)


def test_loop_margins_compare_and_hash_by_identity():
    # LoopMargins holds arrays: the generated __eq__ compared them with ==, whose truth value numpy
    # refuses (ValueError), and __hash__ hashed them (TypeError); like StabilityMargins it is now
    # compared by identity
    a, b = stability_margins(PD_RIGID), stability_margins(PD_RIGID)
    assert a.loops[0] == a.loops[0] and a.loops[0] != b.loops[0]
    assert len({a.loops[0], b.loops[0]}) == 2


@pytest.mark.parametrize("max_states", [-1, 1.5, None, True])
def test_mode_table_markdown_refuses_a_bad_max_states(max_states):
    # max_states=-1 sliced the participation from the end (every state but the last), silently
    table = modes(LinearSystem([[0.0, 1.0], [-4.0, -0.4]], [[0.0], [1.0]]))
    with pytest.raises(ModelError, match=r"max_states must be a non-negative integer, got"):
        table.to_markdown(max_states=max_states)


def test_mode_table_markdown_lists_at_most_max_states():
    table = modes(LinearSystem([[0.0, 1.0], [-4.0, -0.4]], [[0.0], [1.0]]))
    # the mode's eigenvector: x0 and x1 = lambda x0, |lambda| = 2, so x1 is 1.00 and x0 0.50 (closed form)
    assert table.to_markdown(max_states=2).splitlines()[2].endswith("| x1 1.00, x0 0.50 |")
    assert table.to_markdown(max_states=1).splitlines()[2].endswith("| x1 1.00 |")
    assert table.to_markdown(max_states=0).splitlines()[2].endswith("|  |")


@settings(max_examples=20, deadline=None)
@given(log_tol=st.floats(-20.0, -4.0), log_zeta=st.floats(-4.0, -2.0), log_wn=st.floats(1.0, 3.0))
def test_crossings_do_not_depend_on_crossing_tol(log_tol, log_zeta, log_wn):
    # the crossings of a PD loop with a light mode, at any crossing_tol from 1e-20 to 1e-4: the
    # same gain and phase crossovers as at the default 1e-12 (each to the tolerance asked), the
    # same gain margins
    tol, zeta, wn = 10.0**log_tol, 10.0**log_zeta, 10.0**log_wn
    loop = _pd_with_mode(zeta, wn)
    ref, got = stability_margins(loop), stability_margins(loop, crossing_tol=tol)
    assert got.gain_crossovers.size == ref.gain_crossovers.size
    assert got.phase_crossovers.size == ref.phase_crossovers.size
    # crossing_tol bounds the error in log w by tol (1e-3 + |log w|), |log w| <= 7 here
    step = 8.0 * max(tol, 1e-12) * (1e-3 + 7.0)
    np.testing.assert_allclose(np.log(got.gain_crossovers), np.log(ref.gain_crossovers), atol=step)
    np.testing.assert_allclose(np.log(got.phase_crossovers), np.log(ref.phase_crossovers), atol=step)
    # phase crossovers are polished to rounding when the test of |Im L| / |L| needs it; the gain
    # margin is -1 / L there, flat in w to first order: 1e-6 relative
    np.testing.assert_allclose(got.gain_margins, ref.gain_margins, rtol=1e-6)


@pytest.mark.parametrize(("gain", "skew"), [(1.0, 0.0), (0.0, -1.0)])
def test_static_loop_with_an_infinite_disk_margin_tolerates_every_gain_and_phase(gain, skew):
    # L = 1 (skew 0) and L = 0 (skew -1): S + (skew - 1)/2 vanishes, alpha = inf; the gain range
    # and phase were (nan, inf) and nan (inf * 0 in Seiler, Packard and Gahinet's formulas). Their
    # limit as alpha -> inf: gamma_min -> 0, gamma_max -> inf and, at skew 0, 2 atan(alpha / 2) -> 180 deg
    loop = LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[gain]])
    dm = stability_margins(loop, skew=skew).skewed_disk_margin
    assert dm.alpha == np.inf
    assert dm.gain_margin == (0.0, np.inf) and dm.phase_margin == 180.0  # exact limits


def test_finite_disk_margin_of_a_static_loop_matches_the_closed_form():
    # L = 0.2, skew 0: alpha = 1 / |S - 1/2| = 1 / |1/1.2 - 1/2| = 3; phase 2 atan(3/2) [deg];
    # gamma_max = (2 + alpha) / (2 - alpha) < 0: every gain increase, gamma_min = max(0, (2 - 3)/(2 + 3))
    loop = LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[0.2]])
    dm = stability_margins(loop).disk_margin
    assert dm.alpha == pytest.approx(3.0, rel=1e-14)  # rounding of 1 / (1/1.2 - 0.5)
    assert dm.phase_margin == pytest.approx(np.degrees(2 * np.arctan(1.5)), rel=1e-12)
    assert dm.gain_margin == (0.0, np.inf)


def _three_axes(closed: tuple[int, ...], yaw: np.ndarray | None = None) -> LinearSystem:
    """Three unit rigid axes (roll, pitch, yaw), the PD loop (2 s + 1) / s^2 closed on ``closed``
    only; ``yaw``: another 2x2 block for the yaw axis."""
    Z = np.array([[0.0, 1.0], [0.0, 0.0]])
    blocks = [Z, Z, Z if yaw is None else yaw]
    A = scipy.linalg.block_diag(*blocks)
    B, C = np.zeros((6, len(closed))), np.zeros((len(closed), 6))
    for k, axis in enumerate(closed):
        B[2 * axis + 1, k] = 1.0
        C[k, 2 * axis:2 * axis + 2] = [1.0, 2.0]
    return LinearSystem(A, B, C)


@pytest.mark.parametrize("closed", [(0,), (0, 1)])
def test_rigid_axes_outside_the_loop_are_hidden_not_unstable(closed):
    # the roll loop of a three-axis model (or roll and pitch): the open axes' double integrators
    # are closed-loop poles at 0 that no feedback moves (reported unstable, disk margin 0, and a
    # Nyquist-count warning before); reference: the same loop without the other axes
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = stability_margins(_three_axes(closed))
    alone = stability_margins(PD_RIGID)
    assert m.closed_loop_stable and m.closed_loop_unstable_poles == 0
    np.testing.assert_array_equal(m.hidden_poles, np.zeros(2 * (3 - len(closed))))
    # equal to rounding: the loops are the same transfer functions
    np.testing.assert_allclose(m.loops[0].phase_margins, alone.phase_margins, rtol=1e-12)
    np.testing.assert_allclose(m.disk_margin.alpha, alone.disk_margin.alpha, rtol=1e-9)
    assert m.nyquist_encirclements == 0


def test_an_unstable_mode_outside_the_loop_still_makes_the_closed_loop_unstable():
    # a disconnected pole at +1 is hidden from the loop but grows: internal instability counts
    m = stability_margins(_three_axes((0,), yaw=np.array([[1.0, 0.0], [0.0, -1.0]])))
    assert m.closed_loop_unstable_poles >= 1 and not m.closed_loop_stable
