"""Loops and the classic transfer-function types (frequency/_loop.py)."""

import numpy as np
import pytest

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
