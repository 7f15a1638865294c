"""Core linear-system types: validation, immutability, conversions."""

import functools
import warnings
from pathlib import Path

import control
import numpy as np
import pytest
import scipy.linalg
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

import linflex
from linflex import LinearSystem, ModelError, SecondOrderSystem, ShapeError, as_linear_system

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SCENES = sorted(p.stem for p in EXAMPLES.glob("*.toml") if not p.stem.endswith("_sweep"))


def two_mass():
    # Two masses with a spring and dashpot, reference notes linear-analysis-discos.md section 13.
    m1, m2, c, k = 2.0, 3.0, 0.4, 5.0
    A = [[-c / m1, c / m1, -k / m1, k / m1], [c / m2, -c / m2, k / m2, -k / m2], [1, 0, 0, 0], [0, 1, 0, 0]]
    return LinearSystem(A, [[1 / m1], [0], [0], [0]], np.eye(4), states=["v1", "v2", "x1", "x2"],
                        inputs=["F1"], outputs=["v1", "v2", "x1", "x2"])


def test_arrays_are_read_only_copies():
    A = np.array([[0.0, 1.0], [-1.0, 0.0]])
    sys = LinearSystem(A, [[0.0], [1.0]], [[1.0, 0.0]])
    A[0, 0] = 5.0
    assert sys.A[0, 0] == 0.0
    with pytest.raises(ValueError):
        sys.A[0, 0] = 1.0
    assert sys.D.shape == (1, 1) and sys.D[0, 0] == 0.0


def test_shape_errors_name_the_argument():
    with pytest.raises(ShapeError, match=r"B has shape \(3, 1\) but 2 rows were expected"):
        LinearSystem(np.eye(2), np.ones((3, 1)))
    with pytest.raises(ShapeError, match=r"D has shape"):
        LinearSystem(np.eye(2), np.ones((2, 1)), np.ones((1, 2)), np.ones((2, 2)))
    with pytest.raises(ShapeError, match=r"A\[0, 1\] is not finite"):
        LinearSystem([[0, np.nan], [0, 0]], np.ones((2, 1)))


def test_names_are_checked():
    with pytest.raises(ModelError, match="duplicate name 'a'"):
        LinearSystem(np.eye(2), np.ones((2, 1)), states=["a", "a"])
    with pytest.raises(ModelError, match="3 names given for 2 signals"):
        LinearSystem(np.eye(2), np.ones((2, 1)), states=["a", "b", "c"])
    with pytest.raises(ModelError, match="non-empty"):
        LinearSystem(np.eye(2), np.ones((2, 1)), inputs=[""])


def test_control_round_trip_keeps_names_and_matrices():
    sys = two_mass()
    back = LinearSystem.from_control(sys.to_control())
    assert back.states == sys.states and back.inputs == sys.inputs and back.outputs == sys.outputs
    np.testing.assert_array_equal(back.A, sys.A)
    assert as_linear_system(sys.to_control(), "plant").outputs == sys.outputs


def test_from_control_transfer_function_and_refusals():
    sys = LinearSystem.from_control(control.tf([1.0], [1.0, 2.0, 1.0]))
    # Poles of 1/(s+1)^2: -1 twice (closed form).
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(sys.A).real), [-1.0, -1.0], atol=1e-7)
    with pytest.raises(ModelError, match="unspecified sampling period"):
        LinearSystem.from_control(control.ss([[0.5]], [[1]], [[1]], [[0]], dt=True))
    with pytest.raises(ModelError, match="plant must be a LinearSystem"):
        as_linear_system(np.eye(2), "plant")


def test_subsystem_by_name():
    sub = two_mass().subsystem(inputs="F1", outputs=["x1"])
    assert sub.shape == (1, 1) and sub.outputs == ("x1",)
    np.testing.assert_array_equal(sub.C, [[0, 0, 1, 0]])
    with pytest.raises(ModelError, match="did you mean 'x1'"):
        two_mass().subsystem(outputs=["x11"])


