"""Flexible-body equations from modal integrals against the direct sum over mass points."""

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import Beam, ModalData, beam_modal_data
from linflex.dynamics._flexible import flexible_body_terms, inertia_load_factors


def random_body(n_points=9, n_modes=3, seed=5):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n_points, 3, 3))
    return ModalData(positions=rng.normal(size=(n_points, 3)), masses=rng.uniform(0.5, 2, n_points),
                     inertias=0.1 * A @ np.transpose(A, (0, 2, 1)), translations=0.3 * rng.normal(size=(n_points, 3, n_modes)),
                     rotations=0.3 * rng.normal(size=(n_points, 3, n_modes)), frequencies=np.arange(1.0, n_modes + 1),
                     damping=np.zeros(n_modes))


def nodal_inertia_forces(data, q, v, w, qd, vdot, wdot, qdd):
    """-F* by Kane's definition, one mass point at a time (reference notes section 5.1)::

        v_G = v + w x rho + Phi q',   a_G = v' + w x v + w' x rho + w x (w x rho) + 2 w x Phi q' + Phi q''
        w_G = w + Psi q',             alpha_G = w' + w x Psi q' + Psi q''
        partials: V = [U3, -rho~, Phi],  Omega = [0, U3, Psi]
    """
    n = data.n_modes
    total = np.zeros(6 + n)
    for m, r, Phi, Psi, J in zip(data.masses, data.positions, data.translations, data.rotations, data.inertias):
        rho = r + Phi @ q
        a = vdot + np.cross(w, v) + np.cross(wdot, rho) + np.cross(w, np.cross(w, rho)) \
            + 2 * np.cross(w, Phi @ qd) + Phi @ qdd
        wG = w + Psi @ qd
        alpha = wdot + np.cross(w, Psi @ qd) + Psi @ qdd
        torque = J @ alpha + np.cross(wG, J @ wG)
        skew_rho = np.array([[0, -rho[2], rho[1]], [rho[2], 0, -rho[0]], [-rho[1], rho[0], 0]])
        V = np.hstack([np.eye(3), -skew_rho, Phi])
        Om = np.hstack([np.zeros((3, 3)), np.eye(3), Psi])
        total += m * V.T @ a + Om.T @ torque
    return total


def evaluate_terms(data, state, geometric=False):
    n = data.n_modes
    q, v, w, qd = ca.SX.sym("q", n), ca.SX.sym("v", 3), ca.SX.sym("w", 3), ca.SX.sym("qd", n)
    M, C = flexible_body_terms(data, q, v, w, qd, geometric_stiffness=geometric)
    f = ca.Function("terms", [q, v, w, qd], [M, C])
    M_num, C_num = f(state["q"], state["v"], state["w"], state["qd"])
    return np.array(M_num), np.array(C_num).ravel()


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_invariants_equal_the_sum_over_mass_points(seed):
    # Issue 4: the mass matrix and inertia forces from the invariants equal the nodal sums for
    # random states to 1e-12 relative.
    data = random_body(seed=seed)
    rng = np.random.default_rng(100 + seed)
    state = {k: rng.normal(size=s) for k, s in (("q", 3), ("v", 3), ("w", 3), ("qd", 3))}
    accel = {k: rng.normal(size=s) for k, s in (("vdot", 3), ("wdot", 3), ("qdd", 3))}
    M, C = evaluate_terms(data, state)
    Udot = np.concatenate([accel["vdot"], accel["wdot"], accel["qdd"]])
    direct = nodal_inertia_forces(data, state["q"], state["v"], state["w"], state["qd"], **accel)
    np.testing.assert_allclose(M @ Udot + C, direct, rtol=1e-12, atol=1e-12 * np.abs(direct).max())
    np.testing.assert_allclose(M, M.T, atol=1e-12 * np.abs(M).max())  # symmetric without geometric stiffness


