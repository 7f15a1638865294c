"""What a hurried user types at ``linflex simulate`` and ``linflex sweep``: a wrong option, a
malformed input CSV, the two files of a sweep swapped. Each ends with exit code 2 and one message
that names the option or the file, before any simulation runs."""

from __future__ import annotations

from pathlib import Path

import pytest

from linflex import ModelError, load_scene
from linflex.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SCENE = EXAMPLES / "gyrostat.toml"  # inputs motor_x, motor_y, motor_z


@pytest.mark.parametrize(("option", "message"), [
    (["--method", "cvode"], "linflex simulate: error: --method 'cvode' is unknown (did you mean 'cvodes'?)"),
    (["--method", "RK45"], "linflex simulate: error: --method 'RK45' is unknown (did you mean 'scipy-RK45'?)"),
    (["--duration", "inf"], "linflex simulate: error: --duration must be a positive, finite time [s], got inf"),
    (["--rtol", "inf"], "linflex simulate: error: --rtol and --atol must be positive, finite numbers, got inf"),
])
def test_simulate_names_a_bad_option_not_the_scene(option, message, tmp_path, capsys):
    # These used to reach simulate() after the scene had compiled, and the message then blamed the
    # scene file ("gyrostat.toml: method 'cvode' is unknown"; "--duration inf": "timepts must be
    # finite" with a numpy RuntimeWarning).
    assert main(["simulate", str(SCENE), "-o", str(tmp_path), *option]) == 2
    err = capsys.readouterr().err
    assert err.startswith(message)
    assert "RuntimeWarning" not in err and str(SCENE) not in err
    assert not list(tmp_path.iterdir())


def test_simulate_names_a_ragged_row_of_the_inputs_csv(tmp_path, capsys):
    # A row with more cells than the header used to be reported as "every cell must be a number:
    # setting an array element with a sequence ...", numpy's words.
    csv = tmp_path / "in.csv"
    csv.write_text("time,motor_x\n0,1,3\n1,2\n", encoding="utf-8")
    assert main(["simulate", str(SCENE), "--inputs", str(csv), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "every row must have 2 cells (as the header), got 3 in the row '0,1,3'" in err
    assert "sequence" not in err


def test_a_sweep_spec_given_as_the_scene_is_recognized(tmp_path, capsys):
    spec = EXAMPLES / "spacecraft_arrays_sweep.toml"
    with pytest.raises(ModelError, match="this looks like a sweep spec"):
        load_scene(spec)
    assert main(["sweep", str(spec), str(EXAMPLES / "spacecraft_arrays.toml"), "-o", str(tmp_path / "x.csv")]) == 2
    assert "a spec goes second to linflex sweep (SCENE SPEC)" in capsys.readouterr().err


def test_simulate_lists_the_signals_when_a_name_has_no_near_miss(tmp_path, capsys):
    # Before: "--signals: unknown signal(s) 'foo'" and nothing to choose from.
    assert main(["simulate", str(SCENE), "--signals", "foo", "-o", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "unknown signal(s) 'foo'; the model's signals: attitude.qw, attitude.qx" in err
    assert "(25 in all)" in err


def test_sweep_plot_names_its_unknown_columns_with_a_hint(tmp_path, capsys):
    # Before: "--plot: 'foo', 'phase_margin' is neither a parameter ..." and a Python list.
    spec = tmp_path / "grid.toml"
    spec.write_text('analysis = "margins"\n[grid]\n"bodies.hub.inertia[0]" = [60.0, 100.0]\n', encoding="utf-8")
    assert main(["sweep", str(EXAMPLES / "attitude_control.toml"), str(spec), "-o", str(tmp_path / "x.csv"),
                 "--plot", "foo", "phase_margin"]) == 2
    err = capsys.readouterr().err
    assert "--plot: 'foo', 'phase_margin' (did you mean 'phase_margin_deg'?): no such column" in err
    assert "columns: bodies.hub.inertia[0], gain_margin_db" in err
    assert not (tmp_path / "x.csv").exists()
