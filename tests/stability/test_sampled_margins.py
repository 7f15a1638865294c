"""stability_margins of sampled loops (w-plane) and of delayed continuous loops (exact exp(-s tau)).

References: python-control 0.10.2's discrete ``stability_margins`` (polynomial method on the
unit circle) on ``c2d(plant, "zoh")``; brute-force root finding of ``|L(exp(j w T))| = 1`` and
``Im L = 0`` by bisection on dense grids (done here); closed forms of the delayed loop.
"""

from __future__ import annotations

import control
import numpy as np
import pytest
import scipy.optimize
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ModelError
from linflex.stability import stability_margins

SETTINGS = settings(derandomize=True, max_examples=8, deadline=None)
J = 100.0  # [kg m^2]


def sampled_pd_loop(bandwidth: float, zeta: float, T: float):
    """A PD on the ZOH-sampled rigid body 1/(J s^2): u[k] = Kp e[k] + Kd (e[k] - e[k-1]) / T."""
    plant = LinearSystem([[0, 1], [0, 0]], [[0], [1 / J]], [[1, 0]])
    Kp, Kd = J * bandwidth**2, 2 * zeta * bandwidth * J
    C = control.tf([Kp + Kd / T, -Kd / T], [1, 0], dt=T)
    Pd = control.c2d(control.ss(plant.A, plant.B, plant.C, plant.D), T, "zoh")
    L = control.tf(C * control.tf(Pd))
    return L, LinearSystem.from_control(control.ss(L))


def brute_roots(f, lo: float, hi: float, n: int = 20001) -> np.ndarray:
    w = np.linspace(lo, hi, n)
    v = f(w)
    i = np.flatnonzero(np.sign(v[1:]) != np.sign(v[:-1]))
    return np.array([scipy.optimize.brentq(f, w[k], w[k + 1], xtol=1e-14) for k in i])


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # raised inside python-control's reference computation
@SETTINGS
@given(bandwidth=st.floats(0.5, 3.0), zeta=st.floats(0.5, 1.0), T=st.floats(0.02, 0.15))
def test_sampled_pd_margins_match_python_control_discrete_margins(bandwidth, zeta, T):
    L_ctrl, L = sampled_pd_loop(bandwidth, zeta, T)
    gm, pm, _, wpc, wgc, _ = control.stability_margins(L_ctrl, method="poly")
    m = stability_margins(L)
    assert m.closed_loop_stable
    # reference: python-control's discrete margins (polynomial roots on the unit circle)
    assert m.min_phase_margin == pytest.approx(pm, rel=1e-7)
    assert m.min_phase_margin_frequency == pytest.approx(wgc, rel=1e-7)
    if np.isfinite(gm):
        assert m.min_gain_margin == pytest.approx(gm, rel=1e-7)
        assert m.min_gain_margin_frequency == pytest.approx(wpc, rel=1e-7)
    # reference: brute-force bisection of |L(exp(j w T))| = 1 on a dense grid up to pi/T
    def mag(w):
        return np.log(np.abs(L_ctrl(np.exp(1j * np.asarray(w) * T))))
    np.testing.assert_allclose(m.gain_crossovers, brute_roots(mag, 1e-3, np.pi / T * (1 - 1e-9)), rtol=1e-9)
    # the delay margin in seconds, PM / w_c
    assert m.delay_margin == pytest.approx(np.radians(pm) / wgc, rel=1e-7)
    assert np.all(m.phase_crossovers <= np.pi / T * (1 + 1e-12))


def test_a_pole_outside_the_unit_circle_counts_as_unstable_and_the_nyquist_count_agrees():
    T = 0.1
    for k, stable in ((1.0, True), (0.3, False), (2.7, False)):
        L = LinearSystem([[1.5]], [[1.0]], [[k]], dt=T)   # k / (z - 1.5): closed-loop pole 1.5 - k
        m = stability_margins(L)
        assert m.open_loop_unstable_poles == 1
        assert m.closed_loop_stable is stable
        assert m.closed_loop_unstable_poles == (0 if stable else 1)
        assert m.nyquist_encirclements == m.closed_loop_unstable_poles - 1


def test_the_nyquist_frequency_is_a_phase_crossover_when_l_is_negative_there():
    T = 0.1
    k = 0.2
    m = stability_margins(LinearSystem([[-0.5]], [[1.0]], [[k]], dt=T))   # k / (z + 0.5), L(-1) = -2k
    assert m.phase_crossovers[-1] == pytest.approx(np.pi / T, rel=1e-15)
    # closed form: the closed-loop pole -0.5 - g k reaches -1 at g = 1 / (2k)
    assert m.gain_margins[-1] == pytest.approx(1 / (2 * k), rel=1e-12)
    assert m.closed_loop_stable


