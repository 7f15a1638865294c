"""Tests of linflex.stability.stability_margins.

References are named at each assertion: python-control's published margin cases
(control/tests/margin_test.py, python-control 0.10.2), closed forms, and brute-force sweeps with
direct complex solves plus bisection done here.
"""

from __future__ import annotations

import dataclasses

import control
import numpy as np
import pytest

from linflex import LinearSystem, ModelError, SecondOrderSystem, ShapeError
from linflex.frequency import nyquist_response
from linflex.stability import stability_margins

from .stab_models import brute_force_crossovers, direct_response, gyro_loop, hub_loop, hub_loop_response

s = control.tf("s")

# python-control margin_test.py, fixture ``tsys`` (returnall results) and ``test_zmore_*``:
# (system, gain margins, phase margins, phase crossovers, gain crossovers, tolerance of the
# published values, which are rounded to 4-5 significant digits)
PYTHON_CONTROL_CASES = {
    "lightly_damped_sys4": (
        (8.75 * (4 * s**2 + 0.4 * s + 1)) / ((100 * s + 1) * (s**2 + 0.22 * s + 1)) / (s**2 / 10.0**2 + 2 * 0.04 * s / 10.0 + 1),
        [2.2716], [97.5941, -157.7844, 134.7359], [10.0053], [0.0850, 0.9373, 1.0919], 1e-4,
    ),
    "third_order": (control.tf([1], [1, 2, 3, 4]), [2.0], [], [1.7321], [], 1e-4),
    "unstable_ss": (control.ss([[1.0, 4.0], [3.0, 2.0]], [[1.0], [-4.0]], [[1.0, 0.0]], [[0.0]]),
                    [], [147.0743], [], [2.5483], 1e-4),
    "non_minimum_phase": (0.01 * (10 - s) / (2 + s) / (1 + s), [300.0], [], [5.6569], [], 1e-4),
    "no_crossings": (1 / (1 + s), [], [], [], [], 1e-4),
    "type2": ((s + 0.1) / s**2 / (s + 1), [], [44.4594], [], [0.7907], 1e-4),
    "type3": ((s + 0.1) * (s + 0.1) / s**3 / (s + 1), [0.0625], [37.1748], [0.1118], [0.7951], 1e-4),
    "typem1_K2": (2 * s / (s + 1), [], [-120.0007], [], [0.5774], 1e-3),
    "type1": ((s + 0.1) / s / (s + 1), [], [144.9032], [], [0.3162], 1e-4),
    "type0_K2": (2 / (s + 1) ** 3, [4.0], [67.6058], [1.7322], [0.7663], 1e-4),
    "biproper_no_crossings": (3 * (10 + s) / (2 + s), [], [], [], [], 1e-4),
    "example21": (
        0.002 * (s + 0.02) * (s + 0.05) * (s + 5) * (s + 10)
        / ((s - 0.0005) * (s + 0.0001) * (s + 0.01) * (s + 0.2) * (s + 1) * (s + 100) ** 2),
        [0.01, 179.2931, 2.2798e4, 1.5946e7, 7.2477e8], [-14.5640], [0, 0.0243, 0.4385, 6.8640, 84.9323], [0.0022],
        1e-3,
    ),
}


@pytest.mark.parametrize("name", list(PYTHON_CONTROL_CASES))
def test_python_control_published_cases(name):
    sys, gm, pm, wpc, wgc, tol = PYTHON_CONTROL_CASES[name]
    m = stability_margins(control.ss(sys))
    # reference: python-control margin_test.py values, published rounded to 4 decimals (or 5
    # significant digits for large gain margins) and asserted there with atol 1.5e-3 (test_margin_sys);
    # we use the same atol and rtol = 1e-4 for the large gain margins
    # (example21 is published from test_zmore_stability_margins, asserted there with rtol 1e-3)
    np.testing.assert_allclose(m.gain_margins, gm, rtol=tol, atol=1.5e-3)
    np.testing.assert_allclose(m.phase_margins, pm, rtol=tol, atol=1.5e-3)
    np.testing.assert_allclose(m.phase_crossovers, wpc, rtol=tol, atol=1.5e-3 * (0.1 if name == "example21" else 1))
    np.testing.assert_allclose(m.gain_crossovers, wgc, rtol=tol, atol=1.5e-3 * (0.1 if name == "example21" else 1))
    # evaluation_error is an a-posteriori bound (frequency/_evaluate.py): below the 1e-4 warning
    # level; on example21 (poles from 5e-4 to 1e4 rad/s^2, crossing at 2.2e-3 rad/s next to the
    # slow unstable pole) it is 2e-7, elsewhere below 1e-12
    assert m.evaluation_error < (1e-6 if name == "example21" else 1e-10)


def test_python_control_returnall_agrees_on_well_conditioned_cases():
    # Reference: python-control stability_margins(returnall=True) on the same low-order loops
    # (polynomial based, accurate at this order): all crossings to 1e-8 relative.
    for name in ("lightly_damped_sys4", "third_order", "non_minimum_phase", "type3"):
        sys = PYTHON_CONTROL_CASES[name][0]
        gm, pm, _, wpc, wgc, _ = control.stability_margins(sys, returnall=True)
        m = stability_margins(control.ss(sys))
        np.testing.assert_allclose(m.gain_crossovers, wgc, rtol=1e-8)
        np.testing.assert_allclose(m.phase_margins, pm, rtol=1e-8)
        np.testing.assert_allclose(m.phase_crossovers, wpc, rtol=1e-8)
        np.testing.assert_allclose(m.gain_margins, gm, rtol=1e-8)


