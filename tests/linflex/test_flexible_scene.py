"""Flexible bodies in scenes: modal frequencies, conservation, and motion-induced stiffness."""

import numpy as np
import pytest

import linflex
from linflex import Beam, ModelError, beam_modal_data
from linflex.linearize import linearize

EI, MASS, LENGTH = 1.4e4, 1.2, 10.0  # issue 4's spinning beam: first bending mode 3.8 rad/s


def beam_data(n_modes=6, elements=20):
    # EIz = 2 EIy separates flap (z, EIy) and lag (y, EIz) modes.
    return beam_modal_data(Beam((0, 0, 0), (LENGTH, 0, 0), EA=2.8e7, EIy=EI, EIz=2 * EI, GJ=1e4,
                                mass_per_length=MASS, elements=elements), n_modes, damping=0.0)


def frequencies(model):
    lin = linearize(model, linflex.OperatingPoint(model.x0, np.zeros(model.n_inputs)))
    eig = np.linalg.eigvals(lin.sys.A)
    return np.sort(np.abs(eig.imag[eig.imag > 0])), eig


def test_clamped_flexible_body_has_its_modal_frequencies():
    data = beam_data()
    scene = linflex.Scene(name="cantilever", bodies=(linflex.Body(name="beam", mass=0.0, type="flexible",
                                                                  modal_data=data),),
                          joints=(linflex.Joint(name="clamp", type="fixed", child="beam"),))
    w, _ = frequencies(linflex.compile_model(scene))
    np.testing.assert_allclose(w, data.frequencies, rtol=1e-10)


def test_free_flexible_body_conserves_energy_and_momentum():
    # A free-floating beam with a rigid hub at its root, set tumbling and vibrating: no external
    # load, so energy and angular momentum are constant (their drift measures any inconsistency
    # between the mass matrix and the velocity terms).
    data = beam_data(n_modes=4, elements=8)
    scene = linflex.Scene(
        name="floating", bodies=(linflex.Body(name="beam", mass=20.0, inertia=(2.0, 3.0, 4.0), type="flexible",
                                              modal_data=data),),
        joints=(linflex.Joint(name="float", type="free", child="beam", u0=[0.1, 0, 0, 0.05, -0.1, 0.3]),))
    model = linflex.compile_model(scene)
    x0 = np.array(model.x0)
    x0[model.states.index("beam.eta0_rate")] = 0.2
    x0[model.states.index("beam.eta1")] = 0.05
    response = linflex.simulate(model, np.linspace(0.0, 20.0, 201), x0=x0, rtol=1e-11, atol=1e-12)
    energy, momentum = response.energy, response.momentum
    assert np.ptp(energy) <= 1e-8 * np.max(np.abs(energy))
    assert np.max(np.abs(momentum - momentum[0])) <= 1e-8 * np.linalg.norm(momentum[0])


@pytest.mark.parametrize("spin", [2.0, 6.0])
def test_spinning_beam_stiffens_only_with_geometric_stiffness(spin):
    # The beam clamped in a frame spinning at Omega about z (reference notes section 5.8).
    # Reference computed directly from the projected matrices (no scene, no Kane builder): the
    # modal stiffness Lambda - Omega^2 (S4 + S8) - Omega^2 P[:, :, 2, 2] with unit modal mass
    # (flap and lag modes do not couple gyroscopically here: d_lk is along x, w along z).
    # At low spin the first flap and lag frequencies also follow Southwell's
    # omega^2 = w0^2 + K Omega^2 with K1 = 1.1932 and K1 - 1 (Wright et al. 1982).
    # Without geometric stiffness the model is prematurely linearized: flap unchanged, lag
    # softened by Omega^2 and unstable once Omega passes the lag frequency.
    data = beam_data()
    flap0, lag0 = data.frequencies[0], data.frequencies[1]
    S, P = data.geometric_stiffness, data.integrals().P

    def scene(effects):
        return linflex.Scene(name="spinning", effects=effects, frame=linflex.Frame(kind="spin", rate=spin),
                             bodies=(linflex.Body(name="beam", mass=0.0, type="flexible", modal_data=data),),
                             joints=(linflex.Joint(name="clamp", type="fixed", child="beam"),))

    w_geo, eig_geo = frequencies(linflex.compile_model(scene(("geometric_stiffness",))))
    stiffness = np.diag(data.frequencies**2) - spin**2 * (S[3] + S[7] + P[:, :, 2, 2])
    np.testing.assert_allclose(w_geo, np.sort(np.sqrt(np.linalg.eigvalsh(stiffness))), rtol=1e-9)
    assert np.max(eig_geo.real) < 1e-9  # stable
    if spin < flap0:  # single-mode Rayleigh quotient: good to 2e-3 at low spin
        assert np.min(np.abs(w_geo / np.sqrt(flap0**2 + 1.1932 * spin**2) - 1)) < 2e-3
        assert np.min(np.abs(w_geo / np.sqrt(lag0**2 + 0.1932 * spin**2) - 1)) < 2e-3

    w_pre, eig_pre = frequencies(linflex.compile_model(scene(())))
    assert np.min(np.abs(w_pre - flap0)) < 1e-9 * flap0
    if spin < lag0:
        assert np.min(np.abs(w_pre - np.sqrt(lag0**2 - spin**2))) < 1e-9 * lag0
    else:
        assert np.max(eig_pre.real) == pytest.approx(np.sqrt(spin**2 - lag0**2), rel=1e-9)  # divergence


