"""Command and disturbance profiles: a scene's ``[[inputs]]`` and ``linflex simulate --inputs FILE.csv``.

Reference: a free mass on a prismatic joint, ``m x'' = F(t)``, whose motion under a step, a sine
or a ramp of force is a closed form (integrated twice by hand).
"""

from __future__ import annotations

from pathlib import Path

import control
import numpy as np
import pytest

from linflex import (
    Actuator,
    Body,
    Disturbance,
    InputProfile,
    Joint,
    LinearSystem,
    ModelError,
    Scene,
    compile_model,
    load_scene,
    simulate,
)
from linflex.cli import main

MASS = 2.0  # [kg]


def pushed(inputs=(), effects=()):
    """A mass on a prismatic joint along x, pushed by a force actuator and a disturbance."""
    return Scene("pushed", effects=list(effects), bodies=[Body("b", MASS, [1.0, 1.0, 1.0])],
                 joints=[Joint("s", "prismatic", "b", axis=[1, 0, 0])],
                 actuators=[Actuator("f", "force", body="b", axis=[1, 0, 0])],
                 disturbances=[Disturbance("gust", "force", body="b")], inputs=list(inputs))


def test_scene_step_profile_on_a_disturbance_channel():
    # A 0.5 N step at t = 1 s on gust.x: x = F (t - 1)^2 / (2 m) after it, 0 before.
    model = compile_model(pushed([InputProfile("gust.x", "step", time=1.0, before=0.0, after=0.5)]))
    t = np.linspace(0.0, 3.0, 31)
    r = simulate(model, t, method="cvodes", rtol=1e-11, atol=1e-13)
    ref = np.where(t > 1.0, 0.5 * (t - 1.0) ** 2 / (2 * MASS), 0.0)
    np.testing.assert_allclose(r["s.position"], ref, atol=1e-9)
    np.testing.assert_array_equal(r["gust.x"], np.where(t >= 1.0, 0.5, 0.0))
    # given inputs replace the scene's profiles
    assert np.all(simulate(model, t, inputs={"f": 0.0}, method="cvodes")["s.position"] == 0.0)


def test_scene_profiles_add_up_and_follow_a_sine_continuously():
    # F = 0.1 + 0.3 sin(2 t) on the actuator (two profiles): x = 0.1 t^2/(2m) + (0.3/m)(t/2 - sin(2t)/4),
    # with scipy evaluating the profiles continuously.
    model = compile_model(pushed([InputProfile("f", "sine", amplitude=0.3, frequency=2.0),
                                  InputProfile("f", "constant", value=0.1)]))
    t = np.linspace(0.0, 2.0, 11)
    r = simulate(model, t, method="scipy-DOP853", rtol=1e-12, atol=1e-14)
    ref = 0.1 * t**2 / (2 * MASS) + (0.3 / MASS) * (t / 2 - np.sin(2 * t) / 4)
    np.testing.assert_allclose(r["s.position"], ref, atol=1e-10)


@pytest.mark.parametrize("entry, match", [
    (InputProfile("gusty", "step", time=1.0, before=0.0, after=1.0),
     r"inputs\[0\]\.input: unknown input \(an actuator or disturbance\) 'gusty'"),
    (InputProfile("gust", "step", time=1.0, before=0.0, after=1.0), r"inputs\[0\]\.input: 'gust' has three channels: name one, 'gust\.x'"),
    (InputProfile("f", "sine", amplitude=1.0, time=2.0), r"inputs\[0\]\.time: does not apply to a 'sine' profile"),
    (InputProfile("f", "step", time=1.0), r"inputs\[0\]\.before: a 'step' profile needs 'before'"),
    (InputProfile("f", "constant"), r"inputs\[0\]\.value: a 'constant' profile needs 'value'"),
    (InputProfile("f", "sawtooth"), r"inputs\[0\]\.profile: unknown profile 'sawtooth'"),
    (InputProfile("f", "constant", value="big"), r"inputs\[0\]\.value: expected a number"),
])
def test_bad_input_profiles_name_their_path(entry, match):
    with pytest.raises(ModelError, match=match):
        pushed([entry]).validate()


def test_input_profiles_round_trip_through_toml(tmp_path):
    scene = pushed([InputProfile("gust.y", "table", times=[0.0, 1.0, 2.0, 3.0], values=[0.0, 1.0, 0.5, 0.0])])
    path = tmp_path / "p.toml"
    path.write_text(scene.to_toml())
    assert load_scene(path).inputs == scene.inputs