def test_minimum_margins_of_lightly_damped_loop():
    # Reference: python-control margin_test.py tsys, stability_margins(sys) (not returnall):
    # gm 2.2716 at 10.0053 rad/s, pm 97.5941 at 0.0850 rad/s (the smallest |pm|).
    m = stability_margins(control.ss(PYTHON_CONTROL_CASES["lightly_damped_sys4"][0]))
    assert m.min_gain_margin == pytest.approx(2.2716, abs=1e-4)
    assert m.min_gain_margin_frequency == pytest.approx(10.0053, abs=1e-4)
    assert m.min_phase_margin == pytest.approx(97.5941, abs=1.5e-3)  # published tolerance
    assert m.min_phase_margin_frequency == pytest.approx(0.0850, abs=1e-4)
    assert m.gain_increase_margin == pytest.approx(2.2716, abs=1e-4)
    assert m.gain_reduction_margin == 0.0
    assert m.min_gain_margin_db == pytest.approx(20 * np.log10(2.27158587), abs=1e-6)
    np.testing.assert_allclose(m.gain_margins_db, 20 * np.log10(m.gain_margins), rtol=1e-14)


def test_third_order_closed_form():
    # Reference: closed form for 1/(s^3 + 2 s^2 + 3 s + 4): Im L = 0 at w = sqrt(3), where
    # L = 1/(4 - 2*3) = -1/2, so the gain margin is exactly 2.
    m = stability_margins(control.ss(control.tf([1], [1, 2, 3, 4])))
    assert m.phase_crossovers[0] == pytest.approx(np.sqrt(3), rel=1e-12)
    assert m.gain_margins[0] == pytest.approx(2.0, rel=1e-12)
    assert m.gain_crossovers.size == 0 and m.min_phase_margin == np.inf and m.delay_margin == np.inf


def test_double_integrator_pd_no_spurious_gain_margin():
    # Reference: closed form for L = (kd s + kp)/s^2: |L| = 1 at w^2 = (kd^2 + sqrt(kd^4 + 4 kp^2))/2,
    # PM = atan(kd w / kp). The phase is exactly -180 deg as w -> 0, which is not a crossing:
    # no gain margin at zero frequency (python-control reports a spurious one, issue 8).
    kp, kd = 2.0, 1.5
    L = LinearSystem([[0, 1], [0, 0]], [[0], [1]], [[kp, kd]])
    m = stability_margins(L)
    w = np.sqrt((kd**2 + np.sqrt(kd**4 + 4 * kp**2)) / 2)
    np.testing.assert_allclose(m.gain_crossovers, [w], rtol=1e-12)
    np.testing.assert_allclose(m.phase_margins, [np.degrees(np.arctan(kd * w / kp))], rtol=1e-11)
    assert m.phase_crossovers.size == 0 and m.gain_margins.size == 0
    assert m.min_gain_margin == np.inf and m.gain_increase_margin == np.inf and m.gain_reduction_margin == 0.0
    assert m.open_loop_imaginary_poles == 2 and m.open_loop_unstable_poles == 0 and m.closed_loop_stable
    # delay margin closed form: PM [rad] / w
    assert m.delay_margin == pytest.approx(np.arctan(kd * w / kp) / w, rel=1e-11)


def test_unstable_open_loop_closed_form():
    # Reference: closed form for L = 2/(s - 1): |L| = 1 at w = sqrt(3), angle L = -120 deg so
    # PM = 60 deg; L(0) = -2 is a phase crossover at w = 0 with gain margin 1/2 (a gain
    # reduction margin). One open-loop RHP pole, closed-loop pole at -1: Nyquist encircles -1
    # once counterclockwise (argument principle: N = P - Z = 1).
    m = stability_margins(LinearSystem([[1.0]], [[1.0]], [[2.0]]))
    np.testing.assert_allclose(m.gain_crossovers, [np.sqrt(3)], rtol=1e-12)
    np.testing.assert_allclose(m.phase_margins, [60.0], rtol=1e-11)
    np.testing.assert_allclose(m.phase_crossovers, [0.0], atol=0)
    np.testing.assert_allclose(m.gain_margins, [0.5], rtol=1e-14)
    assert m.gain_reduction_margin == pytest.approx(0.5, rel=1e-14) and m.gain_increase_margin == np.inf
    assert m.delay_margin == pytest.approx(np.pi / 3 / np.sqrt(3), rel=1e-11)
    # the encirclement count is measured on the curve (phase of 1 + L tracked along the contour);
    # clockwise, N = Z - P (the convention of linflex.frequency.nyquist_response too)
    assert (m.open_loop_unstable_poles, m.closed_loop_unstable_poles, m.nyquist_encirclements) == (1, 0, -1)
    assert nyquist_response(LinearSystem([[1.0]], [[1.0]], [[2.0]])).encirclements == m.nyquist_encirclements
    assert m.closed_loop_stable and m.disk_margin.alpha > 0


