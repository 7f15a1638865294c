"""The 21 unit inertia loads: geometric stiffness of the nodal rotary-inertia torques (Banerjee 5.19-5.23)."""

import casadi as ca
import numpy as np
import pytest
import scipy.linalg

import linflex
from linflex import Beam, ModelError, PointMassAt, assemble_beams, beam_modal_data
from linflex.dynamics._flexible import flexible_body_terms, inertia_load_factors
from linflex.structures._beam import _unit_inertia_torques

RNG = np.random.default_rng(21)
_A = RNG.normal(size=(3, 3))
NODE_INERTIA = 0.5 * _A @ _A.T + 0.2 * np.eye(3)  # a full (non-diagonal) nodal inertia [kg m^2]

# A frame of two members meeting at a corner, clamped at both far ends: statically
# indeterminate, so a couple at the corner puts axial forces in the members (the shear of one is
# the axial force of the other). A clamped tree would carry a couple by bending alone.
FRAME = tuple(Beam(start, end, EA=1e6, EIy=1e4, EIz=2e4, GJ=1e4, mass_per_length=1.0, torsional_inertia_per_length=0.05,
                   elements=6) for start, end in (((0, 0, 0), (4, 0, 0)), ((4, 0, 0), (4, 3, 0))))
CLAMPED = ((0, 0, 0), (4, 3, 0))
CORNER = PointMassAt((4, 0, 0), 2.0, NODE_INERTIA)


def factors(w, wdot):
    """A_1..A_21 for angular velocity w and acceleration wdot, the reference point at rest."""
    zero = ca.DM.zeros(3)
    return np.array(ca.evalf(inertia_load_factors(zero, ca.DM(w), zero, ca.DM(wdot), rotary=True))).ravel()


def test_unit_torques_are_the_nodal_inertia_torque():
    # Eqs. 5.19-5.21 as tabulated in the reference notes: -(J w' + w x J w) for any J, w, w'.
    w, wdot = RNG.normal(size=3), RNG.normal(size=3)
    expected = -(NODE_INERTIA @ wdot + np.cross(w, NODE_INERTIA @ w))
    np.testing.assert_allclose(_unit_inertia_torques(NODE_INERTIA) @ factors(w, wdot)[12:], expected, rtol=1e-13)


def test_without_rotary_inertia_the_nine_extra_loads_vanish_exactly():
    beam = Beam((0, 0, 0), (10, 0, 0), EA=2.8e7, EIy=1.4e4, EIz=2.8e4, GJ=1e4, mass_per_length=1.2, elements=10)
    twelve = beam_modal_data(beam, 4)
    twentyone = beam_modal_data(beam, 4, unit_loads=21)
    assert twelve.geometric_stiffness.shape[0] == 12 and twentyone.geometric_stiffness.shape[0] == 21
    np.testing.assert_array_equal(twentyone.geometric_stiffness[:12], twelve.geometric_stiffness)
    np.testing.assert_array_equal(twentyone.geometric_stiffness[12:], 0.0)

    # The same equations of motion, to the last bit, on a tumbling hub with the effect.
    def model(data):
        return linflex.compile_model(linflex.Scene(
            name="hub", effects=("geometric_stiffness",),
            bodies=(linflex.Body(name="beam", mass=20.0, inertia=(2.0, 3.0, 4.0), type="flexible", modal_data=data),),
            joints=(linflex.Joint(name="float", type="free", child="beam"),)))

    a, b = model(twelve), model(twentyone)
    x = np.array(a.x0)
    x[7:] += RNG.normal(size=x.size - 7)
    np.testing.assert_array_equal(b.evaluate(x)[0], a.evaluate(x)[0])
    with pytest.raises(ModelError, match="unit_loads must be None, 12 or 21"):
        beam_modal_data(beam, 2, unit_loads=13)


