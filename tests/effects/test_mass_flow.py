"""Propellant tanks feeding thrusters (effect ``mass_flow``): the rocket equation and the momentum
the exhaust carries away."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import cumulative_simpson

from linflex import Actuator, Body, Joint, ModelError, Scene, Tank, compile_model, simulate

C = 2000.0  # exhaust velocity [m/s]


def _scene(jets, *, tank_point=(0.0, 0.0, 0.0), u0=None, exhaust_velocity=C, **tank):
    return Scene("rocket", effects=["thrusters", "mass_flow"],
                 bodies=[Body("sat", 100.0, [30.0, 40.0, 50.0])],
                 joints=[Joint("float", "free", "sat", u0=u0)],
                 actuators=[Actuator(name, "thruster", "sat", point=point, axis=axis) for name, point, axis in jets],
                 tanks=[Tank("tank", "sat", mass=40.0, exhaust_velocity=exhaust_velocity, point=tank_point, **tank)])


def _columns(r, prefix):
    return r.y[:, [r.outputs.index(f"{prefix}.{c}") for c in "xyz"]]


@settings(derandomize=True, max_examples=5, deadline=None)
@given(F=st.floats(10.0, 120.0), reverse=st.booleans(), c=st.floats(500.0, 4000.0))
def test_rocket_equation_and_linear_momentum_bookkeeping(F, reverse, c):
    # Tsiolkovsky: a vehicle of mass m0 expelling propellant at the exhaust velocity c gains
    # delta-v = c ln(m0 / m1); thrust through the mass centre, constant F [N]: m(t) = m0 - |F| t / c.
    F = -F if reverse else F
    model = compile_model(_scene([("jet", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0))], exhaust_velocity=c))
    t = np.linspace(0.0, 30.0 * c / abs(F), 401)  # 30 kg of the 40 kg spent
    r = simulate(model, t, inputs={"jet": F}, rtol=1e-11, atol=1e-12)
    m = 140.0 - abs(F) * t / c
    np.testing.assert_allclose(r.y[:, r.outputs.index("tank.propellant")], m - 100.0, rtol=1e-12)
    v = r.x[:, r.states.index("float.vx")]
    np.testing.assert_allclose(v, np.sign(F) * c * np.log(140.0 / m), rtol=1e-9, atol=1e-9 * c)
    assert abs(v[-1]) > 0.2 * c
    # Momentum of the vehicle plus what the exhaust carried away stays zero.
    exhaust = cumulative_simpson(_columns(r, "tank.exhaust_momentum_rate"), x=t, axis=0, initial=0.0)
    np.testing.assert_allclose(m * v + exhaust[:, 0], 0.0, atol=1e-8 * abs(F) * t[-1])


def test_spinning_vehicle_and_exhaust_keep_their_angular_momentum():
    # A spinning vehicle fires a thruster couple with the tank off its mass centre: the vehicle's
    # angular momentum changes by the couple and by the jet damping; with the exhaust's it stays
    # constant (about the scene origin, inertial axes).
    thrusters = [("a", (0.0, 1.0, 0.2), (1.0, 0.0, 0.0)), ("b", (0.0, -1.0, 0.2), (-1.0, 0.0, 0.0))]
    model = compile_model(_scene(thrusters, tank_point=(0.3, 0.0, 0.4), u0=[0.0, 0.0, 0.0, 0.1, 0.05, 0.5]))
    t = np.linspace(0.0, 10.0, 2001)
    r = simulate(model, t, inputs={"a": 20.0, "b": 20.0}, rtol=1e-11, atol=1e-12)
    exhaust = cumulative_simpson(_columns(r, "tank.exhaust_angular_momentum_rate"), x=t, axis=0, initial=0.0)
    total = r.momentum + exhaust
    H0 = r.momentum[0]
    change = np.max(np.linalg.norm(r.momentum - H0, axis=1))
    assert change > 300.0  # the couple changed the vehicle's
    np.testing.assert_allclose(total, np.broadcast_to(H0, total.shape), rtol=0, atol=1e-7 * change)


def test_tank_validation():
    good = [("jet", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0))]
    with pytest.raises(ModelError, match=r"tanks\[0\].thrusters\[0\]: unknown thruster 'jett'"):
        _scene(good, thrusters=["jett"]).validate()
    with pytest.raises(ModelError, match=r"tanks\[0\]: a propellant tank needs the 'thrusters' effect"):
        _scene(good).replace(effects=["mass_flow"], actuators=()).validate()
    with pytest.raises(ModelError, match=r"tanks\[0\].exhaust_velocity: must be positive"):
        _scene(good).replace(tanks=[Tank("tank", "sat", mass=4.0, exhaust_velocity=0.0)]).validate()