def test_unstable_closed_loop_still_reports_margins():
    # Reference: python-control margin_test.py (StateSpace case): pm 147.0743 at 2.5483 rad/s;
    # the closed loop is unstable (eigenvalues of A - B C): margins are still reported and the
    # disk margin is 0 by definition.
    sys = control.ss([[1.0, 4.0], [3.0, 2.0]], [[1.0], [-4.0]], [[1.0, 0.0]], [[0.0]])
    m = stability_margins(sys)
    assert m.phase_margins[0] == pytest.approx(147.0743, abs=1e-4)
    cl = np.linalg.eigvals(sys.A - sys.B @ sys.C)
    assert not m.closed_loop_stable and m.closed_loop_unstable_poles == int(np.sum(cl.real > 0))
    assert m.open_loop_unstable_poles == 1 and m.nyquist_encirclements == m.closed_loop_unstable_poles - 1 == 0
    assert m.disk_margin.alpha == 0.0 and m.disk_margin.gain_margin == (1.0, 1.0)


def test_delay_margin_brings_loop_to_minus_one():
    # Reference: definition. At the critical crossing, L(jw) exp(-j w tau) = -1 for tau = the
    # delay margin; checked here on the lightly damped loop (including a negative PM crossing).
    sys = control.ss(PYTHON_CONTROL_CASES["lightly_damped_sys4"][0])
    m = stability_margins(sys)
    for w, tau in zip(m.gain_crossovers, m.delay_margins):
        val = control.evalfr(sys, 1j * w) * np.exp(-1j * w * tau)
        assert abs(val + 1) < 1e-9
    # smallest over the crossings of (PM mod 360)/w from the published PMs and crossovers:
    # 134.7359 deg at 1.0919 rad/s (the -157.78 deg crossing needs 202.2 deg of lag)
    assert m.delay_margin == pytest.approx(np.radians(134.7359) / 1.0919, rel=2e-4)


# ------------------------------------------------------------------ disk margins


def test_disk_margin_published_and_sensitivity_peak():
    # Reference: python-control margin_test.py test_siso_disk_margin, L = 25/(s^3 + 10 s^2 + 10 s + 10):
    # balanced disk margin 0.46, 4.05 dB, 25.8 deg (published with atol 0.1); with skew 1 the disk
    # margin is 1/||S||_inf, python-control's stability margin sm (0.40214586 here, computed below).
    L = control.tf(25, [1, 10, 10, 10])
    m = stability_margins(control.ss(L), skew=1.0)
    dm = m.disk_margin
    assert dm.alpha == pytest.approx(0.46, abs=0.005)
    assert dm.gain_margin_db[1] == pytest.approx(4.05, abs=0.01)
    assert dm.phase_margin == pytest.approx(25.8, abs=0.01)
    sm = control.stability_margins(L)[2]
    assert m.skewed_disk_margin.alpha == pytest.approx(sm, rel=1e-7)
    # brute force: |S + (sigma - 1)/2| on a dense grid by direct evaluation; the refined peak is
    # at least the grid maximum and within 1e-6 of it (the grid step is 1e-4 relative)
    w = np.geomspace(0.1, 100, 70000)
    Lw = control.evalfr(L, 1j * w) if False else L(1j * w)
    for skew, disk in ((0.0, m.disk_margin), (1.0, m.skewed_disk_margin)):
        peak = np.max(np.abs(1 / (1 + Lw) + (skew - 1) / 2))
        assert 1 / disk.alpha >= peak * (1 - 1e-12)
        assert 1 / disk.alpha == pytest.approx(peak, rel=1e-6)


@pytest.mark.parametrize("alpha, skew", [(0.46, 0.0), (0.3, 0.5), (0.9, -0.4), (1.5, 1.0)])
def test_disk_gain_and_phase_ranges(alpha, skew):
    # Reference: Seiler, Packard, Gahinet (2020), the disk {(1 + (1-s)/2 d)/(1 - (1+s)/2 d): |d| <= a}.
    # Its real-axis end points are the gain range; its phase margin is the largest angle of a unit
    # modulus point in the disk, checked here by sampling the disk boundary independently.
    from linflex.stability._disk import _disk

    dm = _disk(alpha, skew, 1.0, "siso")
    d = alpha * np.exp(1j * np.linspace(0, 2 * np.pi, 200001))
    f = (1 + (1 - skew) / 2 * d) / (1 - (1 + skew) / 2 * d)
    real = f[np.abs(f.imag) < 1e-3 * np.abs(f)].real
    real = real[real > 0]  # gain margins are positive gains (a disk through infinity also holds negatives)
    assert dm.gain_margin[0] == pytest.approx(real.min(), rel=1e-5)
    if np.isfinite(dm.gain_margin[1]):
        assert dm.gain_margin[1] == pytest.approx(real.max(), rel=1e-5)
    near_unit = np.abs(np.abs(f) - 1) < 1e-4
    assert dm.phase_margin == pytest.approx(np.degrees(np.max(np.abs(np.angle(f[near_unit])))), abs=0.02)
    if skew == 0:
        # closed forms for the balanced disk: gain (2 + a)/(2 - a), phase 2 atan(a/2)
        assert dm.gain_margin[1] == pytest.approx((2 + alpha) / (2 - alpha), rel=1e-14)
        assert dm.phase_margin == pytest.approx(np.degrees(2 * np.arctan(alpha / 2)), rel=1e-12)


