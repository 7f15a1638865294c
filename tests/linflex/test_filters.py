"""Structural filters (linflex.system._filters) against their transfer functions evaluated directly."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import ModelError, lead_lag, low_pass, notch

FAST = dict(derandomize=True, deadline=None, max_examples=40)


def response(sys, w):
    s = 1j * np.asarray(w, dtype=float)
    n = sys.n_states
    return np.array([(sys.C @ np.linalg.solve(si * np.eye(n) - sys.A, sys.B) + sys.D)[0, 0] for si in s])


@settings(**FAST)
@given(w=st.floats(0.1, 1e3), depth=st.floats(1.0, 60.0), rel_width=st.floats(0.01, 1.9))
def test_notch_depth_width_and_unit_gain_far_away(w, depth, rel_width):
    width = rel_width * w
    f = notch(w, depth, width)
    # Reference: the transfer function (s^2 + 2 zn w s + w^2) / (s^2 + 2 zd w s + w^2), zd = width / (2 w),
    # zn = zd 10^(-depth/20), evaluated as polynomials.
    zd = width / (2 * w)
    zn = zd * 10 ** (-depth / 20)
    grid = w * np.logspace(-2, 2, 9)
    s = 1j * grid
    expected = (s**2 + 2 * zn * w * s + w**2) / (s**2 + 2 * zd * w * s + w**2)
    np.testing.assert_allclose(response(f, grid), expected, rtol=1e-9, atol=1e-12)
    # Depth: exactly 10^(-depth/20) at the centre frequency (closed form, 1e-9 relative).
    np.testing.assert_allclose(abs(response(f, [w])[0]), 10 ** (-depth / 20), rtol=1e-9)


def test_notch_width_is_the_pole_pairs_half_power_band():
    # A 40 dB notch at 10 rad/s, 2 rad/s wide: the pole pair's damping is 0.1; between the two
    # frequencies w (sqrt(1 + zd^2) -+ zd) the denominator's gain is 3 dB down (closed form), so the
    # notch there attenuates about 3 dB (the numerator is 100 times smaller: 1e-2 relative).
    f = notch(10.0, 40.0, 2.0)
    zd = 0.1
    edges = 10 * (np.sqrt(1 + zd**2) + np.array([-zd, zd]))
    np.testing.assert_allclose(20 * np.log10(abs(response(f, edges))), -3.0103, atol=0.02)
    np.testing.assert_allclose(edges[1] - edges[0], 2.0, rtol=1e-12)


@settings(**FAST)
@given(w=st.floats(0.1, 1e3), z=st.floats(0.05, 2.0))
def test_low_pass_against_its_transfer_function(w, z):
    f = low_pass(w, z)
    grid = w * np.logspace(-2, 2, 9)
    s = 1j * grid
    np.testing.assert_allclose(response(f, grid), w**2 / (s**2 + 2 * z * w * s + w**2), rtol=1e-9, atol=1e-14)
    np.testing.assert_allclose(abs(response(f, [w])[0]), 1 / (2 * z), rtol=1e-9)  # closed form at w


@settings(**FAST)
@given(a=st.floats(0.01, 100.0), ratio=st.floats(0.05, 20.0), k=st.floats(-10, 10).filter(lambda x: abs(x) > 1e-3))
def test_lead_lag_phase_peak_closed_form(a, ratio, k):
    b = a * ratio
    f = lead_lag(a, b, k)
    grid = np.sqrt(a * b) * np.logspace(-1, 1, 5)
    s = 1j * grid
    np.testing.assert_allclose(response(f, grid), k * (s / a + 1) / (s / b + 1), rtol=1e-9)
    # Largest phase lead at sqrt(a b): arcsin((b - a) / (b + a)) (closed form).
    peak = np.angle(response(f, [np.sqrt(a * b)])[0] / np.sign(k))
    np.testing.assert_allclose(peak, np.arcsin((b - a) / (b + a)), atol=1e-9)


@pytest.mark.parametrize("call, message", [
    (lambda: notch(0.0, 20, 1), "frequency must be a finite positive"),
    (lambda: notch(10.0, -3, 1), "depth must be a finite positive"),
    (lambda: notch(10.0, 20, 25.0), "more than twice the frequency"),
    (lambda: low_pass(float("nan")), "frequency must be a finite positive number, got nan"),
    (lambda: low_pass(10.0, "high"), "damping must be a real number"),
    (lambda: lead_lag(1.0, 10.0, float("inf")), "gain must be a finite number"),
])
def test_bad_filter_parameters_are_named(call, message):
    with pytest.raises(ModelError, match=message):
        call()
