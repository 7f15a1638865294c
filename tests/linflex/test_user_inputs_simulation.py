"""What a hurried user feeds ``simulate``, the linear time responses and scene input profiles:
each either gives the right number (against a closed form or an independent integration, with
the tolerance beside it) or a linflex error naming the argument."""

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import (
    Actuator,
    Body,
    ConvergenceError,
    InputProfile,
    Joint,
    LinearSystem,
    ModelError,
    NonlinearModel,
    Scene,
    ShapeError,
    Wheel,
    compile_model,
    forced_response,
    load_scene,
    simulate,
)

J = 2.0  # moment of inertia of the double integrator [kg m^2]


def _double_integrator() -> NonlinearModel:
    """``theta'' = T / J``: under a constant torque T from rest, ``theta = T t^2 / (2 J)``."""
    x, u = ca.SX.sym("x", 2), ca.SX.sym("u", 1)
    return NonlinearModel.from_casadi(ca.vertcat(x[1], u / J), x, u, x[0], states=["theta", "omega"],
                                      inputs=["torque"], outputs=["angle"])


def test_idas_from_rest_under_a_torque_matches_the_closed_form():
    # Reference: theta = T t^2 / (2 J) (double integrator from rest). IDAS used to start from
    # x'(t0) computed with a zero input (the unused first input column) and failed its error
    # test at t = 0 at these tolerances; now to 1e-9 [rad] (rtol 1e-10 of theta = 1.125 rad).
    timepts = np.linspace(0.0, 3.0, 31)
    r = simulate(_double_integrator(), timepts, [0.0, 0.0], [0.5], method="idas", rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(r.x[:, 0], 0.5 * timepts**2 / (2 * J), rtol=0, atol=1e-9)


@settings(max_examples=8, deadline=None)
@given(st.floats(0.1, 2.0), st.lists(st.floats(-2.0, 2.0), min_size=4, max_size=4))
def test_idas_matches_the_exact_zero_order_hold_response(first, torques):
    # Reference: forced_response (matrix exponentials, exact for held inputs) of the same double
    # integrator from rest, on a non-uniform grid; tolerance 1e-8 [rad, rad/s]: rtol 1e-10 over
    # five restarts of IDAS (with the old first input column IDAS failed at t = 0).
    timepts = np.array([0.0, 0.3, 0.5, 1.2, 2.0])
    U = np.array([first, *torques]).reshape(-1, 1)
    lin = LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0 / J]], [[1.0, 0.0]])
    exact = forced_response(lin, timepts, U)
    r = simulate(_double_integrator(), timepts, [0.0, 0.0], U, method="idas", rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(r.x, exact.x, rtol=0, atol=1e-8)


@pytest.mark.parametrize("rtol", ["1e-6", None, [1e-6, 1e-6], True, float("nan"), -1.0, 0.0])
def test_a_malformed_rtol_is_named(rtol):
    with pytest.raises(ModelError, match=r"rtol must be a (real|finite positive) number"):
        simulate(_double_integrator(), [0.0, 1.0], [0.0, 0.0], [0.5], method="scipy-RK45", rtol=rtol)


def test_non_numeric_timepts_and_inputs_are_named():
    model = _double_integrator()
    with pytest.raises(ShapeError, match="timepts must be a real vector of times"):
        simulate(model, ["a", "b"], [0.0, 0.0], [0.5])
    with pytest.raises(ShapeError, match="inputs must be a real array"):
        simulate(model, [0.0, 1.0], [0.0, 0.0], "torque")
    with pytest.raises(ShapeError, match="inputs must be a real array, got complex values"):
        simulate(model, [0.0, 1.0], [0.0, 0.0], np.array([0.5 + 0.1j]), method="scipy-RK45")
    with pytest.raises(ShapeError, match=r"inputs\['torque'\] must be a real"):
        simulate(model, [0.0, 1.0], [0.0, 0.0], {"torque": "half"})


def test_an_input_function_of_the_wrong_shape_in_a_mapping_is_named():
    model = _double_integrator()
    with pytest.raises(ShapeError, match=r"inputs\['torque'\]\(t\) has shape \(2,\)"):
        simulate(model, [0.0, 1.0], [0.0, 0.0], {"torque": lambda t: [0.5, 1.0]})
    with pytest.raises(ShapeError, match=r"inputs\['torque'\]\(t\)\[0\] is not finite"):
        simulate(model, [0.0, 1.0], [0.0, 0.0], {"torque": lambda t: None})
    # a one-element list is one number: theta = T t^2 / (2 J) to 1e-12 [rad] (scipy's DOP853 at
    # rtol 1e-12 on a polynomial of degree 2)
    r = simulate(model, [0.0, 1.0, 2.0], [0.0, 0.0], {"torque": lambda t: [0.5]}, method="scipy-DOP853",
                 rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(r["theta"], 0.5 * np.array([0.0, 1.0, 4.0]) / (2 * J), rtol=0, atol=1e-12)


def _rotor(inputs) -> Scene:
    return Scene("rotor", bodies=[Body("rod", 1.0, [2.5, 2.5, 2.5])],
                 joints=[Joint("hinge", "revolute", "rod", axis=[0, 0, 1])],
                 actuators=[Actuator("motor", "torque", body="rod", axis=[0, 0, 1])], inputs=inputs)


def test_a_transition_input_profile_can_be_given_and_simulated(tmp_path):
    # The scene vocabulary lists "transition" among the input profiles, but InputProfile had no
    # start and duration keys: no such profile could be written. Reference: the rate after the
    # cycloidal blend from 0 to 0.3 N m over [0.2, 1.2] s is (1/J) (0.3 (t - 1.2) + 0.3 * 1.0 / 2)
    # (the blend's mean is half its change) = 0.156 rad/s at t = 2 s for J = 2.5 kg m^2; to 1e-10
    # (DOP853 at rtol 1e-12).
    scene = _rotor([InputProfile("motor", "transition", start=0.2, duration=1.0, before=0.0, after=0.3)])
    scene.validate()
    r = simulate(compile_model(scene), np.linspace(0.0, 2.0, 11), method="scipy-DOP853", rtol=1e-12, atol=1e-14)
    assert r["hinge.rate"][-1] == pytest.approx((0.3 * 0.8 + 0.15) / 2.5, abs=1e-10)
    scene.save(tmp_path / "rotor.toml")
    assert load_scene(tmp_path / "rotor.toml") == scene
    bad = _rotor([InputProfile("motor", "transition", start=0.2, duration=-1.0, before=0.0, after=0.3)])
    assert bad.problems() == ["inputs[0].duration: must be positive [s]"]


def _spinner() -> NonlinearModel:
    """A body on a spherical joint spinning at 0.8 rad/s about its major axis z: its quaternion is
    ``(cos(w t / 2), 0, 0, sin(w t / 2))`` (rotation about a principal axis, Euler's equations)."""
    return compile_model(Scene("spinner", bodies=[Body("hub", 10.0, [1.0, 2.0, 3.0])],
                               joints=[Joint("attitude", "spherical", "hub", u0=[0.0, 0.0, 0.8])]))


def test_an_initial_quaternion_of_another_norm_gives_unit_quaternions_throughout():
    # Reference: the closed-form spin about z. Before, the quaternion kept the norm 2 it was given
    # up to the last sample, which alone was renormalized (a jump of a factor 2 in the output);
    # now every sample is the unit quaternion to 1e-8 (rtol 1e-10 over 2 rad of spin), and the
    # given norm's deviation is reported as the drift.
    model = _spinner()
    k = model.states.index("attitude.qw")
    x0 = np.array(model.x0, float)
    x0[k:k + 4] = [2.0, 0.0, 0.0, 0.0]
    timepts = np.linspace(0.0, 2.5, 6)
    r = simulate(model, timepts, x0, method="cvodes", rtol=1e-10, atol=1e-12)
    expected = np.column_stack([np.cos(0.4 * timepts), 0 * timepts, 0 * timepts, np.sin(0.4 * timepts)])
    np.testing.assert_allclose(r.x[:, k:k + 4], expected, rtol=0, atol=1e-8)
    assert r.quaternion_drift == pytest.approx(1.0, abs=1e-12)


def test_a_zero_initial_quaternion_is_named():
    # Before: a CasADi LU failure inside CVODES ("8-th row is exactly zero") as a ConvergenceError.
    model = _spinner()
    k = model.states.index("attitude.qw")
    x0 = np.array(model.x0, float)
    x0[k:k + 4] = 0.0
    with pytest.raises(ShapeError, match=rf"x0\[{k}:{k + 4}\] \(attitude.qw, .*\) is a zero quaternion"):
        simulate(model, [0.0, 1.0], x0, method="cvodes")


def test_a_single_entry_where_a_list_goes_is_one_aggregated_problem():
    # Before: TypeError: 'Body' object is not iterable, from the validation's own bookkeeping.
    body, joint = Body("a", 1.0, [1.0, 1.0, 1.0]), Joint("j", "free", "a")
    with pytest.raises(ModelError, match=r"bodies: expected a list of entries, got Body\(.*\(one entry: write "
                                         r"bodies=\[\.\.\.\]\)"):
        Scene("x", bodies=body, joints=[joint]).validate()
    problems = Scene("x", effects=["gravity"], bodies=[body], joints=joint).problems()
    assert len(problems) == 1 and problems[0].startswith("joints: expected a list of entries, got Joint(")


def test_an_entry_in_the_wrong_list_is_a_problem():
    # Before: a Body among the wheels, or an Actuator among the inputs, passed validation.
    scene = Scene("x", bodies=[Body("a", 1.0, [1.0, 1.0, 1.0])], joints=[Joint("j", "free", "a")],
                  actuators=[Actuator("m", "torque", body="a", axis=[1, 0, 0])],
                  wheels=[Body("w", 1.0, [1.0, 1.0, 1.0])], inputs=[Actuator("m", "torque", body="a")])
    assert scene.problems() == ["wheels[0]: Body 'w' in the list wheels, which takes Wheel entries",
                                "inputs[0]: Actuator 'm' in the list inputs, which takes InputProfile entries"]
    # a Wheel among the sensors crashed the validation (AttributeError: no attribute 'type')
    wheel = Wheel("w", body="a", axis=[1.0, 0.0, 0.0], spin_inertia=0.1)
    assert scene.replace(wheels=(), inputs=(), sensors=[wheel]).problems() == [
        "sensors[0]: Wheel 'w' in the list sensors, which takes Sensor entries"]


@pytest.mark.parametrize("chunks", [0, -1, 2.5, "3", True])
def test_a_malformed_chunks_is_named(chunks):
    # Before: 0 and -1 silently became 1, 2.5 became 2, "3" raised a TypeError of a comparison.
    with pytest.raises(ShapeError, match="chunks must be a positive integer"):
        simulate(_double_integrator(), [0.0, 1.0, 2.0], [0.0, 0.0], [0.5], method="scipy-RK45", chunks=chunks)


def test_one_signal_name_alone_is_that_signal(tmp_path):
    # Before: to_csv(path, "theta") wrote the columns 't', 'h', ... ("unknown signal 't'"), as
    # did plot("theta"). Reference: theta = T t^2 / (2 J) = 0.5 * 4 / 4 = 0.5 rad at t = 2 s, to
    # 1e-12 (DOP853 at rtol 1e-12 on a polynomial).
    r = simulate(_double_integrator(), [0.0, 1.0, 2.0], [0.0, 0.0], [0.5], method="scipy-DOP853", rtol=1e-12,
                 atol=1e-14)
    r.to_csv(tmp_path / "theta.csv", "theta")
    lines = (tmp_path / "theta.csv").read_text().splitlines()
    assert lines[0] == "time,theta"
    assert float(lines[-1].split(",")[1]) == pytest.approx(0.5, abs=1e-12)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    handle = r.plot("theta")
    assert [line.get_label() for line in handle.lines] == ["theta"]
    plt.close(handle.figure)


def test_an_input_profile_names_the_unit_of_each_key():
    # Before: every key was "[input units]", the step's time and the sine's frequency too.
    scene = _rotor([InputProfile("motor", "step", time="1 s", before=0.0, after=1.0),
                    InputProfile("motor", "sine", amplitude=1.0, frequency="2 Hz")])
    assert scene.problems() == ["inputs[0].time: expected a number [s], got '1 s'",
                                "inputs[1].frequency: expected a number [rad/s], got '2 Hz'"]


@pytest.mark.parametrize("method", ["cvodes", "cvodes-adams", "idas"])
def test_a_diverging_model_fails_at_once_and_says_why(method):
    # x' = 10 x from 1 overflows at t = 70.7 s. Before: SUNDIALS retried the Inf derivatives
    # with smaller steps up to a million steps (50 s and 4e5 lines of CasADi warnings) and
    # ended with CV_TOO_MUCH_WORK; now the first non-finite derivative ends the run.
    x = ca.SX.sym("x", 1)
    unstable = NonlinearModel.from_casadi(10 * x, x)
    with pytest.raises(ConvergenceError, match="the state derivative became NaN or Inf"):
        simulate(unstable, np.linspace(0.0, 100.0, 11), [1.0], method=method)