def _assert_disk_within_classical(lp):
    # A disk margin never exceeds the classical margins (the disk contains only perturbations
    # the loop tolerates; a classical margin is a perturbation it does not).
    for dm in (lp.disk_margin, lp.skewed_disk_margin):
        lo, hi = dm.gain_margin
        assert hi <= lp.gain_increase_margin * (1 + 1e-9)
        assert lo >= lp.gain_reduction_margin * (1 - 1e-9)
        if lp.phase_margins.size:
            assert dm.phase_margin <= np.min(np.abs(lp.phase_margins)) + 1e-9


@pytest.mark.parametrize("name", ["lightly_damped_sys4", "third_order", "non_minimum_phase", "type2", "type3", "type1"])
def test_disk_margin_never_exceeds_classical_python_control_cases(name):
    m = stability_margins(control.ss(PYTHON_CONTROL_CASES[name][0]), skew=0.5)
    assert m.closed_loop_stable
    _assert_disk_within_classical(m.loops[0])


def test_disk_margin_interior_gains_keep_loop_stable():
    # Reference: eigenvalues of the closed loop A - k B C for real gains k just inside the disk's
    # gain range (the disk guarantees stability there).
    sys = control.ss(PYTHON_CONTROL_CASES["lightly_damped_sys4"][0])
    m = stability_margins(sys, skew=0.3)
    for dm in (m.disk_margin, m.skewed_disk_margin):
        lo, hi = dm.gain_margin
        for k in (lo * (1 + 1e-6), hi * (1 - 1e-6)):
            assert np.max(np.linalg.eigvals(sys.A - k * sys.B @ sys.C).real) < 0


# ------------------------------------------------------------------ hard cases: flexible loops

HUB_CASES = [(order, zeta) for order in (51, 101, 201, 401) for zeta in (0.005, 0.0005)]


@pytest.mark.parametrize("order, zeta", HUB_CASES)
def test_hub_plus_appendage_every_gain_crossover(order, zeta):
    L = hub_loop(order, zeta)
    m = stability_margins(L)
    resp = lambda w: hub_loop_response(w, order, zeta)  # noqa: E731
    # the closed-form response used by the brute force is itself checked against dense complex
    # solves C (jw I - A)^-1 B (reference) at a few frequencies
    wchk = np.array([0.05, 0.9, 7.0, 60.0])
    np.testing.assert_allclose(resp(wchk), direct_response(L, wchk)[:, 0, 0], rtol=1e-10)
    # brute force: uniform log sweep with steps of zeta/5 (five points per half-power band of the
    # sharpest resonance) over 1e-2..1e4 rad/s, then bisection
    wgc, wpc = brute_force_crossovers(resp, 1e-2, 1e4, zeta / 5)
    assert m.gain_crossovers.size == wgc.size  # every crossing found, none spurious
    np.testing.assert_allclose(m.gain_crossovers, wgc, rtol=1e-9)  # bisection to ~1e-16 in log w
    assert m.phase_crossovers.size == wpc.size == 0  # collocated PD: phase stays above -180
    pm_ref = np.degrees(np.angle(-resp(wgc)))
    assert m.min_phase_margin == pytest.approx(pm_ref[np.argmin(np.abs(pm_ref))], abs=0.01)  # issue 8
    np.testing.assert_allclose(m.phase_margins, pm_ref, atol=1e-6)
    assert m.open_loop_imaginary_poles == 2 and m.closed_loop_stable
    # a-posteriori bound at the crossings (eps ||A|| mapped through the conditioning of L there,
    # frequency/_evaluate.py): measured at most 2e-8 at the resonances, far below the 1e-4 warning
    assert m.evaluation_error < 1e-7
    _assert_disk_within_classical(m.loops[0])


@pytest.mark.parametrize("order, zeta", [(51, 0.0005), (201, 0.005), (401, 0.0005)])
def test_hub_with_rolloff_every_phase_crossover(order, zeta):
    # A roll-off filter makes the loop cross -180 deg at many appendage modes.
    L = hub_loop(order, zeta, rolloff=True)
    m = stability_margins(L)
    resp = lambda w: hub_loop_response(w, order, zeta, rolloff=True)  # noqa: E731
    wgc, wpc = brute_force_crossovers(resp, 1e-2, 1e4, zeta / 5)
    assert m.gain_crossovers.size == wgc.size and m.phase_crossovers.size == wpc.size > 5
    np.testing.assert_allclose(m.gain_crossovers, wgc, rtol=1e-9)
    np.testing.assert_allclose(m.phase_crossovers, wpc, rtol=1e-9)
    np.testing.assert_allclose(m.gain_margins, -1 / resp(wpc).real, rtol=1e-7)
    gm_ref = -1 / resp(wpc).real
    assert m.min_gain_margin == pytest.approx(gm_ref[np.argmin(np.abs(np.log(gm_ref)))], rel=1e-7)