def test_whole_period_delays_of_a_sampled_loop_are_exact():
    L_ctrl, L = sampled_pd_loop(1.0, 0.7, 0.05)
    m0 = stability_margins(L)
    m1 = stability_margins(L.with_(input_delay=0.05))   # one period
    # reference: python-control on the same loop times z^-1
    gm, pm, _, wpc, wgc, _ = control.stability_margins(L_ctrl * control.tf([1], [1, 0], dt=0.05))
    assert m1.min_phase_margin == pytest.approx(pm, rel=1e-7)
    assert m1.min_phase_margin_frequency == pytest.approx(wgc, rel=1e-7)
    assert m1.min_phase_margin == pytest.approx(m0.min_phase_margin - np.degrees(m0.gain_crossovers[0] * 0.05), rel=1e-9)


def rigid_pd(Kp: float = 100.0, Kd: float = 200.0, roll_off: float = 20.0) -> LinearSystem:
    """PD with a first-order roll-off on 1/(J s^2): L(s) = (Kp + Kd s) / (J s^2 (1 + s / roll_off))."""
    A = [[0, 1, 0], [0, 0, 1], [0, 0, -roll_off]]
    return LinearSystem(A, [[0], [0], [roll_off / J]], [[Kp, Kd, 0.0]])


def rigid_pd_at(w, tau: float = 0.0):
    w = np.asarray(w, dtype=float)
    return (100.0 + 200.0j * w) / (-J * w**2 * (1 + 1j * w / 20.0)) * np.exp(-1j * w * tau)


@settings(derandomize=True, max_examples=3, deadline=None)
@given(tau=st.floats(0.05, 0.3))
def test_delayed_loop_phase_margin_is_pm0_minus_wc_tau_exactly(tau):
    L0 = rigid_pd()
    m0 = stability_margins(L0)
    m1 = stability_margins(L0.with_(output_delay=tau))
    # closed form: |exp(-j w tau)| = 1 keeps the gain crossovers; the phase drops by w_c tau
    np.testing.assert_allclose(m1.gain_crossovers, m0.gain_crossovers, rtol=1e-12)
    assert m1.min_phase_margin == pytest.approx(m0.min_phase_margin - np.degrees(m0.gain_crossovers[0] * tau), rel=1e-10)
    assert m1.delay_margin == pytest.approx(m0.delay_margin - tau, rel=1e-10)
    assert m1.closed_loop_stable and m1.nyquist_encirclements == 0
    # reference: bisection of Im(L(jw) exp(-j w tau)) = 0 with Re < 0 on a dense grid, below 200 rad/s
    roots = brute_roots(lambda w: rigid_pd_at(w, tau).imag, 0.5, 200.0, 200001)
    roots = roots[rigid_pd_at(roots, tau).real < 0]
    np.testing.assert_allclose(m1.phase_crossovers[m1.phase_crossovers < 200.0], roots, rtol=1e-9)
    # every crossing with a gain margin below 60 dB is reported (reference: bisection up to 1000 rad/s)
    every = brute_roots(lambda w: rigid_pd_at(w, tau).imag, 0.5, 1000.0, 400001)
    every = every[(rigid_pd_at(every, tau).real < 0) & (np.abs(rigid_pd_at(every, tau)) >= 1e-3)]
    assert np.all(np.min(np.abs(m1.phase_crossovers[:, None] - every[None]), axis=0) <= 1e-9 * every)


def test_a_delay_beyond_the_delay_margin_destabilizes_the_loop_by_the_nyquist_count():
    L0 = rigid_pd()
    dm = stability_margins(L0).delay_margin
    m = stability_margins(L0.with_(input_delay=1.2 * dm))
    # the delay margin is exactly where a pair of closed-loop poles crosses the axis
    assert not m.closed_loop_stable and m.closed_loop_unstable_poles == 2 and m.nyquist_encirclements == 2
    assert m.disk_margin.alpha == 0.0
    assert stability_margins(L0.with_(input_delay=0.8 * dm)).closed_loop_stable


def test_delays_on_a_multivariable_loop_are_refused_with_a_clear_error():
    L = LinearSystem(-np.eye(2), np.eye(2), np.eye(2), input_delay=[0.1, 0.0])
    with pytest.raises(ModelError, match="keeps delays exact on single loops"):
        stability_margins(L)