def test_second_order_eigenvalues_match_generalized_problem():
    # Reference: eigenvalues of M q'' + K q = 0 are +-i sqrt(eig(K, M)) (undamped modal analysis).
    rng = np.random.default_rng(0)
    L = rng.normal(size=(5, 5))
    M = L @ L.T + 5 * np.eye(5)
    K = np.diag([1.0, 4.0, 9.0, 16.0, 25.0])
    so = SecondOrderSystem(M, np.zeros((5, 5)), K, np.ones((5, 1)), Cq=np.eye(5)[:1], dofs=list("abcde"))
    ss = so.to_state_space()
    w2 = np.sort(scipy.linalg.eigvalsh(K, M))
    lam = np.linalg.eigvals(ss.A)
    np.testing.assert_allclose(np.sort(lam.imag[lam.imag > 0] ** 2), w2, rtol=1e-10)
    np.testing.assert_allclose(lam.real, 0.0, atol=1e-10)
    assert ss.states[:2] == ("a", "b") and ss.states[5] == "a_dot"
    assert ss.n_states == 10 and so.to_state_space() is ss  # built once


def test_second_order_singular_mass_refused():
    so = SecondOrderSystem(np.diag([1.0, 0.0]), np.zeros((2, 2)), np.eye(2), np.ones((2, 1)))
    with pytest.raises(ModelError, match="singular"):
        so.to_state_space()


@settings(max_examples=25, deadline=None)
@given(st.integers(min_value=1, max_value=8), st.integers(min_value=0, max_value=2**31 - 1))
def test_eigenvalues_survive_conversion_to_control(n, seed):
    # Property: to_control/from_control is exact (no rebalancing), so eigenvalues are identical.
    rng = np.random.default_rng(seed)
    sys = LinearSystem(rng.normal(size=(n, n)), rng.normal(size=(n, 2)), rng.normal(size=(1, n)))
    back = LinearSystem.from_control(sys.to_control())
    np.testing.assert_array_equal(back.A, sys.A)
    np.testing.assert_array_equal(back.B, sys.B)


def test_connected_part_keeps_exactly_the_states_between_inputs_and_outputs():
    # Chain u -> a -> c -> y with b undriven (feeds c), d driven by u but seen by nothing, e
    # isolated: only b, d and e go, and every transfer function stays the same.
    A = np.array([[-1.0, 0.0, 0.0, 0.0, 0.0],
                  [0.0, -2.0, 0.0, 0.0, 0.0],
                  [1.0, 0.5, -3.0, 0.0, 0.0],
                  [0.0, 0.0, 0.0, 0.0, 0.0],
                  [0.0, 0.0, 0.0, 0.0, 0.0]])
    B = np.array([[1.0], [0.0], [0.0], [2.0], [0.0]])
    C = np.array([[0.0, 0.0, 1.0, 0.0, 0.0]])
    sys = LinearSystem(A, B, C, states=["a", "b", "c", "d", "e"])
    part = sys.connected_part()
    assert part.states == ("a", "c")
    assert part.connected_part() is part
    # Transfer function at a few points (direct complex solves) is unchanged.
    for s_ in (0.3j, 1.0 + 2.0j, -0.5 + 0.1j):
        full = C @ np.linalg.solve(s_ * np.eye(5) - A, B)
        reduced = part.C @ np.linalg.solve(s_ * np.eye(2) - part.A, part.B)
        np.testing.assert_allclose(reduced, full, rtol=1e-14)


@settings(derandomize=True, max_examples=40, deadline=None)
@given(st.sampled_from("ABCD"), st.floats(-10, 10).filter(lambda v: v != 0))
def test_complex_matrices_are_refused_naming_the_matrix(which, imaginary):
    # numpy would silently drop the imaginary part (ComplexWarning); a real system cannot hold it
    mats = {"A": np.array([[-1.0]]), "B": np.array([[1.0]]), "C": np.array([[1.0]]), "D": np.array([[0.0]])}
    mats[which] = mats[which] + 1j * imaginary
    with pytest.raises(ShapeError, match=f"^{which} must be a real matrix, got complex values"):
        LinearSystem(mats["A"], mats["B"], mats["C"], mats["D"])
    # a complex array whose imaginary parts are all zero is a real matrix
    mats[which] = mats[which].real + 0j
    assert LinearSystem(mats["A"], mats["B"], mats["C"], mats["D"]).A.dtype == np.float64


# --- interoperability with python-control and scipy.signal (issue 18, item 6) ---------------