def test_badly_scaled_states_same_margins():
    # Reference: a diagonal similarity (state scales 1e-6 .. 1e6) leaves L(s) unchanged, so the
    # crossings must not move.
    L = hub_loop(51, 0.0005)
    sc = np.geomspace(1e-6, 1e6, 51)
    Ls = LinearSystem((L.A * sc[:, None]) / sc[None, :], L.B * sc[:, None], L.C / sc[None, :], L.D)
    m0, m1 = stability_margins(L), stability_margins(Ls)
    # crossings of lightly damped resonances are ill-conditioned in w: a relative perturbation of
    # L by e moves them by about e / (d log|L| / d log w); 1e-8 covers e ~ 1e-12 from the scaling.
    # The phase changes by about 1/zeta rad per unit relative frequency there (2000 at zeta 5e-4),
    # so the phase margins agree to ~1e-4 deg (still 100 times inside the 0.01 deg requirement).
    np.testing.assert_allclose(m1.gain_crossovers, m0.gain_crossovers, rtol=1e-8)
    np.testing.assert_allclose(m1.phase_margins, m0.phase_margins, atol=1e-4)
    assert m1.disk_margin.alpha == pytest.approx(m0.disk_margin.alpha, rel=1e-7)


def test_damping_1e4_single_mode_resonance_crossings():
    # A collocated mode with damping 1e-4 whose resonance lifts |L| above 1 far beyond the
    # bandwidth: two extra crossings within a few zeta*w of 20 rad/s. Reference: brute force.
    zeta, wf, g = 1e-4, 20.0, 0.005
    A = np.array([[0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1], [0, 0, -wf**2, -2 * zeta * wf]])
    B = np.array([[0], [1], [0], [np.sqrt(g)]])
    C = np.array([[1.0, 1.4, 1.0 * np.sqrt(g), 1.4 * np.sqrt(g)]])
    m = stability_margins(LinearSystem(A, B, C))

    def resp(w):
        s_ = 1j * np.atleast_1d(w)
        return (1 + 1.4 * s_) * (1 / s_**2 + g / (s_**2 + 2 * zeta * wf * s_ + wf**2))

    wgc, _ = brute_force_crossovers(resp, 1e-2, 1e3, zeta / 5)
    assert wgc.size == 3
    np.testing.assert_allclose(m.gain_crossovers, wgc, rtol=1e-9)


# ------------------------------------------------------------------ MIMO


def _loop_at_a_time_direct(L: LinearSystem, i: int, w):
    """L_i = L_ii - L_io (I + L_oo)^-1 L_oi from dense complex solves of the full L (reference)."""
    G = direct_response(L, w)
    o = [j for j in range(L.n_inputs) if j != i]
    Loo = G[:, o][:, :, o]
    corr = G[:, [i]][:, :, o] @ np.linalg.solve(np.eye(len(o)) + Loo, G[:, o][:, :, [i]])
    return (G[:, [i]][:, :, [i]] - corr)[:, 0, 0]


def test_mimo_gyroscopic_loop_at_a_time():
    L = gyro_loop()
    m = stability_margins(L)
    assert m.channels == ("Tx", "Ty", "Tz") and len(m.loops) == 3
    # rigid body: three attitude integrators plus the zero of the gyroscopic rate dynamics; the
    # nutation pair is on the imaginary axis (undamped)
    assert m.open_loop_imaginary_poles == 6 and m.open_loop_unstable_poles == 0 and m.closed_loop_stable
    for i, lp in enumerate(m.loops):
        resp = lambda w, i=i: _loop_at_a_time_direct(L, i, w)  # noqa: E731
        wgc, wpc = brute_force_crossovers(resp, 1e-3, 1e3, 2e-4)
        np.testing.assert_allclose(lp.gain_crossovers, wgc, rtol=1e-9)
        np.testing.assert_allclose(lp.phase_crossovers, wpc, rtol=1e-9)
        np.testing.assert_allclose(lp.phase_margins, np.degrees(np.angle(-resp(wgc))), atol=1e-7)
        _assert_disk_within_classical(lp)
        # single-channel perturbations are a special case of the multi-loop ones
        assert lp.disk_margin.alpha >= m.disk_margin.alpha * (1 - 1e-9)
    assert m.min_phase_margin == min((lp.min_phase_margin for lp in m.loops), key=abs)
    assert m.delay_margin == min(lp.delay_margin for lp in m.loops)
    with pytest.raises(ShapeError, match="SISO accessor but this loop has 3 channels"):
        m.gain_crossovers


def _mu_lower_bound(M):
    """max over diagonal unitary U = diag(1, e^{j t1}, ...) of the spectral radius of U M."""
    import scipy.optimize

    m = M.shape[0]

    def rho(t):
        return float(np.max(np.abs(np.linalg.eigvals(np.diag(np.exp(1j * np.concatenate([[0.0], t]))) @ M))))

    grid = np.linspace(0, 2 * np.pi, 73)[:-1]
    pts = np.array(np.meshgrid(*[grid] * (m - 1))).reshape(m - 1, -1).T
    best = max(pts, key=rho)
    res = scipy.optimize.minimize(lambda t: -rho(t), best, method="Nelder-Mead",
                                  options={"xatol": 1e-12, "fatol": 1e-15, "maxiter": 5000})
    return max(rho(best), -res.fun)


