"""Sweeps under a hurried user's inputs: each either gives the right table or a linflex error naming
the argument (and the sweep file and section)."""

from pathlib import Path

import numpy as np
import pytest

from linflex import ModelError, NonlinearModel, load_scene, parameter_grid, parameter_sample, sweep, vary_scene
from linflex.stability import stability_margins
from linflex.stability.report import analyse_scene, margin_summary
from linflex.sweeps import load_sweep_spec

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "examples" / "attitude_control.toml"


def _decay(x, u, p, t):
    return np.array([-p[0] * x[0]])


def _model() -> NonlinearModel:
    return NonlinearModel(_decay, states=["x"], params={"a": 1.0, "b": 2.0})


def _pole(model):
    return {"pole": -float(model.param_values[0])}


# -- cases --------------------------------------------------------------------------------------


def test_grid_refuses_a_zero_dimensional_array():
    # np.array(3.0) is a Sequence-like ndarray without a length: it raised TypeError from len()
    with pytest.raises(ModelError, match="'a' needs a non-empty sequence of values"):
        parameter_grid({"a": np.array(3.0)})


@pytest.mark.parametrize("seed", [-1, 1.5, None, True])
def test_sample_refuses_a_seed_that_is_not_a_non_negative_integer(seed):
    # numpy raised its own ValueError / TypeError (or, for None, drew an irreproducible sample)
    with pytest.raises(ModelError, match="seed must be a non-negative integer"):
        parameter_sample({"a": {"distribution": "uniform", "low": 0.0, "high": 1.0}}, 2, seed=seed)


def test_sample_refuses_a_uniform_range_beyond_the_floats():
    # finite bounds whose difference overflows: numpy raised OverflowError
    with pytest.raises(ModelError, match="'a' has a range high - low"):
        parameter_sample({"a": {"distribution": "uniform", "low": -1e308, "high": 1e308}}, 2)


def test_sweep_refuses_the_values_mapping_in_place_of_cases():
    # the grid's input instead of parameter_grid(...) of it: it raised a bare ValueError from dict()
    with pytest.raises(ModelError, match="cases must be a sequence of mappings.*parameter_grid"):
        sweep(_model(), {"a": [1.0, 2.0]}, _pole, processes=1)
    with pytest.raises(ModelError, match="case 1 must be a mapping"):
        sweep(_model(), [{"a": 1.0}, 2.0], _pole, processes=1)


@pytest.mark.parametrize("processes", [1.5, "2", True])
def test_sweep_refuses_a_process_count_that_is_not_an_integer(processes):
    # 1.5 ran serially and "2" started two processes, silently
    with pytest.raises(ModelError, match="processes must be an integer"):
        sweep(_model(), [{"a": 1.0}], _pole, processes=processes)


def test_resume_without_csv_is_refused():
    # resume=True was ignored: the whole sweep ran again and nothing was kept
    with pytest.raises(ModelError, match="resume=True .* no csv"):
        sweep(_model(), [{"a": 1.0}], _pole, processes=1, resume=True)


def test_two_paths_to_one_scene_entry_are_refused():
    scene = load_scene(SCENE)
    # the last one set won (inertia[0] = 200 in every case) while the table showed 60 and 100
    with pytest.raises(ModelError, match=r"'bodies.hub.inertia\[0\]' and 'bodies\[0\].inertia\[0\]' both set "
                                         r"bodies\[0\].inertia\[0\]"):
        sweep(scene, parameter_grid({"bodies.hub.inertia[0]": [60.0, 100.0], "bodies[0].inertia[0]": [200.0]}),
              margin_summary, processes=1)
    with pytest.raises(ModelError, match=r"both set bodies\[0\].inertia;"):
        vary_scene(scene, {"bodies.hub.inertia": [1.0, 2.0, 3.0], "bodies.hub.inertia[1]": 5.0})
    # distinct elements of one vector stay allowed
    varied = vary_scene(scene, {"bodies.hub.inertia[0]": 90.0, "bodies[0].inertia[1]": 110.0})
    assert varied.bodies[0].inertia[:2] == (90.0, 110.0)


def test_metric_named_like_a_column_fails_the_case():
    # {"error": ...} was overwritten by the error column in rows(); {"a": ...} doubled a column
    result = sweep(_model(), [{"a": 1.0}, {"a": 2.0}], lambda m: {"a": 1.0, "error": 0.0}, processes=1)
    assert result.n_failed == 2 and "metric 'a' has the name of a column" in result.errors[0]


# -- resuming -----------------------------------------------------------------------------------