def test_flexible_bodies_are_validated():
    with pytest.raises(ModelError, match=r"bodies\[0\].modal_data: a flexible body needs modal data"):
        linflex.Scene(name="x", bodies=(linflex.Body(name="b", mass=1.0, type="flexible"),)).validate()
    with pytest.raises(ModelError, match=r"bodies\[0\].modes: must be an integer from 1 to 6"):
        linflex.Scene(name="x", bodies=(linflex.Body(name="b", mass=1.0, type="flexible", modal_data=beam_data(),
                                                     modes=9),)).validate()
    with pytest.raises(ModelError, match="no such modal-data file"):
        linflex.Scene(name="x", bodies=(linflex.Body(name="b", mass=1.0, type="flexible",
                                                     modal_data="missing.npz"),)).validate()


def test_modal_data_file_is_found_relative_to_the_scene_file(tmp_path):
    data = beam_data(n_modes=3, elements=6)
    data.save(tmp_path / "boom.npz")
    (tmp_path / "boom.toml").write_text(
        'name = "boom"\n\n[[bodies]]\nname = "boom"\nmass = 0.0\ntype = "flexible"\nmodal_data = "boom.npz"\n\n'
        '[[joints]]\nname = "clamp"\ntype = "fixed"\nchild = "boom"\n')
    scene = linflex.load_scene(tmp_path / "boom.toml")
    w, _ = frequencies(linflex.compile_model(scene))
    np.testing.assert_allclose(w, data.frequencies, rtol=1e-10)


def test_beam_table_builds_the_modes_and_is_validated():
    spec = {"length": LENGTH, "EI": EI, "EA": 2.8e7, "GJ": 1e4, "mass_per_length": MASS, "elements": 20}
    body = linflex.Body(name="b", mass=0.0, type="flexible", beam=spec, modes=2)
    # Same structure as beam_data() up to EIz: the first flap frequency is the cantilever's; with
    # EIz = EIy the pair is degenerate and the eigensolver's round-off is ~1e-9.
    assert body.resolved_modal_data().frequencies[0] == pytest.approx(beam_data().frequencies[0], rel=1e-8)
    missing = dict(spec)
    del missing["EA"]
    with pytest.raises(ModelError, match=r"bodies\[0\].beam: missing key 'EA'"):
        linflex.Scene(name="x", bodies=(linflex.Body(name="b", mass=0.0, type="flexible", beam=missing),)).validate()
    with pytest.raises(ModelError, match="not both"):
        linflex.Scene(name="x", bodies=(linflex.Body(name="b", mass=0.0, type="flexible", beam=spec,
                                                     modal_data=beam_data()),)).validate()


