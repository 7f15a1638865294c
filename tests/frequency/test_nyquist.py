"""Nyquist contour and encirclement count (frequency/_nyquist.py), cross-checked against
closed-loop eigenvalues: Z = N + P."""

import warnings

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ModelError, ShapeError
from linflex.frequency import Loop, nyquist_response, transfer_function
from linflex.stability import stability_margins

from .conftest import flexible_modal, two_mass


def tf(num, den):
    return LinearSystem.from_control(control.ss(control.tf(num, den)))


def closed_loop_rhp(L):
    """Independent: eigenvalues of the closed loop u = -y around L, counted in Re > 0."""
    F = np.eye(L.n_inputs) + L.D
    Acl = L.A - L.B @ np.linalg.solve(F, L.C)
    return int(np.sum(np.linalg.eigvals(Acl).real > 1e-9))


CASES = {
    "stable_type1": tf([4], [1, 1, 0]),                               # 4/(s(s+1))
    "unstable_K10": tf([10], np.polymul([1, 1, 0], [1, 2])),          # K=10 > 6: Z = 2 (Routh)
    "stable_K5": tf([5], np.polymul([1, 1, 0], [1, 2])),              # K=5 < 6: Z = 0 (Routh)
    "open_loop_unstable": tf([2], [1, -1]),                           # P = 1, N = -1, Z = 0
    "double_integrator_pd": tf([3, 1], [1, 0, 0]),                    # rigid body with PD: stable
    "double_integrator_wrong_sign": tf([-3, -1], [1, 0, 0]),
    "undamped_oscillator": tf([1, 0.5], [1, 0, 4]),                   # poles at +-2j indented
    "unstable_two_rhp": tf([1, 3], np.polymul([1, -1], [1, -2])),     # P = 2
}


@pytest.mark.parametrize("name", list(CASES))
def test_siso_criterion_matches_closed_loop_eigenvalues(name):
    L = CASES[name]
    r = nyquist_response(L)
    assert r.closed_loop_unstable_poles == closed_loop_rhp(L)
    assert r.closed_loop_unstable_poles == r.encirclements + r.open_loop_unstable_poles
    assert r.open_loop_unstable_poles == int(np.sum(np.linalg.eigvals(L.A).real > 1e-9))


def test_known_counts():
    # Routh: s^3 + 3 s^2 + 2 s + K, K = 10: two RHP roots -> N = 2 clockwise encirclements of -1
    assert nyquist_response(CASES["unstable_K10"]).encirclements == 2
    # 2/(s-1): one counter-clockwise encirclement (N = -1) stabilises P = 1
    assert nyquist_response(CASES["open_loop_unstable"]).encirclements == -1


def test_indentation_around_rigid_body_poles():
    r = nyquist_response(CASES["double_integrator_pd"])
    assert r.indentations.tolist() == [0j]
    # the contour avoids the origin by the indentation radius
    assert np.min(np.abs(r.s)) == pytest.approx(r.indent_radius, rel=1e-9)
    # on the indentation L ~ 1/s^2 is huge: |L| >= 1/r^2 roughly (closed form of the dominant term)
    assert np.max(np.abs(r.values)) > 0.5 / r.indent_radius**2
    osc = nyquist_response(CASES["undamped_oscillator"])
    assert sorted(osc.indentations.imag.round(9).tolist()) == [-2.0, 2.0]


def test_loop_with_flexible_plant_and_rigid_body():
    # spacecraft: rigid double integrator + 30 modes (zeta 1e-3), PD attitude controller
    P = flexible_modal(30, 1e-3, seed=4, rigid=True)
    P = P.with_(inputs=["torque"], outputs=["angle"])
    for kp, kd, in ((0.05, 0.4), (5.0, -0.5)):
        K = LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[kp]], inputs=["e"], outputs=["u"])
        # PD via a filtered derivative: kp + kd s/(0.01 s + 1)
        K = LinearSystem([[-100.0]], [[1.0]], [[-kd * 1e4]], [[kp + kd * 100]], inputs=["e"], outputs=["u"])
        loop = Loop(P, K, sensors="angle", actuators="torque")
        r = nyquist_response(loop)
        cl = transfer_function(loop, "closed_loop")
        z_true = int(np.sum(np.linalg.eigvals(cl.A).real > 1e-9))
        assert r.closed_loop_unstable_poles == z_true