def test_mimo_multiloop_disk_margin_brute_force_and_python_control():
    # Reference 1: sigma_max(S + (sigma-1)/2 I) on a dense grid from dense complex solves.
    # Reference 2: python-control disk_margins (slycot ab13md, a mu upper bound for diagonal
    # perturbations) on the same grid: the unstructured margin is a lower bound of it, and the
    # structured margin is a lower bound of every loop-at-a-time margin.
    L = gyro_loop()
    m = stability_margins(L, skew=0.4)
    w = np.geomspace(1e-3, 1e2, 40000)
    S = np.linalg.inv(np.eye(3) + direct_response(L, w))
    for skew, dm in ((0.0, m.unstructured_disk_margin), (0.4, m.unstructured_skewed_disk_margin)):
        peak = np.linalg.svd(S + (skew - 1) / 2 * np.eye(3), compute_uv=False)[:, 0].max()
        assert dm.structure == "unstructured"
        assert 1 / dm.alpha >= peak * (1 - 1e-12)
        assert 1 / dm.alpha == pytest.approx(peak, rel=1e-6)
    # structured (diagonal) margin: unstructured <= structured <= every loop-at-a-time margin
    assert m.unstructured_disk_margin.alpha <= m.disk_margin.alpha <= min(lp.disk_margin.alpha for lp in m.loops)
    assert m.disk_margin.structure == "diagonal"
    # Reference 3: mu of scalar complex blocks is max over diagonal unitary U of rho(U M) (a lower
    # bound for any U; Doyle 1982); for three blocks the D-scaled upper bound equals mu, so
    # maximizing rho over two phases at the reported peak must reproduce 1/alpha
    for skew, dm in ((0.0, m.disk_margin), (0.4, m.skewed_disk_margin)):
        M = np.linalg.inv(np.eye(3) + direct_response(L, [dm.frequency])[0]) + (skew - 1) / 2 * np.eye(3)
        assert 1 / dm.alpha == pytest.approx(_mu_lower_bound(M), rel=1e-6)
    pytest.importorskip("slycot")
    # Reference 4: python-control disk_margins (SLICOT ab13md mu upper bound) on a grid
    wpc = np.geomspace(1e-2, 1e1, 1500)  # covers the peak near 0.65 rad/s
    for skew, dm in ((0.0, m.disk_margin), (0.4, m.skewed_disk_margin)):
        dm_pc = control.disk_margins(L.to_control(), wpc, skew=skew)[0]
        assert dm.alpha == pytest.approx(dm_pc, rel=1e-3)  # ab13md's bound is a little looser


def test_spinning_satellite_disk_margin_published():
    # Reference: python-control margin_test.py test_mimo_disk_margin (Doyle's spinning
    # satellite, loop broken at the plant output): structured balanced disk margin 0.3754,
    # 3.3 dB, 21.26 deg; the unstructured margin equals 1/max sigma_max(S - I/2) by brute force
    # (direct solves on a dense grid; the grid misses the poles at +-10j).
    P = control.ss([[0, 10], [-10, 0]], np.eye(2), [[1, 10], [-10, 1]], 0)
    K = control.ss([], [], [], [[1, -2], [0, 1]])
    L = LinearSystem.from_control(P * K)
    m = stability_margins(L)
    w = np.concatenate([[0.0], np.geomspace(1e-3, 1e3, 40001)])
    S = np.linalg.inv(np.eye(2) + direct_response(L, w))
    peak = np.linalg.svd(S - 0.5 * np.eye(2), compute_uv=False)[:, 0].max()
    assert m.unstructured_disk_margin.alpha == pytest.approx(1 / peak, rel=1e-6)
    assert m.unstructured_disk_margin.alpha <= m.disk_margin.alpha
    # exact structured value: for two blocks mu = max_U rho(U M) (computed independently at the
    # peak, w = 0); the published values come from a grid starting at 0.1 rad/s (python-control
    # itself gives 0.3770 there) and are asserted there with atol 0.1, here with 1e-3 / 0.05 deg
    assert m.disk_margin.frequency == 0.0  # published: peak at the lowest frequency
    M0 = np.linalg.inv(np.eye(2) + direct_response(L, [0.0])[0]) - 0.5 * np.eye(2)
    assert m.disk_margin.alpha == pytest.approx(1 / _mu_lower_bound(M0), rel=1e-9)
    assert m.disk_margin.alpha == pytest.approx(0.3754, abs=1e-3)
    assert m.disk_margin.gain_margin_db[1] == pytest.approx(3.3, abs=0.02)
    assert m.disk_margin.phase_margin == pytest.approx(21.26, abs=0.05)


# ------------------------------------------------------------------ inputs and results


