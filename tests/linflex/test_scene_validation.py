"""One-pass scene validation (issue 17 items 4 and 5): every problem of a scene in one ModelError,
each message naming the entry path, the value and what is expected; integers refused when not
integral; inapplicable keys refused; physically meaningless magnitudes refused before compiling."""

from __future__ import annotations

import copy
import dataclasses
import json
import pathlib
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import (
    Beam,
    Body,
    Controller,
    Joint,
    ModelError,
    Orbit,
    Scene,
    beam_modal_data,
    compile_model,
    load_modal_data,
    load_scene,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

EXAMPLE = pathlib.Path(__file__).parents[2] / "examples" / "spacecraft_arrays.toml"


def arrays_data() -> dict:
    """The example's data with 4-element beams (the same vocabulary; fast modal data)."""
    data = tomllib.loads(EXAMPLE.read_text(encoding="utf-8"))
    for body in data["bodies"][1:]:
        body["beam"]["elements"] = 4
    return data


def problems_of(data: dict) -> list[str]:
    """The problems ``Scene.from_dict(data).validate()`` reports, from its one ModelError."""
    with pytest.raises(ModelError) as err:
        Scene.from_dict(data).validate()
    return [line[4:] for line in str(err.value).splitlines() if line.startswith("  - ")]


def write(tmp_path, text: str, name: str = "scene.toml") -> pathlib.Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def small_modal_data(n_modes: int = 3):
    beam = Beam((0, 0, 0), (1, 0, 0), EA=1e6, EIy=1.0, EIz=1.0, GJ=1.0, mass_per_length=1.0, elements=4)
    return beam_modal_data(beam, n_modes)


def test_the_example_is_valid():
    assert Scene.from_dict(arrays_data()).problems() == []


def test_an_unknown_key_does_not_hide_the_other_problems(tmp_path):
    # On main the unknown key was reported alone: the negative mass and the wheel's zero axis
    # only after it was fixed.
    text = EXAMPLE.read_text(encoding="utf-8").replace("mass = 1000.0", "mass = -1000.0\nmas = 3.0", 1)
    text = text.replace("axis = [1.0, 0.0, 0.0]\nspin_inertia", "axis = [0.0, 0.0, 0.0]\nspin_inertia", 1)
    path = write(tmp_path, text)
    with pytest.raises(ModelError) as err:
        load_scene(path)
    text = str(err.value)
    assert "bodies[0].mas: unknown key (did you mean 'mass'?)" in text
    assert "bodies[0].mass: must be positive [kg], got -1000.0" in text
    assert "wheels[0].axis: must not be the zero vector (it gives a direction), got [0.0, 0.0, 0.0]" in text
    assert str(path) in text and "3 problem(s)" in text


def test_missing_keys_are_reported_with_the_rest_once():
    data = arrays_data()
    del data["joints"][0]["child"]
    data["bodies"][0]["mass"] = "heavy"
    found = problems_of(data)
    assert "joints[0]: missing required key(s) child" in found
    assert "bodies[0].mass: expected a number [kg], got 'heavy'" in found
    assert not any(p.startswith("joints[0].child:") for p in found)  # not repeated by the reference check


def test_modal_json_that_is_a_list(tmp_path):
    path = write(tmp_path, "[1, 2]", "modes.json")
    with pytest.raises(ModelError, match=r"modes\.json: expected a JSON object .* got a list"):
        load_modal_data(path)


def test_modal_json_with_a_version_that_is_no_integer(tmp_path):
    small_modal_data().save(tmp_path / "modes.json")
    raw = json.loads((tmp_path / "modes.json").read_text())
    raw["version"] = "abc"
    path = write(tmp_path, json.dumps(raw), "modes.json")
    with pytest.raises(ModelError, match=r"modes\.json: not a linflex-modal-data file of version 1 \(its version is 'abc'; expected the integer 1\)"):
        load_modal_data(path)


def test_npz_that_is_no_zip_archive(tmp_path):
    path = write(tmp_path, "hello", "modes.npz")
    with pytest.raises(ModelError, match=r"modes\.npz: not an \.npz archive .* starts with b'hello'"):
        load_modal_data(path)


def test_zero_beam_direction_names_the_key():
    data = arrays_data()
    data["bodies"][1]["beam"]["direction"] = [0.0, 0.0, 0.0]
    assert problems_of(data) == [
        "bodies[1].beam.direction: must not be the zero vector (it gives a direction), got [0.0, 0.0, 0.0]"]


@pytest.mark.parametrize("kind, inertia", [("spherical", [0.0, 0.0, 0.0]), ("spherical", [1.0, 1.0, 0.0]),
                                           ("free", [0.0, 2.0, 2.0]), ("revolute", [0.0, 1.0, 1.0])])
def test_a_joint_that_turns_a_body_without_inertia_is_refused(kind, inertia):
    # On main: compiled, then "f is not finite" (or a failed integrator) at the first evaluation.
    scene = Scene("z", bodies=[Body("b", 1.0, inertia)], joints=[Joint("j", kind, "b", axis=[1, 0, 0]
                                                                      if kind == "revolute" else (0.0, 0.0, 1.0))])
    found = scene.problems()
    assert len(found) == 1 and found[0].startswith(f"joints[0]: the {kind} joint turns 'b', which has no "
                                                   "rotational inertia"), found
    assert "bodies[0].inertia" in found[0]


def test_a_point_mass_off_the_hinge_is_inertia_enough():
    # The bob of a pendulum: no central inertia, but m r^2 about the hinge (a revolute joint), or
    # an inertia about the rod for the spherical pendulum's third axis.
    rod = Scene("p", bodies=[Body("b", 1.0, [0, 0, 0], com=[0, 0, -1])], joints=[Joint("j", "revolute", "b",
                                                                                      axis=[0, 1, 0])])
    assert rod.problems() == []
    bob = rod.replace(joints=(Joint("j", "spherical", "b"),))
    assert len(bob.problems()) == 1 and "about the axis [0.0, 0.0, -1.0]" in bob.problems()[0]  # along the rod
    assert bob.replace(bodies=(Body("b", 1.0, [1e-6, 1e-6, 1e-6], com=[0, 0, -1]),)).problems() == []


def test_non_integral_beam_elements_are_refused():
    data = arrays_data()
    data["bodies"][1]["beam"]["elements"] = 4.7  # on main: silently 4 elements
    assert problems_of(data) == ["bodies[1].beam.elements: expected an integer, got 4.7"]
    data["bodies"][1]["beam"]["elements"] = 4.0  # integral: accepted
    assert Scene.from_dict(data).problems() == []


def test_non_integral_modes_are_refused():
    data = arrays_data()
    data["bodies"][2]["modes"] = 2.5  # on main: silently 2 modes
    assert problems_of(data) == ["bodies[2].modes: expected an integer, got 2.5"]
    body = Body("arm", 0.0, type="flexible", modal_data=small_modal_data(), modes=1.5)
    scene = Scene("x", bodies=[body], joints=[Joint("clamp", "fixed", "arm")])
    assert scene.problems() == ["bodies[0].modes: expected an integer, got 1.5"]
    assert scene.replace(bodies=(dataclasses.replace(body, modes=True),)).problems() == [
        "bodies[0].modes: expected an integer, got True"]


def test_locked_on_a_spherical_joint_is_refused():
    data = arrays_data()
    data["joints"][0]["locked"] = 1  # on main: ignored
    assert problems_of(data) == ["joints[0].locked: expected true, false or (free joints) a list of 'x', 'y', "
                                 "'z', got 1"]
    data["joints"][0]["locked"] = True
    assert problems_of(data) == ["joints[0].locked: only revolute and prismatic joints lock as a whole; a free "
                                 "joint takes a list of translations to lock (this joint is 'spherical')"]


def test_inapplicable_keys_are_refused():
    data = arrays_data()
    data["joints"][0]["axis"] = [1.0, 0.0, 0.0]
    data["actuators"][0]["point"] = [1.0, 0.0, 0.0]
    data["controllers"][0]["A"] = [[0.0]]
    data["frame"] = {"kind": "inertial", "rate": 0.1}
    found = problems_of(data)
    assert "joints[0].axis: does not apply: a spherical joint has no axis (revolute and prismatic joints do) " \
           "(got (1.0, 0.0, 0.0); remove it)" in found
    assert any(p.startswith("actuators[0].point: does not apply: a wheel_torque actuator") for p in found)
    assert any(p.startswith("controllers[0].A: does not apply: only state_space controllers") for p in found)
    assert any(p.startswith("frame.rate: does not apply: only a spin frame has a rate") for p in found)
    assert len(found) == 4, found


def test_zero_frequency_modes_are_refused_with_the_reason():
    data = small_modal_data(3)
    free = dataclasses.replace(data, frequencies=np.array([0.0, *data.frequencies[1:]]))
    scene = Scene("x", bodies=[Body("hub", 10.0, [1, 1, 1]), Body("arm", 0.0, type="flexible", modal_data=free)],
                  joints=[Joint("j", "spherical", "hub"), Joint("m", "fixed", "arm", parent="hub")])
    found = scene.problems()
    assert len(found) == 1 and found[0].startswith("bodies[1].modal_data: mode(s) 0 have zero frequency (0 rad/s): "
                                                   "rigid-body modes"), found
    # Keeping only elastic modes is impossible by truncation (the lowest are kept): refused too.
    assert scene.replace(bodies=(scene.bodies[0], dataclasses.replace(scene.bodies[1], modes=2))).problems() == found


def test_effects_that_are_no_list(tmp_path):
    text = EXAMPLE.read_text(encoding="utf-8").replace(
        'effects = ["wheel_gyroscopics", "geometric_stiffness", "control"]', "effects = 5")
    with pytest.raises(ModelError) as err:  # on main: TypeError 'int' object is not iterable
        load_scene(write(tmp_path, text))
    assert "effects: expected a list of effect names" in str(err.value) and "got int 5" in str(err.value)
    assert "1 problem(s)" in str(err.value)  # no follow-up "needs the effect" problems


def test_a_byte_order_mark_is_named(tmp_path):
    path = write(tmp_path, "\ufeff" + EXAMPLE.read_text(encoding="utf-8"))
    with pytest.raises(ModelError, match=r"scene\.toml: the file starts with a UTF-8 byte-order mark \(BOM\)"):
        load_scene(path)
    path.write_bytes(b'name = "caf\xe9"\n')
    with pytest.raises(ModelError, match=r"scene\.toml: not UTF-8 text"):
        load_scene(path)


@pytest.mark.parametrize("change, expected", [
    (lambda d: d["bodies"][0].update(inertia=[1e-300] * 3),
     "bodies[0].inertia: (1e-300, 1e-300, 1e-300) [kg m^2] is outside the physically meaningful inertia range"),
    (lambda d: d["bodies"][0].update(mass=1e300),
     "bodies[0].mass: 1e+300 [kg] is outside the physically meaningful mass range 1e-09 to 1e+12 kg"),
    (lambda d: d.update(orbit={"radius": 1e-3}),
     "orbit.radius: 0.001 [m] gives the orbital rate sqrt(mu / r^3) = 6.31e+11 rad/s"),
    (lambda d: d["wheels"][0].update(speed=1e7),
     "wheels[0].speed: 10000000.0 [rad/s] is outside the physically meaningful rate range"),
    (lambda d: d["bodies"][1]["beam"].update(length=1e-9),
     "bodies[1].beam.length: 1e-09 [m] is outside the physically meaningful length range 1e-06 to 1e+10 m"),
])
def test_magnitudes_outside_the_physical_ranges_are_refused(change, expected):
    # On main: inertia 1e-300 overflowed, the 1 mm orbit failed in a linear solve, 1e300 kg was accepted.
    data = arrays_data()
    change(data)
    found = problems_of(data)
    assert len(found) == 1 and found[0].startswith(expected), found


def test_the_ranges_can_be_changed_by_the_scene():
    from linflex.scene import Limits

    data = arrays_data()
    data["bodies"][0]["mass"] = 1e13
    assert problems_of(data)[0].startswith("bodies[0].mass: 10000000000000.0 [kg] is outside")
    data["limits"] = {"mass": [1e-9, 1e15]}
    scene = Scene.from_dict(data)
    assert scene.limits == Limits(mass=(1e-9, 1e15)) and scene.problems() == []
    assert Scene.from_dict(scene.to_dict()) == scene  # the [limits] table round-trips
    data["limits"] = {"mass": [1e15, 1.0]}  # refused; the default range stays in force
    assert problems_of(data) == [
        "bodies[0].mass: 10000000000000.0 [kg] is outside the physically meaningful mass range 1e-09 to 1e+12 kg "
        "(in magnitude; change it with [limits] mass = [lo, hi])",
        "limits.mass: expected [low, high] with 0 <= low < high (finite), got (1000000000000000.0, 1.0)"]


def test_an_orbit_of_reasonable_size_still_compiles():
    scene = Scene("sat", effects=["gravity_gradient"], bodies=[Body("b", 10.0, [1.0, 2.0, 3.0])],
                  joints=[Joint("j", "spherical", "b")], orbit=Orbit(radius=7e6))
    assert compile_model(scene).n_states == 7


def test_controller_gains_on_a_state_space_controller_are_refused():
    scene = Scene.from_dict(arrays_data())
    ss = Controller("ss", "state_space", inputs=["roll"], outputs=["motor_x"], A=[[0.0]], B=[[1.0]], C=[[1.0]],
                    kp=3.0)
    found = scene.replace(controllers=(ss,)).problems()
    assert found == ["controllers[0].kp: does not apply: only pid controllers take gains and rate inputs "
                     "(got 3.0; remove it)"]


# Independent problems, each injected into the example's data by one mutation and reported under
# one path: any k of them together must give exactly k problems in one error.
def _set(*keys, value):
    def mutate(data):
        target = data
        for key in keys[:-1]:
            target = target[key]
        target[keys[-1]] = value
    return mutate


MUTATIONS = [
    (_set("bodies", 0, "mass", value=-1.0), "bodies[0].mass"),
    (_set("bodies", 0, "mas", value=3.0), "bodies[0].mas"),
    (_set("bodies", 1, "modes", value=2.5), "bodies[1].modes"),
    (_set("bodies", 2, "beam", "elements", value=4.7), "bodies[2].beam.elements"),
    (_set("joints", 0, "locked", value=1), "joints[0].locked"),
    (_set("joints", 1, "parent_point", value=[0.0, 1e20, 0.0]), "joints[1].parent_point"),
    (_set("joints", 2, "child_point", value="x"), "joints[2].child_point"),
    (_set("wheels", 0, "axis", value=[0.0, 0.0, 0.0]), "wheels[0].axis"),
    (_set("wheels", 1, "speed", value=1e9), "wheels[1].speed"),
    (_set("wheels", 2, "spin_inertia", value=-0.2), "wheels[2].spin_inertia"),
    (_set("sensors", 3, "axis", value=[0.0, 0.0, 0.0]), "sensors[3].axis"),
    (_set("sensors", 1, "colour", value="red"), "sensors[1].colour"),
    (_set("actuators", 0, "point", value=[1.0, 0.0, 0.0]), "actuators[0].point"),
    (_set("controllers", 0, "kp", value="high"), "controllers[0].kp"),
    (_set("nmae", value="typo"), "nmae"),
    (_set("orbit", value={"radius": 1e-3}), "orbit.radius"),
    (_set("environment", value={"density": -1.0}), "environment.density"),
    (_set("frame", value={"kind": "inertial", "rate": 0.1}), "frame.rate"),
    (_set("effects", 3, value="gravity_gradiant"), "effects[3]"),
]


def test_each_mutation_is_one_problem():
    for mutate, path in MUTATIONS:
        data = arrays_data()
        data["effects"].append("joint_springs")  # so that effects[3] exists to be replaced
        mutate(data)
        found = problems_of(data)
        assert len(found) == 1 and found[0].startswith(f"{path}:"), (path, found)


@settings(derandomize=True, max_examples=15, deadline=None)
@given(st.sets(st.integers(0, len(MUTATIONS) - 1), min_size=2, max_size=8))
def test_k_independent_problems_are_reported_together(picks):
    data = arrays_data()
    data["effects"].append("joint_springs")
    for k in picks:
        MUTATIONS[k][0](data)
    found = problems_of(copy.deepcopy(data))
    assert sorted(p.split(": ", 1)[0] for p in found) == sorted(MUTATIONS[k][1] for k in picks), found


@pytest.mark.parametrize("segments", [4.7, True, "4"])
def test_segment_counts_that_are_no_integers_are_refused(segments):
    from linflex import rigid_segment_beam

    # On main: int(4.7) = 4 segments, silently.
    with pytest.raises(ModelError, match=f"segments must be an integer, got {segments!r}"):
        rigid_segment_beam("arm", length=1.0, EI=1.0, mass_per_length=1.0, segments=segments)


def test_bodies_fixed_to_the_turning_body_count_as_one_rigid_assembly():
    # Two point masses on one line through the joint (a fixed to the joint, b fixed below it):
    # the spherical joint cannot turn them about that line. A third point off the line can.
    a = Body("a", 1.0, [0, 0, 0], com=[0, 0, -0.5])
    b = Body("b", 1.0, [0, 0, 0], com=[0, 0, -1])
    scene = Scene("z", bodies=[a, b], joints=[Joint("j", "spherical", "a"),
                                              Joint("f", "fixed", "b", parent="a", parent_point=[0, 0, -1])])
    found = scene.problems()
    assert len(found) == 1 and found[0].startswith("joints[0]: the spherical joint turns 'a', which has no "
                                                   "rotational inertia about the axis [0.0, 0.0, -1.0]"), found
    moved = scene.replace(joints=(scene.joints[0], Joint("f", "fixed", "b", parent="a", parent_point=[0.1, 0, -1])))
    assert moved.problems() == []
    # Below a joint that moves, the check stays silent (the model's own equations decide).
    hinged = scene.replace(joints=(scene.joints[0], Joint("f", "revolute", "b", parent="a", parent_point=[0, 0, -1],
                                                          axis=[0, 1, 0])))
    assert not any(p.startswith("joints[0]") for p in hinged.problems())


def test_a_modal_data_file_problem_names_the_body(tmp_path):
    path = write(tmp_path, "[1, 2]", "modes.json")
    scene = Scene("x", bodies=[Body("arm", 0.0, type="flexible", modal_data=str(path))],
                  joints=[Joint("clamp", "fixed", "arm")])
    assert scene.problems() == [f"bodies[0].modal_data: {path}: expected a JSON object with the fields format, "
                                "version, positions, ... at the top level, got a list"]


def test_a_point_given_with_a_node_is_refused():
    from linflex import LoopJoint, Wheel

    data = small_modal_data(2)
    data = dataclasses.replace(data, node_names=("tip",), node_positions=[[1.0, 0, 0]],
                               node_translations=data.translations[-1:], node_rotations=data.rotations[-1:])
    scene = Scene("x", effects=["wheel_gyroscopics"],
                  bodies=[Body("hub", 10.0, [1, 1, 1]), Body("arm", 0.0, type="flexible", modal_data=data)],
                  joints=[Joint("j", "spherical", "hub"), Joint("m", "fixed", "arm", parent="hub")],
                  wheels=[Wheel("w", "arm", 0.01, node="tip", point=[1.0, 0, 0])],
                  loop_joints=[LoopJoint("pin", "ball", "arm", "hub", node_a="tip", point_a=[1.0, 0, 0])])
    assert scene.problems() == [
        "loop_joints[0].point_a: does not apply: a loop joint at node_a sits there (got (1.0, 0, 0); remove it)",
        "wheels[0].point: does not apply: a wheel at a node sits there (got (1.0, 0, 0); remove it)"]
