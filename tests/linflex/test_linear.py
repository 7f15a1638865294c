"""Core linear-system types: validation, immutability, conversions."""

import control
import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ModelError, SecondOrderSystem, ShapeError, as_linear_system


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
    with pytest.raises(ModelError, match="continuous-time"):
        LinearSystem.from_control(control.ss([[0.5]], [[1]], [[1]], [[0]], dt=0.1))
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
