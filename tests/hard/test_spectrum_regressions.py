"""Regressions the long property run found (issue 16): each loop's answer against the exact
loop's, from closed forms.

- ``k / (s - 1e-16)``: the pole is rounding at the loop's own frequency ``k`` (its crossover and
  closed-loop pole), so it is at the origin like the exact ``k / s`` (spectrum policy: the scale of a
  loop includes its closed loop ``A - B (I + D)^-1 C``);
- ``k / s^2`` under a pure gain: the closed-loop poles ``+-j sqrt(k)`` are on the axis, and a
  1e-16 perturbation that puts them at ``-5e-17 +- j sqrt(k)`` leaves them there (not stable);
- ``k / s^2`` in a similarity realization: ``L(jw) = -k / w^2`` is real, its computed imaginary part
  rounding noise: no phase crossover (the curve lies on the critical line), one gain crossover at
  ``sqrt(k)`` with phase margin 0.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from linflex import LinearSystem
from linflex.frequency import nyquist_response
from linflex.frequency._spectrum import classify, system_scale
from linflex.stability import stability_margins


def _quiet(f, *args):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return f(*args)


@pytest.mark.parametrize("r", [0.0, 1e-16, -1e-16, 7e-16, 1e-14])
@pytest.mark.parametrize("k", [6.99, 1e-3, 1e4])
def test_integrator_with_a_rounding_pole_is_the_exact_integrator(r, k):
    # L = k / (s - a), a = r k with |r| <= 1e-14 (within 100 eps of the loop's frequency k, the
    # policy's rounding floor; the corpus drew k = 6.99, a = 1e-16): |L| = 1 at w = sqrt(k^2 -
    # a^2) = k to 1e-28 relative, phase -90 deg to 1e-14 rad (PM 90 deg, delay margin pi / (2 k)),
    # closed-loop pole -k + a: P = 0, N = 0, stable
    a = r * k
    L = LinearSystem([[a]], [[1.0]], [[k]])
    assert system_scale(L.A, L.B, L.C, L.D) == pytest.approx(k, rel=1e-13)  # the closed loop's |-k + a|
    spec = classify(L.A, B=L.B, C=L.C, D=L.D)
    assert spec.n_rhp == 0 and spec.rigid.all()
    m = _quiet(stability_margins, L)
    ny = _quiet(nyquist_response, L)
    assert (m.open_loop_unstable_poles, m.nyquist_encirclements, ny.open_loop_unstable_poles, ny.encirclements) == (0, 0, 0, 0)
    assert m.closed_loop_stable and m.closed_loop_unstable_poles == 0
    np.testing.assert_allclose(m.gain_crossovers, [k], rtol=1e-12)
    np.testing.assert_allclose(m.phase_margins, [90.0], atol=1e-9)
    np.testing.assert_allclose(m.delay_margins, [np.pi / (2 * k)], rtol=1e-12)


def test_a_genuine_slow_unstable_pole_stays_unstable():
    # 1e-6 / (s - 1e-9): the loop acts at 1e-6 rad/s, where 1e-9 is 1e-3 of the frequency, far
    # above rounding: P = 1, and the closed-loop pole -1e-6 + 1e-9 is stable (N = -1)
    L = LinearSystem([[1e-9]], [[1.0]], [[1e-6]])
    m = _quiet(stability_margins, L)
    ny = _quiet(nyquist_response, L)
    assert (m.open_loop_unstable_poles, ny.open_loop_unstable_poles, ny.encirclements) == (1, 1, -1)
    assert m.closed_loop_stable


@pytest.mark.parametrize("A", [[[0.0, 1.0], [0.0, 0.0]], [[0.0, 1.0], [-1e-16, -1e-16]], [[0.0, 1.0], [1e-16, 0.0]]])
def test_double_integrator_under_a_gain_is_not_asymptotically_stable(A):
    # L = c b / s^2 with c b = 1: closed-loop poles +-j exactly (A - B C = [[0, 1], [-1, 0]]); the
    # perturbations move them by 5e-17, within the rounding of the axis: not stable, 2 poles counted
    L = LinearSystem(A, [[0.0], [0.43141313]], [[1.0 / 0.43141313, 0.0]])
    m = _quiet(stability_margins, L)
    assert not m.closed_loop_stable
    assert m.closed_loop_unstable_poles == 2
    assert m.open_loop_unstable_poles == 0


def test_double_integrator_in_a_similarity_has_no_phase_crossover():
    # k / s^2 (k = 6.9923) under the similarity T = [[1, 2], [-0.3, 1]]: L(jw) = -k / w^2 is real at
    # every w; one gain crossover at sqrt(k) with phase margin 0 (to the 1e-12 rounding of L)
    k = 6.9923
    T = np.array([[1.0, 2.0], [-0.3, 1.0]])
    Ti = np.linalg.inv(T)
    A0, B0, C0 = np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]]), np.array([[k, 0.0]])
    rng = np.random.default_rng(0)
    for pert in (0.0, 1e-16):
        A = Ti @ A0 @ T + pert * rng.choice([-1.0, 1.0], (2, 2))
        m = _quiet(stability_margins, LinearSystem(A, Ti @ B0, C0 @ T))
        assert m.phase_crossovers.size == 0, m.phase_crossovers.tolist()
        np.testing.assert_allclose(m.gain_crossovers, [np.sqrt(k)], rtol=1e-9)
        assert abs(m.phase_margins[0]) <= 1e-9
