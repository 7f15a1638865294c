"""Sampled controllers in the stability report, and modes() of discrete systems.

References: the modes of a zero-order-hold discretization are ``z = exp(s dt)`` of the continuous
ones (closed form); the sampled-data loop is rebuilt independently with python-control's ``c2d``
(a fractional input delay ``tau`` split as ``c2d`` over ``T - tau`` and over ``tau``: Franklin,
Powell and Workman, *Digital Control of Dynamic Systems*, 3rd ed., section 4.3.4) and its return
ratios evaluated densely on the unit circle, crossings found by bisection (``brentq``).
"""

import dataclasses
from functools import cache
from pathlib import Path

import control
import numpy as np
import pytest
import scipy.linalg
import scipy.optimize
from hypothesis import given, settings
from hypothesis import strategies as st

import linflex
from linflex import LinearSystem, ModelError, discretize
from linflex.stability import modes
from linflex.stability.report import analyse_scene
from linflex.stability.report._summary import description

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SAMPLED = EXAMPLES / "spacecraft_sampled.toml"
CONTINUOUS = EXAMPLES / "spacecraft_arrays.toml"


# ----------------------------------------------------------------------------------------------
# modes() of discrete systems


@settings(derandomize=True, max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.floats(0.05, 0.9), st.floats(-0.2, 0.95)), min_size=1, max_size=4),
       st.lists(st.floats(-3.0, 1.0).filter(lambda x: abs(x) > 1e-3), max_size=2),
       st.floats(0.01, 0.5), st.integers(0, 2 ** 31 - 1))
def test_discrete_modes_match_the_continuous_system_they_sample(pairs, reals, dt, seed):
    # wn up to 0.9 pi/dt: below the Nyquist frequency, where z = exp(s dt) has a unique principal log
    blocks = []
    for frac, zeta in pairs:
        wn = frac * np.pi / dt
        blocks.append(np.array([[0.0, 1.0], [-wn**2, -2 * zeta * wn]]))
    blocks += [np.array([[r]]) for r in reals]
    Q = np.linalg.qr(np.random.default_rng(seed).standard_normal((sum(b.shape[0] for b in blocks),) * 2))[0]
    A = Q @ scipy.linalg.block_diag(*blocks) @ Q.T
    n = A.shape[0]
    sys = LinearSystem(A, np.ones((n, 1)), np.ones((1, n)))
    cont, disc = modes(sys), modes(discretize(sys, dt, "zoh"))
    assert disc.dt == dt and cont.dt is None and len(cont) == len(disc)
    np.testing.assert_allclose(disc.natural_frequencies, cont.natural_frequencies, rtol=1e-9)
    np.testing.assert_allclose(disc.damping_ratios, cont.damping_ratios, rtol=1e-9, atol=1e-9)
    assert [m.kind for m in disc] == [m.kind for m in cont]
    assert [m.unstable for m in disc] == [m.unstable for m in cont]
    # each row keeps its z, the eigenvalue of exp(A dt)
    np.testing.assert_allclose(disc.z_eigenvalues, np.exp(cont.eigenvalues * dt), rtol=1e-9, atol=1e-12)


def test_discrete_rigid_body_dead_beat_and_unit_circle():
    dt = 0.1
    # double integrator under a zero-order hold with a two-period input delay: two rigid rows
    # (z = 1, a Jordan block), two dead-beat rows (the shift register, z = 0)
    P = discretize(LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]]), dt, "zoh")
    table = modes(P.with_(input_delay=2 * dt))
    assert [m.kind for m in table] == ["rigid-body", "rigid-body", "real", "real"]
    assert table.n_rigid == 2 and not any(m.unstable for m in table)
    dead = table.modes[2:]
    assert all(m.z == 0 and m.time_constant == 0.0 and m.natural_frequency == np.inf and m.damping_ratio == 1.0
               for m in dead)
    # an undamped pair: on the unit circle exactly, rotated by an orthogonal change of basis
    # (rounding moves |z| off 1 by ~eps): not unstable; 1e-6 outside the circle: unstable
    theta = 0.7
    Q = np.linalg.qr(np.random.default_rng(1).standard_normal((2, 2)))[0]
    for radius, unstable in ((1.0, False), (1.0 + 1e-6, True)):
        R = radius * np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
        (row,) = modes(LinearSystem(Q @ R @ Q.T, [[1.0], [0.0]], [[1.0, 0.0]], dt=dt)).modes
        assert row.unstable is unstable and row.kind == "oscillatory"
        assert row.natural_frequency == pytest.approx(np.hypot(np.log(radius), theta) / dt, rel=1e-12)
    # a negative real z alternates at the Nyquist frequency: s = ln|z|/dt + j pi/dt
    (row,) = modes(LinearSystem([[-0.5]], [[1.0]], [[1.0]], dt=dt)).modes
    assert row.kind == "real" and row.damped_frequency == pytest.approx(np.pi / dt, rel=1e-14)
    assert row.time_constant == pytest.approx(dt / np.log(2.0), rel=1e-14)
    with pytest.raises(ModelError, match="time delays"):
        modes(LinearSystem([[-1.0]], [[1.0]], [[1.0]], input_delay=0.1))
    with pytest.raises(ModelError, match="continuous"):
        _ = modes(LinearSystem([[-1.0]], [[1.0]], [[1.0]])).z_eigenvalues


