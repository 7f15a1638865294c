"""Thermal loads on flexible bodies (effect ``thermal``): static bending and the modal step response."""

from __future__ import annotations

import numpy as np
import pytest

from linflex import Body, Joint, ModelError, Scene, ThermalLoad, compile_model, simulate

EI, L = 50.0, 2.0
BEAM = {"length": L, "EI": EI, "EA": 1e6, "GJ": 40.0, "mass_per_length": 0.5, "elements": 8}


def _scene(modes, *, damping=0.0, **load):
    beam = dict(BEAM, damping=damping)
    return Scene("thermal", effects=["thermal"], bodies=[Body("arm", 0.0, type="flexible", beam=beam, modes=modes)],
                 joints=[Joint("root", "fixed", "arm")], thermal=[ThermalLoad("heat", "arm", **load)])


def _static_modes(model, t=0.0):
    """The modal coordinates where the accelerations vanish (the equations are linear in them)."""
    n = len(model.states) // 2

    def accel(x):
        return np.asarray(model.f(x, np.zeros(0), t), dtype=float).ravel()[n:]

    a = accel(np.zeros(2 * n))
    B = np.column_stack([accel(np.eye(2 * n)[k]) - a for k in range(n)])
    return -np.linalg.solve(B, a)


@pytest.mark.parametrize("M", [0.3, -1.7])
def test_static_tip_deflection_is_the_cantilever_closed_form(M):
    # A uniform thermal moment M bends a cantilever to the tip deflection M L^2 / (2 EI) and the
    # tip rotation M L / EI (Euler-Bernoulli; the cubic beam elements are exact for end moments,
    # so with all 40 modes of the 8-element model the modal solution is exact to round-off).
    scene = _scene(40, moment=(0.0, M, 0.0), node="0.end")
    eta = _static_modes(compile_model(scene))
    _, Phi, Psi = scene.bodies[0].resolved_modal_data().node("0.end")
    # A moment about +y turns a beam along +x towards -z.
    np.testing.assert_allclose((Phi @ eta)[2], -M * L**2 / (2 * EI), rtol=1e-9)
    np.testing.assert_allclose((Psi @ eta)[1], M * L / EI, rtol=1e-9)
    np.testing.assert_allclose((Phi @ eta)[[0, 1]], 0.0, atol=1e-12 * abs(M))


def test_modal_load_equals_the_moment_pair():
    # modal_load = Psi_end^T M gives the same generalized forces as the moment at the node.
    M = np.array([0.0, 0.4, -0.2])
    data = _scene(6, moment=tuple(M), node="0.end").bodies[0].resolved_modal_data()
    _, _, Psi = data.node("0.end")
    by_moment = _static_modes(compile_model(_scene(6, moment=tuple(M), node="0.end")))
    by_modes = _static_modes(compile_model(_scene(6, modal_load=tuple(Psi.T @ M))))
    np.testing.assert_allclose(by_moment, by_modes, rtol=1e-12, atol=1e-15)
    # A moment between two nodes at the same place loads nothing.
    nothing = _static_modes(compile_model(_scene(6, moment=tuple(M), node="0.end", opposite_node="0.end")))
    np.testing.assert_allclose(nothing, 0.0, atol=1e-15)


@pytest.mark.parametrize("zeta", [0.0, 0.02])
def test_thermal_snap_step_response_of_one_mode(zeta):
    # One mode under a step of the modal force g = Psi_1 . M at ts: the closed-form step response
    # eta(tau) = g/w^2 [1 - exp(-zeta w tau) (cos wd tau + zeta/sqrt(1 - zeta^2) sin wd tau)].
    M, ts = 0.5, 0.3
    scene = _scene(1, damping=zeta, moment=(0.0, 0.0, M), node="0.end",
                   scale={"profile": "step", "time": ts, "before": 0.0, "after": 1.0})
    data = scene.bodies[0].resolved_modal_data()
    w = float(data.frequencies[0])
    g = float(data.node("0.end")[2][:, 0] @ [0.0, 0.0, M])
    model = compile_model(scene)
    t = np.linspace(0.0, 3.0, 121)
    r = simulate(model, t, rtol=1e-11, atol=1e-13 * abs(g) / w**2)  # the modal coordinate is ~1e-10: absolute tolerance at its scale
    tau = np.clip(t - ts, 0.0, None)
    wd = w * np.sqrt(1 - zeta**2)
    exact = g / w**2 * (1 - np.exp(-zeta * w * tau) * (np.cos(wd * tau) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * tau)))
    np.testing.assert_allclose(r.x[:, 0], exact, rtol=0, atol=1e-7 * abs(g) / w**2)
    assert np.max(np.abs(r.x[:, 0])) > 1.5 * abs(g) / w**2  # the snap overshoots the static bend


def test_thermal_validation():
    with pytest.raises(ModelError, match=r"thermal\[0\].node: unknown node 'tip'"):
        _scene(2, moment=(0.0, 1.0, 0.0), node="tip").validate()
    with pytest.raises(ModelError, match=r"thermal\[0\]: give either moment"):
        _scene(2).validate()
    with pytest.raises(ModelError, match=r"thermal\[0\].modal_load: expected 2 values"):
        _scene(2, modal_load=[1.0, 2.0, 3.0]).validate()
    with pytest.raises(ModelError, match=r"thermal\[0\].scale: unknown profile 'stepp'"):
        _scene(2, moment=(0.0, 1.0, 0.0), node="0.end", scale={"profile": "stepp"}).validate()
    with pytest.raises(ModelError, match=r"thermal\[0\].*'thermal' effect"):
        _scene(2, moment=(0.0, 1.0, 0.0), node="0.end").replace(effects=[]).validate()