def test_a_discrete_controller_on_a_continuous_plant_is_a_sampled_loop_with_its_computational_delay():
    from linflex.frequency import Loop, transfer_function

    T, Kp, Kd = 0.1, 100.0, 200.0
    plant = LinearSystem([[0, 1], [0, 0]], [[0], [1 / J]], [[1, 0]], inputs=["torque"], outputs=["angle"])
    C = control.tf([Kp + Kd / T, -Kd / T], [1, 0], dt=T)
    pd = LinearSystem.from_control(control.ss(C))
    loop = Loop(plant, pd.with_(output_delay=T), sensors="angle", actuators="torque")
    assert loop.dt == T and loop.continuous_plant is plant and loop.plant.dt == T
    m = stability_margins(loop)
    # reference: python-control's discrete margins of C(z) c2d(P, zoh)(z) z^-1
    Pd = control.tf(control.c2d(control.ss(plant.A, plant.B, plant.C, plant.D), T, "zoh"))
    gm, pm, _, wpc, wgc, _ = control.stability_margins(C * Pd * control.tf([1], [1, 0], dt=T), method="poly")
    assert m.min_phase_margin == pytest.approx(pm, rel=1e-8)
    assert m.min_phase_margin_frequency == pytest.approx(wgc, rel=1e-8)
    assert m.min_gain_margin == pytest.approx(gm, rel=1e-8)
    # the closed loop is a discrete system; its poles are those of 1 + L(z) = 0 (inside the unit circle)
    closed = transfer_function(loop, "closed_loop")
    assert closed.dt == T
    num, den = (C * Pd * control.tf([1], [1, 0], dt=T)).num[0][0], (C * Pd * control.tf([1], [1, 0], dt=T)).den[0][0]
    char = np.polyadd(den, num)
    cl = np.sort_complex(np.roots(char))
    ours = np.linalg.eigvals(closed.A)
    ours = np.sort_complex(ours[np.abs(ours) > 1e-9])   # cancelled shift-register states at z = 0
    np.testing.assert_allclose(np.sort(np.abs(ours)), np.sort(np.abs(cl[np.abs(cl) > 1e-9])), rtol=1e-7)
    assert m.closed_loop_stable and np.all(np.abs(ours) < 1)


def test_a_continuous_loop_keeps_its_delays_exact_in_the_open_loop_and_refuses_a_delayed_closed_loop():
    from linflex.frequency import Loop, transfer_function

    plant = LinearSystem([[0, 1], [0, 0]], [[0], [1 / J]], [[1, 0]], inputs=["torque"], outputs=["angle"])
    lead = LinearSystem([[-50.0]], [[1.0]], [[-5000.0]], [[100.0 + 50 * 200.0]])
    loop0 = Loop(plant, lead, sensors="angle", actuators="torque")
    loop = Loop(plant.with_(input_delay=0.02, output_delay=0.01), lead.with_(output_delay=0.03),
                sensors="angle", actuators="torque")
    L = loop.open_loop()
    assert L.input_delay.tolist() == [0.02] and L.output_delay.tolist() == pytest.approx([0.04])
    m0, m = stability_margins(loop0), stability_margins(loop)
    # closed form: PM = PM0 - w_c (0.02 + 0.01 + 0.03)
    assert m.min_phase_margin == pytest.approx(m0.min_phase_margin - np.degrees(m0.gain_crossovers[0] * 0.06), rel=1e-10)
    with pytest.raises(ModelError, match="a continuous closed loop with delays is not rational"):
        transfer_function(loop, "closed_loop")


def test_loops_refuse_a_discrete_plant_with_a_continuous_controller():
    from linflex.frequency import Loop

    with pytest.raises(ModelError, match="plant is discrete"):
        Loop(LinearSystem([[0.5]], [[1.0]], [[1.0]], dt=0.1), LinearSystem([[-1.0]], [[1.0]], [[1.0]]),
             sensors=0, actuators=0)


def test_sampled_disk_margin_matches_a_dense_scan_of_the_unit_circle():
    L_ctrl, L = sampled_pd_loop(1.5, 0.6, 0.1)
    m = stability_margins(L, skew=0.5)
    # reference: alpha = 1 / max |S + (sigma - 1)/2| on 200001 points of the unit circle
    w = np.linspace(1e-4, np.pi / 0.1, 200001)
    S = 1.0 / (1.0 + L_ctrl(np.exp(1j * w * 0.1)))
    for disk, sigma in ((m.disk_margin, 0.0), (m.skewed_disk_margin, 0.5)):
        peak = np.abs(S + (sigma - 1) / 2)
        assert disk.alpha == pytest.approx(1 / peak.max(), rel=1e-6)
        assert disk.frequency == pytest.approx(w[np.argmax(peak)], rel=1e-3)