def test_accepts_second_order_system_and_control():
    # Reference: the same loop in three containers gives identical crossings.
    M, Dm, K = np.eye(1), np.array([[0.4]]), np.array([[4.0]])
    so = SecondOrderSystem(M, Dm, K, [[1.0]], Cq=[[3.0]], Cv=[[1.0]])
    m1 = stability_margins(so)
    m2 = stability_margins(so.to_control())
    m3 = stability_margins(so.to_state_space())
    for m in (m2, m3):
        np.testing.assert_allclose(m.gain_crossovers, m1.gain_crossovers, rtol=1e-12)
        np.testing.assert_allclose(m.phase_margins, m1.phase_margins, rtol=1e-12)


def test_result_is_frozen_and_read_only():
    m = stability_margins(control.ss(PYTHON_CONTROL_CASES["lightly_damped_sys4"][0]))
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.disk_margin = None
    with pytest.raises(ValueError):
        m.gain_crossovers[0] = 1.0
    text = str(m)
    assert "-157.7845" in text and "gain margin 2.2716" in text
    assert m.n_evaluations > m.grid_size > 100 and m.seconds > 0


def test_bad_input():
    with pytest.raises(ShapeError, match="L must be square .* it has 2 outputs and 1 inputs"):
        stability_margins(LinearSystem([[-1.0]], [[1.0]], [[1.0], [2.0]]))
    with pytest.raises(ModelError, match="L must be a LinearSystem"):
        stability_margins(np.eye(2))
    with pytest.raises(ModelError, match=r"skew must be in \[-1, 1\], got 2"):
        stability_margins(LinearSystem([[-1.0]], [[1.0]], [[1.0]]), skew=2)
    with pytest.raises(ModelError, match="I \\+ D is singular"):
        stability_margins(LinearSystem([[-1.0]], [[1.0]], [[1.0]], [[-1.0]]))
    with pytest.raises(ShapeError, match="0 outputs and 0 inputs"):
        stability_margins(LinearSystem([[-1.0]], np.zeros((1, 0)), np.zeros((0, 1))))
    with pytest.raises(ModelError, match="crossing_tol must be a finite positive number"):
        stability_margins(LinearSystem([[-1.0]], [[1.0]], [[1.0]]), crossing_tol=0)


def test_loop_from_frequency_package():
    # Reference: the same loop given as plant + controller (linflex.frequency.Loop, broken at the
    # plant input) and as the explicit open loop L = K P built here by hand.
    from linflex.frequency import Loop

    J = 2.0
    plant = LinearSystem([[0, 1], [0, 0]], [[0], [1 / J]], [[1, 0]], inputs=["torque"], outputs=["angle"])
    kp, kd, tau = 3.0, 2.5, 0.05
    # controller: kp + kd s / (tau s + 1), state f' = (e - f)/tau, output (kp + kd/tau) e - kd/tau f
    ctrl = LinearSystem([[-1 / tau]], [[1 / tau]], [[-kd / tau]], [[kp + kd / tau]])
    loop = Loop(plant, ctrl, sensors=["angle"], actuators=["torque"])
    m_loop = stability_margins(loop)
    A = np.array([[0, 1, 0], [0, 0, 0], [1 / tau, 0, -1 / tau]])
    L = LinearSystem(A, [[0], [1 / J], [0]], [[kp + kd / tau, 0, -kd / tau]])
    m_ref = stability_margins(L)
    np.testing.assert_allclose(m_loop.gain_crossovers, m_ref.gain_crossovers, rtol=1e-12)
    np.testing.assert_allclose(m_loop.phase_margins, m_ref.phase_margins, rtol=1e-10)
    assert m_loop.channels == ("torque",)
    assert m_loop.disk_margin.alpha == pytest.approx(m_ref.disk_margin.alpha, rel=1e-9)


def test_to_markdown_lists_every_crossing():
    m = stability_margins(control.ss(PYTHON_CONTROL_CASES["lightly_damped_sys4"][0]), skew=0.5)
    md = m.to_markdown()
    assert md.count("| gain |") == 3 and md.count("| phase |") == 1
    assert "97.5940" in md and "-157.7845" in md and "skewed" in md
    mm = stability_margins(gyro_loop()).to_markdown()
    assert "multi-loop (diagonal)" in mm and "multi-loop, unstructured" in mm and "**Loop Tz**" in mm


