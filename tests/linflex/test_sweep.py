"""Tests of parameter sweeps: cases, scene paths, serial/process/Dask backends, failures, the CLI."""

import csv
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import (
    ModelError,
    NonlinearModel,
    load_scene,
    parameter_grid,
    parameter_sample,
    sweep,
    vary_scene,
)
from linflex.cli import main
from linflex.cli._sweep import ANALYSES
from linflex.stability.report import margin_summary
from linflex.system import OutputError

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "examples" / "attitude_control.toml"


def pd_margins(inertia, kp, kd):
    """Closed form for one rigid axis under collocated PD, L = (kd s + kp) / (I s^2).

    |L(jw)| = 1 at w^2 = (kd^2 + sqrt(kd^4 + 4 I^2 kp^2)) / (2 I^2); the phase of -L there is
    atan(kd w / kp), so PM = atan(kd w / kp) and the delay margin is PM [rad] / w.
    """
    w = np.sqrt((kd**2 + np.sqrt(kd**4 + 4 * inertia**2 * kp**2)) / (2 * inertia**2))
    pm = np.arctan(kd * w / kp)
    return np.degrees(pm), pm / w


def test_margin_sweep_matches_the_pd_closed_form():
    scene = load_scene(SCENE)
    cases = parameter_grid({"bodies.hub.inertia[0]": [60.0, 100.0, 180.0], "controllers.attitude_pd.kd[0]": [20.0, 70.0]})
    result = sweep(scene, cases, margin_summary, processes=1)
    assert result.n_failed == 0 and result.backend == "serial" and result.n_cases == 6
    assert result.metrics == ANALYSES["margins"][2]  # what `linflex sweep --plot` checks before running
    inertia = np.array([100.0, 120.0, 80.0])
    kp, kd = np.array([25.0, 30.0, 20.0]), np.array([70.0, 84.0, 56.0])
    for i, case in enumerate(cases):
        inertia[0], kd[0] = case["bodies.hub.inertia[0]"], case["controllers.attitude_pd.kd[0]"]
        pm, delay = pd_margins(inertia, kp, kd)
        # Reference: the closed form above, per axis, smallest over the three loops; the margins
        # come from the autodiff linearization, exact, and crossings refined to 1e-9 relative
        # (the same tolerance as tests/stability/test_report_analysis.py)
        assert result.column("phase_margin_deg")[i] == pytest.approx(pm.min(), rel=1e-8)
        assert result.column("delay_margin_s")[i] == pytest.approx(delay.min(), rel=1e-8)
        assert result.column("closed_loop_stable")[i] == 1.0
        assert result.column("gain_margin_db")[i] == np.inf  # a PD on a double integrator never crosses -180 deg
    # the varied parameters are in the table as given
    np.testing.assert_array_equal(result.column("bodies.hub.inertia[0]"), [60, 60, 100, 100, 180, 180])
    rows = result.rows()
    assert rows[3]["controllers.attitude_pd.kd[0]"] == 70.0 and rows[3]["error"] is None


def test_local_processes_give_the_serial_table():
    scene = load_scene(SCENE)
    cases = parameter_sample({"bodies.hub.inertia[1]": {"distribution": "normal", "mean": 120.0, "std": 10.0}}, 4, seed=7)
    serial = sweep(scene, cases, margin_summary, processes=1)
    pooled = sweep(scene, cases, margin_summary, processes=2)
    assert (pooled.backend, pooled.workers) == ("processes", 2)
    # same computation in another process with one BLAS thread: identical to the last bit here,
    # allowed 1e-12 for BLAS kernels that differ between thread counts
    np.testing.assert_allclose(pooled.results, serial.results, rtol=1e-12)
    np.testing.assert_array_equal(pooled.values, serial.values)


def test_dask_local_cluster_gives_the_serial_table():
    distributed = pytest.importorskip("distributed")
    scene = load_scene(SCENE)
    cases = parameter_sample({"controllers.attitude_pd.kp[2]": {"distribution": "uniform", "low": 10.0, "high": 40.0}},
                             8, seed=3)
    serial = sweep(scene, cases, margin_summary, processes=1)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        result = sweep(scene, cases, margin_summary, client=client, seed=3)
    assert (result.backend, result.workers, result.seed) == ("dask", 2, 3)
    np.testing.assert_allclose(result.results, serial.results, rtol=1e-12)


