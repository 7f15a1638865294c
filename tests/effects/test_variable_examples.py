"""The deployment and thermal-snap example scenes run headless and return what their stories promise."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import linflex

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def run(name: str):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.main()


def test_boom_deployment_spin_rate_is_h0_over_the_final_inertia():
    # Two flexible booms deploy from 0.5 m to 12 m: the total angular momentum stays constant to
    # the integrator's tolerance (rtol 1e-10; measured 2e-10), and the final spin rate is the
    # rigid closed form H0 / I within the residual nutation and bending (measured 4e-5).
    drift, error = run("scene_boom_deployment")
    assert drift < 1e-8
    assert error < 1e-3


def test_thermal_snap_is_internal_and_bends_the_array_as_the_closed_form():
    # The initial static bend of 6 modes against M L^2 / (2 EI): the truncation to 6 modes leaves
    # 1.4 % (all modes give the closed form to round-off, tests/effects/test_thermal.py); the
    # thermal load is internal: the total angular momentum stays zero (measured 1e-14 of the hub's).
    ratio, momentum, turn = run("scene_thermal_snap")
    assert ratio == pytest.approx(1.0, abs=0.02)
    assert momentum < 1e-9
    assert turn > 1e-4  # the snap turned the hub


@pytest.mark.parametrize("name", ["boom_deployment", "thermal_snap"])
def test_example_scenes_round_trip(name, tmp_path):
    scene = linflex.load_scene(EXAMPLES / f"{name}.toml")
    scene.save(tmp_path / "copy.toml")
    assert linflex.load_scene(tmp_path / "copy.toml") == scene
    model = linflex.compile_model(scene)
    xdot, y = model.evaluate(model.x0)
    assert np.all(np.isfinite(xdot)) and y.shape == (model.n_outputs,)