def test_cli_applies_the_scene_profiles(tmp_path):
    scene = pushed([InputProfile("f", "step", time=1.0, before=0.0, after=0.5)])
    (tmp_path / "p.toml").write_text(scene.to_toml())
    assert main(["simulate", str(tmp_path / "p.toml"), "--duration", "3", "--samples", "31", "--rtol", "1e-11",
                 "--atol", "1e-13", "--signals", "s.position", "f", "-o", str(tmp_path)]) == 0
    data = np.loadtxt(tmp_path / "pushed.csv", delimiter=",", skiprows=1)
    t = data[:, 0]
    np.testing.assert_allclose(data[:, 1], np.where(t > 1.0, 0.5 * (t - 1.0) ** 2 / (2 * MASS), 0.0), atol=1e-9)


@pytest.mark.parametrize("interpolation", ["linear", "hold"])
def test_cli_reads_input_profiles_from_csv(tmp_path, interpolation):
    # Two rows (0, 0) and (1, 0.5) on f, the scene's own profile on f replaced by the file:
    # linear, a ramp F = 0.5 t up to 1 s then 0.5 (x = 0.5 t^3/(6 m) until then); hold, a step at 1 s.
    scene = pushed([InputProfile("f", "constant", value=7.0)])
    (tmp_path / "p.toml").write_text(scene.to_toml())
    (tmp_path / "u.csv").write_text("time,f\n0.0,0.0\n1.0,0.5\n")
    assert main(["simulate", str(tmp_path / "p.toml"), "--inputs", str(tmp_path / "u.csv"), "--interpolation",
                 interpolation, "--duration", "2", "--samples", "21", "--method", "scipy-DOP853", "--rtol", "1e-12",
                 "--atol", "1e-14", "--signals", "s.position", "-o", str(tmp_path)]) == 0
    data = np.loadtxt(tmp_path / "pushed.csv", delimiter=",", skiprows=1)
    t, x = data[:, 0], data[:, 1]
    if interpolation == "linear":
        ref = np.where(t <= 1.0, 0.5 * t**3 / (6 * MASS),
                       0.5 / (6 * MASS) + 0.25 / MASS * (t - 1.0) + 0.5 * (t - 1.0) ** 2 / (2 * MASS))
        tol = 1e-9
    else:
        ref = np.where(t > 1.0, 0.5 * (t - 1.0) ** 2 / (2 * MASS), 0.0)
        tol = 1e-6  # the step inside one solve_ivp run: the error control locates it
    np.testing.assert_allclose(x, ref, atol=tol)


@pytest.mark.parametrize("text, message", [
    ("t,f\n0,1\n", "no 'time' column"),
    ("time,fx\n0,1\n", "unknown input(s) 'fx' (did you mean 'f'?)"),
    ("time,f\n0,1\n0,2\n", "must increase strictly"),
    ("time,f\n0,abc\n", "every cell must be a number"),
    ("time,f\n0,nan\n", "line 2: non-finite value"),
    ("time,f\n", "no data rows"),
])
def test_cli_reports_bad_input_files(tmp_path, capsys, text, message):
    (tmp_path / "p.toml").write_text(pushed().to_toml())
    (tmp_path / "u.csv").write_text(text)
    assert main(["simulate", str(tmp_path / "p.toml"), "--inputs", str(tmp_path / "u.csv"), "-o", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("system", [control.tf([1.0], [1.0, 1.0]), ([1.0], [1.0, 2.0]),
                                    LinearSystem([[-1.0]], [[1.0]], [[1.0]])])
def test_a_linear_system_is_pointed_to_the_linear_time_responses(system):
    with pytest.raises(ModelError, match="forced_response, step_response"):
        simulate(system, np.linspace(0.0, 1.0, 3))


def test_something_else_gets_no_such_hint():
    with pytest.raises(ModelError, match=r"got int$"):
        simulate(42, np.linspace(0.0, 1.0, 3))


ATTITUDE = Path(__file__).resolve().parents[2] / "examples" / "attitude_control.toml"


@pytest.mark.parametrize("given", [ATTITUDE, str(ATTITUDE), "scene"])
def test_a_scene_is_pointed_to_compile_model(given):
    scene = load_scene(ATTITUDE) if given == "scene" else given
    with pytest.raises(ModelError, match=r"compile the scene first"):
        simulate(scene, np.linspace(0.0, 1.0, 3))


def test_compile_model_takes_a_scene_file():
    """The path and the loaded scene compile to the same model (reference: load_scene)."""
    path = ATTITUDE
    by_path, by_scene = compile_model(path), compile_model(load_scene(path))
    assert by_path.states == by_scene.states
    np.testing.assert_array_equal(by_path.x0, by_scene.x0)
    with pytest.raises(ModelError, match="path of a scene file"):
        compile_model(3)