def test_a_failed_case_is_recorded_and_the_sweep_goes_on():
    scene = load_scene(SCENE)
    result = sweep(scene, parameter_grid({"bodies.hub.mass": [1500.0, -1.0, 10.0]}), margin_summary, processes=1)
    assert result.n_failed == 1
    assert result.errors[0] is None and result.errors[2] is None
    assert "ModelError" in result.errors[1] and "bodies[0].mass" in result.errors[1]
    assert np.all(np.isnan(result.results[1])) and np.all(np.isfinite(result.column("disk_margin")[[0, 2]]))
    # an invalid value in the first case is a failed case too, not a refusal of the sweep
    first_bad = sweep(scene, parameter_grid({"bodies.hub.mass": [-1.0, 1500.0]}), margin_summary, processes=1)
    assert first_bad.n_failed == 1 and "bodies[0].mass" in first_bad.errors[0] and first_bad.errors[1] is None


def test_wrong_paths_fail_once_before_anything_runs():
    scene = load_scene(SCENE)
    with pytest.raises(ModelError, match=r"no entry named 'rotor'.*entries: \['hub'\]"):
        sweep(scene, parameter_grid({"bodies.rotor.mass": [1.0]}), margin_summary, processes=1)
    with pytest.raises(ModelError, match=r"has no element \[3\]"):
        vary_scene(scene, {"bodies.hub.inertia[3]": 1.0})
    with pytest.raises(ModelError, match="mas"):  # the scene's own validation names the unknown key
        vary_scene(scene, {"bodies.hub.mas": 1.0})
    with pytest.raises(ModelError, match="case 1 has the parameters"):
        sweep(scene, [{"bodies.hub.mass": 1.0}, {"bodies.hub.inertia[0]": 1.0}], margin_summary)
    with pytest.raises(ModelError, match="no cases"):
        sweep(scene, [], margin_summary)


def test_vary_scene_changes_only_the_named_entries():
    scene = load_scene(SCENE)
    varied = vary_scene(scene, {"bodies.hub.inertia[2]": 95.0, "controllers.attitude_pd.kp[1]": 33.0})
    assert varied.bodies[0].inertia == (100.0, 120.0, 95.0)
    assert varied.controllers[0].kp == (25.0, 33.0, 20.0)
    assert varied.sensors == scene.sensors and scene.bodies[0].inertia == (100.0, 120.0, 80.0)


def test_model_parameters_are_swept_by_name():
    # Reference: x' = -a x has the pole -a
    model = NonlinearModel(lambda x, u, p, t: np.array([-p[0] * x[0]]), states=["x"], params={"a": 1.0})
    result = sweep(model, parameter_grid({"a": [0.5, 2.0, 8.0]}), _pole, processes=1)
    np.testing.assert_allclose(result.column("pole"), [-0.5, -2.0, -8.0], rtol=1e-12)
    with pytest.raises(ModelError, match=r"no parameters \['b'\]"):
        sweep(model, parameter_grid({"b": [1.0]}), _pole)


def _pole(model):
    from linflex import OperatingPoint
    from linflex.linearize import linearize

    return {"pole": linearize(model, OperatingPoint([0.0], []), method="central").sys.A[0, 0]}


def test_an_analysis_that_cannot_reach_other_processes_is_refused_by_name():
    scene = load_scene(SCENE)
    with pytest.raises(ModelError, match="analysis cannot be sent to worker processes"):
        sweep(scene, parameter_grid({"bodies.hub.mass": [1.0, 2.0]}), lambda s: {"m": 1.0}, processes=2)