# ----------------------------------------------------------------------------------------------
# the report of a sampled loop


@cache
def _sampled():
    return analyse_scene(SAMPLED, stiffness_by_origin=False, figures=False)


def _independent_return_ratios(analysis, T: float, tau: float):
    """The loop-at-a-time return ratios of the sampled loop, rebuilt with python-control.

    The plant is discretized by ``control.c2d`` (zero-order hold) with the computational delay
    ``tau`` on its actuators: ``x[k+1] = Phi x[k] + G0 u[k] + G1 u[k-1]`` with ``Phi =
    Phi(T - tau) Phi(tau)``, ``G0 = Gamma(T - tau)``, ``G1 = Phi(T - tau) Gamma(tau)``.
    """
    P = analysis.plant.sys.connected_part()
    K = linflex.controller_chain(analysis.scene.controllers[0], delay=False)
    Pc = control.ss(P.A, P.B, P.C, P.D)
    late, early = control.c2d(Pc, T - tau, "zoh"), control.c2d(Pc, tau, "zoh")
    act = [P.inputs.index(x) for x in K.outputs]
    sen = [P.outputs.index(y) for y in K.inputs]
    n, m = P.n_states, len(act)
    Pd = control.ss(np.block([[late.A @ early.A, (late.A @ early.B)[:, act]], [np.zeros((m, n + m))]]),
                    np.vstack([late.B[:, act], np.eye(m)]), np.hstack([P.C[sen], np.zeros((len(sen), m))]),
                    P.D[np.ix_(sen, act)], T)
    L = -control.ss(K.A, K.B, K.C, K.D, T) * Pd  # negative feedback: L = -K P at the plant input
    out = []
    for ch in range(m):
        others = np.eye(m)
        others[ch, ch] = 0.0
        out.append(control.feedback(L, control.ss([], [], [], others, T))[ch, ch])
    return out


def _crossings(Lk, T: float):
    """Gain and phase crossovers [rad/s] of ``Lk(exp(j w T))`` on (0, pi/T], by dense sampling and brentq."""
    A, B, C, D = (np.asarray(x) for x in (Lk.A, Lk.B, Lk.C, Lk.D))
    eye = np.eye(A.shape[0])

    def L(w):
        z = np.exp(1j * np.atleast_1d(w) * T)
        x = np.linalg.solve(z[:, None, None] * eye - A, np.broadcast_to(B, (z.size, *B.shape)))
        return (C @ x)[:, 0, 0] + D[0, 0]

    w = np.linspace(1e-3, np.pi / T, 15001)
    v = L(w)

    def roots(f, values):
        idx = np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))
        return np.array([scipy.optimize.brentq(f, w[i], w[i + 1], xtol=1e-15, rtol=1e-15) for i in idx])

    gain = roots(lambda x: abs(L(x)[0]) - 1.0, np.abs(v) - 1.0)
    phase = roots(lambda x: L(x)[0].imag, v.imag)
    phase = phase[L(phase).real < 0] if phase.size else phase
    return L, gain, phase


def test_sampled_report_margins_match_python_control_c2d_on_the_unit_circle():
    a = _sampled()
    T, tau = 0.1, 0.02
    assert a.loop.dt == T and a.controller.dt == T and a.closed_loop_stable
    np.testing.assert_allclose(a.loop.continuous_plant.input_delay[[a.loop.plant.inputs.index(x)
                                                                    for x in a.loop.actuators]], tau)
    for Lk, lm in zip(_independent_return_ratios(a, T, tau), a.margins.loops):
        L, gain, phase = _crossings(Lk, T)
        np.testing.assert_allclose(lm.gain_crossovers, gain, rtol=1e-6)
        pm = (np.degrees(np.angle(L(gain))) + 360.0) % 360.0 - 180.0
        np.testing.assert_allclose(lm.phase_margins, pm, atol=1e-6)
        # delay margin [s]: the added continuous delay that turns the least phase to -180 deg
        assert lm.delay_margin == pytest.approx(min(np.radians(pm % 360.0) / gain), rel=1e-6)
        # the Nyquist frequency pi/T is a phase crossover (L real and negative there), GM = 1/|L(-1)|
        interior = phase[phase < (1 - 1e-9) * np.pi / T]
        np.testing.assert_allclose(lm.phase_crossovers, np.r_[interior, np.pi / T], rtol=1e-6)
        assert lm.gain_margins[-1] == pytest.approx(1.0 / abs(L(np.pi / T)[0]), rel=1e-6)


