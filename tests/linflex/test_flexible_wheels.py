"""Momentum wheels at nodes of flexible bodies: conservation, gyroscopic mode splitting, tip mass."""

import numpy as np
import pytest
import scipy.optimize

import linflex
from linflex import Beam, ModelError, PointMassAt, beam_modal_data
from linflex.linearize import linearize

EI, MASS, LENGTH = 1.4e4, 1.2, 10.0  # issue 4's cantilever [N m^2, kg/m, m]


def cantilever(n_modes, *, EIz=EI, elements=20):
    return beam_modal_data(Beam((0, 0, 0), (LENGTH, 0, 0), EA=2.8e7, EIy=EI, EIz=EIz, GJ=1e4, mass_per_length=MASS,
                                elements=elements), n_modes)


def tip_wheel_model(data, wheel):
    scene = linflex.Scene(name="tip_wheel", effects=("wheel_gyroscopics",),
                          bodies=(linflex.Body(name="beam", mass=0.0, type="flexible", modal_data=data),),
                          joints=(linflex.Joint(name="clamp", type="fixed", child="beam"),), wheels=(wheel,))
    return linflex.compile_model(scene)


def eigenvalues(model):
    return np.linalg.eigvals(linearize(model, linflex.OperatingPoint(model.x0, np.zeros(model.n_inputs))).sys.A)


def test_floating_appendage_with_a_tip_wheel_conserves_energy_and_momentum():
    # A free-floating rigid hub with a flexible appendage mounted off its centre, tumbling and
    # vibrating, with a free-spinning wheel (torque mode, no motor torque) at the appendage tip
    # on a skew axis. No external load and no motor work: total energy and angular momentum are
    # constant; the drift measured scales with the integrator's rtol (9 rtol at 1e-9, 19 rtol at
    # 1e-11 for the energy, below 1 rtol for the momentum), so 100 rtol bounds it. The wheel's
    # relative speed changes by about 0.25 rad/s: the node's rotation does drive it.
    data = cantilever(4, EIz=2 * EI, elements=8)
    scene = linflex.Scene(
        name="floating", effects=("wheel_gyroscopics",),
        bodies=(linflex.Body(name="hub", mass=20.0, inertia=(2.0, 3.0, 4.0)),
                linflex.Body(name="beam", mass=0.0, type="flexible", modal_data=data)),
        joints=(linflex.Joint(name="float", type="free", child="hub", u0=[0.1, 0, 0, 0.05, -0.1, 0.3]),
                linflex.Joint(name="mount", type="fixed", parent="hub", child="beam", parent_point=(0.5, 0.2, 0.0))),
        wheels=(linflex.Wheel(name="rw", body="beam", node="0.end", spin_inertia=0.05, transverse_inertia=0.03,
                              mass=2.0, axis=(0, 1, 1), mode="torque", speed=50.0),))
    model = linflex.compile_model(scene)
    x0 = np.array(model.x0)
    x0[model.states.index("beam.eta0_rate")] = 0.2
    x0[model.states.index("beam.eta1")] = 0.05
    rtol = 1e-11
    response = linflex.simulate(model, np.linspace(0.0, 20.0, 201), x0=x0, rtol=rtol, atol=0.1 * rtol)
    energy, momentum = response.energy, response.momentum
    assert np.ptp(energy) <= 100 * rtol * np.max(np.abs(energy))
    assert np.max(np.abs(momentum - momentum[0])) <= 100 * rtol * np.linalg.norm(momentum[0])
    assert np.ptp(response["rw.speed"]) > 0.1  # rad/s: the wheel is coupled to the structure