def test_resume_with_fewer_parameters_is_refused(tmp_path):
    path = tmp_path / "ab.csv"
    sweep(_model(), parameter_grid({"a": [1.0, 2.0], "b": [3.0]}), _pole, processes=1, csv=path)
    before = path.read_bytes()
    # the file's parameter column b was read as a metric and the resumed table accepted
    with pytest.raises(ModelError, match=r"cannot resume: its columns \['b'\] are parameters of the model"):
        sweep(_model(), parameter_grid({"a": [1.0, 2.0]}), _pole, processes=1, csv=path, resume=True)
    assert path.read_bytes() == before


def test_resume_of_a_scene_sweep_keeps_its_rows(tmp_path):
    # the metric columns of margin_summary are not scene paths: the same spec resumes
    scene, path = load_scene(SCENE), tmp_path / "m.csv"
    cases = parameter_grid({"bodies.hub.inertia[0]": [60.0, 100.0]})
    first = sweep(scene, cases[:1], margin_summary, processes=1, csv=path)  # as if stopped after case 0
    again = sweep(scene, cases, margin_summary, processes=1, csv=path, resume=True)
    # case 0 read back from the file: equal to the digit (CSV floats round-trip exactly)
    np.testing.assert_array_equal(again.results[0], first.results[0])
    assert again.case_seconds[0] == first.case_seconds[0] and again.n_failed == 0


# -- sweep files --------------------------------------------------------------------------------


def _spec(tmp_path, text: str, name: str = "spec.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(("text", "fragment"), [
    ('[grid]\n"bodies.hub.mass" = 1.0\n', r"\[grid\]: parameter_grid: 'bodies.hub.mass' needs a non-empty sequence"),
    ('[grid]\n"bodies.hub.mass" = [nan]\n', r"\[grid\]: bodies.hub.mass: expected a finite number"),
    ('[sample]\nn = 0\n[sample.parameters]\n"a" = {distribution = "uniform", low = 1, high = 2}\n',
     r"\[sample\]: parameter_sample: n must be a positive integer"),
    ('[sample]\nn = 2\n[sample.parameters]\n"a" = {distribution = "uniform", low = 3, high = 2}\n',
     r"\[sample\]: parameter_sample: 'a' has high = 2.0 below low = 3.0"),
    ('[sample]\nn = 2\n[sample.parameters]\n"a" = [1.0, 2.0]\n', r"\[sample\]: parameter_sample: 'a' needs a mapping"),
])
def test_sweep_file_errors_name_the_file_and_section(tmp_path, text, fragment):
    # the messages of parameter_grid / parameter_sample came without the file's name
    path = _spec(tmp_path, text)
    with pytest.raises(ModelError, match=f"{tmp_path}/spec.toml: {fragment}"):
        load_sweep_spec(path)


@pytest.mark.parametrize("text", [
    '[grid]\nbodies.hub.mass = [900.0, 1000.0]\nbodies.hub.inertia = [[1.0, 2.0, 3.0]]\n',
    '[sample]\nn = 2\n[sample.parameters]\nbodies.hub.mass = {distribution = "normal", mean = 1.0, std = 0.1}\n',
])
def test_sweep_file_path_without_quotes_is_named(tmp_path, text):
    # TOML reads a bare dotted key as nested tables: the message was "'bodies' needs a ... got {'hub': ...}"
    with pytest.raises(ModelError, match='write the scene path in quotes: "bodies.hub.mass" = ...'):
        load_sweep_spec(_spec(tmp_path, text))


def test_sweep_file_that_is_not_utf8_is_a_model_error(tmp_path):
    # it raised UnicodeDecodeError (neither the documented ModelError nor OSError)
    path = tmp_path / "spec.toml"
    path.write_bytes(b"\xff\xfe[grid]\n")
    with pytest.raises(ModelError, match="spec.toml: not a valid TOML file"):
        load_sweep_spec(path)


# -- cross-check --------------------------------------------------------------------------------


def test_sweep_rows_equal_stability_margins_of_the_case_loop():
    scene = load_scene(SCENE)
    cases = parameter_grid({"bodies.hub.inertia[2]": [50.0, 160.0]})
    result = sweep(scene, cases, margin_summary, processes=1)
    for i, case in enumerate(cases):
        direct = stability_margins(analyse_scene(vary_scene(scene, case), figures=False).open_loop)
        # Reference: stability_margins on the case's own linearized loop, compiled alone; the
        # sweep compiles once with the inertia as a graph input: equal to round-off (1e-10)
        assert result.column("phase_margin_deg")[i] == pytest.approx(
            min(abs(lp.min_phase_margin) for lp in direct.loops), rel=1e-10)
        assert result.column("delay_margin_s")[i] == pytest.approx(min(lp.delay_margin for lp in direct.loops),
                                                                   rel=1e-10)
        assert result.column("disk_margin")[i] == pytest.approx(direct.disk_margin.alpha, rel=1e-10)
