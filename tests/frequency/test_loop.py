"""Loops and the classic transfer-function types (frequency/_loop.py)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ModelError
from linflex.frequency import Loop, transfer_function

from .conftest import two_mass

POINTS = (0.3 + 0.7j, -0.2 + 2.1j, 1.5j, 4.0 + 0.5j)


def G(sys, s):
    """Independent evaluation: direct complex solve D + C (sI - A)^-1 B."""
    n = sys.n_states
    if n == 0:
        return np.array(sys.D, dtype=complex)
    return sys.D + sys.C @ np.linalg.solve(s * np.eye(n) - sys.A, sys.B)


def lead(kp=2.0, kd=3.0, tau=0.1, name="F1_cmd", inp="x1_meas"):
    """K(s) = kp + kd s/(tau s + 1), one state."""
    return LinearSystem([[-1 / tau]], [[1.0]], [[-kd / tau**2]], [[kp + kd / tau]], states=["xf"],
                        inputs=[inp], outputs=[name])


def two_mass_loop():
    # plant of reference notes section 13, position x1 measured, force F1 applied
    return Loop(two_mass(), lead(), sensors="x1", actuators="F1")


def test_siso_types_against_closed_forms():
    loop = two_mass_loop()
    for s in POINTS:
        P = G(loop.plant, s)[2, 0]            # x1 / F1
        K = G(loop.controller, s)[0, 0]
        L = K * P
        # closed forms of the negative-feedback loop
        assert G(transfer_function(loop, "plant", input="F1", output="x1"), s)[0, 0] == pytest.approx(P, rel=1e-12)
        assert G(transfer_function(loop, "controller"), s)[0, 0] == pytest.approx(K, rel=1e-12)
        assert G(transfer_function(loop, "open_loop_at_input"), s)[0, 0] == pytest.approx(L, rel=1e-10)
        assert G(transfer_function(loop, "open_loop_at_output"), s)[0, 0] == pytest.approx(L, rel=1e-10)
        assert G(loop.open_loop(), s)[0, 0] == pytest.approx(L, rel=1e-10)
        cl = G(transfer_function(loop, "closed_loop"), s)
        assert cl[2, 0] == pytest.approx(P / (1 + L), rel=1e-10)
        # every plant output: y_i/r = P_i/(1 + L)
        assert cl[:, 0] == pytest.approx(G(loop.plant, s)[:, 0] / (1 + L), rel=1e-10)
        noise = G(transfer_function(loop, "closed_loop_sensor_noise", output="x1"), s)[0, 0]
        assert noise == pytest.approx(-L / (1 + L), rel=1e-10)
        for at in ("output", "input"):
            S = G(transfer_function(loop, "sensitivity", at=at), s)[0, 0]
            T = G(transfer_function(loop, "complementary_sensitivity", at=at), s)[0, 0]
            assert S == pytest.approx(1 / (1 + L), rel=1e-10)
            assert T == pytest.approx(L / (1 + L), rel=1e-10)
        # quasi-open with a single channel is the open loop
        q = G(transfer_function(loop, "quasi_open_loop", opened="F1"), s)[0, 0]
        assert q == pytest.approx(L, rel=1e-10)


def test_loop_identity_and_pole_sets():
    # reference notes 14.3: det(sI - A_cl) / det(sI - A_III) = 1 + T_III(s)
    loop = two_mass_loop()
    L = transfer_function(loop, "open_loop_at_input")
    cl = transfer_function(loop, "closed_loop")
    for s in POINTS:
        lhs = np.linalg.det(s * np.eye(5) - cl.A) / np.linalg.det(s * np.eye(5) - L.A)
        assert lhs == pytest.approx(1 + G(L, s)[0, 0], rel=1e-10)
    # Type III poles are the plant poles together with the controller poles (notes 6.2)
    ev = np.sort_complex(np.linalg.eigvals(L.A))
    ref = np.sort_complex(np.r_[np.linalg.eigvals(loop.plant.A), -10.0])
    assert np.max(np.abs(ev - ref)) < 1e-7  # double pole at 0 splits to ~sqrt(eps)


def mimo_loop(seed=0, with_d=True):
    rng = np.random.default_rng(seed)
    n, nk = 6, 3
    P = LinearSystem(rng.normal(size=(n, n)) - 2 * np.eye(n), rng.normal(size=(n, 3)), rng.normal(size=(3, n)),
                     0.1 * rng.normal(size=(3, 3)) if with_d else None,
                     inputs=["ta", "tb", "dist"], outputs=["ya", "yb", "perf"])
    K = LinearSystem(-np.eye(nk) + 0.3 * rng.normal(size=(nk, nk)), rng.normal(size=(nk, 2)), rng.normal(size=(2, nk)),
                     0.5 * rng.normal(size=(2, 2)), inputs=["ea", "eb"], outputs=["ua", "ub"])
    # sensors in a different order from the plant's outputs, to exercise the naming
    return Loop(P, K, sensors=["yb", "ya"], actuators=["tb", "ta"])


@pytest.mark.parametrize("with_d", [True, False])
def test_mimo_types_against_matrix_formulas(with_d):
    loop = mimo_loop(with_d=with_d)
    I2 = np.eye(2)
    for s in POINTS:
        Pfull = G(loop.plant, s)
        P = Pfull[np.ix_([1, 0], [1, 0])]   # sensors (yb, ya) from actuators (tb, ta)
        K = G(loop.controller, s)
        Li, Lo = K @ P, P @ K
        assert G(transfer_function(loop, "open_loop_at_input"), s) == pytest.approx(Li, rel=1e-9)
        assert G(transfer_function(loop, "open_loop_at_output"), s) == pytest.approx(Lo, rel=1e-9)
        So = np.linalg.inv(I2 + Lo)
        Si = np.linalg.inv(I2 + Li)
        assert G(transfer_function(loop, "sensitivity"), s) == pytest.approx(So, rel=1e-9)
        assert G(transfer_function(loop, "sensitivity", at="input"), s) == pytest.approx(Si, rel=1e-9)
        assert G(transfer_function(loop, "complementary_sensitivity"), s) == pytest.approx(I2 - So, rel=1e-9, abs=1e-12)
        assert G(transfer_function(loop, "complementary_sensitivity", at="input"), s) == pytest.approx(
            I2 - Si, rel=1e-9, abs=1e-12)
        # closed loop from the disturbance input: y = (P_yd - P_ya K (I + P_sa K)^-1 P_sd) d
        # with u_act = -K e, e = y_s; solve the linear equations directly
        Pya = Pfull[:, [1, 0]]
        Psd = Pfull[[1, 0], 2]
        e = np.linalg.solve(I2 + P @ K, Psd)
        y_ref = Pfull[:, 2] - Pya @ K @ e
        cl = G(transfer_function(loop, "closed_loop", input="dist"), s)[:, 0]
        assert cl == pytest.approx(y_ref, rel=1e-9)
        # quasi-open loop with channel tb opened, ta closed: L11 - L12 (1 + L22)^-1 L21
        q_ref = Li[0, 0] - Li[0, 1] * Li[1, 0] / (1 + Li[1, 1])
        q = G(transfer_function(loop, "quasi_open_loop", opened="tb"), s)[0, 0]
        assert q == pytest.approx(q_ref, rel=1e-9)
        # Sylvester: det(I + KP) = det(I + PK)
        assert np.linalg.det(I2 + Li) == pytest.approx(np.linalg.det(I2 + Lo), rel=1e-10)


def test_names_of_results():
    loop = mimo_loop()
    L = transfer_function(loop, "open_loop_at_input")
    assert L.inputs == ("tb", "ta") and L.outputs == ("ua", "ub")
    Lo = transfer_function(loop, "open_loop_at_output")
    assert Lo.inputs == ("ea", "eb") and Lo.outputs == ("yb", "ya")
    n = transfer_function(loop, "closed_loop_sensor_noise")
    assert n.inputs == ("yb.noise", "ya.noise") and n.outputs == ("ya", "yb", "perf")
    assert transfer_function(loop, "closed_loop", output="perf").outputs == ("perf",)
    assert L.states[-1] == "controller.x2"


def test_validation_messages():
    P = two_mass()
    with pytest.raises(ModelError, match="unknown signal 'x9'"):
        Loop(P, lead(), sensors="x9", actuators="F1")
    with pytest.raises(ModelError, match="controller has 1 inputs but 2 sensors"):
        Loop(P, lead(), sensors=["x1", "x2"], actuators="F1")
    with pytest.raises(ModelError, match="channels repeat"):
        Loop(P, LinearSystem(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0))), sensors=["x1", "x1"], actuators="F1")
    with pytest.raises(ModelError, match="kind must be one of"):
        transfer_function(two_mass_loop(), "openloop")
    with pytest.raises(ModelError, match="plant must be a LinearSystem"):
        Loop("P", lead(), sensors="x1", actuators="F1")


def test_ill_posed_loop():
    # static plant 1 and static controller -1: 1 + K P = 0 (ill-posed algebraic loop)
    P = LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[1.0]])
    K = LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[-1.0]])
    loop = Loop(P, K, sensors="y0", actuators="u0")
    with pytest.raises(ModelError, match="ill-posed"):
        transfer_function(loop, "closed_loop")


def random_loop(seed):
    """A random MIMO loop: actuators and sensors a shuffled subset of the plant's channels."""
    rng = np.random.default_rng(seed)
    n_p, n_k = int(rng.integers(1, 5)), int(rng.integers(0, 3))
    m, p = int(rng.integers(2, 4)), int(rng.integers(2, 4))
    na, ns = int(rng.integers(1, m + 1)), int(rng.integers(1, p + 1))
    P = LinearSystem(rng.normal(size=(n_p, n_p)), rng.normal(size=(n_p, m)), rng.normal(size=(p, n_p)),
                     0.3 * rng.normal(size=(p, m)), inputs=[f"u{k}" for k in range(m)],
                     outputs=[f"y{k}" for k in range(p)])
    K = LinearSystem(rng.normal(size=(n_k, n_k)), rng.normal(size=(n_k, ns)), rng.normal(size=(na, n_k)),
                     0.3 * rng.normal(size=(na, ns)))
    actuators = [f"u{k}" for k in rng.permutation(m)[:na]]
    sensors = [f"y{k}" for k in rng.permutation(p)[:ns]]
    opened = [a for a in actuators if rng.random() < 0.5] or actuators[:1]
    return Loop(P, K, sensors=sensors, actuators=actuators), opened


