"""Scenes: aggregated validation with paths and hints, TOML load and round trip."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from linflex import (
    Actuator,
    Body,
    Controller,
    Frame,
    Joint,
    ModelError,
    Orbit,
    Pendulum,
    Scene,
    Sensor,
    Surface,
    Wheel,
    compile_model,
    load_scene,
)


def good_scene() -> Scene:
    return Scene(
        "sat", effects=["gravity_gradient", "wheel_gyroscopics", "control", "slosh", "solar_pressure"],
        bodies=[Body("hub", 500.0, [[100.0, 1.0, 0.0], [1.0, 120.0, 0.0], [0.0, 0.0, 80.0]], com=[0, 0, 0.1])],
        joints=[Joint("att", "spherical", "hub", q0=[1.0, 0.0, 0.0, 0.0], u0=[0.0, 0.001, 0.0])],
        wheels=[Wheel("rw", "hub", 0.05, axis=[1, 0, 0], mode="torque", speed=10.0)],
        pendulums=[Pendulum("fuel", "hub", 20.0, 0.3, point=[0, 0, 0.2])],
        surfaces=[Surface("panel", "hub", 4.0, normal=[0, 0, -1], point=[0, 1, 0], reflectivity=0.2)],
        sensors=[Sensor("roll", "attitude", body="hub", axis=[1, 0, 0]),
                 Sensor("p", "rate", body="hub", axis=[1, 0, 0])],
        actuators=[Actuator("tx", "wheel_torque", wheel="rw")],
        controllers=[Controller("pd", "pid", inputs=["roll"], outputs=["tx"], kp=2.0, kd=20.0, rate_inputs=["p"])],
        frame=Frame("lvlh"), orbit=Orbit(altitude=500e3),
    )


def test_good_scene_is_valid_and_frozen():
    scene = good_scene()
    assert scene.problems() == []
    assert scene.validate() is scene
    with pytest.raises(AttributeError):
        scene.name = "x"  # frozen dataclass
    assert isinstance(scene.bodies[0].inertia, tuple)  # lists become tuples
    assert scene.orbit.r0 == pytest.approx(6378137.0 + 500e3, rel=1e-15)  # R_EARTH + altitude


def test_every_problem_is_reported_at_once_with_paths_and_hints():
    scene = Scene(
        "broken", effects=["gravity_gradiant", "slosh"],
        bodies=[Body("hub", 10.0, [1.0, 2.0, 3.0]), Body("arm", 1.0, [1.0, 1.0]),
                Body("panel", math.inf, [[1, 2, 0], [0, 1, 0], [0, 0, 1]]),
                Body("neg", 1.0, [-1.0, 2.0, 2.0])],
        joints=[Joint("j0", "free", "hub"), Joint("j1", "hinge", "arm", parent="hubb"),
                Joint("j2", "revolute", "panel", parent="neg", axis=[0, 0, 0]),
                Joint("j3", "revolute", "neg", parent="panel")],
        sensors=[Sensor("gyro", "rate", body="hob")],
        actuators=[Actuator("t1", "torque", body="hub", axis=[1, 0, 0])],
        controllers=[Controller("c", "pid", inputs=["gyro"], outputs=["t2"], kp=1.0)],
    )
    with pytest.raises(ModelError) as err:
        scene.validate()
    text = str(err.value)
    expected = [
        "effects[0]: unknown effect 'gravity_gradiant' (did you mean 'gravity_gradient'?)",
        "bodies[1].inertia: expected 3 principal values or a 3x3 matrix [kg m^2], got shape (2,)",
        "bodies[2].mass: not finite",
        "bodies[2].inertia: not symmetric positive definite (not symmetric)",
        "bodies[3].inertia: not symmetric positive definite",
        "joints[1].type: unknown joint type 'hinge'",
        "joints[1].parent: unknown body 'hubb' (did you mean 'hub'?)",
        "joints[2].axis: must not be the zero vector",
        "loop in the joint tree",
        "sensors[0].body: unknown body 'hob' (did you mean 'hub'?)",
        "controllers[0].outputs[0]: 't2' is no actuator (did you mean 't1'?)",
        "controllers[0].inputs[0]: sensor 'gyro' has 3 signals",
    ]
    for item in expected:
        assert item in text, item
    assert text.count("\n  - ") == len(scene.problems()) >= len(expected)


def test_orbit_and_effect_requirements():
    scene = Scene("x", effects=["central_gravity"], bodies=[Body("b", 1.0, (1, 1, 1))],
                  joints=[Joint("j", "free", "b")], frame=Frame("lvlh"))
    problems = scene.problems()
    assert any(p.startswith("orbit: an [orbit] table is required by frame.kind = 'lvlh', central_gravity")
               for p in problems), problems
    both = Orbit(radius=7e6, altitude=5e5)
    assert "orbit: give exactly one of radius [m] or altitude [m]" in scene.replace(orbit=both).problems()


def test_wheel_and_actuator_consistency():
    scene = Scene("x", bodies=[Body("b", 1.0, (1, 1, 1))], joints=[Joint("j", "spherical", "b")],
                  wheels=[Wheel("w", "b", 0.1, mode="constant")],
                  actuators=[Actuator("a", "wheel_torque", wheel="w"), Actuator("th", "thruster", body="b")],
                  sensors=[Sensor("s", "wheel_speed", wheel="w")])
    problems = scene.problems()
    assert "actuators[0].wheel: wheel 'w' has mode 'constant'; a wheel_torque actuator needs mode = 'torque'" in problems
    assert "actuators[1].axis: a thruster needs an axis (its thrust direction in body axes)" in problems
    assert "sensors[0]: a wheel_speed sensor needs the 'wheel_gyroscopics' effect" in problems


def test_state_space_controller_shapes_checked():
    scene = good_scene()
    bad = Controller("ss", "state_space", inputs=["roll"], outputs=["tx"], A=[[0.0, 1.0], [0.0, 0.0]],
                     B=[[0.0], [1.0], [2.0]], C=[[1.0, 0.0]])
    problems = scene.replace(controllers=(bad,)).problems()
    assert "controllers[0].B: has shape (3, 1) but (2, 1) was expected (2 controller states, 1 inputs, 1 outputs)" in problems


def test_unknown_body_is_unattached():
    scene = Scene("x", bodies=[Body("a", 1.0, (1, 1, 1)), Body("b", 1.0, (1, 1, 1))], joints=[Joint("j", "free", "a")])
    assert scene.problems() == ["bodies[1]: body 'b' is attached by no joint (add a [[joints]] entry with child = 'b')"]


def test_toml_round_trip(tmp_path):
    scene = good_scene()
    path = tmp_path / "sat.toml"
    scene.save(path)
    loaded = load_scene(path)
    assert loaded == scene
    assert loaded.to_toml() == scene.to_toml()


def test_malformed_toml_reports_file_and_line(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('name = "x"\neffects = ["gravity"]\n\n[[bodies]]\nname = "b"\nmass = = 3\n', encoding="utf-8")
    with pytest.raises(ModelError) as err:
        load_scene(path)
    text = str(err.value)
    assert str(path) in text and "line 6" in text


def test_toml_unknown_keys_and_validation_problems(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(
        'name = "x"\neffects = ["gravity"]\n[[bodies]]\nname = "b"\nmas = 3.0\n'
        '[[bodies]]\nname = "c"\nmass = 1.0\ninertia = [1, 1, 1]\ncolor = "red"\n',
        encoding="utf-8")
    with pytest.raises(ModelError) as err:
        load_scene(path)
    text = str(err.value)
    assert "bodies[0].mas: unknown key (did you mean 'mass'?)" in text
    assert "bodies[1].color: unknown key" in text
    assert str(path) in text


def test_callable_profile_cannot_be_written():
    scene = Scene("x", bodies=[Body("b", 1.0, (1, 1, 1))],
                  joints=[Joint("j", "revolute", "b", prescribed=lambda t: 0.1 * t)])
    assert scene.problems() == []
    with pytest.raises(ModelError, match=r"joints\[0\].prescribed: a function cannot be written to TOML"):
        scene.to_toml()


@settings(max_examples=40, deadline=None)
@given(st.floats(0.5, 10.0), st.floats(0.5, 10.0), st.floats(0.0, 1.0), st.integers(0, 2**31 - 1))
def test_inertia_validation_invariant_under_rotation(a, b, frac, seed):
    # A physical inertia (principal values obeying the triangle inequality) stays valid in any
    # body axes; flipping the sign of one principal value is always reported.
    c = abs(a - b) + frac * (a + b - abs(a - b))  # |a - b| <= c <= a + b
    R = Rotation.random(random_state=seed).as_matrix()
    inertia = R @ np.diag([a, b, c]) @ R.T
    inertia = (inertia + inertia.T) / 2
    ok = Scene("x", bodies=[Body("b", 1.0, inertia.tolist())], joints=[Joint("j", "spherical", "b")])
    assert [p for p in ok.problems() if p.startswith("bodies[0].inertia")] == []
    bad_matrix = R @ np.diag([a, b, -c - 0.1]) @ R.T
    bad = ok.replace(bodies=(Body("b", 1.0, ((bad_matrix + bad_matrix.T) / 2).tolist()),))
    assert any(p.startswith("bodies[0].inertia: not symmetric positive definite") for p in bad.problems())


def test_relative_rate_sensor_in_spin_frame():

    W = 0.4
    scene = Scene("s", bodies=[Body("b", 1.0, (1.0, 2.0, 3.0))], joints=[Joint("j", "spherical", "b")],
                  frame=Frame("spin", rate=W, axis=[0, 0, 2.0]),
                  sensors=[Sensor("gyro", "rate", body="b"), Sensor("rel", "rate", body="b", relative=True)])
    model = compile_model(scene)
    y = model.evaluate(model.x0)[1]
    # At rest in the spinning frame: inertial rate W z, rate relative to the frame 0 (exact).
    np.testing.assert_allclose(y, [0, 0, W, 0, 0, 0], atol=1e-16)


finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.floats(1e-3, 1e4), st.lists(finite, min_size=3, max_size=3),
                          st.sampled_from(["free", "spherical", "revolute", "prismatic", "fixed"]),
                          st.floats(0.0, 1e3)), min_size=1, max_size=4),
       st.text("abcdefgh_", min_size=1, max_size=8))
def test_toml_round_trip_property(tmp_path_factory, entries, name):
    bodies, joints = [], []
    for i, (mass, com, kind, k) in enumerate(entries):
        bodies.append(Body(f"b{i}", mass, [1.0, 2.0, 2.5], com=com))
        joints.append(Joint(f"j{i}", kind, f"b{i}", parent="ground" if i == 0 else f"b{i - 1}",
                            stiffness=k if kind in ("revolute", "prismatic") else 0.0, parent_point=com))
    scene = Scene(name, effects=["joint_springs"], bodies=bodies, joints=joints)
    assert scene.problems() == []
    path = tmp_path_factory.mktemp("rt") / "s.toml"
    scene.save(path)
    # Floats are written with repr (shortest round-trip form): exact equality after reading.
    assert load_scene(path) == scene


def test_mapping_entries_with_unknown_keys_are_reported():
    with pytest.raises(ModelError) as err:
        Scene("x", bodies=[{"name": "b", "mas": 1.0}], frame={"knd": "lvlh"})
    text = str(err.value)
    assert "bodies[0].mas: unknown key (did you mean 'mass'?)" in text
    assert "bodies[0]: missing required key(s) mass" in text
    assert "frame.knd: unknown key (did you mean 'kind'?)" in text