@pytest.mark.parametrize("speed", [40.0, 400.0])
def test_spinning_tip_wheel_splits_the_bending_pairs(speed):
    # A wheel at the tip of a cantilever clamped to the ground, spin axis along the beam. The
    # bending modes in the x-y and x-z planes (equal stiffness: degenerate pairs) split into
    # forward and backward whirl. Independent construction from the modal data only, no scene:
    #   M q'' + G q' + K q = 0,  M = U + m Phi^T Phi + Psi^T J Psi (wheel mass and inertia at the
    #   tip), K = diag(w^2), G = h (Psi_y^T Psi_z - Psi_z^T Psi_y) with h = J_s Omega, the rate of
    #   change of the wheel's momentum h a turned by the tip rotation Psi q (d/dt (h a) = h Psi q' x a).
    data = cantilever(6)
    mass, spin_inertia, transverse = 2.0, 0.5, 0.3
    wheel = linflex.Wheel(name="rw", body="beam", node="0.end", spin_inertia=spin_inertia,
                          transverse_inertia=transverse, mass=mass, axis=(1, 0, 0), speed=speed)
    eig = eigenvalues(tip_wheel_model(data, wheel))

    _, Phi, Psi = data.node("0.end")
    n = data.n_modes
    M = np.eye(n) + mass * Phi.T @ Phi + Psi.T @ np.diag([spin_inertia, transverse, transverse]) @ Psi
    K = np.diag(data.frequencies**2)
    h = spin_inertia * speed
    G = h * (np.outer(Psi[1], Psi[2]) - np.outer(Psi[2], Psi[1]))
    companion = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, G)]])
    expected = np.linalg.eigvals(companion)
    # Undamped and gyroscopic: purely imaginary pairs; compare the frequencies, relative to the largest.
    w_model, w_expected = np.sort(eig.imag[eig.imag > 0]), np.sort(expected.imag[expected.imag > 0])
    np.testing.assert_allclose(w_model, w_expected, rtol=0, atol=1e-8 * w_expected.max())
    assert np.max(np.abs(eig.real)) < 1e-9 * w_expected.max()
    # The pairs do split: without spin the first two frequencies coincide (to the eigensolver's
    # round-off); with h = 20 N m s the first pair is 2.8 % apart.
    assert w_model[1] / w_model[0] - 1 > 0.02


def test_wheel_without_spin_is_a_tip_mass_with_rotary_inertia():
    # Zero spin: the wheel is only mass m and inertia J at the tip. Reference: the classical
    # frequency equation of an Euler-Bernoulli cantilever with a tip mass and rotary inertia
    # (from the tip's shear and moment conditions; mu = m / (rho A L), j = J / (rho A L^3)):
    #   1 + cos l cosh l + l mu (cos l sinh l - sin l cosh l) - l^3 j (cosh l sin l + sinh l cos l)
    #     + l^4 mu j (1 - cos l cosh l) = 0,   omega = l^2 sqrt(EI / (rho A L^4)).
    # The modes are the bare beam's, so the wheel enters through 12 of them: the first flap
    # frequency converges to 3e-5, the first lag frequency (EIz = 3 EIy) to 7e-5 (measured
    # against 20 modes and against beam_modal_data with the tip mass in the finite-element model,
    # which matches the closed form to 1e-8).
    data = cantilever(12, EIz=3 * EI)
    mass, spin_inertia, transverse = 3.0, 0.5, 2.0
    wheel = linflex.Wheel(name="rw", body="beam", node="0.end", spin_inertia=spin_inertia,
                          transverse_inertia=transverse, mass=mass, axis=(1, 0, 0), speed=0.0)
    eig = eigenvalues(tip_wheel_model(data, wheel))
    w = np.sort(eig.imag[eig.imag > 0])
    mu, j = mass / (MASS * LENGTH), transverse / (MASS * LENGTH**3)

    def frequency_equation(x):
        c, s, ch, sh = np.cos(x), np.sin(x), np.cosh(x), np.sinh(x)
        return 1 + c * ch + x * mu * (c * sh - s * ch) - x**3 * j * (ch * s + sh * c) + x**4 * mu * j * (1 - c * ch)

    root = scipy.optimize.brentq(frequency_equation, 0.3, 2.0, xtol=1e-14)
    flap, lag = (root**2 * np.sqrt(stiffness / (MASS * LENGTH**4)) for stiffness in (EI, 3 * EI))
    assert w[0] == pytest.approx(flap, rel=1e-4)
    assert w[1] == pytest.approx(lag, rel=1e-4)
    assert w[0] < 0.71 * data.frequencies[0]  # the frequency drop the wheel causes (bare: 3.8 rad/s)
    # The same tip mass in the finite-element model (PointMassAt) gives the same drop.
    in_fe = beam_modal_data(Beam((0, 0, 0), (LENGTH, 0, 0), EA=2.8e7, EIy=EI, EIz=3 * EI, GJ=1e4,
                                 mass_per_length=MASS, elements=20), 2,
                            point_masses=(PointMassAt((LENGTH, 0, 0), mass, (spin_inertia, transverse, transverse)),))
    np.testing.assert_allclose(w[:2], in_fe.frequencies, rtol=1e-4)