def test_parameter_sample_is_reproducible_and_has_the_asked_moments():
    spec = {"x": {"distribution": "normal", "mean": 5.0, "std": 2.0}, "y": {"distribution": "uniform", "low": -1.0, "high": 3.0}}
    a, b = parameter_sample(spec, 4000, seed=11), parameter_sample(spec, 4000, seed=11)
    assert a == b and a != parameter_sample(spec, 4000, seed=12)
    x, y = np.array([c["x"] for c in a]), np.array([c["y"] for c in a])
    # sample mean within 5 standard errors (std / sqrt(n)); uniform bounds respected
    assert abs(x.mean() - 5.0) < 5 * 2.0 / np.sqrt(4000) and abs(x.std() - 2.0) < 0.1
    assert y.min() >= -1.0 and y.max() <= 3.0 and abs(y.mean() - 1.0) < 5 * (4 / np.sqrt(12)) / np.sqrt(4000)
    for bad, message in [
        ({"x": {"distribution": "cauchy", "loc": 0}}, "distribution = one of"),
        ({"x": {"distribution": "normal", "mean": 0.0}}, "needs exactly the keys"),
        ({"x": {"distribution": "normal", "mean": 0.0, "std": -1.0}}, "negative std"),
        ({"x": {"distribution": "uniform", "low": 2.0, "high": 1.0}}, "below low"),
        ({"x": {"distribution": "uniform", "low": 0.0, "high": float("inf")}}, "finite"),
    ]:
        with pytest.raises(ModelError, match=message):
            parameter_sample(bad, 3)
    with pytest.raises(ModelError, match="positive integer"):
        parameter_sample(spec, 0)
    with pytest.raises(ModelError, match="non-empty sequence"):
        parameter_grid({"x": []})


def test_cli_writes_the_table_and_the_scatter_plot(tmp_path, capsys):
    spec = tmp_path / "spec.toml"
    spec.write_text('analysis = "margins"\n[grid]\n"controllers.attitude_pd.kd[0]" = [20.0, 70.0, 140.0]\n')
    out = tmp_path / "out" / "margins.csv"
    status = main(["sweep", str(SCENE), str(spec), "-o", str(out), "--processes", "1",
                   "--plot", "controllers.attitude_pd.kd[0]", "phase_margin_deg"])
    assert status == 0
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    assert [float(r["controllers.attitude_pd.kd[0]"]) for r in rows] == [20.0, 70.0, 140.0]
    # more damping, more phase margin on the roll axis, until another axis is the smallest
    pm = [float(r["phase_margin_deg"]) for r in rows]
    assert pm[0] < pm[1] <= pm[2]
    assert out.with_suffix(".png").stat().st_size > 5000
    assert "3 cases, 0 failed, serial" in capsys.readouterr().out

    bad = tmp_path / "bad.toml"
    bad.write_text('[grid]\n"x" = [1.0]\n[sample]\nn = 2\n')
    assert main(["sweep", str(SCENE), str(bad), "-o", str(out)]) == 2
    assert "exactly one of [grid]" in capsys.readouterr().err


def test_example_sweep_spec_loads():
    from linflex.sweeps import load_sweep_spec

    cases, analysis, seed = load_sweep_spec(ROOT / "examples" / "spacecraft_arrays_sweep.toml")
    assert (len(cases), analysis, seed) == (200, "margins", 2026)
    scene = load_scene(ROOT / "examples" / "spacecraft_arrays.toml")
    varied = vary_scene(scene, cases[0])
    assert varied.bodies[1].beam["EI"] == pytest.approx(cases[0]["bodies.array_left.beam.EI"])


# -- streaming to a CSV, stopping, resuming ---------------------------------------------------

TWO_PARAMETERS = NonlinearModel(lambda x, u, p, t: np.array([-p[0] * x[0] + p[1]]), states=["x"],
                                params={"a": 1.0, "b": 0.0})


def _decay(model):
    """Reference: x' = -a x + b has the pole -a and the equilibrium b / a; a <= 0 is refused."""
    a, b = model.param_values
    if a <= 0:
        raise ValueError(f"a = {a} is not a decay rate")
    return {"pole": -a, "equilibrium": b / a}


def _table(path):
    with open(path, newline="") as f:
        return [{k: v for k, v in row.items() if k != "seconds"} for row in csv.DictReader(f)]