@pytest.mark.parametrize("case", ["example21", "type3", "hub_rolloff_unstable", "gyro", "spinning_satellite", "hub401"])
def test_nyquist_count_from_curve_matches_eigenvalues(case):
    # Reference: argument principle with eigenvalue counts, N_ccw = P - Z (P: open-loop RHP poles
    # from eig(A), Z: closed-loop RHP poles from eig(A - B (I + D)^-1 C)), against the count
    # measured on the curve det(I + L) with indentations around imaginary-axis poles (rigid-body
    # poles, a triple integrator, nutation at 0.022j, the spinning satellite's +-10j).
    L = {
        "example21": lambda: control.ss(PYTHON_CONTROL_CASES["example21"][0]),
        "type3": lambda: control.ss(PYTHON_CONTROL_CASES["type3"][0]),
        "hub_rolloff_unstable": lambda: hub_loop(51, 0.0005, rolloff=True),
        "gyro": gyro_loop,
        "spinning_satellite": lambda: control.ss([[0, 10], [-10, 0]], np.eye(2), [[1, 10], [-10, 1]], 0)
        * control.ss([], [], [], [[1, -2], [0, 1]]),
        "hub401": lambda: hub_loop(401, 0.0005),
    }[case]()
    sys = L if isinstance(L, LinearSystem) else LinearSystem.from_control(L)
    lam = np.linalg.eigvals(sys.A)
    # (a triple integrator's rounding splits it into |lambda| ~ 2e-6, one with Re > 0: not a pole
    # in the right half-plane; the genuine slow unstable pole of example21 is at 5e-4)
    P = int(np.sum((lam.real > 1e-9) & (np.abs(lam) > 1e-4)))
    Acl = sys.A - sys.B @ np.linalg.solve(np.eye(sys.n_inputs) + sys.D, sys.C)
    Z = int(np.sum(np.linalg.eigvals(Acl).real > 0))
    m = stability_margins(L)
    assert (m.open_loop_unstable_poles, m.closed_loop_unstable_poles) == (P, Z)
    assert m.nyquist_encirclements == Z - P  # clockwise: N = Z - P
    assert m.closed_loop_stable == (Z == 0)


def test_type0_closed_form():
    # Reference: closed form for L = 2/(s + 1)^3: the phase is -180 deg at w = sqrt(3), where
    # |L| = 2/8, so the gain margin is exactly 4; |L| = 1 at w = sqrt(2^(2/3) - 1).
    m = stability_margins(control.ss(2 / (s + 1) ** 3))
    np.testing.assert_allclose(m.phase_crossovers, [np.sqrt(3)], rtol=1e-12)
    np.testing.assert_allclose(m.gain_margins, [4.0], rtol=1e-12)
    w = np.sqrt(2 ** (2 / 3) - 1)
    np.testing.assert_allclose(m.gain_crossovers, [w], rtol=1e-12)
    np.testing.assert_allclose(m.phase_margins, [180 - 3 * np.degrees(np.arctan(w))], rtol=1e-12)


def test_loop_with_unmatched_channel_names_is_refused():
    # Bad input named in issue 8: a controller wired to channels the plant does not have; the
    # Loop refuses it (with a did-you-mean hint) before any margin is computed.
    from linflex.frequency import Loop

    plant = LinearSystem([[0, 1], [0, 0]], [[0], [1]], [[1, 0]], inputs=["torque"], outputs=["angle"])
    ctrl = LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[2.0]])
    with pytest.raises(ModelError, match="angel"):
        stability_margins(Loop(plant, ctrl, sensors=["angel"], actuators=["torque"]))


def test_grid_cap_warns():
    # A grid cap too small for 31 resonances is reported, not silently accepted.
    from linflex import AccuracyWarning

    with pytest.warns(AccuracyWarning, match="max_points=500"):
        stability_margins(hub_loop(51, 0.0005), max_points=500)


def _hamiltonian_unity_gain_frequencies(L: LinearSystem) -> np.ndarray:
    """Frequencies where |L(jw)| = 1 from the imaginary eigenvalues of the Hamiltonian matrix.

    For a SISO L = (A, B, C, 0), jw is an eigenvalue of H = [[A, B B^T], [-C^T C, -A^T]] exactly
    when |L(jw)| = 1 (Boyd, Balakrishnan and Kabamba 1989, the basis of H-infinity norm
    bisection): an eigenvalue method independent of any frequency grid.
    """
    A, B, C = (np.asarray(x) for x in (L.A, L.B, L.C))
    assert not np.any(np.asarray(L.D))
    lam = np.linalg.eigvals(np.block([[A, B @ B.T], [-C.T @ C, -A.T]]))
    return np.sort(lam[(np.abs(lam.real) <= 1e-7 * np.abs(lam)) & (lam.imag > 1e-6)].imag)


@pytest.mark.parametrize("order, zeta", [(51, 0.0005), (201, 0.0005), (401, 0.0005)])
def test_gain_crossovers_match_hamiltonian_eigenvalues(order, zeta):
    # Reference: the Hamiltonian eigenvalue characterization above (no grid, no bisection).
    L = hub_loop(order, zeta)
    w_ham = _hamiltonian_unity_gain_frequencies(L)
    m = stability_margins(L)
    assert m.gain_crossovers.size == w_ham.size
    np.testing.assert_allclose(m.gain_crossovers, w_ham, rtol=1e-9)  # eigenvalues to ~1e-12 here


def test_mimo_loop_at_a_time_crossovers_match_hamiltonian_eigenvalues():
    # Reference: Hamiltonian eigenvalues of each loop broken with the others closed, the loop
    # built here by an independent LFT of the state-space model (u_o = -y_o).
    L = gyro_loop()
    m = stability_margins(L)
    A, B, C = (np.asarray(x) for x in (L.A, L.B, L.C))
    for i, lp in enumerate(m.loops):
        o = [j for j in range(3) if j != i]
        Li = LinearSystem(A - B[:, o] @ C[o, :], B[:, [i]], C[[i], :])
        np.testing.assert_allclose(lp.gain_crossovers, _hamiltonian_unity_gain_frequencies(Li), rtol=1e-9)