def test_sampled_loop_loses_phase_at_the_flexible_crossing():
    sampled = _sampled()
    continuous = analyse_scene(CONTINUOUS, stiffness_by_origin=False, figures=False)
    for lm_s, lm_c in zip(sampled.margins.loops, continuous.margins.loops):
        # motor_x and motor_z cross 0 dB again at the arrays' coupled bending mode near 2.5 rad/s
        if lm_s.gain_crossovers.size > 1:
            pm_s, pm_c = (lm.phase_margins[np.argmin(np.abs(lm.gain_crossovers - 2.5))] for lm in (lm_s, lm_c))
            assert abs(pm_s) < abs(pm_c) - 10.0  # 84.9 against 99.1 deg on motor_x
        assert abs(lm_s.phase_margins[0]) < abs(lm_c.phase_margins[0]) - 8.0  # rigid crossover: 54.1 against 64.1
    # The same law and notch in continuous time isolate the sampling: at the rigid crossover
    # (w T = 0.044) the hold and the delay lag by w (T/2 + tau) (the hold's e^(-s T/2) at low
    # frequency, Franklin, Powell and Workman section 4.3): 1.75 deg, found 1.73 (Tustin's law
    # and the crossover's shift make the rest).
    scene = linflex.load_scene(SAMPLED)
    law = dataclasses.replace(scene.controllers[0], sample_time=None, delay=0.0, saturation=None)
    notched = analyse_scene(dataclasses.replace(scene, controllers=(law,)), stiffness_by_origin=False, figures=False)
    for lm_s, lm_n in zip(sampled.margins.loops, notched.margins.loops):
        wc = lm_s.gain_crossovers[0]
        lag = lm_n.phase_margins[0] - lm_s.phase_margins[0]
        assert lag == pytest.approx(np.degrees(wc * (0.1 / 2 + 0.02)), abs=0.1)


def test_summary_states_the_sampling():
    text = description(_sampled())
    for part in ("sampled every 0.1 s (10 Hz) with a zoh hold", "computational delay 0.02 s (0.2 periods)",
                 "notch (frequency 1.554 rad/s, depth 20 dB, width 0.8 rad/s",
                 "saturation 0.2 N m", "pi/T = 31.42 rad/s", "delay margins in seconds"):
        assert part in text
    assert "sampled" not in description(analyse_scene(EXAMPLES / "attitude_control.toml", figures=False,
                                                      stiffness_by_origin=False)).split("Controller")[1]


def test_mixed_or_different_sample_times_are_refused_naming_the_controllers():
    scene = linflex.load_scene(SAMPLED)
    pd = scene.controllers[0]
    x = dataclasses.replace(pd, name="pd_x", inputs=("roll",), rate_inputs=("p",), outputs=("motor_x",),
                            kp=pd.kp[0], kd=pd.kd[0])
    yz = dataclasses.replace(pd, name="pd_yz", inputs=("pitch", "yaw"), rate_inputs=("q", "r"),
                             outputs=("motor_y", "motor_z"), kp=pd.kp[1:], kd=pd.kd[1:])
    for other, words in ((dataclasses.replace(yz, sample_time=None, delay=0.0, saturation=None, filters=()),
                          "continuous: ['pd_yz']"),
                         (dataclasses.replace(yz, sample_time=0.05), "sample_time 0.05 s: ['pd_yz']")):
        with pytest.raises(ModelError, match="sample_time") as err:
            analyse_scene(dataclasses.replace(scene, controllers=(x, other)), figures=False)
        assert words in str(err.value) and "['pd_x']" in str(err.value)


def test_sampled_report_tables_and_root_locus_are_in_z():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from linflex.stability.report import stability_report
    from linflex.stability.report._figures import report_figures

    a = analyse_scene(SAMPLED, stiffness_by_origin=False)
    report = stability_report(a)
    closed = next(t for t in report.tables() if t.title == "Closed-loop modes")
    assert closed.header[1:3] == ("z [-]", "s = ln(z)/dt [1/s]") and "unit circle" in closed.note
    # every closed-loop z inside the unit circle (the loop is stable), each row's s = ln(z)/dt
    z = a.closed_loop_modes.z_eigenvalues
    assert np.all(np.abs(z) < 1) and not a.closed_loop_modes[0].unstable
    np.testing.assert_allclose(np.exp(a.closed_loop_modes.eigenvalues * 0.1), z, rtol=1e-12, atol=1e-15)
    plant = next(t for t in report.tables() if t.title.startswith("Plant modes"))
    assert plant.header[1] == "eigenvalue [1/s]"  # the continuous plant's modes
    (title, draw), = [(t, d) for t, d in report_figures(a) if t.endswith("motor_x")]
    fig = draw()
    try:
        ax_all = fig.axes[0]
        assert ax_all.get_xlabel() == "real z [-]"
        # the unit circle is drawn: a line whose points all have modulus 1
        assert any(np.allclose(np.hypot(*line.get_data()), 1.0) for line in ax_all.get_lines()
                   if len(line.get_xdata()) > 100)
        # the nominal closed-loop roots marked are the z of the modes table
        nominal = next(line for line in ax_all.get_lines() if line.get_label() == "nominal (1x)")
        marked = np.asarray(nominal.get_xdata()) + 1j * np.asarray(nominal.get_ydata())
        assert np.min(np.abs(marked[:, None] - z[None, :]), axis=0).max() < 1e-12
    finally:
        plt.close(fig)