@settings(derandomize=True, max_examples=15, deadline=None)
@given(stop=st.integers(0, 7), cut=st.integers(0, 30), first_fails=st.booleans())
def test_a_sweep_stopped_after_any_case_resumes_to_the_uninterrupted_table(tmp_path_factory, stop, cut, first_fails):
    rates = [-1.0 if first_fails else 0.5, 1.0, -2.0, 2.0]  # failed cases too: their rows must survive
    cases = parameter_grid({"a": rates, "b": [0.0, 3.0]})
    folder = tmp_path_factory.mktemp("resume")
    reference = folder / "reference.csv"
    sweep(TWO_PARAMETERS, cases, _decay, processes=1).to_csv(reference)
    out = folder / "sweep.csv"

    def stopped_at_case(model):  # Ctrl-C while case `stop` runs
        if list(model.param_values) == [cases[stop]["a"], cases[stop]["b"]]:
            raise KeyboardInterrupt
        return _decay(model)

    with pytest.raises(KeyboardInterrupt):
        sweep(TWO_PARAMETERS, cases, stopped_at_case, processes=1, csv=out)
    written = out.read_bytes()
    assert written.count(b"\n") == stop + 1  # the header and every finished case, flushed
    last = written[:-1].rfind(b"\n") + 1
    # a kill in the middle of writing the last line: it is cut, that case runs again
    out.write_bytes(written[:max(len(written) - cut, last + 1)] if cut else written)
    result = sweep(TWO_PARAMETERS, cases, _decay, processes=1, csv=out, resume=True)
    assert _table(out) == _table(reference)  # the same rows, sorted by case id; wall times aside
    assert result.n_failed == (4 if first_fails else 2) == sum(row["error"] != "" for row in _table(out))


def test_resume_refuses_a_table_of_another_specification(tmp_path):
    out = tmp_path / "sweep.csv"
    sweep(TWO_PARAMETERS, parameter_grid({"a": [1.0, 2.0, 3.0]}), _decay, processes=1, csv=out)
    before = out.read_bytes()
    with pytest.raises(ModelError, match=r"line 3: .*case 1 has a = 2.0 in the file but 2.5 in the specification"):
        sweep(TWO_PARAMETERS, parameter_grid({"a": [1.0, 2.5, 3.0]}), _decay, processes=1, csv=out, resume=True)
    with pytest.raises(ModelError, match=r"the columns \['a', 'pole', 'equilibrium'\] and the specification varies \['b'\]"):
        sweep(TWO_PARAMETERS, parameter_grid({"b": [1.0]}), _decay, processes=1, csv=out, resume=True)
    with pytest.raises(ModelError, match="case 2, but the specification has 2 cases"):
        sweep(TWO_PARAMETERS, parameter_grid({"a": [1.0, 2.0]}), _decay, processes=1, csv=out, resume=True)
    with pytest.raises(OutputError, match="exists"):
        sweep(TWO_PARAMETERS, parameter_grid({"a": [1.0, 2.0, 3.0]}), _decay, processes=1, csv=out)
    assert out.read_bytes() == before  # every refusal left the table as it was
    # the same specification resumes with nothing to run
    again = sweep(TWO_PARAMETERS, parameter_grid({"a": [1.0, 2.0, 3.0]}), _decay, processes=1, csv=out, resume=True)
    np.testing.assert_array_equal(again.column("pole"), [-1.0, -2.0, -3.0])


def _pole_and_matrix(m):
    a = m.param_values[0]
    if a < 0:
        raise ValueError("a must be positive")
    return {"pole": -a}, np.diag([-a, -2 * a])


def _not_a_pair(m):
    return {"pole": -m.param_values[0]}


def test_keep_returns_what_the_analysis_kept_beside_its_metrics():
    model = NonlinearModel(lambda x, u, p, t: np.array([-p[0] * x[0]]), states=["x"], params={"a": 1.0})
    res = sweep(model, parameter_grid({"a": [1.0, -1.0, 3.0]}), _pole_and_matrix, processes=1, keep=True)
    assert res.column("pole")[[0, 2]].tolist() == [-1.0, -3.0] and res.n_failed == 1
    assert res.kept[1] is None and "a must be positive" in res.errors[1]
    np.testing.assert_array_equal(res.kept[2], np.diag([-3.0, -6.0]))
    assert sweep(model, parameter_grid({"a": [1.0]}), _pole_and_matrix, processes=1).kept is None
    wrong = sweep(model, parameter_grid({"a": [1.0]}), _not_a_pair, processes=1, keep=True)
    assert wrong.n_failed == 1 and "returns (metrics, kept)" in wrong.errors[0]