@functools.cache
def example_linearization(name):
    """Each example scene compiled and linearized once about its x0 (some are not equilibria)."""
    from linflex.linearize import linearize

    model = linflex.compile_model(linflex.load_scene(EXAMPLES / f"{name}.toml"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # accuracy warnings do not matter for a conversion test
        return linearize(model, allow_non_equilibrium=True).sys


def test_example_scene_list_is_complete():
    # The round-trip test below covers every scene file of examples/ but the sweep spec.
    assert len(SCENES) >= 6 and "spacecraft_arrays" in SCENES and "attitude_control" in SCENES


@pytest.mark.parametrize("name", SCENES)
def test_example_scenes_round_trip_through_python_control(name):
    sys = example_linearization(name)
    try:
        ctrl = sys.to_control()
    except ModelError as err:
        # python-control 0.10.2 turns D of shape (1, 0) into (0, 0) and then refuses its own
        # shapes (python-control issue #1176): the one case that may fail, with this message.
        assert sys.D.shape == (1, 0) and "one output and no inputs" in str(err) and "#1176" in str(err)
        return
    assert not any("." in n for n in ctrl.input_labels + ctrl.output_labels)
    back = LinearSystem.from_control(ctrl)
    assert (back.states, back.inputs, back.outputs) == (sys.states, sys.inputs, sys.outputs)
    for which in "ABCD":
        np.testing.assert_array_equal(getattr(back, which), getattr(sys, which))  # exact: no arithmetic
    assert as_linear_system(ctrl).inputs == sys.inputs


def test_scenes_with_dotted_names_are_among_the_examples():
    # The bug this guards against: every compiled scene with a sensor or actuator has dotted names.
    dotted = [n for n in SCENES if any("." in s for s in example_linearization(n).inputs + example_linearization(n).outputs)]
    assert len(dotted) >= 3


NAME = st.text(alphabet="ab.x_1 []-", min_size=1, max_size=8).filter(lambda s: s.strip())


@settings(derandomize=True, max_examples=60, deadline=None)
@given(st.lists(NAME, min_size=1, max_size=4, unique=True), st.lists(NAME, min_size=1, max_size=4, unique=True),
       st.lists(NAME, min_size=1, max_size=3, unique=True), st.integers(0, 2**31 - 1))
def test_dotted_names_round_trip_exactly(states, inputs, outputs, seed):
    rng = np.random.default_rng(seed)
    n, m, p = len(states), len(inputs), len(outputs)
    sys = LinearSystem(rng.normal(size=(n, n)), rng.normal(size=(n, m)), rng.normal(size=(p, n)), rng.normal(size=(p, m)),
                       states=states, inputs=inputs, outputs=outputs)
    ctrl = sys.to_control()
    # python-control holds them under names without dots, one to one
    assert ctrl.input_labels == [s.replace(".", "$") for s in inputs]
    assert list(ctrl.state_labels) == states
    back = LinearSystem.from_control(ctrl)
    assert (back.states, back.inputs, back.outputs) == (tuple(states), tuple(inputs), tuple(outputs))
    for which in "ABCD":
        np.testing.assert_array_equal(getattr(back, which), getattr(sys, which))


def test_reserved_character_is_refused_naming_the_signal():
    with pytest.raises(ModelError, match=r"outputs\[1\] = 'a\$b' holds '\$'"):
        LinearSystem([[-1.0]], [[1.0]], [[1.0], [2.0]], outputs=["y", "a$b"]).to_control()


def direct_tf(sys, s):
    """C (sI - A)^-1 B + D by a dense complex solve (the reference)."""
    return sys.C @ np.linalg.solve(s * np.eye(sys.n_states) - sys.A, sys.B) + sys.D


POINTS = (0.1j, 1.0j, 3.0j, 0.5 + 2.0j)


def test_state_space_inputs_keep_their_matrices():
    rng = np.random.default_rng(3)
    A, B, C, D = rng.normal(size=(3, 3)), rng.normal(size=(3, 2)), rng.normal(size=(2, 3)), rng.normal(size=(2, 2))
    ref = control.ss(A, B, C, D)
    for given_ in (ref, scipy.signal.StateSpace(A, B, C, D), (A, B, C, D)):
        sys = as_linear_system(given_, "plant")
        for which in "ABCD":  # exact copies: no realization step
            np.testing.assert_array_equal(getattr(sys, which), getattr(ref, which))


def test_transfer_function_inputs_match_the_polynomial_ratio():
    # Reference: num(s) / den(s) by np.polyval; realizations are exact up to round-off (1e-12).
    num, den = [2.0, 3.0, 1.0], [1.0, 0.6, 4.0, 0.5]
    zeros, poles, gain = np.roots(num), np.roots(den), 2.0
    for given_ in (control.tf(num, den), scipy.signal.TransferFunction(num, den), (num, den),
                   scipy.signal.ZerosPolesGain(zeros, poles, gain), control.ss(control.tf(num, den))):
        sys = as_linear_system(given_, "plant")
        assert sys.shape == (1, 1) and sys.n_states == 3
        for s_ in POINTS:
            expected = np.polyval(num, s_) / np.polyval(den, s_)
            np.testing.assert_allclose(direct_tf(sys, s_)[0, 0], expected, rtol=1e-12)


def test_a_control_transfer_function_is_realized_exactly_in_its_coefficients():
    # 1/s^4 + 2/(s+1) as python-control's sum: (2 s^4 + s + 1) / (s^5 + s^4). SLICOT's TD04AD
    # (control.ss with slycot) perturbs the quadruple pole by eps^(1/4) (3e-4 relative error at
    # 1e-3 rad/s); the controllable canonical form keeps the coefficients exact, so the response
    # and its estimate are the transfer function's. Reference: np.polyval of num / den.
    from linflex.frequency import frequency_response

    G = control.tf([1.0], [1.0, 0, 0, 0, 0]) + control.tf([2.0], [1.0, 1.0])
    sys = as_linear_system(G)
    A = np.asarray(sys.A)
    assert not np.any(np.tril(A, -2)) and np.all(np.diag(A, -1) == 1.0)  # companion (Hessenberg)
    w = np.geomspace(1e-4, 1e2, 13)
    num, den = G.num[0][0], G.den[0][0]
    exact = np.polyval(num, 1j * w) / np.polyval(den, 1j * w)
    fr = frequency_response(G, w)
    err = np.abs(fr.response[:, 0, 0] - exact) / np.abs(exact)
    assert err.max() <= max(fr.error_estimate, 4 * np.finfo(float).eps) and fr.error_estimate < 1e-12


def test_biproper_and_constant_tuples():
    # (s + 3) / (s + 1): D = 1 (the value at infinity), pole -1; a constant gain has no states.
    sys = as_linear_system(([1.0, 3.0], [1.0, 1.0]))
    np.testing.assert_allclose(sys.D, [[1.0]], rtol=1e-15)
    np.testing.assert_allclose(direct_tf(sys, 2.0j)[0, 0], (2j + 3) / (2j + 1), rtol=1e-14)
    gain = as_linear_system(([0.0, 5.0], [2.0]))
    assert gain.n_states == 0 and gain.D[0, 0] == 2.5


@settings(derandomize=True, max_examples=40, deadline=None)
@given(st.integers(1, 5), st.integers(0, 5), st.integers(0, 2**31 - 1))
def test_num_den_tuples_match_polyval(order, num_order, seed):
    # Property against np.polyval on random stable denominators (poles from 0.2 to 5 rad/s).
    rng = np.random.default_rng(seed)
    den = np.poly(-rng.uniform(0.2, 5.0, order))
    num = rng.normal(size=min(num_order, order) + 1)
    sys = as_linear_system((num, den))
    assert sys.n_states == order
    for s_ in POINTS:
        expected = np.polyval(num, s_) / np.polyval(den, s_)
        np.testing.assert_allclose(direct_tf(sys, s_)[0, 0], expected, rtol=1e-9, atol=1e-12 * abs(expected) + 1e-13)


def test_mimo_control_transfer_function_or_a_clear_error():
    tf = control.tf([[[1.0], [2.0]]], [[[1.0, 1.0], [1.0, 3.0]]])
    try:
        sys = as_linear_system(tf, "plant")
    except ModelError as err:  # without slycot python-control cannot realize a MIMO transfer function
        assert "plant: python-control cannot realize" in str(err)
        return
    np.testing.assert_allclose(direct_tf(sys, 1.0j), [[1 / (1j + 1), 2 / (1j + 3)]], rtol=1e-12)


def _realizable_mimo(tf):
    try:
        return LinearSystem.from_control(tf)
    except ModelError as err:  # without slycot python-control cannot realize a MIMO transfer function
        assert "python-control cannot realize" in str(err)
        pytest.skip("python-control without slycot: no MIMO realization to check")


def test_a_mimo_realization_that_moved_a_multiple_pole_is_reported():
    # [[1/s^4, (s^2+2)/(s^2+s+4)], [(2s+1)/(s+1), 1/(s+3)]]: SLICOT TD04AD's staircase moves the
    # quadruple pole at 0 by about eps^(1/4): at 1e-4 rad/s the realization's 1/s^4 entry is off
    # by a factor of several (np.polyval as the reference). The warning names the difference.
    G = control.tf([[[1.0], [1.0, 0.0, 2.0]], [[2.0, 1.0], [1.0]]],
                   [[[1.0, 0, 0, 0, 0], [1.0, 1.0, 4.0]], [[1.0, 1.0], [1.0, 3.0]]])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sys = _realizable_mimo(G)
    messages = [str(w.message) for w in caught if issubclass(w.category, linflex.AccuracyWarning)]
    err = abs(direct_tf(sys, 1e-4j)[0, 0] * (1e-4j) ** 4 - 1.0)  # the realization against 1/s^4
    if err < 1e-8:
        assert not messages  # a python-control that realizes it exactly: nothing to report
        return
    assert len(messages) == 1 and "differs from its polynomials by" in messages[0]
    reported = float(messages[0].split("differs from its polynomials by ")[1].split(" ")[0])
    assert reported >= 0.5 * err  # the scan found at least about what one point shows


@pytest.mark.parametrize("bad", ["num", "den"])
def test_a_mimo_transfer_function_with_non_finite_coefficients_is_refused(bad):
    # SLICOT's TD04AD (control.ss with slycot) does not return on a NaN: refused before it, by name
    num, den = [[[1.0], [2.0]]], [[[1.0, 1.0], [1.0, 3.0]]]
    (num if bad == "num" else den)[0][1] = [1.0, float("nan")] if bad == "den" else [float("nan")]
    with pytest.raises(ShapeError, match=f"plant: the transfer function's {bad}\\[0\\]\\[1\\] has non-finite"):
        as_linear_system(control.tf(num, den), "plant")


def test_zero_entries_and_shared_integrators_pass_the_realization_check():
    # zero numerators (an entry of exactly 0) and two entries sharing 1/s: no division by zero,
    # no warning; the realization's entries against np.polyval.
    for num, den, expected in (([[[0.0], [1.0]], [[0.0], [0.0]]], [[[1.0, 1.0], [1.0, 2.0]], [[1.0, 3.0], [1.0, 4.0]]],
                                lambda z: [[0.0, 1 / (z + 2)], [0.0, 0.0]]),
                               ([[[1.0], [1.0]]], [[[1.0, 0.0], [1.0, 0.0]]], lambda z: [[1 / z, 1 / z]])):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            sys = _realizable_mimo(control.tf(num, den))
        np.testing.assert_allclose(direct_tf(sys, 0.7j), expected(0.7j), rtol=1e-12, atol=1e-15)


@settings(derandomize=True, max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**16), dt=st.sampled_from([None, 0.1]))
def test_a_faithful_mimo_realization_passes_in_silence(seed, dt):
    # 2x2 transfer functions with distinct simple poles (stable, or inside the unit circle):
    # the realization matches np.polyval of every entry to 1e-9 at test points, and no warning.
    rng = np.random.default_rng(seed)
    poles = (-rng.uniform(0.2, 5.0, (2, 2, 2)) if dt is None else rng.uniform(-0.9, 0.9, (2, 2, 2)))
    num = [[list(rng.normal(size=2)) for _ in range(2)] for _ in range(2)]
    den = [[list(np.poly(poles[i, j])) for j in range(2)] for i in range(2)]
    G = control.tf(num, den) if dt is None else control.tf(num, den, dt=dt)
    with warnings.catch_warnings():
        warnings.simplefilter("error", linflex.AccuracyWarning)
        sys = _realizable_mimo(G)
    for z in ((0.3j, 2.0j) if dt is None else (np.exp(0.3j), np.exp(2.0j))):
        expected = [[np.polyval(num[i][j], z) / np.polyval(den[i][j], z) for j in range(2)] for i in range(2)]
        np.testing.assert_allclose(direct_tf(sys, z), expected, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("given_", [
    control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], dt=0.1),
    control.tf([1.0], [1.0, -0.5], dt=0.1),
    scipy.signal.StateSpace([[0.5]], [[1.0]], [[1.0]], [[0.0]], dt=0.1),
    scipy.signal.TransferFunction([1.0], [1.0, -0.5], dt=0.1),
    scipy.signal.ZerosPolesGain([], [0.5], 1.0, dt=0.1),
])
def test_discrete_time_systems_keep_their_period_and_are_refused_where_not_handled(given_):
    with pytest.raises(ModelError, match=r"^plant: this function takes continuous-time systems only, got a discrete-time "
                                         r"one \(dt = 0.1 s\)$"):
        as_linear_system(given_, "plant")
    sys = as_linear_system(given_, "plant", discrete=True)
    # 1 / (z - 0.5) sampled at 0.1 s: one pole at z = 0.5, DC gain 1 / (1 - 0.5) = 2 (closed form).
    assert sys.dt == 0.1 and sys.is_discrete
    np.testing.assert_allclose(np.linalg.eigvals(sys.A), [0.5], rtol=1e-14)
    dc = sys.C @ np.linalg.solve(np.eye(1) - sys.A, sys.B) + sys.D
    np.testing.assert_allclose(dc, [[2.0]], rtol=1e-14)


