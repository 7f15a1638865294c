"""Scene controllers as chains: sampled-data simulation, filters, delays and output stages.

References: the exact discrete solution of a double integrator under a sampled PD with a
zero-order hold (scipy.signal.cont2discrete of the plant, recursion by hand, the delay split
into the two partial-period integrals); a notch's depth from its transfer function; Tustin's
map ``s = (2/T)(z - 1)/(z + 1)`` with prewarping evaluated directly.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from linflex import (
    Actuator,
    Body,
    Controller,
    Joint,
    ModelError,
    Scene,
    Sensor,
    compile_model,
    controller_chain,
    controller_system,
    notch,
    simulate,
)

MASS = 2.0  # [kg]: the plant is 1/(m s^2) from force to position


def slider(controllers, disturbances=(), q0=0.1, effects=("control",)):
    """A body on a prismatic joint: position and velocity sensors, a force actuator (exactly linear)."""
    return Scene("slider", effects=list(effects), bodies=[Body("b", MASS, [1.0, 1.0, 1.0])],
                 joints=[Joint("s", "prismatic", "b", axis=[1, 0, 0], q0=q0)],
                 sensors=[Sensor("pos", "position", body="b", axis=[1, 0, 0]),
                          Sensor("vel", "velocity", body="b", axis=[1, 0, 0])],
                 actuators=[Actuator("f", "force", body="b", axis=[1, 0, 0])],
                 disturbances=list(disturbances), controllers=controllers)


def pd(**kw):
    return Controller("pd", "pid", inputs="pos", rate_inputs="vel", outputs="f", kp=kw.pop("kp", 8.0),
                      kd=kw.pop("kd", 6.0), **kw)


def exact_pd(kp, kd, T, tau, n, x0, mass=MASS):
    """Positions and velocities at the samples: the plant's ZOH discretization, by hand.

    With ``tau = d T + r`` (``0 <= r < T``) the force over ``[kT, kT + r)`` is the command of
    sample ``k - d - 1`` and over ``[kT + r, (k + 1) T)`` that of sample ``k - d`` (zero before
    the first), so ``x[k+1] = Phi x[k] + Phi(T - r) Gamma(r) u[k-d-1] + Gamma(T - r) u[k-d]``.
    """
    A, B = np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0 / mass]])

    def zoh(h):
        if h == 0:
            return np.eye(2), np.zeros((2, 1))
        Ad, Bd, *_ = signal.cont2discrete((A, B, np.eye(2), np.zeros((2, 1))), h, method="zoh")
        return Ad, Bd
    d = int(np.floor(tau / T + 1e-9))
    r = max(tau - d * T, 0.0)
    Phi, _ = zoh(T)
    Phi_rest, Gamma_rest = zoh(T - r)
    _, Gamma_r = zoh(r)
    B_now, B_before = Gamma_rest.ravel(), (Phi_rest @ Gamma_r).ravel()
    x, commands, out = np.array(x0, float), [], [np.array(x0, float)]
    for k in range(n):
        commands.append(-kp * x[0] - kd * x[1])
        now = commands[k - d] if k - d >= 0 else 0.0
        before = commands[k - d - 1] if k - d - 1 >= 0 else 0.0
        x = Phi @ x + B_now * now + B_before * before
        out.append(x)
    return np.array(out)


@pytest.mark.parametrize("tau", [0.0, 0.03, 0.1, 0.25])
def test_sampled_pd_matches_the_exact_discrete_solution(tau):
    # 10 Hz PD on 1/(m s^2), computational delay 0, 30 ms (a fraction of a period), one period
    # and two and a half periods.
    T, kp, kd, n = 0.1, 8.0, 6.0, 30
    model = compile_model(slider([pd(kp=kp, kd=kd, sample_time=T, delay=tau)]))
    r = simulate(model, np.linspace(0.0, n * T, n + 1), method="cvodes", rtol=1e-10, atol=1e-12)
    ref = exact_pd(kp, kd, T, tau, n, [0.1, 0.0])
    # the integrator's tolerance: rtol 1e-10 over 30 restarts on states of size 0.1
    np.testing.assert_allclose(r["s.position"], ref[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(r["s.rate"], ref[:, 1], rtol=0, atol=1e-9)
    # the held command is the law at the samples (in effect from the sample on without delay)
    if tau == 0.0:
        np.testing.assert_allclose(r["f"][:-1], -kp * ref[:-1, 0] - kd * ref[:-1, 1], atol=1e-12)


@settings(derandomize=True, max_examples=8, deadline=None)
@given(kp=st.floats(0.5, 20.0), zeta=st.floats(0.3, 1.5), T=st.floats(0.02, 0.2), delay=st.floats(0.0, 1.5))
def test_sampled_pd_matches_the_exact_recursion_for_any_gains_period_and_delay(kp, zeta, T, delay):
    # kd from a damping ratio on the continuous loop; delay in periods (0 to 1.5). Output times
    # on the samples; the closed loop may be unstable for large gains and delays: compared over
    # 15 samples, relative to the largest state.
    kd = 2 * zeta * np.sqrt(kp * MASS)
    tau = delay * T
    n = 15
    model = compile_model(slider([pd(kp=kp, kd=kd, sample_time=T, delay=tau)]))
    r = simulate(model, np.arange(n + 1) * T, method="cvodes", rtol=1e-11, atol=1e-13)
    ref = exact_pd(kp, kd, T, tau, n, [0.1, 0.0])
    scale = np.max(np.abs(ref))
    np.testing.assert_allclose(r["s.position"], ref[:, 0], rtol=0, atol=1e-8 * scale)
    np.testing.assert_allclose(r["s.rate"], ref[:, 1], rtol=0, atol=1e-8 * scale * max(1.0, 1.0 / T))


def test_two_controllers_at_different_rates_on_a_shared_time_grid():
    # Two sliders, each under its own PD at 10 Hz and at 30 ms: every sample instant k T is a
    # multiple of 10 ms but differs from the output grid np.linspace(0, 3, 301) by round-off,
    # which the simulator snaps; each slider follows its own exact recursion.
    bodies = [Body("b", MASS, [1.0, 1.0, 1.0]), Body("c", 2 * MASS, [1.0, 1.0, 1.0])]
    joints = [Joint("s", "prismatic", "b", axis=[1, 0, 0], q0=0.1), Joint("u", "prismatic", "c", axis=[0, 1, 0], q0=-0.2)]
    sensors = [Sensor("pos", "position", body="b", axis=[1, 0, 0]), Sensor("vel", "velocity", body="b", axis=[1, 0, 0]),
               Sensor("pos2", "position", body="c", axis=[0, 1, 0]), Sensor("vel2", "velocity", body="c", axis=[0, 1, 0])]
    actuators = [Actuator("f", "force", body="b", axis=[1, 0, 0]), Actuator("g", "force", body="c", axis=[0, 1, 0])]
    controllers = [pd(sample_time=0.1, delay=0.05),
                   Controller("pd2", "pid", inputs="pos2", rate_inputs="vel2", outputs="g", kp=5.0, kd=9.0,
                              sample_time=0.03)]
    scene = Scene("two", effects=["control"], bodies=bodies, joints=joints, sensors=sensors, actuators=actuators,
                  controllers=controllers)
    t = np.linspace(0.0, 3.0, 301)
    r = simulate(compile_model(scene), t, method="cvodes", rtol=1e-11, atol=1e-13)
    ref1 = exact_pd(8.0, 6.0, 0.1, 0.05, 30, [0.1, 0.0])
    ref2 = exact_pd(5.0, 9.0, 0.03, 0.0, 100, [-0.2, 0.0], mass=2 * MASS)
    np.testing.assert_allclose(r["s.position"][::10], ref1[:, 0], atol=1e-9)
    np.testing.assert_allclose(r["u.position"][::3], ref2[:, 0], atol=1e-9)


def test_sampled_pd_between_samples_with_scipy_and_a_finer_grid():
    # Output times between the samples (every 25 ms, with a 10 Hz controller): the same sample
    # values as the exact recursion, and the input held constant over each period.
    T, n = 0.1, 20
    model = compile_model(slider([pd(sample_time=T)]))
    r = simulate(model, np.linspace(0.0, n * T, 4 * n + 1), method="scipy-DOP853", rtol=1e-11, atol=1e-13)
    ref = exact_pd(8.0, 6.0, T, 0.0, n, [0.1, 0.0])
    np.testing.assert_allclose(r["s.position"][::4], ref[:, 0], atol=1e-9)
    f = r["f"][:-1].reshape(n, 4)
    np.testing.assert_array_equal(f, f[:, :1].repeat(4, axis=1))


def test_continuous_controller_results_unchanged():
    # Without chain keys the controller is continuous and in the model's equations, as before:
    # the closed loop m x'' = -kp x - kd x' of the same scene, by matrix exponential.
    model = compile_model(slider([pd()]))
    assert model.compiled.sampled_controllers == ()
    assert "pd" not in "".join(model.inputs)
    t = np.linspace(0.0, 2.0, 11)
    r = simulate(model, t, method="cvodes", rtol=1e-10, atol=1e-12)
    from scipy.linalg import expm

    Acl = np.array([[0.0, 1.0], [-8.0 / MASS, -6.0 / MASS]])
    ref = np.array([expm(Acl * tk) @ [0.1, 0.0] for tk in t])
    np.testing.assert_allclose(r["s.position"], ref[:, 0], atol=1e-9)
    assert controller_chain(pd()).A.shape == (0, 0)
    assert controller_chain(pd()).D.tolist() == controller_system(pd()).D.tolist()


def test_continuous_filter_in_the_loop_is_the_chain():
    # A continuous low-pass after a continuous PD: the model's controller states are the
    # chain's, and the closed loop equals plant + chain assembled by hand.
    c = pd(filters=[{"kind": "low_pass", "frequency": 30.0, "damping": 0.7}])
    model = compile_model(slider([c]))
    assert [s for s in model.states if s.startswith("pd.")] == ["pd.filter0.x0", "pd.filter0.x1"]
    K = controller_chain(c)
    A = np.zeros((4, 4))
    A[0, 1] = 1.0
    A[1, 2:] = K.C[0] / MASS
    A[1, :2] += K.D[0] / MASS
    A[2:, 2:] = K.A
    A[2:, :2] = K.B
    t = np.linspace(0.0, 1.0, 6)
    r = simulate(model, t, method="cvodes", rtol=1e-10, atol=1e-12)
    from scipy.linalg import expm

    ref = np.array([expm(A * tk) @ [0.1, 0.0, 0.0, 0.0] for tk in t])
    np.testing.assert_allclose(r["s.position"], ref[:, 0], atol=1e-9)


def test_notch_attenuates_a_sinusoid_by_its_depth_in_simulation():
    # The controller (a unit gain, kp = -1, then a 20 dB notch at w0, 100 Hz) reads a position
    # driven as sin(w0 t) by a prescribed joint and pushes a separate body (no feedback): at
    # steady state its held command is the sampled notch's output, of amplitude 10^(-20/20) at
    # w0 (Tustin with prewarping at w0 puts the depth exactly there).
    w0, T = 6.0, 0.01
    c = Controller("p", "pid", inputs="pos", outputs="f", kp=-1.0, sample_time=T,
                   filters=[{"kind": "notch", "frequency": w0, "depth": 20.0, "width": 3.0}])
    scene = Scene("driven", effects=["control"], bodies=[Body("b", MASS, [1.0, 1.0, 1.0]), Body("c", 1.0, [1, 1, 1])],
                  joints=[Joint("s", "prismatic", "b", axis=[1, 0, 0],
                                prescribed={"profile": "sine", "amplitude": 1.0, "frequency": w0}),
                          Joint("free", "prismatic", "c", axis=[0, 1, 0])],
                  sensors=[Sensor("pos", "position", body="b", axis=[1, 0, 0])],
                  actuators=[Actuator("f", "force", body="c", axis=[0, 1, 0])], controllers=[c])
    model = compile_model(scene)
    n_per = int(round(2 * np.pi / w0 / T))
    t = np.arange(0, 40 * n_per + 1) * T
    r = simulate(model, t, method="cvodes-adams", rtol=1e-9, atol=1e-11)
    last = r["f"][-10 * n_per:]
    amplitude = 0.5 * (last.max() - last.min())
    # the sampled sinusoid's peak is within (1 - cos(w0 T / 2)) of its amplitude; 0.4 % transients
    assert amplitude == pytest.approx(0.1, rel=5e-3)
    # the continuous notch's own depth at w0 (the one definition, linflex.notch)
    g = notch(w0, 20.0, 3.0)
    assert abs((g.C @ np.linalg.solve(1j * w0 * np.eye(2) - g.A, g.B) + g.D)[0, 0]) == pytest.approx(0.1)


@settings(derandomize=True, max_examples=25, deadline=None)
@given(w0=st.floats(1.0, 25.0), T=st.floats(0.01, 0.1), depth=st.floats(3.0, 40.0))
def test_tustin_prewarp_puts_the_notch_depth_at_its_frequency(w0, T, depth):
    # Reference: the continuous notch at s = j w0 and the discrete chain at z = exp(j w0 T):
    # with prewarping they agree exactly (the bilinear map sends that z to s = j w0).
    if w0 * T >= 0.9 * np.pi:
        return
    c = Controller("k", "pid", inputs="y", outputs="u", kp=1.0, sample_time=T,
                   filters=[{"kind": "notch", "frequency": w0, "depth": depth, "width": 0.5 * w0}])
    K = controller_chain(c)
    z = np.exp(1j * w0 * T)
    g = (K.C @ np.linalg.solve(z * np.eye(K.n_states) - K.A, K.B) + K.D)[0, 0]
    assert abs(g) == pytest.approx(10 ** (-depth / 20), rel=1e-9)  # command sign: kp = 1 gives -1
    assert K.dt == T


def test_chain_in_z_and_delay_as_output_delay():
    # A filter given in z is taken as it is; a delay of whole periods is the output delay.
    c = pd(sample_time=0.05, delay=0.1, filters=[{"kind": "transfer_function", "num": [0.5, 0.5], "den": [1.0, 0.0],
                                                  "domain": "z"}])
    K = controller_chain(c)
    assert K.dt == 0.05 and K.output_delay.tolist() == [0.1]
    # two-tap average after the PD: D = 0.5 D_pd, B feeds the tap, C = 0.5
    np.testing.assert_allclose(K.D, 0.5 * controller_system(c).D)
    # a fractional delay cannot be carried by a discrete LinearSystem: said, and delay=False works
    frac = pd(sample_time=0.1, delay=0.02)
    with pytest.raises(ModelError, match=r"controllers\['pd'\]\.delay.*delay=False"):
        controller_chain(frac)
    assert controller_chain(frac, delay=False).output_delay.tolist() == [0.0]


def test_saturation_clips_the_held_command():
    model = compile_model(slider([pd(sample_time=0.1, saturation=0.3)], q0=1.0))
    r = simulate(model, np.linspace(0.0, 1.0, 11), method="cvodes")
    assert np.max(np.abs(r["f"])) == pytest.approx(0.3, abs=1e-15)
    assert r["f"][0] == pytest.approx(-0.3)  # unclipped it would be -kp * 1 = -8
    # rate limit and quantization: steps of at most 0.5 N/s * 0.1 s, multiples of 0.01 N
    model = compile_model(slider([pd(sample_time=0.1, rate_limit=0.5, quantization=0.01)], q0=1.0))
    r = simulate(model, np.linspace(0.0, 1.0, 11), method="cvodes")
    f = r["f"]
    assert np.all(np.abs(np.diff(f)) <= 0.05 + 0.005 + 1e-12)
    np.testing.assert_allclose(f / 0.01, np.round(f / 0.01), atol=1e-9)
    assert f[0] == pytest.approx(-0.05)


def test_noise_is_reproducible_with_the_seed_and_absent_without():
    t = np.linspace(0.0, 1.0, 11)
    runs = [simulate(compile_model(slider([pd(sample_time=0.1, **kw)])), t, method="cvodes")["f"]
            for kw in ({"noise": [0.01, 0.02], "seed": 7}, {"noise": [0.01, 0.02], "seed": 7},
                       {"noise": [0.01, 0.02], "seed": 8}, {})]
    np.testing.assert_array_equal(runs[0], runs[1])
    assert np.max(np.abs(runs[0] - runs[2])) > 1e-4
    # the first command's noise is exactly the generator's first draws, scaled by the gains
    draws = np.random.default_rng(7).standard_normal(2) * [0.01, 0.02]
    assert runs[0][0] - runs[3][0] == pytest.approx(-8.0 * draws[0] - 6.0 * draws[1], abs=1e-12)


@pytest.mark.parametrize("changes, match", [
    ({"sample_time": -0.1}, r"controllers\[0\]\.sample_time: must be positive"),
    ({"sample_time": 0.1, "filters": [{"kind": "nocth", "frequency": 1.0}]},
     r"controllers\[0\]\.filters\[0\]\.kind: unknown filter kind 'nocth' \(did you mean 'notch'\?\)"),
    ({"filters": [{"kind": "transfer_function", "num": [1.0], "den": [1.0, 0.5], "domain": "z"}]},
     r"controllers\[0\]\.filters\[0\]\.domain: a filter in z needs the controller's sample_time"),
    ({"delay": 0.02}, r"controllers\[0\]\.delay: needs sample_time"),
    ({"saturation": 1.0}, r"controllers\[0\]\.saturation: needs sample_time"),
    ({"sample_time": 0.1, "delay": -0.01}, r"controllers\[0\]\.delay: must not be negative"),
    ({"sample_time": 0.1, "saturation": [1.0, 2.0]}, r"controllers\[0\]\.saturation: expected a number \[actuator units\], got \(1.0, 2.0\)"),
    ({"sample_time": 0.1, "noise": -1.0}, r"controllers\[0\]\.noise: must be non-negative"),
    ({"sample_time": 0.1, "hold": "foh"}, r"controllers\[0\]\.hold: unknown hold 'foh'"),
    ({"sample_time": 0.1, "filters": [{"kind": "notch", "frequency": 40.0, "depth": 20.0, "width": 4.0}]},
     r"controllers\[0\]\.filters\[0\]\.frequency: 40.0 rad/s is not below the Nyquist frequency"),
    ({"filters": [{"kind": "notch", "frequency": 4.0, "depth": 20.0}]},
     r"controllers\[0\]\.filters\[0\]: a notch filter needs width"),
    ({"filters": [{"kind": "notch", "frequency": 4.0, "depth": -3.0, "width": 1.0}]},
     r"controllers\[0\]\.filters\[0\]: depth must be a finite positive"),
    ({"filters": [{"kind": "low_pass", "frequency": 4.0, "q": 1.0}]},
     r"controllers\[0\]\.filters\[0\]\.q: unknown key for a low_pass filter"),
])
def test_bad_chain_keys_name_the_entry_path(changes, match):
    with pytest.raises(ModelError, match=match):
        slider([pd(**changes)]).validate()


def test_toml_round_trip_of_a_chain(tmp_path):
    from linflex import load_scene

    scene = slider([pd(sample_time=0.1, delay=0.02, saturation=0.5, noise=[0.001, 0.002], seed=3,
                       filters=[{"kind": "notch", "frequency": 10.0, "depth": 20.0, "width": 4.0},
                                {"kind": "low_pass", "frequency": 25.0}])])
    path = tmp_path / "s.toml"
    path.write_text(scene.to_toml())
    back = load_scene(path)
    assert back.controllers[0] == scene.controllers[0]


def test_sampled_example_scene_slews_within_its_torque_limit():
    # examples/spacecraft_sampled.toml: 10 Hz, 20 ms delay, notch at 1.554 rad/s, 0.2 N m limit,
    # 0.01 rad roll set point. References: the saturation (every held command within it, the
    # first ones on it), the delay (nothing in effect at t = 0), the PD's steady state (the set
    # point, within the 0.5 % the lightly damped arrays leave after 60 s), the notch's depth at
    # its frequency on the linear chain (20 dB: kp 290.4 N m/rad times 0.1, prewarped exactly).
    from pathlib import Path

    from linflex import load_scene

    scene = load_scene(Path(__file__).resolve().parents[2] / "examples" / "spacecraft_sampled.toml")
    r = simulate(compile_model(scene), np.linspace(0.0, 60.0, 601))
    assert np.max(np.abs(r["motor_x"])) == pytest.approx(0.2, abs=1e-15)
    assert r["motor_x"][0] == 0.0 and r["motor_x"][1] == pytest.approx(-0.2)
    assert r["roll"][-1] == pytest.approx(0.01, rel=5e-3)
    K = controller_chain(scene.controllers[0], delay=False)
    z = np.exp(1j * 1.554 * 0.1)
    H = K.C @ np.linalg.solve(z * np.eye(K.n_states) - K.A, K.B) + K.D
    assert abs(H[0, 0]) == pytest.approx(290.4 * 0.1, rel=1e-9)
    assert K.dt == 0.1 and abs(H[0, 1]) < 1e-12


def _response(sys, x):
    """``C (x I - A)^-1 B + D`` at a point ``x`` of the s- or z-plane."""
    return sys.C @ np.linalg.solve(x * np.eye(sys.n_states) - sys.A, sys.B) + sys.D


@settings(derandomize=True, max_examples=20, deadline=None)
@given(w=st.floats(0.05, 20.0), T=st.floats(0.005, 0.1), zero=st.floats(0.5, 5.0), pole=st.floats(5.0, 50.0))
def test_chain_is_the_product_of_its_parts_in_s_and_by_tustin_in_z(w, T, zero, pole):
    # Two channels, a PI law then five filters. References, written from the definitions: the
    # transfer functions of each part at s = j w (continuous chain); at z = exp(j w T), each
    # continuous part at Tustin's s = (2/T)(z - 1)/(z + 1) (a notch at its prewarped
    # s = (w0/tan(w0 T/2))(z - 1)/(z + 1)) and the filter in z at z itself (sampled chain).
    kp, ki = np.array([3.0, 5.0]), np.array([0.5, 0.0])
    w0 = min(8.0, 0.8 * np.pi / T)
    filters = [{"kind": "lead_lag", "zero": zero, "pole": pole, "gain": 2.0},
               {"kind": "notch", "frequency": w0, "depth": 12.0, "width": 0.4 * w0},
               {"kind": "low_pass", "frequency": 40.0, "damping": 0.6},
               {"kind": "transfer_function", "num": [1.0, 3.0], "den": [1.0, 6.0]},
               {"kind": "state_space", "A": [[-2.0, 0.0], [0.0, -4.0]], "B": [[1.0, 0.0], [0.0, 1.0]],
                "C": [[2.0, 0.5], [0.0, 4.0]], "D": [[0.0, 0.0], [0.0, 0.0]]}]
    common = dict(inputs=["y1", "y2"], outputs=["u1", "u2"], kp=kp.tolist(), ki=ki.tolist(), filters=filters)

    def parts(s):
        law = -np.diag(kp + ki / s)
        lead = 2.0 * (s / zero + 1) / (s / pole + 1)
        zd = 0.4 * w0 / (2 * w0)
        zn = zd * 10 ** (-12.0 / 20)
        return law, lead, zn, zd, 1600.0 / (s * s + 2 * 0.6 * 40.0 * s + 1600.0), (s + 3.0) / (s + 6.0)

    def mimo(s):
        return np.array([[2.0 / (s + 2.0), 0.5 / (s + 4.0)], [0.0, 4.0 / (s + 4.0)]])

    s = 1j * w
    law, lead, zn, zd, lp, tf = parts(s)
    nt = (s * s + 2 * zn * w0 * s + w0**2) / (s * s + 2 * zd * w0 * s + w0**2)
    ref = mimo(s) @ (lead * nt * lp * tf * law)
    np.testing.assert_allclose(_response(controller_chain(Controller("k", "pid", **common)), s), ref, rtol=1e-9)

    filters[4] = dict(filters[4], domain="z")  # the same matrices, now a discrete filter
    z = np.exp(1j * w * T)
    st_ = (2 / T) * (z - 1) / (z + 1)
    sp = (w0 / np.tan(w0 * T / 2)) * (z - 1) / (z + 1)
    law, lead, zn, zd, lp, tf = parts(st_)
    nt = (sp * sp + 2 * zn * w0 * sp + w0**2) / (sp * sp + 2 * zd * w0 * sp + w0**2)
    Az, Bz, Cz = np.array([[-2.0, 0.0], [0.0, -4.0]]), np.eye(2), np.array([[2.0, 0.5], [0.0, 4.0]])
    ref = Cz @ np.linalg.solve(z * np.eye(2) - Az, Bz) @ (lead * nt * lp * tf * law)
    K = controller_chain(Controller("k", "pid", sample_time=T, **common))
    assert K.dt == T and K.n_states == 1 + 2 * (1 + 2 + 2 + 1) + 2  # one integrator (ki = 0 on y2)
    np.testing.assert_allclose(_response(K, z), ref, rtol=1e-8)


def test_report_loop_has_the_continuous_filters_and_samples_sampled_controllers():
    # The report closes its loop with the chain (law and filters): a continuous low-pass adds
    # its two states; a sampled controller is analysed as the sampled-data loop (its chain in z,
    # the plant held and sampled), not as if it were continuous
    # (tests/stability/test_sampled_report.py checks its margins).
    from linflex.stability.report import analyse_scene

    c = pd(filters=[{"kind": "low_pass", "frequency": 30.0, "damping": 0.7}])
    a = analyse_scene(slider([c]), figures=False, stiffness_by_origin=False)
    assert a.controller.states == ("pd.filter0.x0", "pd.filter0.x1")
    np.testing.assert_array_equal(a.controller.A, controller_chain(c).A)
    sampled = analyse_scene(slider([pd(sample_time=0.1)]), figures=False, stiffness_by_origin=False)
    assert sampled.loop.dt == sampled.controller.dt == 0.1 and sampled.closed_loop_modes.dt == 0.1
