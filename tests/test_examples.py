"""Every example runs headless and returns the number its story is about."""

import importlib.util
import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted(p.stem for p in (ROOT / "examples").glob("*.ipynb"))


def load(name):
    spec = importlib.util.spec_from_file_location(f"example_{name}", ROOT / "examples" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


notebooks = load("execute_notebooks")


def test_flexible_spacecraft_methods_agree(capsys):
    example = load("flexible_spacecraft")
    perturbation_error = example.main(3)
    out = capsys.readouterr().out
    assert "linflex autodiff" in out and "python-control linearize" in out
    # The classic perturbation method reaches its 6 requested digits on this smooth model.
    assert perturbation_error < 1e-6
    rows, exact = example.compare_methods(3)
    for name, error, estimate, _, _ in rows[1:-1]:
        assert error <= max(estimate, 1e-15), f"{name}: error {error} above its estimate {estimate}"
    # Closed form: the wheel's nutation frequency is h_w / sqrt(Ix Iz) for a rigid hub; the
    # appendages' participation shifts it, so compare loosely (10 %) and the rigid poles exactly.
    eig = np.linalg.eigvals(exact.sys.A)
    h_w = example.WHEEL_INERTIA * example.WHEEL_SPEED
    nutation = h_w / np.sqrt(example.HUB_INERTIA[0, 0] * example.HUB_INERTIA[2, 2])
    # Rigid-body poles sit in Jordan blocks, so they are computed to ~sqrt(eps): 1e-6 separates
    # them from the nutation pole (1.2e-2 rad/s).
    slow = np.abs(eig[(np.abs(eig) > 1e-6) & (np.abs(eig) < 0.1)])
    assert slow.size == 2 and abs(slow[0] / nutation - 1) < 0.1
    # Zero poles: q_w (1), pitch attitude and rate (2), roll/yaw attitude (2), wheel speed (1).
    assert np.sum(np.abs(eig) < 1e-6) == 6


def run_notebook(name, tmp_path, names):
    """Execute ``examples/NAME.ipynb`` as ``jupyter nbconvert --execute`` does: a fresh kernel, in
    the notebook's own folder (a scratch copy of ``examples/``, so outputs land there), cells in
    order. Returns the values of the expressions ``names`` at the end (pickled out by one extra cell).
    """
    folder = tmp_path / "examples"
    shutil.copytree(ROOT / "examples", folder, ignore=shutil.ignore_patterns("report-notebook", "*.png"))
    values = tmp_path / "values.pickle"
    extra = f"import pickle\nwith open({str(values)!r}, 'wb') as f:\n    pickle.dump({{k: eval(k) for k in {list(names)!r}}}, f)"
    notebook = notebooks.execute(folder / f"{name}.ipynb", extra_source=extra)
    errors = [o for c in notebook.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors, errors
    with open(values, "rb") as f:
        return pickle.load(f)


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_committed_notebook_is_executed_and_current(name):
    # Readers see the outputs without running anything, and they belong to the sources as committed:
    # examples/execute_notebooks.py stores the hash of the sources it executed.
    import nbformat

    notebook = nbformat.read(ROOT / "examples" / f"{name}.ipynb", as_version=4)
    assert all(cell.get("id") for cell in notebook.cells), "every cell has an id"
    assert notebook.metadata.get("linflex", {}).get("sources_sha256") == notebooks.sources_sha256(notebook), (
        f"{name}.ipynb changed since it was executed: run python examples/execute_notebooks.py {name}")
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert all(cell.execution_count for cell in code)
    assert any(cell.outputs for cell in code), "the outputs are stored"


def test_stability_report_notebook(tmp_path, monkeypatch):
    namespace = run_notebook("stability_report", tmp_path, ["worst_phase_margin"])
    # The PD design per axis (wn = 0.5 rad/s, zeta = 0.7): phase margin atan(2 zeta wc / wn) with
    # wc^2 = wn^2 (2 zeta^2 + sqrt(4 zeta^4 + 1)), 65.16 deg.
    wc = 0.5 * np.sqrt(2 * 0.49 + np.sqrt(4 * 0.7**4 + 1))
    assert namespace["worst_phase_margin"] == pytest.approx(np.degrees(np.arctan(2 * 0.7 * wc / 0.5)), rel=1e-9)
    assert (tmp_path / "examples" / "report-notebook" / "report.html").exists()


def test_spinning_beam_notebook(tmp_path, monkeypatch):
    namespace = run_notebook("spinning_beam", tmp_path, ["peak", "tip_error", "growth", "southwell",
                                                          "shares.shares['inertia'][in_plane]"])
    # Reference: 6 rigid segments (rigid_segment_beam), within 1.2 % of the peak of 10 segments,
    # the reference of benchmarks/flexible.py and tests/linflex/test_flexible_scene.py (Kane, Ryan
    # and Banerjee 1987 spin-up). 2 modes with geometric stiffness follow it to 1.3 % of the peak
    # (measured); 5 % allows for the reference's own discretization and the modal truncation.
    assert 0.3 < namespace["peak"] < 1.0  # the spin-up bends the beam back by about half a metre
    assert namespace["tip_error"] < 0.05
    # Without geometric stiffness the in-plane mode diverges once the spin passes 3.8 rad/s.
    assert namespace["growth"] > 1e3
    # Kane's stiffness by origin at 6 rad/s: the in-plane mode's Southwell coefficient (Wright et
    # al. 1982: K1 = 1.1932 for a uniform cantilever; measured 1.195 with 2 modes of 12 elements),
    # the inertia forces' share exactly -Omega^2 (premature softening).
    assert namespace["southwell"] == pytest.approx(1.1932, abs=0.005)
    assert namespace["shares.shares['inertia'][in_plane]"] == pytest.approx(-36.0, rel=1e-9)


def test_reduction_design_notebook(tmp_path, monkeypatch):
    namespace = run_notebook("reduction_design", tmp_path, ["glover", "dc_gain_error", "exchange", "eigenvalue_change"])
    first_discarded, measured, bound = namespace["glover"]
    # Glover (Int. J. Control 39, 1984): hsv[r] <= ||G - Gr||_inf <= 2 sum(hsv[r:]) for balanced
    # truncation of the stable part; the measured norm is certified to 1e-6 relative, so allow
    # that much either side (measured: 6.5e-4 <= 1.30e-3 <= 5.0e-3).
    assert first_discarded * (1 - 1e-6) <= measured <= bound * (1 + 1e-6)
    # Static correction makes the DC gain of the modal truncation exact: the discarded modes'
    # D - C A^-1 B is added to the feedthrough (measured 3e-18 relative; 1e-10 is round-off with room).
    assert namespace["dc_gain_error"] < 1e-10
    # The exchange of variables made the six sensor signals states by a similarity transformation,
    # which leaves the eigenvalues alone (measured 2e-15 1/s; the rigid body's zero eigenvalues sit
    # in Jordan blocks, computed to ~sqrt(eps), hence 1e-6).
    assert namespace["exchange"].sys.states[-6:] == ("roll", "pitch", "yaw", "p", "q", "r")
    assert namespace["eigenvalue_change"] < 1e-6


def test_margin_sweep_notebook(tmp_path, monkeypatch):
    namespace = run_notebook("margin_sweep", tmp_path, ["result", "worst_phase_margin"])
    result = namespace["result"]
    assert result.n_cases == 20 and result.n_failed == 0
    # Closed form for one rigid axis under collocated PD, L = (kd s + kp) / (I s^2): |L(jw)| = 1 at
    # w^2 = (kd^2 + sqrt(kd^4 + 4 I^2 kp^2)) / (2 I^2), PM = atan(kd w / kp), smallest over the
    # three axes (as tests/linflex/test_sweep.py); the margins come from the exact (autodiff)
    # linearization with crossings refined to 1e-9 relative, hence 1e-8 (measured 4e-14).
    inertia, kp, kd = (np.column_stack([result.column(f"{prefix}[{k}]") for k in range(3)])
                       for prefix in ("bodies.hub.inertia", "controllers.attitude_pd.kp", "controllers.attitude_pd.kd"))
    w = np.sqrt((kd**2 + np.sqrt(kd**4 + 4 * inertia**2 * kp**2)) / (2 * inertia**2))
    expected = np.degrees(np.arctan(kd * w / kp)).min(axis=1)
    worst, _ = namespace["worst_phase_margin"]
    assert worst == pytest.approx(expected.min(), rel=1e-8)
    np.testing.assert_allclose(result.column("phase_margin_deg"), expected, rtol=1e-8)


def test_attitude_design_notebook(tmp_path, monkeypatch):
    names = ["inertia.axes", "tuned.x[0]", "tuned.active.quantity", "tuned.active.value", "tuned.active.required",
             "tuned_margins", "requirements",
             "float(abs(frequency_response(notch_z, [notch.frequency]).response[0, 0, 0]))",
             "float(np.max(np.abs(roll_nl - linear_small)) / small)", "ratio", "saturated",
             "float(abs(roll_large[-1] - large) / large)"]
    v = run_notebook("attitude_design", tmp_path, names)
    # Closed form of the rigid inertia about the hub axes: hub + each array's integral of m y^2 over
    # 1..9 m, 5 (9^3 - 1) / 3, about x and z and their torsional inertia 2 * 0.2 * 8 about y, plus the transverse inertia
    # (0.1) of the two wheels that do not spin about the axis (a motor turns its own wheel); negative
    # in the wheels' reaction sign.
    arrays = 2 * 5 * (9**3 - 1) / 3
    np.testing.assert_allclose(-v["inertia.axes"], [800 + arrays + 0.2, 600 + 3.2 + 0.2, 900 + arrays + 0.2], rtol=1e-9)
    # The tuned loop meets every requirement, the active one at equality to tune's xtol (1e-3 in the
    # bandwidth, so well within 1 % of the margin).
    for key, required in v["requirements"].items():
        assert v["tuned_margins"][key] >= required * (1 - 1e-9), key
    assert v["tuned.active.value"] == pytest.approx(v["tuned.active.required"], rel=1e-2)
    assert 0.05 < v["tuned.x[0]"] < 1.0
    # The prewarped Tustin notch keeps its depth exactly at the mode: -20 dB (closed form of prewarping).
    assert v["float(abs(frequency_response(notch_z, [notch.frequency]).response[0, 0, 0]))"] == pytest.approx(0.1, rel=1e-9)
    # A 0.2 mrad step stays linear: the nonlinear sampled-data run follows the linear sampled loop at
    # the samples, the difference of second order in the amplitude (measured 1.8e-8 of the step).
    assert v["float(np.max(np.abs(roll_nl - linear_small)) / small)"] < 1e-6
    # Plant pulse: halving the amplitude divides the relative difference by 4 (third order: a rotation
    # about one axis has no quadratic term; measured 4.00).
    assert v["ratio"] == pytest.approx(4.0, rel=0.05)
    # The 10 mrad step saturates the wheel motor and still settles on the reference.
    assert v["saturated"] > 0.05
    assert v["float(abs(roll_large[-1] - large) / large)"] < 1e-4