def test_inertia_load_factors_are_the_rigid_acceleration_field():
    # Section 5.4: A_1..A_12 give a_O + alpha x x + w x (w x x) at body point x (verified form).
    rng = np.random.default_rng(9)
    v, w, vdot, wdot, x = (rng.normal(size=3) for _ in range(5))
    A = np.array(ca.evalf(inertia_load_factors(ca.DM(v), ca.DM(w), ca.DM(vdot), ca.DM(wdot)))).ravel()
    field = np.hstack([np.eye(3), x[0] * np.eye(3), x[1] * np.eye(3), x[2] * np.eye(3)]) @ A
    expected = vdot + np.cross(w, v) + np.cross(wdot, x) + np.cross(w, np.cross(w, x))
    np.testing.assert_allclose(field, expected, rtol=1e-13)


def test_geometric_stiffness_of_a_steady_spin_is_the_southwell_stiffening():
    # Steady spin about z at Omega with v = 0 and no acceleration: the modal rows gain
    # -Omega^2 (S4 + S8) q (reference notes section 5.8).
    data = beam_modal_data(Beam((0, 0, 0), (10, 0, 0), EA=1e9, EIy=2e4, EIz=6e4, GJ=1e4, mass_per_length=1.5,
                                elements=10), 4)
    q = np.array([0.01, -0.02, 0.005, 0.001])
    state = {"q": q, "v": np.zeros(3), "w": np.array([0.0, 0.0, 1.3]), "qd": np.zeros(4)}
    _, C_plain = evaluate_terms(data, state)
    M_geo, C_geo = evaluate_terms(data, state, geometric=True)
    S = data.geometric_stiffness
    expected = -1.3**2 * (S[3] + S[7]) @ q
    # A difference of two evaluations: round-off relative to the largest entry.
    np.testing.assert_allclose(C_geo[6:] - C_plain[6:], expected, rtol=1e-9, atol=1e-11 * np.abs(expected).max())
    # The acceleration part: dv_x/dt multiplies S1 q in the modal rows (A_1 = v_x' + ...).
    np.testing.assert_allclose(M_geo[6:, 0], S[0] @ q, rtol=1e-9, atol=1e-11 * np.abs(S[0] @ q).max())


def test_graph_size_does_not_grow_with_the_number_of_points():
    # Issue 4: the equations' cost must not grow with the number of finite-element nodes. The
    # number of CasADi instructions is a deterministic measure of it (no timing in tests).
    sizes = []
    for n_points in (50, 5000):
        data = random_body(n_points=n_points, n_modes=4, seed=11)
        q, v, w, qd = ca.SX.sym("q", 4), ca.SX.sym("v", 3), ca.SX.sym("w", 3), ca.SX.sym("qd", 4)
        M, C = flexible_body_terms(data, q, v, w, qd)
        sizes.append(ca.Function("f", [q, v, w, qd], [M, C]).n_instructions())
    # Equal up to CasADi's simplification of the constants (a few instructions either way); a
    # loop over points would make the second graph about 100 times larger.
    assert sizes[1] <= 1.05 * sizes[0]


def test_pair_folding_equals_the_full_kronecker_contraction():
    # Independent computation: einsum of the unfolded tensor with a (x) a.
    import casadi as ca

    from linflex.dynamics._flexible import pair_products, pair_tensor

    rng = np.random.default_rng(7)
    for n in (1, 2, 5):
        T, a = rng.standard_normal((4, n, n)), rng.standard_normal(n)
        sym = ca.SX.sym("a", n)
        folded = ca.Function("p", [sym], [ca.DM(pair_tensor(T)) @ pair_products(sym)])(a)
        np.testing.assert_allclose(np.asarray(folded).ravel(), np.einsum("ikl,k,l->i", T, a, a), rtol=1e-13, atol=1e-13)


