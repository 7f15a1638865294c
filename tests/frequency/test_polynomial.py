"""Polynomial blocks to state space (frequency/_polynomial.py, reference notes 9 and 14.4)."""

import numpy as np
import pytest

from linflex import ModelError, ShapeError
from linflex.frequency import bode_form, frequency_response, realize_polynomial, zpk


@pytest.mark.parametrize(
    ("num", "den"),
    [
        ([1.0], [1.0, 0.4, 4.0]),                       # m = 0 < n = 2
        ([2.0, 1.0], [1.0, 3.0, 3.0, 1.0]),             # m = 1 < n = 3
        ([1.0, 2.0, 3.0, 4.0], [2.0, 1.0, 5.0, 3.0]),   # m = n = 3
        ([0.0, 0.0, 5.0], [0.5, 1.0]),                   # leading zeros dropped: 5/(0.5 s + 1)
        ([7.0], [2.0]),                                  # static gain 3.5
    ],
)
def test_observer_form_reproduces_polynomial_ratio(num, den):
    # notes 14.4: P(jw)/Q(jw) evaluated directly with numpy.polyval (order <= 3: well conditioned)
    sys = realize_polynomial(num, den)
    w = np.array([0.1, 0.7, 1.9, 13.0])
    fr = frequency_response(sys, w)
    ref = np.polyval(num, 1j * w) / np.polyval(den, 1j * w)
    assert fr.response[:, 0, 0] == pytest.approx(ref, rel=1e-12)


def test_round_trip_through_zpk_and_bode_form():
    # (s + 2) / (s^2 + 0.2 s + 4): zero -2, poles -0.1 +- j 1.99750 (closed form), root gain 1,
    # Bode gain 2/4 = 0.5, zeta = 0.05, omega = 2
    sys = realize_polynomial([1.0, 2.0], [1.0, 0.2, 4.0])
    z = zpk(sys)
    assert z.zeros.real == pytest.approx([-2.0], rel=1e-12)
    assert z.gain == pytest.approx(1.0, rel=1e-12)
    bf = bode_form(z)
    assert bf.gain == pytest.approx(0.5, rel=1e-12)
    assert bf.pole_frequencies == pytest.approx([2.0], rel=1e-12)
    assert bf.pole_damping == pytest.approx([0.05], rel=1e-12)
    s = np.array([0.3j, 2.5j])
    assert bf.evaluate(s) == pytest.approx((s + 2) / (s**2 + 0.2 * s + 4), rel=1e-12)


def test_validation():
    with pytest.raises(ModelError, match="improper"):
        realize_polynomial([1.0, 0.0, 0.0], [1.0, 1.0])
    with pytest.raises(ModelError, match="limited to order 10"):
        realize_polynomial([1.0], np.poly(-np.arange(1, 13)))
    with pytest.raises(ModelError, match="zero polynomial"):
        realize_polynomial([1.0], [0.0, 0.0])
    with pytest.raises(ShapeError, match="not finite"):
        realize_polynomial([np.nan], [1.0, 1.0])
    assert realize_polynomial([1.0], [1.0, 1.0], input="e", output="v").inputs == ("e",)