@settings(derandomize=True, max_examples=40, deadline=None)
@given(st.integers(min_value=0, max_value=2**31 - 1))
def test_every_kind_against_its_matrix_formula(seed):
    # Property over random MIMO loops (feedthrough in plant and controller, channel subsets in
    # any order, quasi-open loops with several channels opened): each kind, built by name from
    # the named blocks of one interconnection, equals its frequency-domain formula from P(s)
    # and K(s) by dense complex solves (reference notes section 6; u = w - beta, e = y_s + n).
    loop, opened = random_loop(seed)
    P, K = loop.plant, loop.controller
    a = [P.inputs.index(x) for x in loop.actuators]
    s_ = [P.outputs.index(x) for x in loop.sensors]
    Ea = np.zeros((P.n_inputs, len(a)))
    Ea[a, range(len(a))] = 1.0
    S = np.zeros((len(s_), P.n_outputs))
    S[range(len(s_)), s_] = 1.0
    closed = np.diag([0.0 if x in opened else 1.0 for x in loop.actuators])
    opened_rows = [loop.actuators.index(x) for x in opened]
    for s in (0.4 + 1.3j, -0.3 + 0.2j):
        for sys in (P, K):
            if sys.n_states and np.linalg.cond(s * np.eye(sys.n_states) - sys.A) > 1e8:
                return  # s next to a pole of P or K: formulas and realizations both lose digits
        Pf, Kf = G(P, s), G(K, s)
        Li, Lo = Kf @ S @ Pf @ Ea, S @ Pf @ Ea @ Kf
        Ia, Is, Ip = np.eye(len(a)), np.eye(len(s_)), np.eye(P.n_outputs)
        if min(np.linalg.svd(Ia + Li, compute_uv=False)) < 1e-6:
            return  # (nearly) singular return difference: the loop has a pole at s
        Y = np.linalg.solve(Ip + Pf @ Ea @ Kf @ S, Pf)  # closed loop, y from w
        Si = np.linalg.inv(Ia + Li)
        So = np.linalg.inv(Is + Lo)
        Lq = np.linalg.solve(Ia + Li @ closed, Li)  # beta from w_a with the opened channels cut
        expected = {
            "plant": Pf, "controller": Kf, "open_loop_at_input": Li, "open_loop_at_output": Lo,
            "closed_loop": Y, "closed_loop_sensor_noise": -np.linalg.solve(Ip + Pf @ Ea @ Kf @ S, Pf @ Ea @ Kf),
            "quasi_open_loop": Lq[np.ix_(opened_rows, opened_rows)],
            ("sensitivity", "output"): So, ("sensitivity", "input"): Si,
            ("complementary_sensitivity", "output"): Is - So, ("complementary_sensitivity", "input"): Ia - Si,
        }
        for key, ref in expected.items():
            kind, at = key if isinstance(key, tuple) else (key, "output")
            extra = {"opened": opened} if kind == "quasi_open_loop" else {}
            got = G(transfer_function(loop, kind, at=at, **extra), s)
            # Two dense solves of well-conditioned (cond < 1e8 checked above) small systems.
            np.testing.assert_allclose(got, ref, rtol=1e-7, atol=1e-7 * max(1.0, np.max(np.abs(ref))),
                                       err_msg=str(key))