def test_discrete_round_trip_through_python_control_keeps_dt_and_names():
    sys = LinearSystem([[0.9, 0.1], [0.0, 0.8]], [[0.0], [1.0]], [[1.0, 0.0]], dt=0.05,
                       inputs=["motor.command"], outputs=["gyro.x"])
    back = LinearSystem.from_control(sys.to_control())
    assert sys.to_control().dt == 0.05 and back.dt == 0.05
    assert back.inputs == ("motor.command",) and back.outputs == ("gyro.x",)
    np.testing.assert_array_equal(back.A, sys.A)
    assert LinearSystem.from_control(LinearSystem([[-1.0]], [[1.0]], [[1.0]]).to_control()).dt is None


def test_delays_broadcast_validate_and_survive_subsystem():
    sys = LinearSystem(-np.eye(2), np.eye(2), np.eye(2), input_delay=0.02, output_delay=[0.0, 0.01])
    assert sys.has_delay and sys.input_delay.tolist() == [0.02, 0.02]
    sub = sys.subsystem(inputs=[1], outputs=[1])
    assert sub.input_delay.tolist() == [0.02] and sub.output_delay.tolist() == [0.01]
    assert not sys.subsystem(outputs=[0]).with_(input_delay=0.0).has_delay
    with pytest.raises(ModelError, match=r"input_delay\[1\] = -0.1 s: a delay cannot be negative"):
        LinearSystem(-np.eye(2), np.eye(2), input_delay=[0.0, -0.1])
    with pytest.raises(ModelError, match="not a whole number of sampling periods"):
        LinearSystem([[0.5]], [[1.0]], [[1.0]], dt=0.1, input_delay=0.05)
    with pytest.raises(ModelError, match="convert linflex.pade"):
        as_linear_system(sys, "plant")
    with pytest.raises(ModelError, match="holds no time delays"):
        sys.to_control()
    assert as_linear_system(sys, "plant", delay=True) is sys


