"""linflex.system on what a hurried user types: integrators under the matched map, scipy static gains,
flat empty matrices, loose output maps of a SecondOrderSystem (references named per test)."""

import control
import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ModelError, SecondOrderSystem, ShapeError, as_linear_system, discretize, notch, pade

FAST = dict(derandomize=True, deadline=None, max_examples=25)


def response(sys, s):
    """``C (sI - A)^-1 B + D`` at one point ``s`` (the system's own variable: ``s`` or ``z``)."""
    n = sys.n_states
    return (sys.C @ np.linalg.solve(s * np.eye(n) - sys.A, sys.B) + sys.D)[0, 0] if n else sys.D[0, 0]


@pytest.mark.parametrize("num, den, closed_form", [
    # Reference (hand computation of the matched map, Franklin, Powell and Workman 1998, 6.3.2):
    # s -> (z - 1)/T at the origin, so 1/s^2 -> T^2/(z - 1)^2, 1/(s (s + 2)) -> T (1 - e^-2T)/2 /
    # ((z - 1)(z - e^-2T)), s/(s + 1) -> (1 - e^-T)/T (z - 1)/(z - e^-T).
    ([1.0], [1.0, 0.0, 0.0], lambda z, T: T * T / (z - 1) ** 2),
    ([1.0], [1.0, 2.0, 0.0], lambda z, T: T * (1 - np.exp(-2 * T)) / 2 / ((z - 1) * (z - np.exp(-2 * T)))),
    ([1.0, 0.0], [1.0, 1.0], lambda z, T: (1 - np.exp(-T)) / T * (z - 1) / (z - np.exp(-T))),
])
def test_matched_keeps_integrators_and_differentiators(num, den, closed_form):
    # python-control's sample_system(method="matched") divides the infinite (zero) DC gain: nan,
    # which linflex used to realize as an empty zero system, silently.
    T = 0.1
    d = discretize((num, den), T, "matched")
    assert d.n_states == len(den) - 1 and d.dt == T
    for z in np.exp(1j * np.array([0.05, 0.7, 2.5])):
        # rounding of a 2-state realization of exact coefficients: 1e-12 relative
        assert abs(response(d, z) - closed_form(z, T)) <= 1e-12 * abs(closed_form(z, T))


@settings(**FAST)
@given(poles=st.lists(st.floats(0.05, 20.0), min_size=1, max_size=3), zero=st.one_of(st.none(), st.floats(0.05, 20.0)),
       k=st.floats(0.1, 10.0))
def test_matched_agrees_with_python_control_without_poles_at_the_origin(poles, zero, k):
    # Reference: python-control 0.10's sample_system(method="matched") where its DC gain match is
    # finite (stable real poles, a left half-plane zero); 1e-9 relative: both round the roots.
    T = 0.05
    num = k * (np.array([1.0, zero]) if zero is not None else np.array([1.0]))
    den = np.poly(-np.array(poles))
    d = discretize((num, den), T, "matched")
    ref = control.sample_system(control.tf(num, den), T, method="matched")
    for z in np.exp(1j * np.array([0.01, 0.5, 2.0])):
        assert abs(response(d, z) - ref(z)) <= 1e-9 * abs(ref(z))


def test_matched_of_a_notch_and_of_the_zero_system():
    # Reference: python-control's matched map of the notch (no pole at the origin), 1e-10 relative;
    # the zero system maps to the zero system.
    f = notch(10.0, 20.0, 4.0)
    d = discretize(f, 0.02, "matched")
    ref = control.sample_system(control.ss2tf(control.ss(f.A, f.B, f.C, f.D)), 0.02, method="matched")
    z = np.exp(1j * 10.0 * 0.02)
    assert abs(response(d, z) - ref(z)) <= 1e-10 * abs(ref(z))
    zero = discretize(LinearSystem([[-1.0]], [[1.0]], [[0.0]]), 0.1, "matched")
    assert zero.n_states == 0 and zero.D.tolist() == [[0.0]]


@pytest.mark.parametrize("sys", [scipy.signal.lti([3.0], [1.0]), scipy.signal.ZerosPolesGain([], [], 3.0),
                                 scipy.signal.TransferFunction([6.0], [2.0]),
                                 scipy.signal.dlti([3.0], [1.0], dt=0.1)])