def test_spin_up_of_a_cantilever_on_a_hub():
    # Issue 4's benchmark (Kane, Ryan and Banerjee 1987): a 10 m cantilever (EI = 1.4e4 N m^2,
    # EA = 2.8e7 N, 1.2 kg/m) on a hub spun up to 6 rad/s in 15 s about z, in-plane bending.
    # With geometric stiffness the tip deflection stays bounded and agrees with the rigid-segment
    # reference (10 segments: converged to 0.03 % against 20 segments, measured when this test
    # was written) within 5 % of its peak; without it the deflection grows without bound once
    # the spin passes the first bending frequency (3.8 rad/s).
    spin = linflex.Joint(name="spin", type="revolute", child="hub", axis=(0.0, 0.0, 1.0),
                         prescribed={"profile": "spinup", "rate": 6.0, "ramp_time": 15.0})
    hub = linflex.Body(name="hub", mass=1.0, inertia=(1.0, 1.0, 1.0))
    timepts = np.linspace(0.0, 30.0, 301)
    data = beam_modal_data(Beam((0, 0, 0), (LENGTH, 0, 0), EA=2.8e7, EIy=10 * EI, EIz=EI, GJ=1e4,
                                mass_per_length=MASS, elements=20), 4)
    _, tip, _ = data.node("0.end")

    def modal_tip(effects):
        scene = linflex.Scene(name="spinup", effects=effects,
                              bodies=(hub, linflex.Body(name="beam", mass=0.0, type="flexible", modal_data=data)),
                              joints=(spin, linflex.Joint(name="clamp", type="fixed", parent="hub", child="beam")))
        response = linflex.simulate(linflex.compile_model(scene), timepts, rtol=1e-8, atol=1e-10)
        return np.column_stack([response[f"beam.eta{k}"] for k in range(4)]) @ tip[1]

    n = 10
    bodies, joints = linflex.rigid_segment_beam("beam", length=LENGTH, EI=EI, mass_per_length=MASS, segments=n,
                                                parent="hub")
    reference = linflex.simulate(linflex.compile_model(linflex.Scene(
        name="segments", effects=("joint_springs",), bodies=(hub, *bodies), joints=(spin, *joints))),
        timepts, rtol=1e-8, atol=1e-10)
    angles = np.cumsum(np.column_stack([reference[f"beam_joint{k}.angle"] for k in range(n)]), axis=1)
    lengths = np.full(n, LENGTH / n)
    lengths[-1] /= 2  # the free half segment at the tip
    reference_tip = np.sin(angles) @ lengths

    with_geometric = modal_tip(("geometric_stiffness",))
    peak = np.max(np.abs(reference_tip))
    assert 0.3 < peak < 1.0  # the spin-up bends the beam back by about half a metre
    assert np.max(np.abs(with_geometric - reference_tip)) < 0.05 * peak
    premature = modal_tip(())
    assert np.max(np.abs(premature[timepts > 20])) > 1e3 * peak  # diverges


def test_sensors_and_actuators_at_nodes_of_a_flexible_body():
    # A tip force along z and a tip moment about y on a clamped beam, sensed by the tip's
    # position along z and its attitude about y. The static compliance must be Euler-Bernoulli's
    # [[L^3/3EI, -L^2/2EI], [-L^2/2EI, L/EI]] (theta_y = -w') up to modal truncation, and
    # symmetric by Maxwell-Betti reciprocity.
    data = beam_modal_data(Beam((0, 0, 0), (LENGTH, 0, 0), EA=1e9, EIy=EI, EIz=3 * EI, GJ=1e4,
                                mass_per_length=MASS, elements=20), 12)
    scene = linflex.Scene(
        name="tip", bodies=(linflex.Body(name="beam", mass=0.0, type="flexible", modal_data=data),),
        joints=(linflex.Joint(name="clamp", type="fixed", child="beam"),),
        sensors=(linflex.Sensor(name="tip_z", type="position", body="beam", node="0.end", axis=(0, 0, 1)),
                 linflex.Sensor(name="tip_theta", type="attitude", body="beam", node="0.end", axis=(0, 1, 0))),
        actuators=(linflex.Actuator(name="push", type="force", body="beam", node="0.end", axis=(0, 0, 1)),
                   linflex.Actuator(name="twist", type="torque", body="beam", node="0.end", axis=(0, 1, 0))))
    model = linflex.compile_model(scene)
    sys = linearize(model, linflex.OperatingPoint(model.x0, np.zeros(model.n_inputs))).sys
    sys = sys.subsystem(inputs=["push", "twist"], outputs=["tip_z", "tip_theta"])
    compliance = sys.D - sys.C @ np.linalg.solve(sys.A, sys.B)
    # Exact for the model: the modal static sum over the kept unit-mass modes, from the modal data.
    _, trans, rot = data.node("0.end")
    shapes = np.vstack([trans[2], rot[1]])  # tip z translation and y rotation per mode
    modal_sum = (shapes / data.frequencies**2) @ shapes.T
    np.testing.assert_allclose(compliance, modal_sum, rtol=1e-9)
    assert compliance[0, 1] == pytest.approx(compliance[1, 0], rel=1e-10)  # reciprocity
    # Beam theory: truncation converges fast for the force (2e-3 with 12 modes), slowly for the
    # concentrated moment (6 % on the rotation it causes).
    expected = np.array([[LENGTH**3 / (3 * EI), -LENGTH**2 / (2 * EI)], [-LENGTH**2 / (2 * EI), LENGTH / EI]])
    np.testing.assert_allclose(compliance[0, 0], expected[0, 0], rtol=2e-3)
    np.testing.assert_allclose(compliance[0, 1], expected[0, 1], rtol=5e-3)
    np.testing.assert_allclose(compliance[1, 1], expected[1, 1], rtol=0.07)
    with pytest.raises(ModelError, match=r"sensors\[0\].node: unknown node '0.ned'"):
        linflex.Scene(name="x", bodies=scene.bodies, joints=scene.joints,
                      sensors=(linflex.Sensor(name="s", type="rate", body="beam", node="0.ned"),)).validate()
