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
from hypothesis import example, given, settings
from hypothesis import strategies as st

from linflex import LinearSystem
from linflex.frequency import frequency_response, nyquist_response
from linflex.frequency._spectrum import classify, system_scale
from linflex.stability import stability_margins
from tests.hard.loops import EPS_LD, refined_response


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


# ----------------------------------------------------------------------------------------------
# companion forms (what tf2ss gives): the state matrix is Hessenberg already


def _companion(den, num, lower: bool, seed: int) -> LinearSystem:
    """Controllable canonical form of ``num / den`` (upper Hessenberg ``A``) with a rounding-size
    perturbation (1e-16) of its upper triangle, as a realization routine leaves it, or its
    transpose, the observable canonical form (lower Hessenberg)."""
    n = len(den) - 1
    A = np.zeros((n, n))
    A[0] = -np.asarray(den[1:]) / den[0]
    A[np.arange(1, n), np.arange(n - 1)] = 1.0
    A += np.triu(1e-16 * np.random.default_rng(seed).standard_normal((n, n)))
    B = np.zeros((n, 1))
    B[0, 0] = 1.0
    C = (np.r_[np.zeros(n - len(num) + 1), num][1:] / den[0])[None, :]
    if lower:
        return LinearSystem(A.T, C.T, B.T)
    return LinearSystem(A, B, C)


@settings(derandomize=True, max_examples=25, deadline=None)
@given(mult=st.integers(1, 4), slow=st.sampled_from([0.0, 1e-9, 1e-6]), others=st.lists(
    st.floats(0.05, 50.0), min_size=1, max_size=4), gain=st.floats(0.1, 10.0), lower=st.booleans(),
       seed=st.integers(0, 2**16))
@example(mult=4, slow=0.0, others=[1.0], gain=2.0, lower=False, seed=0)
def test_companion_forms_are_evaluated_by_their_hessenberg_lu(mult, slow, others, gain, lower, seed):
    # a cluster of poles at or near the origin that the eigenvalue paths only know to
    # eps^(1/mult) of ||A||. Reference:
    # iterative refinement with extended-precision residuals (tests/hard/loops.py). The long
    # property run found 1/s^4 + 2/(s+1) in companion form off by 1e-7 at 1e-3 rad/s (modal,
    # estimate 1.8e-3); the Hessenberg LU of the matrix as given is exact there, and its
    # componentwise residual bound says so.
    # G = 1 / (s + slow)^mult + gain / prod (s + p), the corpus's sum of terms
    cluster, rest = np.poly(np.full(mult, -slow)), np.poly(-np.asarray(others))
    sys = _companion(np.polymul(cluster, rest), np.polyadd(rest, gain * cluster), lower, seed)
    w = np.geomspace(1e-3, 1e2, 11)
    G_ref, ok, kappa = refined_response(sys, w)
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        fr = frequency_response(sys, w)
    err = np.abs(fr.response - G_ref).max(axis=(1, 2)) / np.abs(G_ref).max(axis=(1, 2))
    ref_err = 64 * sys.n_states * EPS_LD * kappa
    assert np.all(err[ok] <= fr.error_estimate + ref_err[ok])
    # and the truth is what a backward-stable solve in a good scaling gives (16 n eps kappa,
    # kappa the normwise condition after balancing A alone), or 1e-12
    assert np.all(err[ok] <= np.maximum(1e-12, 16 * sys.n_states * np.finfo(float).eps * kappa[ok]))


# ----------------------------------------------------------------------------------------------
# the long property run of session 7


_UNDAMPED_100 = [0, False, True, 2, 1, True, 0.5, -1.0, 0, 1, 2.0, "undamped", -2.0, -1.0, 1, 0, 0.0, "modal",
                 "random", 0.0]


def test_crossing_next_to_an_undamped_mode_under_a_1e16_perturbation():
    # 1.21 (1/s^2 + 1/s^2 + 1/(s^2 - 0.632 s + 10) + 0.257/(s^2 + 1e4)) with three entries of
    # 1e-16 max|A| added: |L| = 1 at 99.99844 and 100.00156 rad/s, the second on a grid point of
    # the scan; the perturbed loop's engine found only the first. Reference: the exact loop's
    # brute force (check_margins of the property suite, strict).
    from tests.hard.loops import replayed_loop
    from tests.hard.test_frequency_properties import check_invariance

    lp = replayed_loop(_UNDAMPED_100, max_order=24, allow_perturbation=False, realizations=("modal", "similarity"))
    A = np.array(lp.sys.A)
    A[4, 0] -= 1e-12
    A[5, 2] -= 1e-12
    A[6, 2] -= 1e-12
    check_invariance((lp, LinearSystem(A, lp.sys.B, lp.sys.C, lp.sys.D), 0))


def test_root_locus_from_a_pole_of_the_split_block():
    # 1.05 (1/s^2 + 1/s + 1/(s+1)) in modal form: the Aberth iteration of a gain started on the
    # open-loop poles, one of them exactly an eigenvalue of the split-off block (a singular solve,
    # before: numpy's LinAlgError escaped). Reference: eig(A - k b c) at every gain
    # (check_root_locus of the property suite).
    from tests.hard.loops import replayed_loop
    from tests.hard.test_frequency_properties import check_root_locus

    check_root_locus(replayed_loop([0, False, True, 1, 0, 1, 0.0, 0, 0, 0.0, "modal", "random", 0.0, False]))
