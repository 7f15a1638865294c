"""The momentum form of a compiled flexible model (``linflex/simulation/_momentum.py``) against
independent computations: the kinetic energy's gradient for the momenta, central differences of
``M(q) u`` along the motion for their rates, central differences of the rates for the Jacobian,
and DOP853 on the model's own state for a run."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import linflex
from linflex import simulate
from linflex.simulation._momentum import momentum_form

ROOT = Path(__file__).resolve().parents[2]


def arrays(n_modes: int, effects=None):
    """The hub with two undamped arrays of ``n_modes`` modes (examples/spacecraft_arrays.toml)."""
    scene = linflex.vary_scene(linflex.load_scene(ROOT / "examples" / "spacecraft_arrays.toml"),
                               {f"bodies.{b}.modes": n_modes for b in ("array_left", "array_right")})
    bodies = tuple(dataclasses.replace(b, beam={**b.beam, "damping": 0.0}) if b.beam else b for b in scene.bodies)
    return linflex.compile_model(dataclasses.replace(scene, bodies=bodies,
                                                     effects=scene.effects if effects is None else effects))


@pytest.fixture(scope="module")
def arrays4():
    return arrays(4)


@pytest.fixture(scope="module")
def arrays4_without_geometric_stiffness():
    # Without the motion-induced geometric stiffness the mass matrix is symmetric: the momenta
    # are the kinetic energy's gradient.
    return arrays(4, effects=("wheel_gyroscopics", "control"))


def deflected(model, rng, size=1.0):
    """A state near the model's x0: modal coordinates and every speed drawn at ``size`` (the
    attitude quaternion kept)."""
    x = np.array(model.x0, float)
    for k, name in enumerate(model.states):
        if ".eta" in name or name.endswith((".wx", ".wy", ".wz", ".speed")):
            x[k] += size * rng.standard_normal() * (0.1 if name.endswith((".wx", ".wy", ".wz")) else 1.0)
    return x


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31))
def test_momenta_are_the_gradient_of_the_kinetic_energy(arrays4_without_geometric_stiffness, seed):
    # Independent computation: dT/du by central differences of the model's energy monitor (the
    # potential depends on the coordinates only), step 1e-5: truncation ~1e-10 of the momenta.
    model = arrays4_without_geometric_stiffness
    form = momentum_form(model)
    x, pv = deflected(model, np.random.default_rng(seed)), model.param_values
    z = form.to_z(x, pv, 0.0)
    grad = np.zeros(model.n_states)
    for k in range(form.speeds.start, form.speeds.stop):
        e = np.zeros(model.n_states)
        e[k] = 1e-5
        grad[k] = (float(model.energy(x + e, 0.0)) - float(model.energy(x - e, 0.0))) / 2e-5
    p = z[form.speeds]
    np.testing.assert_allclose(p, grad[form.speeds], rtol=0, atol=1e-7 * np.max(np.abs(p)))


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31))
def test_momentum_rates_are_the_rate_of_m_times_u(arrays4, seed):
    # Independent computation: p' = M(q) u' + d/dt (M(q) u) at fixed u, with u' from the model's
    # own state derivative, M(q) u' from the form's momenta of the speeds u', and the second term
    # by central differences of M(q + e q') u (the coordinates moved along their rates). The
    # coordinates' rates are the model's.
    model = arrays4
    form = momentum_form(model)
    rng = np.random.default_rng(seed)
    x, pv = deflected(model, rng), model.param_values
    u_in = rng.standard_normal(model.n_inputs)
    xdot = np.asarray(model.f(x, u_in, 0.0), float).ravel()
    zdot = np.asarray(form.f(form.to_z(x, pv, 0.0), u_in, pv, 0.0), float).ravel()
    s = form.speeds
    np.testing.assert_allclose(zdot[:s.start], xdot[:s.start], rtol=1e-12, atol=1e-14)
    with_accelerations = x.copy()
    with_accelerations[s] = xdot[s]
    M_udot = form.to_z(with_accelerations, pv, 0.0)[s]
    e = 1e-5
    ahead, behind = x.copy(), x.copy()
    ahead[:s.start] += e * xdot[:s.start]
    behind[:s.start] -= e * xdot[:s.start]
    Mdot_u = (form.to_z(ahead, pv, 0.0)[s] - form.to_z(behind, pv, 0.0)[s]) / (2 * e)
    expected = M_udot + Mdot_u
    np.testing.assert_allclose(zdot[s], expected, rtol=0, atol=1e-7 * np.max(np.abs(expected)))


def test_states_come_back_from_the_momenta_and_the_jacobian_is_the_rates_derivative(arrays4):
    # Round trip x -> z -> x to round-off; dz'/dz against central differences of z' (step 1e-6
    # of each coordinate's scale: truncation and round-off ~1e-8 relative).
    model = arrays4
    form = momentum_form(model)
    rng = np.random.default_rng(4)
    pv = model.param_values
    X = np.array([deflected(model, rng) for _ in range(3)])
    Z = np.array([form.to_z(x, pv, 0.0) for x in X])
    np.testing.assert_allclose(form.to_x(Z, pv, np.zeros(3)), X, rtol=0, atol=1e-12 * np.max(np.abs(X)))
    z, u_in = Z[0], rng.standard_normal(model.n_inputs)
    J = np.asarray(form.jacobian(z, u_in, pv, 0.0), float)
    fd = np.zeros_like(J)
    for k in range(z.size):
        h = 1e-6 * max(1.0, abs(z[k]))
        e = np.zeros(z.size)
        e[k] = h
        fd[:, k] = (np.asarray(form.f(z + e, u_in, pv, 0.0)).ravel() - np.asarray(form.f(z - e, u_in, pv, 0.0)).ravel()) / (2 * h)
    np.testing.assert_allclose(J, fd, rtol=0, atol=1e-6 * np.max(np.abs(J)))


def test_models_without_a_varying_mass_block_keep_their_own_state():
    # No Kane equations (a NonlinearModel), a rigid gyrostat (no constant modal block), and a
    # beam on a prescribed spin (its mass matrix is the constant modal mass): no momentum form.
    import casadi as ca

    x, u, t = ca.SX.sym("x", 2), ca.SX.sym("u", 1), ca.SX.sym("t")
    plain = linflex.NonlinearModel(ca.Function("f", [x, u, t], [ca.vertcat(x[1], -x[0] + u)]), states=["q", "v"],
                                   inputs=["u"])
    assert momentum_form(plain) is None
    assert momentum_form(linflex.compile_model(linflex.load_scene(ROOT / "examples" / "gyrostat.toml"))) is None
    data = linflex.beam_modal_data(linflex.Beam((0, 0, 0), (10.0, 0, 0), EA=2.8e7, EIy=1.4e5, EIz=1.4e4, GJ=1e4,
                                                mass_per_length=1.2, elements=12), 10)
    spin = linflex.Joint(name="spin", type="revolute", child="hub", axis=(0.0, 0.0, 1.0),
                         prescribed={"profile": "spinup", "rate": 6.0, "ramp_time": 4.0})
    scene = linflex.Scene(name="spinup", bodies=(linflex.Body(name="hub", mass=1.0, inertia=(1.0, 1.0, 1.0)),
                                                 linflex.Body(name="beam", mass=0.0, type="flexible", modal_data=data)),
                          joints=(spin, linflex.Joint(name="clamp", type="fixed", parent="hub", child="beam")))
    assert momentum_form(linflex.compile_model(scene)) is None


def test_exponential_run_in_momentum_form_against_dop853(arrays4):
    # The exponential integrator steps in the momentum form here; the states it returns are the
    # model's (speeds, not momenta): every state within 100 rtol of its peak against DOP853 at
    # rtol 1e-12 on the model's own state, through a 2 s yaw-wheel pulse (an input jump).
    assert momentum_form(arrays4) is not None
    t = np.linspace(0.0, 6.0, 61)
    inputs = {"motor_z": 50.0 * (t < 2.0)}
    r = simulate(arrays4, t, inputs=inputs, method="exponential", rtol=1e-8, atol=1e-10)
    ref = simulate(arrays4, t, inputs=inputs, method="scipy-DOP853", rtol=1e-12, atol=1e-14).x
    err, peak = np.max(np.abs(r.x - ref), axis=0), np.max(np.abs(ref), axis=0)
    assert np.all(err <= 100 * 1e-8 * peak + 1e-9)


def test_momentum_form_is_more_accurate_than_the_speeds_at_the_same_steps():
    # Why the form exists: the hub with two 12-mode arrays, the 2 s yaw-wheel pulse, 4 s at one
    # step per 0.1 s sample with the Jacobian of the start frozen (tolerances too loose to
    # reject a step), against DOP853 at rtol 1e-11. Stepping in the speeds leaves the stiff
    # modes' forces, passed through the deflection-dependent M(q)^-1, in the explicit remainder:
    # measured 1.5e-8 largest error of the modal coordinates against 1.7e-9 in the momentum form
    # (the margin below: 4x).
    from linflex.simulation._exponential import exponential_stepper
    from linflex.simulation._steppers import IntegratorCounts, buffered_function, jacobian_function

    model = arrays(12)
    t = np.linspace(0.0, 4.0, 41)
    inputs = {"motor_z": 50.0 * (t < 2.0)}
    ref = simulate(model, t, inputs=inputs, method="scipy-DOP853", rtol=1e-11, atol=1e-13).x
    form, pv = momentum_form(model), model.param_values
    f, _ = model.casadi_functions()
    jx = jacobian_function(model)
    U = np.zeros((t.size, model.n_inputs))
    U[:, model.input_index("motor_z")] = inputs["motor_z"]
    speeds = exponential_stepper(buffered_function(f, pv), lambda x, u, tt: jx(x, u, pv, tt).full(), 1e6, 1e6,
                                 IntegratorCounts())
    momenta = exponential_stepper(buffered_function(form.f, pv), lambda z, u, tt: form.jacobian(z, u, pv, tt).full(),
                                  1e6, 1e6, IntegratorCounts())
    runs = {"speeds": [model.x0], "momenta": [model.x0]}
    for lo, hi in ((0, 20), (20, t.size - 1)):  # the input jumps at 2 s
        runs["speeds"].append(speeds(t[lo:hi + 1], runs["speeds"][-1][-1] if lo else model.x0, U[lo:hi + 1]))
        z0 = form.to_z(runs["momenta"][-1][-1] if lo else model.x0, pv, t[lo])
        runs["momenta"].append(form.to_x(momenta(t[lo:hi + 1], z0, U[lo:hi + 1]), pv, t[lo + 1:hi + 1]))
    modal = [k for k, name in enumerate(model.states) if ".eta" in name and not name.endswith("_rate")]
    errors = {key: float(np.max(np.abs(np.vstack([np.atleast_2d(p) for p in parts])[:, modal] - ref[:, modal])))
              for key, parts in runs.items()}
    assert errors["momenta"] < errors["speeds"] / 4
    assert errors["momenta"] < 5e-9
