"""What a hurried user types into linflex.structures: it gives the right answer (checked against
closed forms and an independent computation) or a ModelError / ShapeError naming the argument."""

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
from hypothesis import example, given
from hypothesis import strategies as st

from linflex import (
    Beam,
    ModalData,
    ModelError,
    PointMassAt,
    ShapeError,
    assemble_beams,
    beam_modal_data,
    component_damping,
    constraint_modes,
    craig_bampton,
    frequency_filter,
    modal_truncation_vectors,
    structural_modes,
    svd_component_reduction,
    synthesize,
)
from linflex.structures import inertia_load_stiffness

# Cantilever bending, Euler-Bernoulli: omega_1 = 1.8751^2 sqrt(EI / (m L^4)) (Blevins table 8-1).
BETA1 = 1.8751040687
# Three 1 kg masses and 1 N/m springs, free: a chain for the component functions.
CHAIN_K = np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])


def rod(L=1.0, EI=1.0, m=1.0, EA=1e6, elements=8, **kw):
    return Beam((0, 0, 0), (L, 0, 0), EA=EA, EIy=EI, EIz=EI, GJ=1.0, mass_per_length=m, elements=elements, **kw)


def first_bending(L=1.0, EI=1.0, m=1.0):
    return BETA1**2 * np.sqrt(EI / (m * L**4))


# -- Beam, PointMassAt ----------------------------------------------------------------------------

def test_float_element_count_and_list_orientation_are_read():
    # elements=8.0 crashed in the mesh (range of a float), orientation=[0, 0, 1] in the element
    # cache (an unhashable list); both are what people type. 8 Hermite elements: 1e-6 on mode 1.
    md = beam_modal_data(rod(elements=8.0, orientation=[0, 0, 1]), 1)
    assert md.frequencies[0] == pytest.approx(first_bending(), rel=1e-5)


@pytest.mark.parametrize("field, value, message", [
    ("elements", float("nan"), "Beam.elements must be a positive integer"),
    ("elements", True, "Beam.elements must be a positive integer"),
    ("elements", 2.5, "Beam.elements must be a positive integer"),
    ("EA", "1e6", "Beam.EA must be positive"),
    ("EA", None, "Beam.EA must be positive"),
    ("orientation", (np.nan, 1.0, 0.0), "Beam.orientation must be a nonzero vector of 3 finite"),
    ("orientation", (0.0, 1.0), "Beam.orientation must be a nonzero vector of 3 finite"),
    ("orientation", (0.0, 0.0, 0.0), "Beam.orientation must be a nonzero vector of 3 finite"),
])
def test_bad_beam_fields_are_named(field, value, message):
    # Before: numpy's TypeError/ValueError, or (NaN orientation) "the structure is not restrained".
    props = dict(EA=1e6, EIy=1.0, EIz=1.0, GJ=1.0, mass_per_length=1.0, elements=4)
    props[field] = value
    with pytest.raises(ModelError, match=message):
        Beam((0, 0, 0), (1, 0, 0), **props)


def test_bad_point_masses_are_named():
    with pytest.raises(ModelError, match=r"PointMassAt.position must be 3 finite coordinates"):
        PointMassAt((1.0, 0.0), 1.0)
    with pytest.raises(ModelError, match=r"PointMassAt.position must be 3 finite coordinates"):
        PointMassAt((np.nan, 0.0, 0.0), 1.0)  # was accepted
    with pytest.raises(ModelError, match=r"PointMassAt.inertia must be 3 principal values or a 3x3 matrix"):
        PointMassAt((1.0, 0.0, 0.0), 1.0, inertia=(1.0, 2.0))


# -- beam_modal_data ------------------------------------------------------------------------------

def test_mode_count_damping_and_clamped_as_people_type_them():
    # n_modes=2.0 crashed (slice of a float); a single clamped point (x, y, z) other than the
    # origin crashed (iteration over a 0-d array). Clamped at its tip, the member is the same
    # cantilever: omega_1 = 1.8751^2 sqrt(EI / (m L^4)), 8 elements: 1e-5.
    md = beam_modal_data(rod(), 2.0, clamped=(1.0, 0.0, 0.0), damping=[0.01, 0.02])
    np.testing.assert_allclose(md.frequencies, first_bending(), rtol=1e-5)
    np.testing.assert_array_equal(md.damping, [0.01, 0.02])
    with pytest.raises(ModelError, match=r"n_modes must be between 1 and \d+ \(freedoms with mass\), got 2.5"):
        beam_modal_data(rod(), 2.5)
    with pytest.raises(ModelError, match=r"damping has shape \(3,\); one ratio .* or one per mode \(2\)"):
        beam_modal_data(rod(), 2, damping=[0.01, 0.02, 0.03])
    with pytest.raises(ModelError, match=r"clamped: a point must be 3 finite coordinates \[m\], got \(0, 0\)"):
        beam_modal_data(rod(), 2, clamped=[(0, 0)])
    with pytest.raises(ModelError, match=r"nodes\['tip'\]: a point must be 3 finite coordinates"):
        beam_modal_data(rod(), 2, nodes={"tip": (1, 0)})
    with pytest.raises(ModelError, match=r"beams\[1\] must be a Beam, got tuple"):
        beam_modal_data([rod(), (0, 0, 0)], 2)