def test_dropping_roundoff_entries_changes_the_terms_by_roundoff_only(monkeypatch):
    # Independent computation: the same terms with every tensor entry kept (ROUNDOFF_SHARE = 0).
    # A 3D beam's modes mix bending in two planes and torsion, so most entries of its tensors are
    # round-off of sums that vanish by symmetry; dropping them must not change M or C beyond
    # round-off (1e-12 of the largest entry, the share dropped).
    import linflex.dynamics._flexible as flexible

    data = beam_modal_data(Beam((0, 0, 0), (8, 0, 0), EA=1e7, EIy=4e3, EIz=4e4, GJ=3e3, mass_per_length=5.0,
                                torsional_inertia_per_length=0.2, elements=8), 8)
    rng = np.random.default_rng(11)
    state = {name: rng.standard_normal(k) for name, k in (("q", 8), ("v", 3), ("w", 3), ("qd", 8))}
    cleaned = evaluate_terms(data, state, geometric=True)
    monkeypatch.setattr(flexible, "ROUNDOFF_SHARE", 0.0)
    full = evaluate_terms(data, state, geometric=True)
    for a, b in zip(cleaned, full):
        assert np.max(np.abs(a - b)) <= 1e-11 * np.max(np.abs(b))


def rotary_rows(data, w, qd):
    """``[0; sum t_G; sum Psi_G^T t_G]`` with ``t_G = J_G (w x Psi_G q') + w_G x J_G w_G``, point by
    point in numpy: the reference of both forms of the rotary velocity terms."""
    total = np.zeros(6 + data.n_modes)
    for J, Psi in zip(data.inertias, data.rotations):
        psi = Psi @ qd
        wG = w + psi
        t = J @ np.cross(w, psi) + np.cross(wG, J @ wG)
        total[3:6] += t
        total[6:] += Psi.T @ t
    return total


@settings(max_examples=40, deadline=None)
@given(n_points=st.integers(1, 12), n_modes=st.integers(1, 9), rank=st.integers(1, 3), seed=st.integers(0, 2**31))
def test_both_forms_of_the_rotary_terms_equal_the_sum_over_points(n_points, n_modes, rank, seed):
    # Independent computation: rotary_rows, a numpy loop over the points. The tensor form and
    # the point form are two summation orders of the same sum (rotary inertias of any rank).
    from linflex.dynamics._flexible import _rotary_point_terms, _rotary_tensor_terms

    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n_points, 3, rank))
    data = ModalData(positions=rng.normal(size=(n_points, 3)), masses=rng.uniform(0.5, 2, n_points),
                     inertias=A @ np.transpose(A, (0, 2, 1)), translations=rng.normal(size=(n_points, 3, n_modes)),
                     rotations=rng.normal(size=(n_points, 3, n_modes)), frequencies=np.arange(1.0, n_modes + 1),
                     damping=np.zeros(n_modes))
    w, qd = rng.normal(size=3), rng.normal(size=n_modes)
    reference = rotary_rows(data, w, qd)
    ws, qs = ca.SX.sym("w", 3), ca.SX.sym("qd", n_modes)
    for form in (_rotary_point_terms, _rotary_tensor_terms):
        value = np.array(ca.Function("rotary", [ws, qs], [form(data, ws, qs)])(w, qd)).ravel()
        np.testing.assert_allclose(value, reference, rtol=0, atol=1e-12 * np.abs(reference).max())


def test_rotary_terms_take_the_smaller_graph():
    # The example arrays (64 points with torsional inertia): the modal tensors are the smaller
    # graph at 8 modes, the sum over points at 48 (the tensors' terms grow like n^3, the points'
    # like n); the choice is the smaller of the two, counted on the same symbols.
    from linflex.dynamics._flexible import _rotary_point_terms, _rotary_tensor_terms, _rotary_velocity_terms

    for n_modes, smaller in ((8, _rotary_tensor_terms), (48, _rotary_point_terms)):
        data = beam_modal_data(Beam((0, 0, 0), (0, 8, 0), EA=1e7, EIy=4e3, EIz=4e3, GJ=3e3, mass_per_length=5.0,
                                    torsional_inertia_per_length=0.2, elements=16), n_modes)
        ws, qs = ca.SX.sym("w", 3), ca.SX.sym("qd", n_modes)
        count = {form: ca.Function("c", [ws, qs], [form(data, ws, qs)]).n_instructions()
                 for form in (_rotary_point_terms, _rotary_tensor_terms, _rotary_velocity_terms)}
        assert count[_rotary_velocity_terms] == count[smaller] == min(count[_rotary_point_terms],
                                                                      count[_rotary_tensor_terms])
