"""Deploying booms (effect ``deployment``): spin rate against conservation of angular momentum."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import linflex.linearize as lz
from linflex import Body, Boom, Joint, ModelError, OperatingPoint, Scene, compile_model, simulate
from linflex.effects._deployment import boom_stiffness, quadrature_points


def _scene(*, Izz=20.0, r0=0.5, rho=0.4, L=8.0, w0=2.0, before=0.0, after=8.0, EI=None, modes=None,
           duration=20.0, joint=None):
    length = {"profile": "transition", "start": 1.0, "duration": duration, "before": before, "after": after}
    return Scene("deploy", effects=["deployment"], bodies=[Body("hub", 50.0, [10.0, 10.0, Izz])],
                 joints=[joint or Joint("spin", "revolute", "hub", axis=[0, 0, 1], u0=w0)],
                 booms=[Boom("boom", "hub", mass_per_length=rho, length=length, total_length=L, point=(r0, 0, 0),
                             EI=EI, modes=modes)])


def _spin_inertia(Izz, r0, rho, L, l):
    """Hub + stowed mass at the root + the deployed thin rod from r0 to r0 + l, about the spin axis."""
    return Izz + rho * (L - l) * r0**2 + rho * ((r0 + l) ** 3 - r0**3) / 3


@settings(derandomize=True, max_examples=6, deadline=None)
@given(Izz=st.floats(2.0, 20.0), r0=st.floats(0.0, 1.5), rho=st.floats(0.05, 2.0), retract=st.booleans())
def test_rigid_boom_spin_rate_is_h0_over_inertia(Izz, r0, rho, retract):
    # (the hub is [10, 10, Izz] kg m^2: a physical body needs Izz <= 20, the triangle inequality)
    # Closed form: no external torque, the boom material moves radially, so H = I(t) w is
    # constant and w(t) = H0 / I(t) with I(t) from the deployed length.
    L, w0 = 8.0, 2.0
    before, after = (L, 0.5) if retract else (0.0, L)
    model = compile_model(_scene(Izz=Izz, r0=r0, rho=rho, L=L, w0=w0, before=before, after=after))
    t = np.linspace(0.0, 25.0, 51)
    r = simulate(model, t, rtol=1e-11, atol=1e-12)
    length = r.y[:, r.outputs.index("boom.length")]
    inertia = _spin_inertia(Izz, r0, rho, L, length)
    w = r.x[:, r.states.index("spin.rate")]
    np.testing.assert_allclose(w, inertia[0] * w0 / inertia, rtol=1e-8)
    # The spin rate changed a lot (the test is not trivially satisfied) and so did the length.
    assert abs(inertia[-1] / inertia[0] - 1) > 0.05
    np.testing.assert_allclose(length[[0, -1]], [before, after], atol=1e-12)
    # The model's own momentum monitor (hub + stowed + deployed material) agrees.
    np.testing.assert_allclose(r.momentum[:, 2], inertia[0] * w0, rtol=1e-8)


def test_flexible_boom_conserves_total_angular_momentum():
    # A free hub (spherical joint: all three rotations) spinning about z deploys a flexible boom:
    # the deployment excites its bending, the spin axis nutates, and the total angular momentum
    # (hub, stowed, deployed and bent material) stays constant to the integrator's tolerance.
    joint = Joint("spin", "spherical", "hub", u0=[0.05, 0.0, 1.0])
    model = compile_model(_scene(w0=1.0, before=0.5, after=6.0, EI=30.0, modes=1, duration=8.0, joint=joint))
    t = np.linspace(0.0, 12.0, 61)
    r = simulate(model, t, rtol=1e-10, atol=1e-12)
    H = r.momentum
    drift = np.max(np.linalg.norm(H - H[0], axis=1)) / np.linalg.norm(H[0])
    assert drift < 1e-8
    bend = r.x[:, [r.states.index("boom.eta0"), r.states.index("boom.eta1")]]
    assert np.max(np.abs(bend)) > 1e-3  # it bends: the conservation is not of a rigid body
    # The Coriolis force -2 W x v of the outgoing material bends the boom (along +x, spin about +z)
    # backwards, towards -y.
    assert -np.min(bend[:, 0]) > 2 * max(np.max(bend[:, 0]), 0.0)
    w = r.x[:, [r.states.index(f"spin.w{c}") for c in "xyz"]]
    assert abs(w[-1, 2] / w[0, 2] - 1) > 0.1  # the inertia grew: the spin slowed


def test_fixed_length_boom_frequency_is_the_cantilever_s():
    # Constant length, hub held: the frequencies are the Rayleigh-Ritz ones of the shapes xi^2,
    # xi^3, xi^4 (mass int xi^(i+j+4), stiffness int (xi^(i+2))'' (xi^(j+2))'', computed here by
    # numpy's polynomials), an upper bound of Euler-Bernoulli's 1.87510407^2 sqrt(EI / (rho L^4)).
    from numpy.polynomial import polynomial as P
    from scipy.linalg import eigh

    EI, rho, l = 30.0, 0.4, 6.0
    scene = Scene("held", effects=["deployment"], bodies=[Body("hub", 50.0, [10.0, 10.0, 20.0])],
                  joints=[Joint("spin", "revolute", "hub", axis=[0, 0, 1], locked=True)],
                  booms=[Boom("boom", "hub", mass_per_length=rho, length=l, point=(0.5, 0, 0), EI=EI, modes=3)])
    model = compile_model(scene)
    lin = lz.linearize(model, OperatingPoint(model.x0), method="autodiff")
    w = np.sort(np.abs(np.linalg.eigvals(lin.sys.A).imag))[::2]
    shapes = [np.eye(k + 3)[k + 2] for k in range(3)]  # coefficients of xi^2, xi^3, xi^4

    def integral(a, b):
        return P.polyval(1.0, P.polyint(P.polymul(a, b)))

    Mr = rho * l * np.array([[integral(a, b) for b in shapes] for a in shapes])
    Kr = EI / l**3 * np.array([[integral(P.polyder(a, 2), P.polyder(b, 2)) for b in shapes] for a in shapes])
    ritz = np.sqrt(eigh(Kr, Mr, eigvals_only=True))
    np.testing.assert_allclose(w[0::2], ritz, rtol=1e-9)
    np.testing.assert_allclose(w[1::2], ritz, rtol=1e-9)  # both transverse directions
    exact = 1.87510407**2 * np.sqrt(EI / (rho * l**4))
    assert exact < w[0] < exact * (1 + 5e-4)


def test_boom_stiffness_and_quadrature():
    # int_0^1 (k+2)(k+1) xi^k (j+2)(j+1) xi^j dxi, and points exact to the stated degree.
    K = boom_stiffness(2)
    np.testing.assert_allclose(K, [[4.0, 6.0], [6.0, 12.0]], rtol=1e-15)
    for n in (0, 1, 3):
        xi, w = quadrature_points(n)
        degree = 2 if n == 0 else 2 * (2 * n + 3) + 2
        assert np.dot(w, xi**degree) == pytest.approx(1 / (degree + 1), rel=1e-13)


def test_boom_validation():
    with pytest.raises(ModelError, match=r"booms\[0\].*'deployment' effect"):
        _scene().replace(effects=[]).validate()
    with pytest.raises(ModelError, match=r"booms\[0\].length: a flexible boom needs a positive length"):
        _scene(EI=10.0).validate()
    with pytest.raises(ModelError, match=r"booms\[0\].length: the deployed length ranges over \[0, 9\]"):
        _scene(after=9.0).validate()
    with pytest.raises(ModelError, match=r"booms\[0\].length.duration: must be positive"):
        _scene(duration=-1.0).validate()
    with pytest.raises(ModelError, match="not supported by order-n"):
        compile_model(_scene(), formulation="order-n")


@pytest.mark.parametrize("retract", [False, True])
def test_free_hub_recoils_so_that_the_mass_centre_stays(retract):
    # Momentum accounting of the material that moves: a free hub at rest pushes a rigid boom out
    # (or pulls it in) through its mass centre. No external force: the system's mass centre stays,
    # so the hub moves by -rho l(t)^2 / (2 M) along the boom (M = hub + whole boom; the stowed
    # material sits at the root). Without the momentum flux of the mass crossing the root, the hub
    # would not get the recoil of the material accelerated there.
    m_hub, rho, L, r0 = 50.0, 0.4, 8.0, 0.5
    before, after = (L, 1.0) if retract else (0.0, L)
    scene = _scene(rho=rho, L=L, r0=r0, before=before, after=after, joint=Joint("float", "free", "hub"))
    model = compile_model(scene)
    t = np.linspace(0.0, 25.0, 26)
    r = simulate(model, t, rtol=1e-11, atol=1e-13)
    length = r.y[:, r.outputs.index("boom.length")]
    x = r.x[:, r.states.index("float.x")]
    M = m_hub + rho * L
    np.testing.assert_allclose(x - x[0], -rho * (length**2 - length[0] ** 2) / (2 * M), rtol=1e-7, atol=1e-9)
    assert abs(x[-1] - x[0]) > 0.1


@pytest.mark.parametrize("method", ["autodiff", "kane"])
def test_spinning_boom_stiffens_as_rayleigh_ritz_with_centrifugal_tension(method):
    # Constant length, hub spun at a prescribed rate W about z: the axial foreshortening gives the
    # centrifugal stiffening. Reference (independent, numpy polynomials): Rayleigh-Ritz with the
    # same shapes and the geometric stiffness of the tension T(x) = rho W^2 int_x^l (r0 + s) ds:
    # out of the spin plane (K + Kg) eta = w^2 M eta, in the plane (K + Kg - W^2 M) eta = w^2 M eta
    # (Southwell's result; the in-plane mode also feels the centrifugal softening).
    from numpy.polynomial import polynomial as P
    from scipy.linalg import eigh

    EI, rho, l, r0, W = 30.0, 0.4, 6.0, 0.5, 1.5
    joint = Joint("spin", "revolute", "hub", axis=[0, 0, 1], prescribed={"profile": "ramp", "rate": W})
    scene = Scene("spun", effects=["deployment"], bodies=[Body("hub", 50.0, [10.0, 10.0, 20.0])], joints=[joint],
                  booms=[Boom("boom", "hub", mass_per_length=rho, length=l, point=(r0, 0, 0), EI=EI, modes=3)])
    model = compile_model(scene)
    lin = lz.linearize(model, OperatingPoint(model.x0), method=method)
    n = 3
    A = lin.sys.A
    shapes = [np.eye(k + 3)[k + 2] for k in range(n)]

    def integral(p):
        return P.polyval(1.0, P.polyint(p))

    tension = rho * W**2 * np.array([r0 * l + l**2 / 2, -r0 * l, -(l**2) / 2])  # in xi = x / l
    Mr = rho * l * np.array([[integral(P.polymul(a, b)) for b in shapes] for a in shapes])
    Kr = EI / l**3 * np.array([[integral(P.polymul(P.polyder(a, 2), P.polyder(b, 2))) for b in shapes]
                               for a in shapes])
    Kg = np.array([[integral(P.polymul(tension, P.polymul(P.polyder(a), P.polyder(b)))) for b in shapes]
                   for a in shapes]) / l
    out_of_plane = np.sqrt(eigh(Kr + Kg, Mr, eigvals_only=True))
    in_plane = np.sqrt(eigh(Kr + Kg - W**2 * Mr, Mr, eigvals_only=True))
    # The model's coordinates: eta0..2 bend along y (in the spin plane), eta3..5 along z.
    states = lin.sys.states
    for rows, expected in ((range(0, n), in_plane), (range(n, 2 * n), out_of_plane)):
        idx = [states.index(f"boom.eta{k}") for k in rows] + [states.index(f"boom.eta{k}_rate") for k in rows]
        w = np.sort(np.abs(np.linalg.eigvals(A[np.ix_(idx, idx)]).imag))[::2]
        np.testing.assert_allclose(w, expected, rtol=1e-8)
    # The planes do not couple at this equilibrium, and spin stiffened the out-of-plane mode.
    coupling = A[np.ix_([states.index(f"boom.eta{k}_rate") for k in range(n)],
                        [states.index(f"boom.eta{k}") for k in range(n, 2 * n)])]
    assert np.max(np.abs(coupling)) < 1e-12 * np.max(np.abs(A))
    at_rest = np.sqrt(eigh(Kr, Mr, eigvals_only=True))
    assert out_of_plane[0] > 2 * at_rest[0]


def test_transition_profile_is_smooth_and_reaches_its_values():
    # The cycloidal blend s - sin(2 pi s)/(2 pi): before, after, the midpoint, and rate and
    # acceleration zero at both ends (d/dt by CasADi, against the closed form inside).
    import casadi as ca

    from linflex.scene._values import profile_function

    t = ca.SX.sym("t")
    value = profile_function({"profile": "transition", "start": 2.0, "duration": 4.0, "before": 1.0, "after": 5.0})(t)
    rate, accel = ca.jacobian(value, t), ca.jacobian(ca.jacobian(value, t), t)
    f = ca.Function("f", [t], [value, rate, accel])
    for time, expected in ((0.0, (1.0, 0.0, 0.0)), (2.0, (1.0, 0.0, 0.0)), (4.0, (3.0, 2.0, 0.0)),
                           (6.0, (5.0, 0.0, 0.0)), (9.0, (5.0, 0.0, 0.0))):
        np.testing.assert_allclose([float(v) for v in f(time)], expected, atol=1e-12)
    s = 0.3
    np.testing.assert_allclose(float(f(2.0 + 4 * s)[1]), 4.0 / 4 * (1 - np.cos(2 * np.pi * s)), rtol=1e-12)


def test_quadrature_is_exact_for_the_momentum_of_a_bent_boom(monkeypatch):
    # The Gauss points integrate the bent, foreshortened, stretching boom's momentum exactly:
    # 6 more points change the angular momentum and the accelerations by round-off only, at a
    # random state in the middle of a deployment.
    import linflex.effects._deployment as deployment

    scene = _scene(before=0.5, after=6.0, EI=30.0, modes=2, joint=Joint("spin", "spherical", "hub"))
    coarse = compile_model(scene)
    points = deployment.quadrature_points
    monkeypatch.setattr(deployment, "quadrature_points", lambda n: points(n + 3))
    fine = compile_model(scene)
    rng = np.random.default_rng(7)
    x = coarse.x0 + 0.3 * rng.standard_normal(coarse.n_states)
    for t in (0.0, 6.0, 11.0):
        H1, H2 = (np.asarray(m.momentum(x, t), dtype=float).ravel() for m in (coarse, fine))
        np.testing.assert_allclose(H1, H2, rtol=1e-13, atol=1e-13 * np.linalg.norm(H2))
        f1, f2 = (np.asarray(m.f(x, np.zeros(0), t), dtype=float).ravel() for m in (coarse, fine))
        np.testing.assert_allclose(f1, f2, rtol=1e-11, atol=1e-11 * np.max(np.abs(f2)))


def test_fixed_length_flexible_boom_conserves_energy_and_momentum():
    # Constant length, free hub, the boom ringing: a conservative system. The energy monitor
    # (kinetic energy of hub and material, bending energy 1/2 eta^T K eta) and the angular
    # momentum stay constant to the integrator's tolerance.
    scene = _scene(joint=Joint("spin", "spherical", "hub", u0=[0.02, -0.01, 0.8]), EI=30.0, modes=2).replace(
        booms=[Boom("boom", "hub", mass_per_length=0.4, length=5.0, total_length=8.0, point=(0.5, 0, 0),
                    EI=30.0, modes=2)])
    model = compile_model(scene)
    x0 = np.array(model.x0)
    x0[model.states.index("boom.eta0_rate")] = 0.3
    x0[model.states.index("boom.eta2")] = 0.05
    t = np.linspace(0.0, 10.0, 41)
    r = simulate(model, t, x0=x0, rtol=1e-11, atol=1e-13)
    E, H = r.energy, r.momentum
    assert np.ptp(E) < 1e-8 * abs(E[0])
    assert np.max(np.linalg.norm(H - H[0], axis=1)) < 1e-8 * np.linalg.norm(H[0])
    assert np.ptp(r.x[:, model.states.index("boom.eta2")]) > 0.05  # it rings