@pytest.mark.parametrize("dt", [-0.1, float("nan"), "fast", True])
def test_bad_sampling_periods_are_refused(dt):
    with pytest.raises(ModelError, match="dt must be"):
        LinearSystem([[0.5]], [[1.0]], [[1.0]], dt=dt)


def test_other_inputs_are_refused_naming_the_argument():
    with pytest.raises(ModelError, match="controller must be a LinearSystem.*got list"):
        as_linear_system([[1.0], [1.0, 2.0]], "controller")
    with pytest.raises(ModelError, match=r"controller: a tuple must be \(A, B, C, D\[, dt\]\) or \(num, den\[, dt\]\), got 6"):
        as_linear_system((np.eye(1),) * 6, "controller")
    with pytest.raises(ModelError, match="controller: improper transfer function"):
        as_linear_system(([1.0, 0.0, 1.0], [1.0, 1.0]), "controller")
    with pytest.raises(ModelError, match="controller: den must have a non-zero"):
        as_linear_system(([1.0], [0.0, 0.0]), "controller")
    with pytest.raises(ShapeError, match="controller: num has non-finite"):
        as_linear_system(([np.nan], [1.0, 1.0]), "controller")
    with pytest.raises(ShapeError, match="B has shape"):
        as_linear_system((np.eye(2), np.ones((3, 1)), np.ones((1, 2)), np.zeros((1, 1))), "controller")
    with pytest.raises(ModelError, match="controller: expected a control.StateSpace"):
        as_linear_system(control.frd([1.0, 2.0], [1.0, 2.0]), "controller")
