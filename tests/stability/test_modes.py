"""Tests of linflex.stability.modes against closed forms and python-control's damp."""

from __future__ import annotations

import control
import numpy as np
import pytest

from linflex import LinearSystem, ModelError, SecondOrderSystem
from linflex.stability import modes

from .stab_models import hub_loop, hub_parameters


def oscillator(wn, zeta):
    return LinearSystem([[0, 1], [-wn**2, -2 * zeta * wn]], [[0], [1]], [[1, 0]], states=["q", "v"])


@pytest.mark.parametrize("wn, zeta", [(2.0, 0.1), (50.0, 1e-4), (0.01, 0.7)])
def test_single_oscillator_closed_form(wn, zeta):
    # Reference: closed form, lambda = -zeta wn +- j wn sqrt(1 - zeta^2).
    t = modes(oscillator(wn, zeta))
    assert len(t) == 1
    m = t[0]
    assert m.kind == "oscillatory" and not m.unstable
    assert m.natural_frequency == pytest.approx(wn, rel=1e-12)  # rounding of a 2x2 eig
    assert m.frequency_hz == pytest.approx(wn / (2 * np.pi), rel=1e-12)
    assert m.damping_ratio == pytest.approx(zeta, rel=1e-9)  # rel error ~ eps / zeta at 1e-4
    assert m.damped_frequency == pytest.approx(wn * np.sqrt(1 - zeta**2), rel=1e-12)
    assert m.time_constant == pytest.approx(1 / (zeta * wn), rel=1e-9)


def test_real_roots_and_unstable():
    # Reference: diagonal A, eigenvalues are the diagonal; tau = -1/lambda.
    t = modes(LinearSystem(np.diag([-2.0, 0.5, -0.1]), np.ones((3, 1)), states=["a", "b", "c"]))
    lam = t.eigenvalues
    np.testing.assert_allclose(lam.real, [-0.1, 0.5, -2.0], rtol=1e-14)
    kinds = [(m.kind, m.unstable) for m in t]
    assert kinds == [("real", False), ("real", True), ("real", False)]
    np.testing.assert_allclose([m.time_constant for m in t], [10.0, -2.0, 0.5], rtol=1e-14)
    np.testing.assert_allclose(t.damping_ratios, [1.0, -1.0, 1.0], rtol=1e-14)
    # each diagonal mode involves exactly its own state
    assert [m.participation for m in t] == [(("c", 1.0),), (("b", 1.0),), (("a", 1.0),)]


def test_hub_order_401_zeta_1e4_closed_form_and_rigid_body():
    # Reference: the hub model is built in modal form, so its eigenvalues are known in closed
    # form: 0 (twice, rigid hub), -1/tau (filter) and -zeta w_i +- j w_i sqrt(1 - zeta^2).
    zeta = 1e-4
    L = hub_loop(401, zeta)
    w, _, _ = hub_parameters(401, zeta)
    rng = np.random.default_rng(3)
    Q, _ = np.linalg.qr(rng.standard_normal((401, 401)))
    Ls = LinearSystem(Q.T @ L.A @ Q, Q.T @ L.B, L.C @ Q, L.D)  # dense, non-modal realization
    for sys in (L, Ls):
        t = modes(sys)
        assert t.n_rigid == 2
        assert [m.kind for m in t[:2]] == ["rigid-body", "rigid-body"]
        osc = [m for m in t if m.kind == "oscillatory"]
        real = [m for m in t if m.kind == "real"]
        assert len(osc) == 199 and len(real) == 1
        assert len(t) == 2 + 199 + 1  # complex pairs listed once
        np.testing.assert_allclose([m.natural_frequency for m in osc], np.sort(w), rtol=1e-10)
        # damping 1e-4 from a dense orthogonally transformed 401x401 A: absolute error about
        # eps * ||A|| / w_i, ||A|| ~ 1e5 here, so 1e-8 absolute on zeta (1e-4 relative)
        np.testing.assert_allclose([m.damping_ratio for m in osc], zeta, atol=1e-8)
        assert real[0].time_constant == pytest.approx(0.02, rel=1e-9)
    # participation in the modal realization: mode i is carried by q_i and q_i_dot
    t = modes(L)
    lowest = [m for m in t if m.kind == "oscillatory"][0]
    names = {name for name, _ in lowest.participation}
    i = int(np.argmin(w))
    assert {f"q{i}", f"q{i}_dot"} <= names