def test_a_floating_member_is_refused_not_given_rigid_body_modes():
    # Two 1 cm members whose ends are 1 um apart (tol 1 nm): the second floats. Its rigid-body
    # modes were returned as the structure's lowest modes, at 6.03 rad/s (round-off; the clamped
    # member's first bending is 1.8751^2 sqrt(EI / (m L^4)) = 3.5e4 rad/s).
    props = dict(EA=1e3, EIy=1e-2, EIz=1e-2, GJ=1e-2, mass_per_length=1e-2, torsional_inertia_per_length=1e-5,
                 elements=40)
    a = Beam((0, 0, 0), (0.01, 0, 0), **props)
    b = Beam((0.010001, 0, 0), (0.02, 0, 0), **props)
    with pytest.raises(ModelError, match=r"not restrained: the part with the node at \(0.010001, 0.0, 0.0\)"):
        beam_modal_data([a, b], 2, geometric_stiffness=False)
    with pytest.raises(ModelError, match="not restrained"):  # was: 1.94 rad/s for a free member
        beam_modal_data(Beam((0, 0, 0), (0.01, 0, 0), **props), 1, clamped=(), geometric_stiffness=False)
    # Joined (the gap closed), it is a 2 cm cantilever whose lowest mode is torsion, pi / 2
    # sqrt(GJ / rho J) / L; 80 linear elements: (pi / 160)^2 / 24 = 1.6e-5.
    b = Beam((0.01, 0, 0), (0.02, 0, 0), **props)
    md = beam_modal_data([a, b], 1, geometric_stiffness=False)
    assert md.frequencies[0] == pytest.approx(np.pi / 2 * np.sqrt(1e-2 / 1e-5) / 0.02, rel=5e-5)


@given(L=st.floats(0.1, 1000.0), EI=st.floats(1e-2, 1e6), m=st.floats(1e-2, 10.0),
       slenderness=st.floats(30.0, 3000.0))
@example(L=1000.0, EI=1.0, m=1.0, slenderness=1000.0)  # a 1 km tether, or a 1 m beam typed in mm
def test_soft_restrained_cantilevers_are_solved_not_refused(L, EI, m, slenderness):
    # Was refused as "not restrained" whenever omega_1^2 < 1e-10 (rad/s)^2: a unit-dependent floor.
    # EA from the slenderness L / r: EA = EI (L / r)^2 / L^2. 12 Hermite elements: 1e-6 on mode 1.
    beam = rod(L, EI, m, EA=EI * slenderness**2 / L**2, elements=12)
    md = beam_modal_data(beam, 1, geometric_stiffness=False)
    assert md.frequencies[0] == pytest.approx(first_bending(L, EI, m), rel=1e-5)


# -- component functions ---------------------------------------------------------------------------

def test_boolean_masks_are_masks_and_fractional_indices_are_refused():
    # A mask [True, False, False] was read as the freedoms 0 and 1 (silently another boundary);
    # [0.7] as freedom 0.
    mask = np.array([True, False, False])
    by_mask, by_index = craig_bampton(CHAIN_K, np.eye(3), mask, 1), craig_bampton(CHAIN_K, np.eye(3), [0], 1)
    assert by_mask.kept == by_index.kept == ("mode 0", "boundary 0")
    np.testing.assert_allclose(by_mask.frequencies, by_index.frequencies, rtol=1e-14, atol=1e-14)
    with pytest.raises(ModelError, match=r"boundary: freedom indices must be integers .*got \[0.7\]"):
        constraint_modes(CHAIN_K, [0.7])
    with pytest.raises(ModelError, match=r"boundary: a boolean mask must have one entry per freedom \(3\)"):
        constraint_modes(CHAIN_K, [True, False])
    with pytest.raises(ModelError, match=r"K has shape \(3, 2\); square matrices"):
        constraint_modes(np.ones((3, 2)), [0])  # was an IndexError


