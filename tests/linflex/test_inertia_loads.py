"""Geometric stiffness of the unit inertia loads from assembled matrices (the generic path),
against the element path of beam_modal_data and the classic spinning and accelerated beams."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import Beam, ModelError, PointMassAt, assemble_beams, beam_modal_data
from linflex.structures import inertia_load_stiffness
from linflex.structures._beam import _modes

EI, MASS, LENGTH = 1.4e4, 1.2, 10.0


def both_paths(beams, n_modes=6, point_masses=(), rotary=False):
    """The generic path on assemble_beams' matrices and the element path of beam_modal_data,
    with the same modes (the eigensolver beam_modal_data uses, clamped at the origin)."""
    s = assemble_beams(beams, point_masses=point_masses)
    free = np.arange(6, s.K.shape[0])
    _, Phi = _modes(np.array(s.K), np.array(s.M), free, n_modes)
    J = None
    if rotary:
        J = np.zeros((len(s.nodes), 3, 3))
        for pm in point_masses:
            J[np.argmin(np.linalg.norm(s.nodes - pm.position, axis=1))] += pm.inertia_matrix()
    generic = inertia_load_stiffness(s.K, s.M, s.nodes, Phi, fixed=range(6), rotary_inertias=J)
    element = beam_modal_data(beams, n_modes, point_masses=point_masses, unit_loads=21 if rotary else 12)
    return generic, element


def straight(direction=(1.0, 0.0, 0.0), elements=40, **kw):
    props = dict(EA=1e9, EIy=EI, EIz=3 * EI, GJ=1e4, mass_per_length=MASS, elements=elements)
    props.update(kw)
    return Beam((0.0, 0.0, 0.0), tuple(LENGTH * np.asarray(direction)), **props)


def test_southwell_and_greenhill_through_the_generic_path():
    generic, element = both_paths(straight(), n_modes=6)
    S, S_beam = generic.S, element.geometric_stiffness
    # Straight member: the unit loads are exact, so both paths agree to round-off.
    assert generic.error_estimate == 0.0
    np.testing.assert_allclose(S, S_beam, rtol=0, atol=1e-12 * np.abs(S_beam).max())
    # Southwell (Wright et al. 1982): K1 = 1.1932 for the flapwise mode of a spinning cantilever.
    P = element.integrals().P
    flap = int(np.argmax(np.abs(element.translations[-1, 2])))
    added = -(S[3] + S[7]) - P[:, :, 2, 2]
    assert added[flap, flap] == pytest.approx(1.1932, abs=1e-3)
    # Greenhill (1881): a cantilever accelerated along its axis buckles at q L^3 / EI = 7.837.
    lam = np.diag(element.frequencies**2)
    ratio = np.linalg.eigvals(np.linalg.solve(-S[0], lam)).real
    ratio_beam = np.linalg.eigvals(np.linalg.solve(-S_beam[0], lam)).real
    a_cr = np.min(ratio[ratio > 0])
    assert a_cr == pytest.approx(np.min(ratio_beam[ratio_beam > 0]), rel=1e-11)
    assert a_cr == pytest.approx(7.837 * EI / (MASS * LENGTH**3), rel=2e-3)


def test_rotary_loads_of_a_tip_mass_agree_with_the_element_path():
    tip = PointMassAt((LENGTH, 0.0, 0.0), 3.0, inertia=(0.4, 0.2, 0.3))
    generic, element = both_paths(straight(elements=12), n_modes=5, point_masses=[tip], rotary=True)
    S_beam = element.geometric_stiffness
    assert generic.S.shape == S_beam.shape == (21, 5, 5)
    np.testing.assert_allclose(generic.S, S_beam, rtol=0, atol=1e-11 * np.abs(S_beam).max())


@settings(derandomize=True, max_examples=8, deadline=None)
@given(theta=st.floats(0.0, np.pi), phi=st.floats(0.0, 2 * np.pi), ratio=st.floats(0.3, 3.0))
def test_any_straight_member_is_exact(theta, phi, ratio):
    # A member along any direction: the element path is the reference, the estimate is zero. The
    # two paths compute the axial forces differently (EA elongation / L against K_ba times the
    # relative end motion): they agree to the round-off of the static solve, cond(K_ff) eps ~ 1e-8
    # here (EA L^2 / EI ~ 1e7 for the member, times the mesh's own conditioning).
    direction = (np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta))
    generic, element = both_paths(straight(direction, elements=8, EIz=ratio * EI, torsional_inertia_per_length=0.01),
                                  n_modes=4)
    S_beam = element.geometric_stiffness
    assert generic.error_estimate == 0.0
    np.testing.assert_allclose(generic.S, S_beam, rtol=0, atol=1e-7 * np.abs(S_beam).max())


@pytest.mark.parametrize("frame", [
    [((0, 0, 0), (5, 0, 0)), ((5, 0, 0), (5, 5, 0))],
    [((0, 0, 0), (2, 0, 0)), ((2, 0, 0), (2, 2, 1)), ((2, 2, 1), (0, 2, 2))],
])
def test_joints_of_members_carry_an_error_estimate(frame):
    # At a joint of members in different directions the nodal slope field is an average; the
    # estimate covers the difference to the element path (measured 0.5 and 0.8 of it).
    props = dict(EA=1e8, EIy=EI, EIz=1.3 * EI, GJ=1e4, mass_per_length=MASS, torsional_inertia_per_length=0.01,
                 elements=6)
    generic, element = both_paths([Beam(a, b, **props) for a, b in frame], n_modes=6)
    error = np.abs(generic.S - element.geometric_stiffness).max()
    assert 0.0 < error <= generic.error_estimate
    assert generic.error_estimate < 0.05 * np.abs(element.geometric_stiffness).max()


def test_models_it_cannot_read_are_refused():
    s = assemble_beams(straight(elements=4))
    Phi = np.zeros((s.K.shape[0], 1))
    Phi[-6] = 1.0
    with pytest.raises(ModelError, match=r"K \(30, 30\) and M \(30, 30\) must be \(6 n, 6 n\)"):
        inertia_load_stiffness(s.K, s.M, s.nodes[:4], Phi, fixed=range(6))
    with pytest.raises(ModelError, match=r"modes have shape \(29, 1\)"):
        inertia_load_stiffness(s.K, s.M, s.nodes, Phi[:29], fixed=range(6))
    grounded = np.array(s.K)
    grounded[13, 13] += 1e6  # a spring to ground at node 2
    with pytest.raises(ModelError, match="stiffness at node 2 is not a sum of two-node members"):
        inertia_load_stiffness(grounded, s.M, s.nodes, Phi, fixed=range(6))
    # a three-node term that does not follow rigid rotation about z of three nodes not on a line
    frame = assemble_beams([Beam((0, 0, 0), (5, 0, 0), EA=1e8, EIy=EI, EIz=EI, GJ=1e4, mass_per_length=MASS,
                                 elements=1), Beam((5, 0, 0), (5, 5, 0), EA=1e8, EIy=EI, EIz=EI, GJ=1e4,
                                                   mass_per_length=MASS, elements=1)])
    plate = np.array(frame.K)
    coupling = np.zeros(plate.shape[0])
    coupling[[0, 6, 12]] = [1.0, -2.0, 1.0]
    plate += 1e6 * np.outer(coupling, coupling)
    with pytest.raises(ModelError, match="not a sum of two-node members"):
        inertia_load_stiffness(plate, frame.M, frame.nodes, np.zeros((18, 1)), fixed=range(6))
    with pytest.raises(ModelError, match="do not restrain the structure"):
        inertia_load_stiffness(s.K, s.M, s.nodes, Phi, fixed=())
    with pytest.raises(ModelError, match=r"rotary_inertias have shape \(2, 3, 3\)"):
        inertia_load_stiffness(s.K, s.M, s.nodes, Phi, fixed=range(6), rotary_inertias=np.zeros((2, 3, 3)))