def test_three_axis_rigid_body_and_python_control_damp():
    # 3-axis double integrators plus two flexible modes; reference: python-control's damp
    # (independent eigenvalue post-processing) for the flexible rows; six rigid eigenvalues.
    n_rig = 3
    A = np.zeros((10, 10))
    for k in range(n_rig):
        A[2 * k, 2 * k + 1] = 1.0
    A[6:8, 6:8] = [[0, 1], [-9.0, -0.006]]
    A[8:10, 8:10] = [[0, 1], [-400.0, -0.4]]
    A[7, 1] = 0.3  # coupling of the rigid rate into a mode (still block triangular)
    sys = LinearSystem(A, np.ones((10, 1)), np.ones((1, 10)))
    t = modes(sys)
    assert t.n_rigid == 6
    flex = [m for m in t if m.kind != "rigid-body"]
    with np.errstate(invalid="ignore", divide="ignore"):  # damp divides by |lambda| = 0 for rigid rows
        wn_ref, zeta_ref, _ = control.damp(sys.to_control(), doprint=False)
    keep = wn_ref > 1e-3
    pairs = sorted(set(zip(np.round(wn_ref[keep], 9), np.round(zeta_ref[keep], 12))))
    np.testing.assert_allclose([m.natural_frequency for m in flex], [p[0] for p in pairs], rtol=1e-10)
    np.testing.assert_allclose([m.damping_ratio for m in flex], [p[1] for p in pairs], rtol=1e-8)


def test_badly_scaled_states():
    # A similarity with state scales from 1e-6 to 1e6 (metres beside micro-radians) leaves the
    # eigenvalues unchanged (reference: similarity invariance); the rigid-body tolerance is scaled
    # by the balanced norm, so the rigid-body pair is still recognized.
    L = hub_loop(21, 0.005)
    s = np.geomspace(1e-6, 1e6, 21)
    As = (L.A * s[:, None]) / s[None, :]
    t0, t1 = modes(L), modes(LinearSystem(As, np.ones((21, 1))))
    assert t1.n_rigid == 2
    osc0 = np.array([m.natural_frequency for m in t0 if m.kind == "oscillatory"])
    osc1 = np.array([m.natural_frequency for m in t1 if m.kind == "oscillatory"])
    np.testing.assert_allclose(osc1, osc0, rtol=1e-9)  # LAPACK balancing undoes the scaling
    z0 = np.array([m.damping_ratio for m in t0 if m.kind == "oscillatory"])
    z1 = np.array([m.damping_ratio for m in t1 if m.kind == "oscillatory"])
    np.testing.assert_allclose(z1, z0, rtol=1e-6)


def test_second_order_system_names_and_control_input():
    # Reference: two uncoupled oscillators, w = 1 and 3 rad/s, zeta from D = 2 zeta w.
    so = SecondOrderSystem(np.eye(2), np.diag([0.02, 0.06]), np.diag([1.0, 9.0]), [[1], [1]], dofs=["panel", "boom"])
    t = modes(so)
    np.testing.assert_allclose(t.natural_frequencies, [1.0, 3.0], rtol=1e-12)
    np.testing.assert_allclose(t.damping_ratios, [0.01, 0.01], rtol=1e-10)
    assert {n for n, _ in t[0].participation} == {"panel", "panel_dot"}
    assert {n for n, _ in t[1].participation} == {"boom", "boom_dot"}
    t2 = modes(so.to_control())
    np.testing.assert_allclose(t2.natural_frequencies, [1.0, 3.0], rtol=1e-12)
    text, md = str(t), t.to_markdown()
    assert "panel" in text and "0.01" in text
    assert md.count("\n") == 3 and "| 1 |" in md


def test_eigenvectors_are_eigenvectors():
    # Reference: A v = lambda v for every row, to rounding.
    L = hub_loop(51, 0.005)
    t = modes(L)
    for k, m in enumerate(t):
        v = t.eigenvectors[:, k]
        r = np.linalg.norm(L.A @ v - m.eigenvalue * v)
        # rigid rows: Jordan block, residual ~ sqrt(eps)*||A|| at worst
        assert r <= (1e-6 if m.kind == "rigid-body" else 1e-9) * np.linalg.norm(L.A, 1)


def test_bad_input():
    with pytest.raises(ModelError, match="sys must be a LinearSystem"):
        modes(np.eye(2))
    with pytest.raises(ModelError, match=r"participation_threshold must be in \[0, 1\], got 2"):
        modes(oscillator(1.0, 0.1), participation_threshold=2)
    with pytest.raises(ModelError, match="rigid_tol must be a finite non-negative number"):
        modes(oscillator(1.0, 0.1), rigid_tol=-1.0)


def test_slow_libration_is_not_rigid_body():
    # Reference: block-diagonal A, eigenvalues in closed form: three double integrators (six
    # rigid-body eigenvalues), an undamped gravity-gradient libration at 1.7e-3 rad/s (a pair
    # that sums to zero like a rounding cloud, but stands apart from the origin) and a stiff mode
    # at 300 rad/s that sets the scale.
    A = np.zeros((12, 12))
    for k in range(3):
        A[2 * k, 2 * k + 1] = 1.0
    A[6:8, 6:8] = [[0, 1], [-(1.7e-3**2), 0]]
    A[8:10, 8:10] = [[0, 1], [-(300.0**2), -0.3]]
    A[10:12, 10:12] = [[0, 1], [-1.0, -0.002]]
    t = modes(LinearSystem(A, np.ones((12, 1))))
    assert t.n_rigid == 6
    lib = [m for m in t if m.kind == "oscillatory" and m.natural_frequency < 0.01]
    assert len(lib) == 1
    assert lib[0].natural_frequency == pytest.approx(1.7e-3, rel=1e-9)
    assert lib[0].damping_ratio == pytest.approx(0.0, abs=1e-9)