def test_mode_counts_are_integers():
    # structural_modes(..., 2.5) silently kept 2 modes; craig_bampton(..., 1.0) crashed.
    with pytest.raises(ModelError, match="n_modes must be between 1 and 3, got 2.5"):
        structural_modes(CHAIN_K + np.eye(3), np.eye(3), 2.5)
    # Fixed at freedom 0, the interior is a 1 kg - 1 N/m - 1 kg chain on a 1 N/m spring:
    # omega^2 = (3 - sqrt 5) / 2 -> 0.618 rad/s (the docstring's reference).
    cb = craig_bampton(CHAIN_K, np.eye(3), [0], 1.0)
    assert cb.fixed_interface_frequencies[0] == pytest.approx(np.sqrt((3 - np.sqrt(5)) / 2), rel=1e-12)


def test_modal_truncation_vectors_of_a_free_structure_and_bad_shapes():
    with pytest.raises(ModelError, match=r"need a restrained structure \(K nonsingular\)"):
        modal_truncation_vectors(CHAIN_K, np.eye(3), np.zeros((3, 0)), [[1.0], [0.0], [0.0]])
    with pytest.raises(ShapeError, match=r"modes has shape \(2, 1\) but 3 rows were expected"):
        modal_truncation_vectors(CHAIN_K + np.eye(3), np.eye(3), np.zeros((2, 1)), [[1.0], [0.0], [0.0]])
    # A load vector given flat: the static response K^-1 F is reproduced exactly (Dickens).
    K = CHAIN_K + np.eye(3)
    psi, omega = modal_truncation_vectors(K, np.eye(3), np.zeros((3, 0)), [0.0, 0.0, 1.0])
    static = np.linalg.solve(K, [0.0, 0.0, 1.0])
    np.testing.assert_allclose(psi @ ((psi.T @ [0.0, 0.0, 1.0]) / omega**2), static, rtol=1e-12)  # round-off


def test_frequency_filter_inputs():
    with pytest.raises(ModelError, match=r"damping has shape \(3,\); one ratio"):
        frequency_filter([1.0, 2.0], [0.1, 0.2, 0.3], 0.1)
    with pytest.raises(ModelError, match=r"time_step must be positive \[s\], got '0.1'"):
        frequency_filter([1.0, 2.0], 0.01, "0.1")
    with pytest.raises(ModelError, match=r"time_step must be positive \[s\], got inf"):
        frequency_filter([1.0, 2.0], 0.01, np.inf)  # was: every mode, rigid ones too, moved to 0 rad/s
    with pytest.raises(ShapeError, match=r"frequencies\[0\] is not finite"):
        frequency_filter([np.nan, 2.0], 0.01, 0.1)


def test_synthesize_checks_each_component():
    K1 = np.array([[1.0, -1.0], [-1.0, 1.0]])
    with pytest.raises(ModelError, match=r"component_masses\[0\] is not symmetric"):
        synthesize([[[1.0, 0.5], [0.0, 1.0]]], [K1], [[0.0, 0.0]])  # was symmetrized silently
    with pytest.raises(ModelError, match=r"constraints \(rank 2\) fix all 2 component coordinates"):
        synthesize([np.eye(2)], [K1], np.eye(2))
    with pytest.raises(ModelError, match="constraints have non-finite entries"):
        synthesize([np.eye(2)], [K1], [[np.nan, 1.0]])
    with pytest.raises(ModelError, match="one mass and one stiffness matrix per component, got 2 and 1"):
        synthesize([np.eye(2), np.eye(2)], [K1], [[0.0, 1.0, -1.0, 0.0]])


def test_svd_and_damping_synthesis_inputs():
    with pytest.raises(ShapeError, match=r"projected must be 2-D"):
        svd_component_reduction([1.0, 2.0, 3.0])
    with pytest.raises(ShapeError, match=r"projected\[0, 0\] is not finite"):
        svd_component_reduction([[np.nan]])
    modes = structural_modes(CHAIN_K + np.eye(3), np.eye(3))
    with pytest.raises(ModelError, match="damping must be finite non-negative ratios"):
        component_damping(np.eye(3), modes.shapes, modes.frequencies, -0.01)  # was a negative damping matrix
    with pytest.raises(ShapeError, match=r"modes has shape \(3, 3\) but 2 rows were expected"):
        component_damping(np.eye(2), modes.shapes, modes.frequencies, 0.01)


# -- inertia_load_stiffness ------------------------------------------------------------------------