def test_every_kind_is_formed_by_name():
    from linflex.frequency import TRANSFER_FUNCTION_KINDS

    loop = two_mass_loop()
    assert TRANSFER_FUNCTION_KINDS == ("plant", "controller", "open_loop_at_input", "open_loop_at_output",
                                       "closed_loop", "closed_loop_sensor_noise", "quasi_open_loop", "sensitivity",
                                       "complementary_sensitivity")
    for kind in TRANSFER_FUNCTION_KINDS:
        assert isinstance(transfer_function(loop, kind), LinearSystem)
    with pytest.raises(ModelError, match="opened= applies to kind 'quasi_open_loop' only"):
        transfer_function(loop, "closed_loop", opened="F1")


def test_loop_channels_default_to_every_plant_signal():
    """A SISO loop typed as Loop(P, K): the channels are the plant's one output and input; its
    phase margin is python-control's ``margin(K P)`` (reference, 1e-6 deg)."""
    import control

    from linflex.stability import stability_margins

    P, K = control.tf([1.0], [1.0, 0.0, 0.0]), control.tf([2.0, 1.0], [0.01, 1.0])
    loop = Loop(P, K)
    assert (loop.sensors, loop.actuators) == (("y[0]",), ("u[0]",))
    _, pm, _, _ = control.margin(K * P)
    assert stability_margins(loop).min_phase_margin == pytest.approx(pm, abs=1e-6)
    with pytest.raises(ModelError, match="name the sensors="):
        Loop(LinearSystem(-np.eye(2), np.eye(2), np.eye(2)), K)