def test_wheel_nodes_are_validated():
    data = cantilever(2, elements=4)
    flexible = linflex.Body(name="beam", mass=0.0, type="flexible", modal_data=data)
    rigid = linflex.Body(name="hub", mass=1.0, inertia=(1.0, 1.0, 1.0))
    scene = linflex.Scene(name="x", bodies=(rigid, flexible),
                          joints=(linflex.Joint(name="clamp", type="fixed", child="hub"),
                                  linflex.Joint(name="arm", type="fixed", parent="hub", child="beam")),
                          wheels=(linflex.Wheel(name="w1", body="beam", spin_inertia=0.1, node="0.ned"),
                                  linflex.Wheel(name="w2", body="hub", spin_inertia=0.1, node="0.end")))
    with pytest.raises(ModelError) as info:
        scene.validate()
    assert "wheels[0].node: unknown node '0.ned' of 'beam'" in str(info.value)
    assert "wheels[1].node: nodes belong to flexible bodies; 'hub' is rigid" in str(info.value)


def test_motor_torque_of_a_tip_wheel_reacts_on_the_structure():
    # A torque-mode wheel at the tip, at rest, motor torque tau about the wheel axis a = z (the
    # node's bending rotation axis in the x-y plane). Hand-built from the modal data (Hughes 2004,
    # 3.5, with the node's rotation Psi q in place of the body's):
    #   [M        J_s Psi^T a] [q''  ]   [0  ]
    #   [J_s a^T Psi     J_s ] [Om'  ] = [tau],  M = U + m Phi^T Phi + Psi^T J Psi
    # so the reaction -tau a on the node excites the lag modes. Round-off: 1e-12.
    data = cantilever(4, EIz=2 * EI)
    mass, spin_inertia, transverse = 2.0, 0.5, 0.3
    wheel = linflex.Wheel(name="rw", body="beam", node="0.end", spin_inertia=spin_inertia,
                          transverse_inertia=transverse, mass=mass, axis=(0, 0, 1), mode="torque", speed=0.0)
    scene = linflex.Scene(name="tip_motor", effects=("wheel_gyroscopics",),
                          bodies=(linflex.Body(name="beam", mass=0.0, type="flexible", modal_data=data),),
                          joints=(linflex.Joint(name="clamp", type="fixed", child="beam"),), wheels=(wheel,),
                          actuators=(linflex.Actuator(name="motor", type="wheel_torque", wheel="rw"),),
                          sensors=(linflex.Sensor(name="tach", type="wheel_speed", wheel="rw"),))
    model = linflex.compile_model(scene)
    tau = 0.2
    xdot, y = model.evaluate(model.x0, [tau])
    _, Phi, Psi = data.node("0.end")
    n = data.n_modes
    J = np.diag([transverse, transverse, spin_inertia])
    coupling = spin_inertia * Psi[2]
    K = np.block([[np.eye(n) + mass * Phi.T @ Phi + Psi.T @ J @ Psi, coupling[:, None]],
                  [coupling[None, :], np.array([[spin_inertia]])]])
    expected = np.linalg.solve(K, np.r_[np.zeros(n), tau])
    rates = [model.states.index(f"beam.eta{k}_rate") for k in range(n)] + [model.states.index("rw.speed")]
    np.testing.assert_allclose(xdot[rates], expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    assert np.max(np.abs(expected[:n])) > 0.01 * abs(expected[n])  # the structure does react
    np.testing.assert_array_equal(y, [0.0, tau])  # the tachometer and the command

    # Without the effect the wheel is locked to the node: the same structure as at zero spin.
    locked = tip_wheel_model(data, linflex.Wheel(name="rw", body="beam", node="0.end", spin_inertia=spin_inertia,
                                                 transverse_inertia=transverse, mass=mass, axis=(0, 0, 1)))
    scene_locked = linflex.Scene(name="locked", bodies=scene.bodies, joints=scene.joints,
                                 wheels=(linflex.Wheel(name="rw", body="beam", node="0.end", spin_inertia=spin_inertia,
                                                       transverse_inertia=transverse, mass=mass, axis=(0, 0, 1)),))
    np.testing.assert_allclose(np.sort(eigenvalues(linflex.compile_model(scene_locked)).imag),
                               np.sort(eigenvalues(locked).imag), rtol=1e-12)