def test_inertia_load_stiffness_reads_a_fixed_mask():
    # A mask of the clamped freedoms was read as freedoms 0 and 1 and refused as "not restrained".
    # Southwell's coefficient of the flapwise mode: 1.1932 (20 elements give 1.194, the docstring).
    s = assemble_beams(Beam((0, 0, 0), (1, 0, 0), EA=1e8, EIy=1.0, EIz=3.0, GJ=1.0, mass_per_length=1.0,
                            torsional_inertia_per_length=1e-3, elements=20))
    n = s.K.shape[0]
    free = np.arange(6, n)
    modes = np.zeros((n, 1))
    modes[free] = structural_modes(s.K[np.ix_(free, free)], s.M[np.ix_(free, free)], 1).shapes
    result = inertia_load_stiffness(s.K, s.M, s.nodes, modes, fixed=np.arange(n) < 6)
    assert -(result.S[3] + result.S[7])[0, 0] == pytest.approx(1.1932, abs=2e-3)
    with pytest.raises(ModelError, match="modes have non-finite entries"):
        inertia_load_stiffness(s.K, s.M, s.nodes, modes * np.nan, fixed=range(6))  # was a NaN S
    with pytest.raises(ModelError, match="K has non-finite entries"):
        inertia_load_stiffness(s.K * np.nan, s.M, s.nodes, modes, fixed=range(6))
    with pytest.raises(ModelError, match="tol must be a finite positive number"):
        inertia_load_stiffness(s.K, s.M, s.nodes, modes, fixed=range(6), tol=-1.0)


# -- ModalData -------------------------------------------------------------------------------------

def one_point(**changes):
    fields = dict(positions=np.zeros((1, 3)), masses=[1.0], inertias=np.zeros((1, 3, 3)),
                  translations=np.zeros((1, 3, 1)), rotations=np.zeros((1, 3, 1)), frequencies=[1.0],
                  damping=[0.0])
    fields.update(changes)
    return ModalData(**fields)


def test_modal_data_fields():
    with pytest.raises(ModelError, match="geometric_stiffness has non-finite entries"):
        one_point(geometric_stiffness=np.full((12, 1, 1), np.nan))  # was accepted
    with pytest.raises(ModelError, match="node_names repeat 'a'"):
        one_point(node_names=("a", "a"), node_positions=np.zeros((2, 3)))  # node("a") found the first only
    with pytest.raises(ModelError, match="ModalData.masses must be an array of numbers"):
        one_point(masses=["one"])
    tip = one_point(node_names="tip", node_positions=[[1.0, 0.0, 0.0]])  # was read as 3 nodes t, i, p
    assert tip.node_names == ("tip",)
    np.testing.assert_array_equal(tip.node("tip")[0], [1.0, 0.0, 0.0])
    md = beam_modal_data(rod(elements=4), 3)
    np.testing.assert_array_equal(md.truncated(2.0).frequencies, md.frequencies[:2])  # was a TypeError


# -- NASTRAN ---------------------------------------------------------------------------------------

def test_nastran_inputs(tmp_path):
    pyyeti = pytest.importorskip("pyyeti")
    from linflex.structures import join_components, nastran_modal_data, read_nastran

    inboard = Path(pyyeti.__file__).parent / "tests" / "nas2cam_extseout" / "inboard.op4"
    # A directory named like the file: pyyeti opens a file-selection window for a directory
    # (a hang in a desktop session, "no $DISPLAY" on a server).
    (tmp_path / "model.op4").mkdir()
    with pytest.raises(ModelError, match=r"model.op4: no such NASTRAN file \(a directory\)"):
        read_nastran(tmp_path / "model.op4")
    with pytest.raises(ModelError, match="join_components needs a sequence of two or more components"):
        join_components(str(inboard))  # was read letter by letter: "/: unsupported NASTRAN file kind"
    with pytest.raises(ModelError, match="length_unit must be a positive length in metres, got '1e-3'"):
        nastran_modal_data(inboard, length_unit="1e-3")
    with pytest.raises(ModelError, match=r"damping has shape \(2,\); one ratio .* one per mode \(8\)"):
        nastran_modal_data(inboard, length_unit=1e-3, damping=[0.01, 0.02])
    # n_modes=2.0 crashed; inboard.out prints 38.51181 and 38.51677 rad/s (7 digits).
    data = nastran_modal_data(inboard, length_unit=1e-3, n_modes=2.0)
    np.testing.assert_allclose(data.frequencies, [38.51181, 38.51677], atol=5e-6)


def test_beam_free_free_modes_match_scipy_on_the_assembled_matrices():
    # Independent check of the assembly with scipy.linalg.eigh: the first free-free bending
    # frequency 4.7300^2 sqrt(EI / (m L^4)) (Blevins table 8-1), 16 elements: 1e-5.
    s = assemble_beams(rod(L=2.0, EI=3.0, m=0.5, elements=16, torsional_inertia_per_length=1e-3))
    lam = scipy.linalg.eigh(s.K, s.M, eigvals_only=True, subset_by_index=[0, 7])
    assert np.abs(lam[:6]).max() < 1e-6 * lam[6]  # six rigid-body modes
    assert np.sqrt(lam[6]) == pytest.approx(4.7300408**2 * np.sqrt(3.0 / (0.5 * 2.0**4)), rel=1e-5)