@pytest.mark.parametrize("seed", range(4))
def test_mimo_determinant_criterion(seed):
    rng = np.random.default_rng(seed)
    n = 6
    A = rng.normal(size=(n, n)) + (0.5 - seed * 0.4) * np.eye(n)
    L = LinearSystem(A, rng.normal(size=(n, 2)), rng.normal(size=(2, n)) * (1 + seed))
    r = nyquist_response(L)
    assert r.closed_loop_unstable_poles == closed_loop_rhp(L)
    # values are det(I + L) - 1: check at one contour point against a direct solve
    s = r.s[len(r.s) // 3]
    G = L.C @ np.linalg.solve(s * np.eye(n) - L.A, L.B)
    assert r.values[len(r.s) // 3] == pytest.approx(np.linalg.det(np.eye(2) + G) - 1, rel=1e-9)


def test_two_mass_loop_from_notes():
    # two-mass plant (notes 13) with a lead controller on x1: closed-loop eigenvalues decide
    K = LinearSystem([[-10.0]], [[1.0]], [[-300.0]], [[32.0]], inputs=["e"], outputs=["u"])
    loop = Loop(two_mass(), K, sensors="x1", actuators="F1")
    r = nyquist_response(loop)
    cl = transfer_function(loop, "closed_loop")
    assert r.closed_loop_unstable_poles == int(np.sum(np.linalg.eigvals(cl.A).real > 1e-9))


def test_validation():
    with pytest.raises(ShapeError, match="must be square"):
        nyquist_response(LinearSystem(np.eye(2) * -1, np.ones((2, 2)), np.ones((1, 2))))
    with pytest.raises(ModelError, match="indent_radius"):
        nyquist_response(CASES["stable_type1"], indent_radius=-1.0)


def test_slow_undamped_pairs_are_not_a_rigid_group():
    # issue 16 (property corpus): rigid body + undamped modes at 0.01 and 0.0359 rad/s (and
    # 6.18, 31.6) under PD, spectral scale 97: the two slow pairs sum to exactly zero and lie
    # within 100 eps^(1/4) scale of the origin, so the trace rule took all six poles as one
    # rigid group, indented the origin by 0.38 rad/s and hid four closed-loop poles in the
    # right half-plane (N = 2 against Z = 6 from the eigenvalues). The group's polynomial
    # (c_2 = 0.01^2 + 0.0359^2, not at rounding level) now rejects them.
    from linflex.frequency._spectrum import classify

    from ..hard.loops import assemble, scale_output

    def mode(w, g):
        return ("mode", w, 0.0, 2, np.array([g]), np.ones(1))

    parts = [("rigid", 0.0, 0.0, 2, np.ones(1), np.ones(1)), ("real", -2.898, 0.0, 1, np.ones(1), np.ones(1)),
             ("real", -1.0, 0.0, 1, np.ones(1), np.ones(1)), mode(6.18287, 0.32), mode(0.01, -0.514),
             mode(31.6228, -0.373), mode(0.0359061, -0.18)]
    L = scale_output(assemble(parts, m=1, kp=0.384, kd=2.16, tau=0.0316, dp=-0.371), 8.8842e-05)
    spec = classify(L.A, B=L.B, C=L.C)
    assert np.count_nonzero(spec.rigid) == 2
    Z = closed_loop_rhp(L)
    r = nyquist_response(L)
    assert Z == 6 and r.open_loop_unstable_poles == 0
    assert r.encirclements + r.open_loop_unstable_poles == Z


@settings(max_examples=25, deadline=None)
@given(k=st.floats(1e-3, 1e3), w2=st.sampled_from([0.0, 0.25, 4.0, 100.0]))
def test_closed_loop_pole_on_the_axis_counts_as_not_stable(k, w2):
    """``k / (s^2 + w2)`` closes to ``s^2 + w2 + k``: two closed-loop poles on the axis at
    ``+-j sqrt(w2 + k)``, where the curve passes through -1 (at the grid point itself for
    ``1 / s^2``). Reference: that closed form and stability_margins' eigenvalue count; the
    response is a count, not an error, and no RuntimeWarning leaks."""
    L = control.tf([k], [1.0, 0.0, w2])
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        r = nyquist_response(L)
    assert r.open_loop_unstable_poles == 0
    assert r.closed_loop_unstable_poles == 2 == stability_margins(L).closed_loop_unstable_poles
    assert r.encirclements == 2


def test_double_integrator_under_unit_gain_passes_through_minus_one():
    r = nyquist_response(control.tf([1.0], [1.0, 0.0, 0.0]))
    assert r.min_distance <= 1e-12   # L(j 1) = -1 on a grid point (closed form)
    assert (r.encirclements, r.closed_loop_unstable_poles) == (2, 2)