def test_scipy_static_gain_has_no_state(sys):
    # Reference: a static gain 3 has no state (as (num, den) and python-control's tf); scipy's to_ss
    # gives it a spurious uncontrollable, unobservable state at the origin (a closed-loop pole at 0).
    lin = as_linear_system(sys, discrete=True)
    assert lin.n_states == 0 and lin.D.tolist() == [[3.0]]


def test_scipy_single_output_is_the_controllable_canonical_form_and_mimo_static_has_no_state():
    # Reference: the same realization as the tuple (num, den) (scipy.signal.tf2ss of the coefficients).
    lin = as_linear_system(scipy.signal.lti([1.0, 2.0], [1.0, 3.0, 5.0]))
    ref = as_linear_system(([1.0, 2.0], [1.0, 3.0, 5.0]))
    np.testing.assert_array_equal(lin.A, ref.A)
    np.testing.assert_array_equal(lin.C, ref.C)
    mimo = as_linear_system(scipy.signal.lti([[1.0], [2.0]], [2.0]))
    assert mimo.n_states == 0 and mimo.D.tolist() == [[0.5], [1.0]]


def test_scipy_dlti_of_unspecified_period_names_the_argument():
    with pytest.raises(ModelError, match=r"plant: a scipy.signal.dlti of unspecified sampling period"):
        as_linear_system(scipy.signal.dlti([1.0], [1.0, -0.5]), "plant", discrete=True)


def test_flat_empty_matrices_take_their_size_from_D():
    # Reference: python-control's ss([], [], [], D) is the static gain D.
    assert LinearSystem([], [], [], [[3.0]]).shape == (1, 1)
    assert LinearSystem([], [], [], [[1.0, 2.0]]).shape == (1, 2)
    assert LinearSystem([], [], [], 3.0).D.tolist() == [[3.0]]
    assert as_linear_system(([], [], [], [[2.0]])).D.tolist() == [[2.0]]
    assert LinearSystem([[-1.0]], [[1.0]], []).shape == (0, 1)


def test_second_order_output_maps_of_the_wrong_size_raise_shape_errors():
    M, D, K, B = np.eye(2), np.zeros((2, 2)), np.eye(2), [[1.0], [0.0]]
    with pytest.raises(ShapeError, match="Cq must be 2-D"):
        SecondOrderSystem(M, D, K, B, Cq=[1.0, 0.0, 0.0])
    # a scalar Du on one dof and one input is the 1 x 1 feedthrough
    sys = SecondOrderSystem(1.0, 0.0, 1.0, 1.0, Du=2.0).to_state_space()
    assert sys.D.tolist() == [[2.0]]
    # no dofs at all: the static feedthrough
    static = SecondOrderSystem(np.zeros((0, 0)), np.zeros((0, 0)), np.zeros((0, 0)), np.zeros((0, 1)), Du=[[1.0]])
    assert static.to_state_space().n_states == 0


def test_filter_and_discretize_refuse_bools_and_text_with_the_argument_named():
    with pytest.raises(ModelError, match="frequency must be a real number, got True"):
        notch(True, 20.0, 4.0)
    with pytest.raises(ModelError, match="prewarp must be a real number, got 'fast'"):
        discretize(([1.0], [1.0, 1.0]), 0.1, "tustin", prewarp="fast")


def test_pade_options_and_subsystem_keys_that_are_not_numbers_or_names():
    delayed = LinearSystem([[-1.0]], [[1.0]], [[1.0]], input_delay=0.1)
    with pytest.raises(ModelError, match="bandwidth must be a real number, got 'x'"):
        pade(delayed, 3, bandwidth="x")
    with pytest.raises(ModelError, match="phase_tol must be a real number, got 'x'"):
        pade(delayed, 3, phase_tol="x")
    with pytest.raises(ModelError, match="inputs: unknown signal 0.0"):
        delayed.subsystem(inputs=0.0)


def test_tustin_on_a_pole_at_two_over_dt_says_so():
    # Reference: the bilinear map s = (2/T)(z - 1)/(z + 1) sends s = 2/T = 20 rad/s to z = infinity.
    with pytest.raises(ModelError, match="pole at s = 2/dt = 20 rad/s"):
        discretize(LinearSystem([[20.0]], [[1.0]], [[1.0]]), 0.1, "tustin")