def test_a_diagonal_sampled_mimo_loop_has_the_margins_of_its_channels():
    _, L1 = sampled_pd_loop(1.0, 0.7, 0.1)
    _, L2 = sampled_pd_loop(2.0, 0.5, 0.1)
    A = np.block([[L1.A, np.zeros((L1.n_states, L2.n_states))], [np.zeros((L2.n_states, L1.n_states)), L2.A]])
    B = np.block([[L1.B, np.zeros((L1.n_states, 1))], [np.zeros((L2.n_states, 1)), L2.B]])
    C = np.block([[L1.C, np.zeros((1, L2.n_states))], [np.zeros((1, L1.n_states)), L2.C]])
    L = LinearSystem(A, B, C, np.diag([L1.D[0, 0], L2.D[0, 0]]), dt=0.1)
    m = stability_margins(L)
    for loop, single in zip(m.loops, (stability_margins(L1), stability_margins(L2))):
        np.testing.assert_allclose(loop.gain_crossovers, single.gain_crossovers, rtol=1e-9)
        np.testing.assert_allclose(loop.phase_margins, single.phase_margins, rtol=1e-9)
        np.testing.assert_allclose(loop.gain_margins, single.gain_margins, rtol=1e-9)
    assert m.closed_loop_stable


def test_scipy_dlti_and_tuples_are_sampled_loops_too():
    import scipy.signal

    L_ctrl, L = sampled_pd_loop(1.0, 0.7, 0.1)
    num, den = L_ctrl.num[0][0], L_ctrl.den[0][0]
    ref = stability_margins(L)
    for given_ in (scipy.signal.dlti(num, den, dt=0.1), (num, den, 0.1)):
        m = stability_margins(given_)
        assert m.min_phase_margin == pytest.approx(ref.min_phase_margin, rel=1e-9)
        assert m.min_gain_margin == pytest.approx(ref.min_gain_margin, rel=1e-9)


def test_a_delayed_loop_with_feedthrough_warns_when_its_nyquist_count_cannot_close():
    from linflex import AccuracyWarning

    # L = 0.5 exp(-s tau) (s + 2)/(s + 1): |L| -> 0.5 on a circle for ever, the contour never settles
    L = LinearSystem([[-1.0]], [[1.0]], [[0.5]], [[0.5]], input_delay=0.1)
    with pytest.warns(AccuracyWarning, match="Pade approximation"):
        m = stability_margins(L)
    # reference: |L| < 1 everywhere (small-gain theorem): stable for any delay
    assert m.closed_loop_stable


@settings(derandomize=True, max_examples=8, deadline=None)
@given(wf=st.floats(2.0, 20.0), zeta=st.floats(0.001, 0.05), T=st.floats(0.02, 0.2), bandwidth=st.floats(0.3, 1.5))
def test_sampled_flexible_loops_against_dense_bisection_on_the_unit_circle(wf, zeta, T, bandwidth):
    """A PD on a rigid body with one flexible mode, sampled with ZOH: every crossing and the verdict."""
    A = np.array([[0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1], [0, 0, -wf**2, -2 * zeta * wf]])
    plant = LinearSystem(A, [[0], [1 / J], [0], [0.5 / J]], [[1, 0, 1, 0]])
    Kp, Kd = J * bandwidth**2, 1.4 * bandwidth * J
    C = control.tf([Kp + Kd / T, -Kd / T], [1, 0], dt=T)
    Pd = control.ss(*(np.asarray(x) for x in scipy.signal.cont2discrete((plant.A, plant.B, plant.C, plant.D), T)[:4]), T)
    L = LinearSystem.from_control(control.series(Pd, control.ss(C)))
    m = stability_margins(L)
    T_ = L.dt

    def Lz(w):   # batched dense solves at z = exp(j w T)
        z = np.exp(1j * np.atleast_1d(np.asarray(w, dtype=float)) * T_)
        X = np.linalg.solve(z[:, None, None] * np.eye(L.n_states) - L.A, np.broadcast_to(L.B, (z.size,) + L.B.shape))
        return L.D[0, 0] + (L.C @ X)[:, 0, 0]

    # reference: dense bisection of log|L| = 0 on the unit circle (away from the mode's own pole)
    w = np.linspace(1e-3, np.pi / T_ * (1 - 1e-9), 40001)
    v = np.log(np.abs(Lz(w)))
    idx = np.flatnonzero(np.sign(v[1:]) != np.sign(v[:-1]))
    ref = np.array([scipy.optimize.brentq(lambda x: float(np.log(np.abs(Lz(x)[0]))), w[k], w[k + 1], xtol=1e-13)
                    for k in idx])
    np.testing.assert_allclose(m.gain_crossovers, ref, rtol=1e-8)
    pm_ref = np.degrees(np.angle(-Lz(ref)))
    np.testing.assert_allclose(m.phase_margins, pm_ref, atol=1e-7)
    # reference: closed-loop eigenvalues against the unit circle
    Acl = L.A - L.B @ np.linalg.solve(np.eye(1) + L.D, L.C)
    assert m.closed_loop_stable == bool(np.all(np.abs(np.linalg.eigvals(Acl)) < 1))