def test_a_couple_on_a_clamped_tree_gives_no_geometric_stiffness():
    # Closed-form statics: a cantilever carries end couples by bending and torsion, with zero
    # axial force, so the rotary loads of a torsional inertia and a tip inertia add nothing.
    beam = Beam((0, 0, 0), (10, 0, 0), EA=2.8e7, EIy=1.4e4, EIz=2.8e4, GJ=1e4, mass_per_length=1.2,
                torsional_inertia_per_length=0.05, elements=10)
    data = beam_modal_data(beam, 4, point_masses=(PointMassAt((10, 0, 0), 2.0, NODE_INERTIA),))
    S = data.geometric_stiffness
    assert S.shape[0] == 21  # rotary inertia present: 21 loads by default
    assert np.max(np.abs(S[12:])) <= 1e-12 * np.max(np.abs(S[:12]))


def _hermite_geometric(L):
    """Consistent geometric stiffness of a cubic Hermite beam per unit axial force, closed form
    (Przemieniecki, Theory of Matrix Structural Analysis, 1968, Eq. 15.28) on (v1, v'1, v2, v'2)."""
    return np.array([[36, 3 * L, -36, 3 * L], [3 * L, 4 * L**2, -3 * L, -L**2],
                     [-36, -3 * L, 36, -3 * L], [3 * L, -L**2, -3 * L, 4 * L**2]]) / (30 * L)


def test_rotary_loads_of_an_indeterminate_frame_against_a_direct_construction():
    # Reference built here from the assembled stiffness only: the corner's inertia torque
    # -(J w' + w x J w) as a nodal couple; each element's torsional inertia J_e = rho J L e e^T
    # as a uniformly distributed couple, whose consistent loads are half its axial component on
    # each end's twist and, for its transverse components m_y, m_z (local), the force pairs
    # -/+ m_z / L on v and +/- m_y / L on w (the work of a couple through v' = tz, w' = -ty);
    # the static solution with both ends clamped, each element's axial force
    # N = EA/L (u_b - u_a) . e, and N times the closed-form Hermite geometric stiffness in both
    # bending planes, projected on the mode shapes at every node. It must equal
    # sum_{i=13}^{21} S^(i) A_i (round-off: 1e-10).
    structure = assemble_beams(FRAME, point_masses=(CORNER,))
    named = {f"n{k}": tuple(p) for k, p in enumerate(structure.nodes)}
    data = beam_modal_data(FRAME, 6, clamped=CLAMPED, point_masses=(CORNER,), nodes=named)
    assert data.geometric_stiffness.shape[0] == 21
    Phi = np.zeros((structure.K.shape[0], data.n_modes))  # all 6 freedoms of every node, by mode
    for k, p in enumerate(structure.nodes):
        _, trans, rot = data.node(f"n{k}")
        Phi[structure.dofs(p)] = np.vstack([trans, rot])

    w, wdot = np.array([0.3, -1.1, 0.7]), np.array([0.5, 0.2, -0.9])
    load = np.zeros((structure.K.shape[0], 2))  # the corner's couple, the members' couples
    load[structure.dofs(CORNER.position)[3:], 0] = -(NODE_INERTIA @ wdot + np.cross(w, NODE_INERTIA @ w))
    for beam in FRAME:
        R, e = beam.rotation(), beam.rotation()[0]
        a, b = np.asarray(beam.start), np.asarray(beam.end)
        L = beam.length / beam.elements
        J_e = beam.torsional_inertia_per_length * L * np.outer(e, e)
        m = R @ -(J_e @ wdot + np.cross(w, J_e @ w))  # the element's couple, local axes
        for k in range(beam.elements):
            da, db = structure.dofs(a + (b - a) * k / beam.elements), structure.dofs(a + (b - a) * (k + 1) / beam.elements)
            for dofs, sign in ((da, -1.0), (db, 1.0)):
                load[dofs[3:], 1] += R.T @ np.array([m[0] / 2, 0.0, 0.0])
                load[dofs[:3], 1] += R.T @ np.array([0.0, sign * m[2] / L, -sign * m[1] / L])
    fixed = np.concatenate([structure.dofs(p) for p in CLAMPED])
    free = np.setdiff1d(np.arange(load.shape[0]), fixed)
    u = np.zeros_like(load)
    u[free] = scipy.linalg.solve(structure.K[np.ix_(free, free)], load[free])

    parts = np.zeros((2, data.n_modes, data.n_modes))
    for beam in FRAME:
        R = beam.rotation()
        a, b = np.asarray(beam.start), np.asarray(beam.end)
        L = beam.length / beam.elements
        G = _hermite_geometric(L)
        for k in range(beam.elements):
            da, db = structure.dofs(a + (b - a) * k / beam.elements), structure.dofs(a + (b - a) * (k + 1) / beam.elements)
            N = beam.EA / L * (R[0] @ (u[db[:3]] - u[da[:3]]))
            local = [R @ Phi[d] for d in (da[:3], da[3:], db[:3], db[3:])]  # (3, M) each, local axes
            v = np.vstack([local[0][1], local[1][2], local[2][1], local[3][2]])  # v, tz = v'
            w_ = np.vstack([local[0][2], -local[1][1], local[2][2], -local[3][1]])  # w, -ty = w'
            parts += N[:, None, None] * (v.T @ G @ v + w_.T @ G @ w_)

    S = data.geometric_stiffness
    A = factors(w, wdot)
    rotary = np.einsum("i,ijk->jk", A[12:], S[12:])
    expected = parts.sum(axis=0)
    # Neither part is negligible (against the translational loads, and the members' against the total).
    assert np.max(np.abs(expected)) > 1e-3 * np.max(np.abs(np.einsum("i,ijk->jk", A[:12], S[:12])))
    assert np.max(np.abs(parts[1])) > 1e-3 * np.max(np.abs(expected))
    np.testing.assert_allclose(rotary, expected, rtol=0, atol=1e-10 * np.max(np.abs(expected)))


