"""``linflex simulate``: CSV and PNG from a scene file."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from linflex.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_simulate_command_writes_csv_and_png(tmp_path, capsys):
    status = main(["simulate", str(EXAMPLES / "double_pendulum.toml"), "--duration", "2", "--samples", "21",
                   "--signals", "shoulder.angle", "elbow.angle", "--rtol", "1e-10", "-o", str(tmp_path)])
    assert status == 0
    data = np.loadtxt(tmp_path / "double_pendulum.csv", delimiter=",", skiprows=1)
    assert data.shape == (21, 3)
    # Starts at the scene's initial angles (q0 = 1.2 and -0.4 rad), exactly.
    np.testing.assert_array_equal(data[0], [0.0, 1.2, -0.4])
    png = (tmp_path / "double_pendulum.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
    assert "wrote" in capsys.readouterr().out


def test_simulate_command_reports_bad_input(tmp_path, capsys):
    status = main(["simulate", str(EXAMPLES / "double_pendulum.toml"), "--signals", "shoulder.angel", "-o", str(tmp_path)])
    assert status == 2
    assert "did you mean 'shoulder.angle'" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    bad.write_text("name = \n", encoding="utf-8")
    assert main(["simulate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "line 1" in err


def test_simulate_refuses_an_output_it_cannot_write_before_simulating(tmp_path, capsys, monkeypatch):
    import linflex.simulation._simulate as simulation

    def never(*args, **kwargs):
        raise AssertionError("the simulation ran")

    monkeypatch.setattr(simulation, "simulate", never)
    taken = tmp_path / "out"
    taken.write_text("mine")
    assert main(["simulate", str(EXAMPLES / "double_pendulum.toml"), "-o", str(taken)]) == 2
    assert "is a file" in capsys.readouterr().err and taken.read_text() == "mine"
    (tmp_path / "dir" / "double_pendulum.csv").mkdir(parents=True)  # the CSV's name is taken by a folder
    assert main(["simulate", str(EXAMPLES / "double_pendulum.toml"), "-o", str(tmp_path / "dir")]) == 2
    assert "double_pendulum.csv is a folder" in capsys.readouterr().err
