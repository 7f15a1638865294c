"""NASTRAN Craig-Bampton components read through pyyeti, checked against NASTRAN's own output.

The references are the test models shipped in pyyeti's wheel (run by NX/Simcenter NASTRAN; their
``.out`` files print the eigenvalue tables) and pyyeti's Craig-Bampton checks (``cb.cbcheck``).
"""

from __future__ import annotations

import io
import re
import shutil
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import linflex
from linflex import MethodUnavailableError, ModelError, load_modal_data, structural_modes
from linflex.linearize import linearize
from linflex.structures import join_components, nastran_modal_data, read_nastran

with np.printoptions():  # pyyeti sets numpy's legacy print style when imported (doctests elsewhere print arrays)
    pyyeti = pytest.importorskip("pyyeti")  # the test extra installs it; this guards bare installs only
    from pyyeti import cb
    from pyyeti.nastran import op2, op4
TESTS = Path(pyyeti.__file__).parent / "tests"
INBOARD = TESTS / "nas2cam_extseout" / "inboard.op4"
OUTBOARD = TESTS / "nas2cam_extseout" / "outboard.op4"
OUTBOARD_2020 = TESTS / "cla_test_data_2020" / "outboard.op4"


def printed_eigenvalue_table(out: Path, which: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """Radians column of a ``R E A L   E I G E N V A L U E S`` table of a NASTRAN .out file,
    and half a unit of its last printed digit (the table prints 7 significant digits)."""
    text = out.read_text()
    tables = text.split("R E A L   E I G E N V A L U E S")[1:]
    rows = re.findall(r"^\s+\d+\s+\d+\s+(\S+)\s+(\S+)\s+\S+\s+\S+\s+\S+\s*$", tables[which].split("PAGE")[0], re.M)
    printed = [r[1] for r in rows]
    values = np.array([float(p) for p in printed])
    half_digit = np.array([0.5 * 10.0 ** (int(p.split("E")[1]) - 6) for p in printed])
    return values, half_digit


def test_fixed_interface_frequencies_match_nastran_to_the_printed_digits():
    # inboard.out and outboard.out (cla_test_data_2020): the q-set of EXTSEOUT holds the modes
    # of the last table (after augmentation by residual vectors); 8 and 22 of them are kept.
    for op4, n_q in ((INBOARD, 8), (OUTBOARD_2020, 22)):
        data = nastran_modal_data(op4, length_unit=1e-3)
        printed, half_digit = printed_eigenvalue_table(op4.with_suffix(".out"))
        assert data.n_modes == n_q
        assert np.all(np.abs(data.frequencies - printed[:n_q]) <= half_digit[:n_q])


def test_joined_components_reproduce_nastrans_system_modes():
    # assemble.out: NASTRAN's system run of the outboard and inboard components joined at grids
    # 3, 11, 19 and 27 (54 a-set freedoms, 6 rigid-body and 48 elastic modes).
    both = join_components([INBOARD, OUTBOARD])
    assert both.K.shape == (54, 54) and both.boundary.size == 24 and both.modal.size == 30
    w = structural_modes(both.K, both.M).frequencies
    # NASTRAN's own system matrices (the residual's KAA/MAA in its nas2cam output): same modes, to
    # the round-off of a free-free eigenproblem with |K| ~ 4e9 N/mm (eps |K| / lambda ~ 1e-9 on
    # the lowest elastic eigenvalue, 114 rad^2/s^2).
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nas = op2.rdnas2cam(str(INBOARD.with_name("nas2cam")))
    w_nastran_matrices = structural_modes(nas["kaa"][0], nas["maa"][0]).frequencies
    np.testing.assert_allclose(w[6:], w_nastran_matrices[6:], rtol=2e-9)
    # The printed table: to its last digit, plus the accuracy of NASTRAN's own numbers, measured
    # on these files: its Householder (AHOU) eigenvalues (LAMA, 'lambda' of its op2) differ from
    # the exact eigenvalues of its own KAA/MAA by up to 2.5e-8 relative, and its printed radians
    # column differs from the square roots of those eigenvalues by up to 1.8e-8 beyond the last
    # digit (mode 43: sqrt(lambda) = 5909.06761, printed 5909.067); that decides the rounding of
    # 5 of the 48 printed values.
    printed, half_digit = printed_eigenvalue_table(INBOARD.with_name("assemble.out"), which=0)
    assert printed.size == 54
    assert np.all(np.abs(w[:6]) < 1e-3)  # NASTRAN prints ~1e-4 rad/s for its rigid-body modes
    assert np.all(np.abs(w[6:] - printed[6:]) <= half_digit[6:] + 5e-8 * printed[6:])
    assert np.sum(np.abs(w[6:] - printed[6:]) <= half_digit[6:]) >= 43


def test_recovered_grid_shapes_match_nastrans_full_model_eigenvectors():
    # full.op2: NASTRAN's eigenvectors of the unreduced model (inboard and outboard trusses in one
    # run) at every grid point. The joined components' system modes, recovered at the interior
    # output grids 4, 16 (inboard) and 45 (outboard) by MUG1, agree with them for the first four
    # elastic modes to 2e-6 of their largest component (measured 1.6e-6: the Craig-Bampton
    # reduction's own error; the close pair at 44.13/44.14 rad/s mixes more and is left out).
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        full = op2.rdpostop2(str(INBOARD.with_name("full.op2")), getougv1=True)["mats"]["ougv1"][0]
    phi, dof = full["ougv1"], np.asarray(full["dof"])
    inboard, outboard = read_nastran(INBOARD), read_nastran(OUTBOARD)
    both = join_components([inboard, outboard])
    modes = structural_modes(both.K, both.M).shapes
    np.testing.assert_allclose(structural_modes(both.K, both.M).frequencies[6:10], np.sqrt(full["lambda"][6:10]),
                               rtol=1e-7)
    column = {tuple(d): i for i, d in enumerate(both.dof_map.tolist())}
    checked = []
    for component in (inboard, outboard):
        recovered = component.recovery @ modes[[column[tuple(d)] for d in component.dof_map.tolist()]]
        for grid in (4, 16, 45):
            rows = np.flatnonzero(component.recovery_dof_map[:, 0] == grid)
            if rows.size == 0:
                continue
            full_rows = [np.flatnonzero((dof[:, 0] == grid) & (dof[:, 1] == c))[0] for c in range(1, 7)]
            for k in range(6, 10):
                ours, nastran = recovered[rows, k], phi[full_rows, k]
                sign = np.sign(ours @ nastran)
                assert np.abs(ours - sign * nastran).max() <= 2e-6 * np.abs(nastran).max()
            checked.append(grid)
    assert sorted(checked) == [4, 16, 45]
    # the same matrices give the nodes of the modal data (grid 60 of outboard.dat is driven by an
    # MPC from a modal coordinate, not moved rigidly with the interface: left out and said so)
    data = nastran_modal_data(both, reference=(600.0, 150.0, 150.0), length_unit=1e-3)
    assert data.node_names == ("grid_3", "grid_11", "grid_19", "grid_27", "grid_4", "grid_16", "grid_45")
    np.testing.assert_allclose(data.node("grid_4")[0], [0.3, -0.15, 0.15], atol=1e-15)  # [m] from the interface
    assert "left out (not moved rigidly with the interface by MUG1): 60" in data.source


def test_cbcheck_effective_mass_and_rigid_body_modes():
    # pyyeti's cbcheck on the same matrices: the effective masses of the fixed-interface modes
    # about the basic origin, and the stiffness-based rigid-body modes of the boundary (which
    # exercise the freedom map: grid 11 has its own output coordinate system).
    model = read_nastran(INBOARD)
    b = model.boundary
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check = cb.cbcheck(io.StringIO(), np.array(model.M), np.array(model.K), b, b[:6],
                           uset=model.uset.iloc[b], uref=(0, 0, 0), reorder=False)
    np.testing.assert_allclose(check.cb_frq * 2 * np.pi, nastran_modal_data(model).frequencies, rtol=1e-12)
    data = nastran_modal_data(model, reference=(0.0, 0.0, 0.0))  # model units (kg, mm)
    I = data.integrals()
    L = np.vstack([I.b, I.c + I.W4])  # rigid-elastic coupling, rows x y z rx ry rz
    np.testing.assert_allclose(L.T**2, check.effmass.to_numpy(), rtol=1e-9, atol=1e-12 * np.max(L**2))
    # the equivalent mass points reproduce the component's rigid mass and unit modal mass
    R = model.rigid_body_modes((0.0, 0.0, 0.0))
    Mrr = R.T @ model.M[np.ix_(b, b)] @ R
    assert I.mass == pytest.approx(Mrr[0, 0], rel=1e-14)
    np.testing.assert_allclose(I.I0 + I.W1, Mrr[3:, 3:], rtol=1e-12)
    np.testing.assert_allclose(I.e + I.W9, np.eye(data.n_modes), atol=1e-12)
    rbs = check.rbs[b]  # stiffness-based rigid-body modes relative to grid 3's six freedoms
    np.testing.assert_allclose(model.rigid_body_modes(model.grid_position(3)), rbs, atol=1e-6)


def test_nas2cam_op2_superelement_equals_its_extseout_component():
    op2 = TESTS / "nas2cam_extseout" / "nas2cam.op2"
    with pytest.raises(ModelError, match=r"several superelements \(0, 101, 102\)"):
        read_nastran(op2)
    from_op2 = nastran_modal_data(op2, superelement=102)
    np.testing.assert_allclose(from_op2.frequencies, nastran_modal_data(INBOARD).frequencies, rtol=1e-9)
    with pytest.raises(ModelError, match="no superelement 7"):
        read_nastran(op2, superelement=7)


def test_load_modal_data_and_scene_key_read_nastran_files(tmp_path):
    data = load_modal_data(INBOARD)  # SI units assumed by the scene key
    assert data.node_names == ("grid_3", "grid_11", "grid_19", "grid_27", "grid_4", "grid_16")
    scene = linflex.Scene(name="truss", bodies=(linflex.Body(name="truss", mass=0.0, type="flexible",
                                                             modal_data=str(INBOARD), modes=3),),
                          joints=(linflex.Joint(name="clamp", type="fixed", child="truss"),),
                          sensors=(linflex.Sensor(name="s", type="rate", body="truss", node="grid_16"),))
    scene.validate()
    model = linflex.compile_model(scene)
    A = linearize(model, linflex.OperatingPoint(model.x0, np.zeros(model.n_inputs))).sys.A
    eig = np.linalg.eigvals(A)
    printed, half_digit = printed_eigenvalue_table(INBOARD.with_suffix(".out"))
    assert np.all(np.abs(np.sort(eig.imag[eig.imag > 0]) - printed[:3]) <= half_digit[:3])
    toml = tmp_path / "truss.toml"
    toml.write_text(f'name = "truss"\n\n[[bodies]]\nname = "truss"\nmass = 0.0\ntype = "flexible"\n'
                    f'modal_data = "{INBOARD.as_posix()}"\nmodes = 3\n\n[[joints]]\nname = "clamp"\ntype = "fixed"\n'
                    'child = "truss"\n\n[[sensors]]\nname = "s"\ntype = "rate"\nbody = "truss"\nnode = "grid_16"\n')
    from_toml = linflex.load_scene(toml)
    np.testing.assert_array_equal(from_toml.bodies[0].resolved_modal_data().frequencies,
                                  scene.bodies[0].resolved_modal_data().frequencies)
    with pytest.raises(ModelError, match=r"sensors\[0\].node: unknown node 'grid_12'"):
        linflex.Scene(name="x", bodies=scene.bodies, joints=scene.joints,
                      sensors=(linflex.Sensor(name="s", type="rate", body="truss", node="grid_12"),)).validate()


def test_bad_nastran_input_is_named(tmp_path):
    lone = tmp_path / "lone.op4"
    shutil.copy(INBOARD, lone)
    with pytest.raises(ModelError, match=r"lone.op4: missing DOF map: .*lone.asm or lone.pch"):
        read_nastran(lone)
    other = tmp_path / "other.op4"
    op4.write(str(other), {"phg": np.eye(3)})
    shutil.copy(INBOARD.with_suffix(".asm"), other.with_suffix(".asm"))
    with pytest.raises(ModelError, match=r"other.op4: unsupported .op4 file: no KXX/MXX"):
        read_nastran(other)
    sizes = tmp_path / "sizes.op4"
    model = read_nastran(INBOARD)
    op4.write(str(sizes), {"kxx": np.array(model.K), "mxx": np.array(model.M)[:31, :31]})
    shutil.copy(INBOARD.with_suffix(".asm"), sizes.with_suffix(".asm"))
    with pytest.raises(ModelError, match=r"sizes.op4: mass \(31, 31\) and stiffness \(32, 32\) matrices"):
        read_nastran(sizes)
    short = tmp_path / "short.op4"
    op4.write(str(short), {"kxx": np.array(model.K)[:30, :30], "mxx": np.array(model.M)[:30, :30]})
    shutil.copy(INBOARD.with_suffix(".asm"), short.with_suffix(".asm"))
    with pytest.raises(ModelError, match=r"short.op4: the matrices have 30 rows but the freedom map has 32"):
        read_nastran(short)
    coupled = np.array(model.K)
    coupled[0, 30] = coupled[30, 0] = 1e-3 * np.abs(coupled).max()
    with pytest.raises(ModelError, match=r"coupled: not in Craig-Bampton form: .* by stiffness \(relative 0.001"):
        nastran_modal_data(linflex.structures.NastranModel(coupled, model.M, model.dof_map, model.uset, model.boundary,
                                                           model.modal, "coupled"))
    post = tmp_path / "post.op2"
    shutil.copy(TESTS / "nastran_op2_data" / "rdop2opg_1.op2", post)
    with pytest.raises(ModelError, match=r"post.op2: missing DOF map: a nas2cam .op2 needs its .op4"):
        read_nastran(post)
    with pytest.raises(ModelError, match=r"model.bdf: unsupported NASTRAN file kind '.bdf'"):
        (tmp_path / "model.bdf").write_text("BEGIN BULK\n")
        read_nastran(tmp_path / "model.bdf")
    with pytest.raises(ModelError, match="no such NASTRAN file"):
        read_nastran(tmp_path / "absent.op4")
    with pytest.raises(ModelError, match="grid 3 is at"):
        moved = read_nastran(INBOARD)
        uset = moved.uset.copy()
        uset.loc[(3, 1), "x"] += 1.0
        join_components([OUTBOARD, linflex.structures.NastranModel(moved.K, moved.M, moved.dof_map, uset, moved.boundary,
                                                                     moved.modal, "moved")])
    with pytest.raises(ModelError, match="no grid point 99 in the a-set; grid points: 3, 11, 19, 27"):
        model.grid_position(99)


def test_importing_pyyeti_keeps_numpys_print_style():
    # pyyeti's modules call np.set_printoptions(legacy="1.13") when first imported; reading a
    # model must not change how the user's (and the doctests') arrays print.
    import subprocess

    code = ("import numpy as np, pathlib, pyyeti; from linflex.structures import read_nastran; "
            "read_nastran(pathlib.Path(pyyeti.__file__).parent / 'tests/nas2cam_extseout/inboard.op4'); "
            "print(np.get_printoptions()['legacy'])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_missing_pyyeti_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyyeti.nastran", None)
    with pytest.raises(MethodUnavailableError, match=r'pip install "linflex\[nastran\]"'):
        read_nastran(INBOARD)


def test_example_scene_with_a_nastran_truss():
    # examples/scene_nastran_truss.py: bus + joined NASTRAN truss, free-floating, linearized by
    # linflex; against the elastic frequencies of the Craig-Bampton matrices with the bus mass on
    # the interface's rigid-body motion (independent of the scene, Kane's equations and the
    # equivalent mass points): agreement to round-off (measured 3.4e-12).
    import importlib.util

    path = Path(__file__).resolve().parents[2] / "examples" / "scene_nastran_truss.py"
    spec = importlib.util.spec_from_file_location("scene_nastran_truss", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main() < 1e-9
