"""Sweeps that compile once per structure (issue 20, target 6): the same numbers as compiling every case."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import Beam, beam_modal_data, compile_model, load_scene, sweep, vary_scene
from linflex.compiler import _parametric
from linflex.compiler._parametric import basis_change, compile_once, modal_matrices
from linflex.stability.report import margin_summary
from linflex.sweeps import load_sweep_spec

ROOT = Path(__file__).resolve().parents[2]
ARRAYS = ROOT / "examples" / "spacecraft_arrays.toml"


def _relative_difference(a, b):
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    with np.errstate(invalid="ignore", divide="ignore"):
        return float(np.max(np.where(same, 0.0, np.abs(a - b) / np.abs(b))))


def test_the_example_sweep_compiled_once_gives_the_per_case_table():
    # Cases of the example study on both sides of EI = 3114 N m^2, where an array's third bending
    # frequency passes its torsion frequency (24.06 rad/s) and the sixth kept mode changes kind:
    # case 0 (both arrays stiffer), case 8 (the right one softer), 39 (the left one), 1 (stiffer again).
    scene = load_scene(ARRAYS)
    spec, _, _ = load_sweep_spec(ROOT / "examples" / "spacecraft_arrays_sweep.toml")
    cases = [spec[i] for i in (0, 8, 39, 1)]
    softer = [(c["bodies.array_left.beam.EI"] < 3114, c["bodies.array_right.beam.EI"] < 3114) for c in cases]
    assert len(set(softer)) == 3
    once = sweep(scene, cases, margin_summary, processes=1)
    compiled = sum(c.compilations for c in _parametric._COMPILERS.values())
    each = sweep(scene, cases, margin_summary, processes=1, compile_once=False)
    assert once.n_failed == each.n_failed == 0
    # Reference: compiling every case (the behaviour before issue 20), the same equations in the
    # case's own modal basis: equal to round-off, 1e-10 relative in every metric.
    assert _relative_difference(once.results, each.results) < 1e-10
    # Case 1 reuses case 0's graph; the three mode sets are three structures.
    assert compiled == 3


@settings(derandomize=True, max_examples=15, deadline=None)
@given(scale=st.floats(0.5, 2.0), n_modes=st.sampled_from([3, 4, 5]))
def test_a_stiffer_beam_is_the_same_structure_with_scaled_modal_stiffness(scale, n_modes):
    # Scaling the bending stiffness of a beam whose axial and torsion modes lie above the kept
    # ones (torsion at 139 rad/s, the fifth mode at most 39 rad/s) keeps the mode shapes (K
    # scales, M does not) and multiplies the squared frequencies by the scale; the n_modes cut
    # goes through a repeated bending pair for 3 and 5.
    def modes(EI):
        beam = Beam((0, 0, 0), (0, 8, 0), EA=1e7, EIy=EI, EIz=EI, GJ=1e5, mass_per_length=5.0,
                    torsional_inertia_per_length=0.2, elements=12)
        return beam_modal_data(beam, n_modes, damping=0.005)

    reference, case = modes(4000.0), modes(4000.0 * scale)
    Q = basis_change(reference, case)
    assert Q is not None
    # Repeated pairs come in a fixed basis: the same shapes to the eigenvectors' round-off.
    assert np.max(np.abs(Q - np.eye(n_modes))) < 1e-9
    K, C = modal_matrices(case)
    Qi = np.linalg.inv(Q)
    w = np.sqrt(np.sort(np.linalg.eigvalsh(Qi.T @ K @ Qi)))
    # References: the case's own frequencies (the same matrix in the basis Q, good to the
    # shapes' round-off, 1e-11 here), and the closed form sqrt(scale) times the reference's, to
    # the eigen-solve's accuracy (eps times the largest FE eigenvalue: 1e-9 of the lowest here).
    np.testing.assert_allclose(w, case.frequencies, rtol=1e-10)
    np.testing.assert_allclose(w, np.sqrt(scale) * reference.frequencies, rtol=1e-8)


def test_a_mode_set_that_changes_kind_is_another_structure():
    scene = load_scene(ARRAYS)
    left = [vary_scene(scene, {"bodies.array_left.beam.EI": EI}).bodies[1].resolved_modal_data()
            for EI in (3000.0, 4000.0, 5000.0)]
    # 3000: the sixth mode is the second third-bending mode; 4000 and 5000: it is torsion
    assert basis_change(left[1], left[0]) is None
    assert basis_change(left[1], left[2]) is not None


def test_compile_once_returns_the_case_values_on_one_graph():
    scene = load_scene(ARRAYS)
    plant = [vary_scene(scene, {"bodies.hub.mass": m, "bodies.array_left.beam.EI": EI})
             for m, EI in ((900.0, 4200.0), (1100.0, 4600.0))]
    with compile_once(("bodies.hub.mass", "bodies.array_left.beam.EI")) as compiler:
        models = [compile_model(s) for s in plant]
    assert compiler.compilations == 1
    assert models[0].f is models[1].f and models[1].scene is plant[1]
    assert models[1].param_values[list(models[1].params).index("hub.mass")] == 1100.0
    # Reference: each scene compiled on its own; the state derivative at a perturbed state agrees
    # to round-off (same modal basis here: the array's shapes do not depend on EI)
    rng = np.random.default_rng(1)
    for s, m in zip(plant, models):
        own = compile_model(s)
        x = own.x0 + 1e-3 * rng.standard_normal(own.n_states)
        u = rng.standard_normal(own.n_inputs)
        want = own.evaluate(x, u)[0]
        np.testing.assert_allclose(m.evaluate(x, u)[0], want, rtol=0, atol=1e-10 * np.max(np.abs(want)))


def test_unknown_paths_are_structure_and_compile_per_value():
    scene = load_scene(ARRAYS)
    with compile_once(("wheels.wheel_x.spin_inertia",)) as compiler:
        for value in (0.2, 0.3, 0.2):
            compile_model(vary_scene(scene, {"wheels.wheel_x.spin_inertia": value}))
    assert compiler.compilations == 2


def test_the_modal_parameters_are_named_and_checked():
    scene = load_scene(ARRAYS)
    names = _parametric.modal_parameter_names("array_left", 6)
    model = compile_model(scene, params=names)
    assert len(model.params) == 2 * 21
    K, _ = modal_matrices(scene.bodies[1].resolved_modal_data())
    assert model.param_values[list(model.params).index("array_left.modal_stiffness[2,2]")] == pytest.approx(K[2, 2])
    plain = compile_model(scene)
    x = plain.x0 + 1e-3 * np.arange(plain.n_states)
    # Reference: the plain compilation, whose modal stiffness is the same numbers as constants
    np.testing.assert_allclose(model.evaluate(x, np.zeros(3))[0], plain.evaluate(x, np.zeros(3))[0], rtol=1e-12,
                               atol=1e-14)
