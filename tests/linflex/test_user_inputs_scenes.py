"""A hurried user's edits of the example scenes: each compiles with the right physics or is refused
with a message that names the entry and what to change."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from linflex import (
    Body,
    Controller,
    Joint,
    ModelError,
    Scene,
    compile_model,
    controller_chain,
    controller_system,
    load_scene,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


# -- sampled controllers: a filter frequency at or above the Nyquist frequency ------------------


def test_notch_above_nyquist_names_the_entry_and_sample_time():
    # 40 rad/s is above pi / 0.1 s = 31.4 rad/s: Tustin cannot be prewarped there; the message
    # names the filter's frequency key and the sample_time (as the scene check does), not prewarp.
    pd = Controller("pd", "pid", inputs="roll", rate_inputs="p", outputs="tx", kp=25.0, kd=70.0,
                    sample_time=0.1, filters=[{"kind": "notch", "frequency": 40.0, "depth": 20.0, "width": 4.0}])
    with pytest.raises(ModelError) as info:
        controller_chain(pd)
    message = str(info.value)
    assert message.startswith("controllers['pd'].filters[0].frequency: ")
    assert "sample_time = 0.1 s" in message and "31.4159 rad/s" in message
    assert "prewarp" not in message


def test_notch_below_nyquist_still_prewarped_at_its_frequency():
    # Reference: a prewarped Tustin notch has its zero exactly at e^{i w0 dt} (tolerance: round-off).
    pd = Controller("pd", "pid", inputs="roll", rate_inputs="p", outputs="tx", kp=25.0, kd=70.0,
                    sample_time=0.1, filters=[{"kind": "notch", "frequency": 30.0, "depth": 20.0, "width": 4.0}])
    K = controller_chain(pd)
    z = np.exp(1j * 30.0 * 0.1)
    gain = K.C @ np.linalg.solve(z * np.eye(K.n_states) - K.A, K.B) + K.D
    dc = K.C @ np.linalg.solve(np.eye(K.n_states) - K.A, K.B) + K.D
    assert abs(gain[0, 0]) / abs(dc[0, 0]) == pytest.approx(10 ** (-20 / 20), rel=1e-9)


# -- wheels --------------------------------------------------------------------------------------


def test_torque_wheel_without_spin_inertia_is_refused_with_its_path(tmp_path):
    # gyrostat.toml with wheel_x's spin_inertia set to 0: its speed state would have no inertia
    # (a zero row of the mass matrix, LAPACK's "row is exactly zero" at every evaluation).
    path = tmp_path / "gyrostat.toml"
    path.write_text((EXAMPLES / "gyrostat.toml").read_text().replace("spin_inertia = 1.0", "spin_inertia = 0.0", 1))
    with pytest.raises(ModelError) as info:
        compile_model(path)
    assert "wheels[0].spin_inertia: a torque-driven wheel needs a positive spin inertia" in str(info.value)


# -- joint springs exposed as parameters ----------------------------------------------------------


def test_joint_stiffness_parameter_from_zero_nominal_acts():
    # A hinge without a spring in the scene (stiffness 0), its stiffness exposed to be swept:
    # with k = 9 N m/rad the rod's acceleration at 0.1 rad is -k q / I = -9 rad/s^2 (I = 0.1 kg m^2
    # about the hinge; exact up to round-off).
    s = Scene("rod", effects=["joint_springs"], bodies=[Body("rod", 1.0, [0.1, 0.1, 0.01])],
              joints=[Joint("hinge", "revolute", "rod", axis=[0, 1, 0])])
    model = compile_model(s, params=["hinge.stiffness", "hinge.damping"])
    xdot = np.asarray(model.f([0.1, 0.0], [], [9.0, 0.0], 0.0)).ravel()
    assert xdot[1] == pytest.approx(-9.0, rel=1e-12)
    xdot = np.asarray(model.f([0.0, 2.0], [], [0.0, 0.5], 0.0)).ravel()  # damping: -c q' / I = -10 rad/s^2
    assert xdot[1] == pytest.approx(-10.0, rel=1e-12)


def test_joint_stiffness_parameter_without_joint_springs_is_refused():
    # a stiffness of 0 in the scene (valid without the effect), exposed to be set later
    s = Scene("rod", effects=[], bodies=[Body("rod", 1.0, [0.1, 0.1, 0.01])],
              joints=[Joint("hinge", "revolute", "rod", axis=[0, 1, 0])])
    with pytest.raises(ModelError, match=r"params\[0\]: 'hinge.stiffness' acts through the 'joint_springs' effect"):
        compile_model(s, params=["hinge.stiffness"])


# -- physics cross-checks of example scenes (no fix needed; guards) --------------------------------


def test_gravity_gradient_pitch_libration_matches_closed_form():
    # satellite_lvlh.toml about nadir: pitch n sqrt(3 (Ix - Iz) / Iy) (Hughes, Spacecraft Attitude
    # Dynamics, 9.3); tolerance 1e-9 relative (autodiff Jacobian, eigenvalue round-off).
    from linflex.linearize import linearize

    scene = load_scene(EXAMPLES / "satellite_lvlh.toml")
    scene = dataclasses.replace(scene, joints=[dataclasses.replace(scene.joints[0], q0=None)])
    lin = linearize(compile_model(scene))
    n = scene.orbit.mean_motion
    pitch = n * np.sqrt(3 * (900.0 - 400.0) / 1100.0)
    frequencies = np.abs(np.linalg.eigvals(lin.sys.A).imag)
    assert np.min(np.abs(frequencies - pitch)) < 1e-9 * pitch


def test_state_space_controller_shape_names_the_entry_and_matrix():
    # A given as one row of two: the message names controllers['c'].A with the expected shape
    # (as the scene validation words it), not a bare "A has shape" from LinearSystem.
    c = Controller("c", "state_space", inputs=["a"], outputs=["t"], A=[[0.0, 1.0]], B=[[1.0]], C=[[1.0]])
    with pytest.raises(ModelError, match=r"^controllers\['c'\]\.A: has shape \(1, 2\) but \(1, 1\) was expected"):
        controller_system(c)


# -- gravity on flexible bodies ---------------------------------------------------------------------


def _beam(direction):
    from linflex import Beam, beam_modal_data

    return beam_modal_data(Beam((0, 0, 0), tuple(8.0 * np.asarray(direction)), EA=1e7, EIy=4000.0, EIz=4000.0,
                                GJ=3000.0, mass_per_length=5.0, torsional_inertia_per_length=0.2, elements=8), 4)


@pytest.mark.parametrize("formulation", ["dense", "order-n"])
def test_uniform_gravity_acts_on_flexible_material(formulation):
    # thermal_snap.toml's hub and 24 kg array, free-floating under the gravity effect: uniform
    # gravity accelerates everything at g (free fall: no rotation, no deformation). Before, the
    # array's material felt no gravity: vz = -9.748 m/s^2. Tolerance: round-off.
    scene = load_scene(EXAMPLES / "thermal_snap.toml")
    scene = dataclasses.replace(scene, effects=("gravity",), thermal=(),
                                environment=dataclasses.replace(scene.environment, gravity=[0.0, 0.0, -9.81]),
                                joints=[dataclasses.replace(scene.joints[0], type="free"), scene.joints[1]])
    model = compile_model(scene, formulation=formulation)
    xdot = np.asarray(model.f(model.x0, np.zeros(model.n_inputs), 0.0)).ravel()
    k = model.states.index("attitude.vz")
    assert xdot[k] == pytest.approx(-9.81, rel=1e-12)
    assert np.max(np.abs(np.delete(xdot, k))) < 1e-12


@pytest.mark.parametrize("effects", [["gravity_gradient"], ["gravity_gradient", "central_gravity"]])
def test_gravity_gradient_pitch_of_a_flexible_spacecraft(effects):
    # A hub with two 8 m arrays along the nadir (z) axis in LVLH: the pitch libration is
    # n sqrt(3 (Ix - Iz) / Iy) with the composite inertia of the hub and the arrays' mass points
    # (Hughes, Spacecraft Attitude Dynamics, 9.3). Before, the arrays felt no gradient: the hub
    # alone (Ix < Iz) is unstable in pitch. Tolerance 1e-6: the bending modes (~1 rad/s) shift
    # the 1.6e-3 rad/s libration by ~(n / w)^2.
    from linflex import Frame, Orbit
    from linflex.linearize import linearize

    up, down = _beam([0, 0, -1.0]), _beam([0, 0, 1.0])
    scene = Scene("ggflex", effects=effects, frame=Frame("lvlh"), orbit=Orbit(altitude=700e3),
                  bodies=[Body("hub", 1000.0, [800.0, 600.0, 900.0]),
                          Body("up", 0.0, [0, 0, 0], type="flexible", modal_data=up),
                          Body("down", 0.0, [0, 0, 0], type="flexible", modal_data=down)],
                  joints=[Joint("att", "spherical", "hub"),
                          Joint("m1", "fixed", "up", parent="hub", parent_point=[0, 0, -1.0]),
                          Joint("m2", "fixed", "down", parent="hub", parent_point=[0, 0, 1.0])])
    inertia = np.diag([800.0, 600.0, 900.0])
    for data, offset in ((up, [0, 0, -1.0]), (down, [0, 0, 1.0])):
        for m, x, J in zip(data.masses, data.positions + offset, data.inertias):
            inertia += m * (x @ x * np.eye(3) - np.outer(x, x)) + J
    Ix, Iy, Iz = np.diag(inertia)
    pitch = scene.orbit.mean_motion * np.sqrt(3 * (Ix - Iz) / Iy)
    frequencies = np.abs(np.linalg.eigvals(linearize(compile_model(scene)).sys.A).imag)
    assert np.min(np.abs(frequencies - pitch)) < 1e-6 * pitch
