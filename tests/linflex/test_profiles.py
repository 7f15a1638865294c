"""Time profiles of prescribed joint coordinates: spin-up, step, table."""

import casadi as ca
import numpy as np
import pytest

import linflex
from linflex import ModelError
from linflex.scene._values import profile_function


def rate_and_acceleration(profile, times):
    t = ca.SX.sym("t")
    q = profile(t)
    qd = ca.jacobian(q, t)
    f = ca.Function("f", [t], [q, qd, ca.jacobian(qd, t)])
    return np.array([[float(v) for v in f(ti)] for ti in times])


def test_spinup_rate_is_the_classic_profile():
    # Kane, Ryan and Banerjee (1987): w(t) = (W/T)(t - T/(2 pi) sin(2 pi t/T)) for t <= T, then W.
    W, T = 6.0, 15.0
    profile = profile_function({"profile": "spinup", "rate": W, "ramp_time": T, "offset": 0.3})
    times = np.array([0.0, 2.0, 7.5, 14.9, 15.0, 15.1, 30.0])
    q, qd, qdd = rate_and_acceleration(profile, times).T
    expected = np.where(times <= T, W / T * (times - T / (2 * np.pi) * np.sin(2 * np.pi * times / T)), W)
    np.testing.assert_allclose(qd, expected, rtol=1e-12, atol=1e-12)
    assert q[0] == pytest.approx(0.3)
    assert q[4] == pytest.approx(0.3 + W * T / 2, rel=1e-12)  # the integral of the ramp
    # Rate and acceleration continuous at T (the reason for this profile).
    np.testing.assert_allclose(qdd[[3, 5]], [qdd[3], 0.0], atol=2e-3)


def test_table_is_a_spline_through_the_points_held_outside():
    times, values = [0.0, 1.0, 2.0, 3.0, 4.0], [0.0, 0.5, 0.2, 0.9, 1.0]
    profile = profile_function({"profile": "table", "times": times, "values": values})
    q = rate_and_acceleration(profile, [0.0, 1.0, 2.0, 3.0, 4.0, -1.0, 9.0])[:, 0]
    np.testing.assert_allclose(q[:5], values, atol=1e-12)
    np.testing.assert_allclose(q[5:], [0.0, 1.0], atol=1e-12)


def test_step():
    profile = profile_function({"profile": "step", "time": 2.0, "before": 0.1, "after": -0.4})
    q = rate_and_acceleration(profile, [1.9, 2.0, 5.0])[:, 0]
    np.testing.assert_allclose(q, [0.1, -0.4, -0.4])


def spinning_table(prescribed):
    # The spinning table of the reference notes (section 3.3): a table on a prescribed revolute
    # joint about z carrying a bar on a spring joint about z at radius R.
    return linflex.Scene(
        name="table", effects=("joint_springs",),
        bodies=(linflex.Body(name="table", mass=10.0, inertia=(1.0, 1.0, 2.0)),
                linflex.Body(name="bar", mass=1.0, inertia=(0.01, 0.1, 0.1), com=(0.5, 0.0, 0.0))),
        joints=(linflex.Joint(name="spin", type="revolute", child="table", axis=(0.0, 0.0, 1.0),
                              prescribed=prescribed),
                linflex.Joint(name="hinge", type="revolute", parent="table", child="bar", axis=(0.0, 0.0, 1.0),
                              parent_point=(1.0, 0.0, 0.0), stiffness=50.0)))


def test_profiles_are_validated_with_paths():
    with pytest.raises(ModelError, match=r"joints\[0\].prescribed.ramp_time: a 'spinup' profile needs"):
        spinning_table({"profile": "spinup", "rate": 1.0}).validate()
    with pytest.raises(ModelError, match=r"joints\[0\].prescribed.times: must increase strictly"):
        spinning_table({"profile": "table", "times": [0, 2, 1, 3], "values": [0, 1, 2, 3]}).validate()
    with pytest.raises(ModelError, match="at least 4 points"):
        spinning_table({"profile": "table", "times": [0, 1], "values": [0, 1]}).validate()


def test_spinup_scene_round_trips_and_simulates(tmp_path):
    scene = spinning_table({"profile": "spinup", "rate": 2.0, "ramp_time": 4.0})
    path = tmp_path / "table.toml"
    path.write_text(scene.to_toml())
    back = linflex.load_scene(path)
    assert back.joints[0].prescribed == {"profile": "spinup", "rate": 2.0, "ramp_time": 4.0}
    model = linflex.compile_model(back)
    response = linflex.simulate(model, np.linspace(0.0, 6.0, 61))
    # During the spin-up the bar lags behind the table (the spring deflects against the
    # angular acceleration), and it oscillates about the rotating table once the rate is steady.
    hinge = response[model.states[0]]
    assert np.min(hinge[:40]) < -1e-4 and np.all(np.isfinite(hinge))