def test_geometric_stiffness_effect_uses_the_rotary_loads():
    # Run time (reference notes, sections 5.4 and 5.8, corrected Eq. 5.25): a steady spin Omega
    # about x has A8 = A12 = -Omega^2, A19 = Omega^2, A21 = -Omega^2, so the modal rows gain
    # -Omega^2 (S8 + S12 - S19 + S21) q; the angular acceleration w3' multiplies
    # (S15 + S5 - S7) q. In this frame (in the x-y plane) only in-plane couples (about z) load
    # the members axially: S19 (the couple I12 w1^2 about z) is the rotary term that shows.
    data = beam_modal_data(FRAME, 4, clamped=CLAMPED, point_masses=(CORNER,))
    S = data.geometric_stiffness
    q = np.array([0.01, -0.02, 0.005, 0.001])
    n = data.n_modes
    qs, v, w, qd = ca.SX.sym("q", n), ca.SX.sym("v", 3), ca.SX.sym("w", 3), ca.SX.sym("qd", n)
    terms = {g: ca.Function("t", [qs, v, w, qd], list(flexible_body_terms(data, qs, v, w, qd, geometric_stiffness=g)))
             for g in (False, True)}
    spin = 1.3
    state = (q, np.zeros(3), [spin, 0.0, 0.0], np.zeros(n))
    (M_plain, C_plain), (M_geo, C_geo) = ([np.array(x) for x in terms[g](*state)] for g in (False, True))
    expected = -spin**2 * (S[7] + S[11] - S[18] + S[20]) @ q
    assert np.max(np.abs(S[18])) > 1e-3 * np.max(np.abs(S[7] + S[11]))  # the rotary part matters
    np.testing.assert_allclose(C_geo.ravel()[6:] - C_plain.ravel()[6:], expected, rtol=0,
                               atol=1e-10 * np.abs(expected).max())
    column = (S[14] + S[4] - S[6]) @ q
    assert np.max(np.abs(S[14] @ q)) > 1e-3 * np.max(np.abs(column))
    np.testing.assert_allclose(M_geo[6:, 5] - M_plain[6:, 5], column, rtol=0, atol=1e-10 * np.abs(column).max())
