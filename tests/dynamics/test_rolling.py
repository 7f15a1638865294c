"""Non-holonomic contacts: a rolling disk and a knife edge (Chaplygin's sleigh) against closed forms.

Rolling disk (Routh, *Advanced Rigid Dynamics*, art. 244; K. T. McDonald, "The rolling motion of
a disk on a horizontal plane", Princeton 2000, sec. 2.5; Greenhill, "Gyroscope", Encyclopaedia
Britannica 11th ed., eq. 23). An axisymmetric wheel of mass ``m``, radius ``R``, moment of inertia
``A`` about a diameter through its centre and ``C`` about its axis rolls upright and straight at
spin rate ``Omega`` (speed ``v = R Omega``). Linearized about that motion (lean ``theta``,
heading ``psi``; the spin and the speed stay constant to first order)::

    (A + m R^2) theta'' + (C + m R^2) Omega psi' - m g R theta = 0
    A psi'' - C Omega theta' = 0

so ``psi' = (C Omega / A) theta`` and the lean obeys ``theta'' = lambda^2 theta`` with::

    lambda^2 = (m g R - C (C + m R^2) Omega^2 / A) / (A + m R^2)

Upright rolling is (neutrally) stable when ``lambda^2 < 0``: ``Omega^2 > m g R A / (C (C + m R^2))``;
for a thin uniform disk (``A = m R^2/4``, ``C = m R^2/2``) that is ``v^2 > g R / 3``.

The wheel of these scenes is a disk body spinning on a hinge in an axisymmetric hub (the hub
carries the free joint, so that no body frame spins with the wheel and steady rolling is a
steady state of the model): the pair rolls like one wheel with ``m`` the total mass, ``A`` the
hub's and the disk's transverse moments together and ``C`` the spinning disk's axial moment
alone (the hub's turning about the axle is a free, decoupled motion at zero frequency).

Chaplygin's sleigh (Bloch 2003, *Nonholonomic Mechanics and Control*, sec. 1.7; Neimark and
Fufaev 1972): a body of mass ``m`` and central moment ``I`` about the vertical whose knife edge
at distance ``a`` behind its mass centre cannot move sideways; sliding straight ahead at speed
``u`` its yaw rate obeys ``omega' = -m a u omega / (I + m a^2)``: one eigenvalue
``-m a u / (I + m a^2)``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import Body, Constraint, Joint, ModelError, OperatingPoint, Scene, compile_model, simulate
from linflex.linearize import constrained_linearization

G = 9.81


def disk_scene(v: float, *, R: float = 0.5, md: float = 2.0, mh: float = 0.3, Ah: float = 0.01, Ch: float = 0.02,
               axis=(0.0, 1.0, 0.0), **contact) -> Scene:
    """A thin uniform disk (mass ``md``) spinning about y on a hub (mass ``mh``, moments ``Ah``,
    ``Ch``), rolling along +x at ``v`` [m/s] on level ground (z up)."""
    return Scene("disk", effects=["gravity"],
                 bodies=[Body("hub", mh, (Ah, Ch, Ah)), Body("disk", md, (md * R**2 / 4, md * R**2 / 2, md * R**2 / 4))],
                 joints=[Joint("float", "free", "hub", q0=[0, 0, R, 1, 0, 0, 0], u0=[v, 0, 0, 0, 0, 0]),
                         Joint("spin", "revolute", "disk", parent="hub", axis=[0, 1, 0], u0=v / R)],
                 constraints=[Constraint("contact", "rolling", "disk", axis=list(axis), radius=R, **contact)])


def closed_form(v: float, *, R: float = 0.5, md: float = 2.0, mh: float = 0.3, Ah: float = 0.01) -> complex:
    """The lean eigenvalue with non-negative real and imaginary parts [1/s] (module notes)."""
    m, A, C, Om = md + mh, md * R**2 / 4 + Ah, md * R**2 / 2, v / R
    return np.sqrt(complex((m * G * R - C * (C + m * R**2) * Om**2 / A) / (A + m * R**2)))


def lean_pair(model, method: str = "kane", op=None) -> np.ndarray:
    """The two eigenvalues of the constrained linearization largest in magnitude, and the rest."""
    lin = constrained_linearization(model, op, method=method, allow_non_equilibrium=True)
    ev = np.linalg.eigvals(lin.sys.A)
    ev = ev[np.argsort(-np.abs(ev))]
    return ev[:2], ev[2:], lin


@settings(derandomize=True, max_examples=12, deadline=None)
@given(v=st.floats(0.0, 6.0), R=st.floats(0.1, 1.0), md=st.floats(0.5, 10.0), mh=st.floats(0.01, 2.0),
       Ah=st.floats(1e-3, 0.1), axial=st.floats(0.05, 1.0))
def test_rolling_disk_lean_eigenvalues_match_the_closed_form(v, R, md, mh, Ah, axial):
    Ch = 2 * Ah * axial  # the hub's axial moment (at most twice the transverse: a physical body)
    want = closed_form(v, R=R, md=md, mh=mh, Ah=Ah)
    model = compile_model(disk_scene(v, R=R, md=md, mh=mh, Ah=Ah, Ch=Ch))
    pair, rest, lin = lean_pair(model)
    if abs(want) < 1e-3:  # at the critical speed itself the pair joins the zero eigenvalues
        return
    # Kane's direct linearization is exact: the lean pair to round-off (relative 1e-10), every
    # other eigenvalue zero (heading, position, spin angle, the hub's free turning), Jordan blocks
    # at sqrt(eps) included.
    assert np.sort(np.abs(pair.imag)) == pytest.approx([want.imag] * 2, rel=1e-10, abs=1e-10 * abs(want))
    assert np.sort(np.abs(pair.real)) == pytest.approx([want.real] * 2, rel=1e-10, abs=1e-10 * abs(want))
    assert np.max(np.abs(rest)) < 1e-6
    assert lin.invariance_residual < 1e-12


def test_thin_uniform_disk_is_stable_above_sqrt_gR_over_3():
    # The hub's mass and moments at 1e-6 of the disk's: the critical speed is sqrt(g R / 3) to
    # about 1e-6 (the closed form with the hub: v_c^2 = m g R^3 A / (C (C + m R^2))).
    R, md = 0.5, 2.0
    hub = dict(R=R, md=md, mh=1e-6 * md, Ah=1e-6 * md * R**2 / 4)
    v_c = np.sqrt(G * R / 3)
    m, A, C = md + hub["mh"], md * R**2 / 4 + hub["Ah"], md * R**2 / 2
    assert np.sqrt(m * G * R**3 * A / (C * (C + m * R**2))) == pytest.approx(v_c, rel=2e-6)
    for factor, stable in ((0.99, False), (1.01, True)):
        model = compile_model(disk_scene(factor * v_c, Ch=1e-6 * md * R**2 / 2, **hub))
        pair, _, _ = lean_pair(model)
        want = closed_form(factor * v_c, **hub)
        assert np.max(pair.real) == pytest.approx(0.0 if stable else want.real, abs=1e-10)
        assert np.max(pair.imag) == pytest.approx(want.imag if stable else 0.0, abs=1e-10)


# The difference methods reach the accuracy the model's measured noise allows, without
# warnings (a smooth model: no kink, no jump); the eigenvalues are checked to that accuracy.
@pytest.mark.filterwarnings("error::linflex.AccuracyWarning")
@pytest.mark.parametrize("formulation", ["dense", "order-n"])
@pytest.mark.parametrize("method, tol", [("kane", 1e-11), ("autodiff", 1e-11), ("central", 1e-7),
                                         ("perturbation", 1e-5)])
def test_every_method_and_formulation_gives_the_lean_mode(formulation, method, tol):
    want = closed_form(2.0)  # 4.3057 rad/s: stable (above 1.43 m/s)
    model = compile_model(disk_scene(2.0), formulation=formulation)
    pair, _, lin = lean_pair(model, method)
    assert np.sort(pair.imag) == pytest.approx([-want.imag, want.imag], abs=tol * abs(want))
    assert np.max(np.abs(pair.real)) < tol * abs(want)
    # The full linearization has the constraints' stabilization eigenvalues besides: Baumgarte's
    # kd = 20 on the non-holonomic rows, the double root of s^2 + 20 s + 100 on the holonomic one.
    full = np.linalg.eigvals(lin.full.sys.A)
    assert np.sum(np.abs(full + 20.0) < 1e-5) == 2 and np.sum(np.abs(full + 10.0) < 1e-4) == 2


def test_contact_force_is_the_weight_in_steady_rolling():
    model = compile_model(disk_scene(2.0, md=2.0, mh=0.3))
    _, y = model.evaluate(model.x0)
    force = dict(zip(model.outputs, y))
    # Steady rolling: no friction along the ground, the normal force carries the weight [N].
    assert force["contact.force.z"] == pytest.approx(2.3 * G, rel=1e-13)
    assert abs(force["contact.force.x"]) < 1e-12 and abs(force["contact.force.y"]) < 1e-12


def test_contact_force_in_a_lean_balances_the_turn():
    # Leaning by 0.2 rad from rest: the disk starts to fall; the contact force's vertical part
    # m (g + z'') and its horizontal part m x_G'' follow from the model's own accelerations.
    scene = disk_scene(0.0)
    model = compile_model(scene)
    x = np.array(model.x0)
    lean = 0.2  # about the x axis: the hub's quaternion; Newton puts the contact back on the ground
    x[3:7] = [np.cos(lean / 2), np.sin(lean / 2), 0, 0]
    model = compile_model(scene.replace(joints=(scene.joints[0].__class__(
        "float", "free", "hub", q0=[0, 0, 0.5, *x[3:7]], u0=[0, 0, 0, 0, 0, 0]), scene.joints[1])))
    x0 = model.x0
    assert x0[2] == pytest.approx(0.5 * np.cos(lean), rel=1e-12)  # the centre's height [m]
    xdot, y = model.evaluate(x0)
    force = dict(zip(model.outputs, y))
    # The mass centre (the hub's origin) accelerates at (vx', vy', vz') [m/s^2].
    acc = xdot[[8, 9, 10]]
    weight = np.array([0.0, 0.0, -2.3 * G])
    F = np.array([force[f"contact.force.{c}"] for c in "xyz"])
    assert F + weight == pytest.approx(2.3 * acc, abs=1e-11)


def sleigh(u: float, a: float, m: float = 3.0, Iz: float = 0.4, formulation: str = "dense"):
    """A sled whose knife edge is at its body origin, mass centre ``a`` [m] ahead (x), sliding
    along x at ``u`` [m/s] on level ground (the height held)."""
    scene = Scene("sleigh", bodies=[Body("sled", m, (0.1, 0.3, Iz), com=[a, 0, 0])],
                  joints=[Joint("slide", "free", "sled", locked=["z"], u0=[u, 0, 0, 0, 0, 0])],
                  constraints=[Constraint("edge", "knife_edge", "sled", axis=[0, 1, 0])])
    return compile_model(scene, formulation=formulation)


@pytest.mark.parametrize("formulation", ["dense", "order-n"])
@pytest.mark.parametrize("u, a", [(1.5, 0.4), (1.5, -0.4), (-2.0, 0.25)])
def test_chaplygin_sleigh_yaw_eigenvalue(u, a, formulation):
    m, Iz = 3.0, 0.4
    model = sleigh(u, a, m, Iz, formulation)
    for method in ("kane", "autodiff"):
        lin = constrained_linearization(model, method=method, allow_non_equilibrium=True)
        ev = np.linalg.eigvals(lin.sys.A)
        big = ev[np.abs(ev) > 1e-6]
        assert big.size == 1 and big[0] == pytest.approx(-m * a * u / (Iz + m * a**2), rel=1e-12)
    # The edge's force is the only lateral force: zero in straight sliding [N].
    _, y = model.evaluate(model.x0)
    assert np.max(np.abs(y)) < 1e-12


def test_knife_edge_speeds_are_made_consistent():
    # Start sliding partly sideways: the lateral speed is removed from the initial state.
    model = compile_model(Scene("sleigh", bodies=[Body("sled", 3.0, (0.1, 0.3, 0.4), com=[0.4, 0, 0])],
                                joints=[Joint("slide", "free", "sled", locked=["z"], u0=[1.0, 0.3, 0, 0, 0, 0])],
                                constraints=[Constraint("edge", "knife_edge", "sled", axis=[0, 1, 0])]))
    assert model.constraints.residual(model.x0)[1] == pytest.approx([0.0], abs=1e-14)
    assert model.constraints.rows == ("edge.lateral",)
    op = OperatingPoint(model.x0)
    assert constrained_linearization(model, op, allow_non_equilibrium=True).dependent == ("slide.vy",)


def test_a_wheel_lying_flat_is_refused_with_the_entry_path():
    with pytest.raises(ModelError, match=r"constraints\[0\] \('contact'\): the rolling constraint is singular at the "
                                         r"initial configuration: the wheel's axis is along the ground's normal"):
        compile_model(disk_scene(1.0, axis=(0.0, 0.0, 1.0)))


def test_a_contact_that_cannot_close_names_the_entry():
    # The plane 2 m below the wheel, which hangs from a hinge: Newton cannot reach the ground.
    scene = Scene("hanging", effects=["gravity"],
                  bodies=[Body("wheel", 1.0, (0.1, 0.2, 0.1))],
                  joints=[Joint("axle", "revolute", "wheel", axis=[0, 1, 0], parent_point=[0, 0, 2.5])],
                  constraints=[Constraint("contact", "rolling", "wheel", radius=0.5, height=-2.0)])
    with pytest.raises(ModelError, match=r"constraints\[0\] \(contact\): the initial coordinates do not close the "
                                         r"loop: constraint row 'contact.normal' is off by"):
        compile_model(scene)


def test_a_contact_on_a_flexible_body_is_refused():
    scene = Scene("s", bodies=[Body("boom", 0.0, type="flexible", modes=2, beam={
        "length": 2.0, "EI": 50.0, "EA": 1e6, "GJ": 40.0, "mass_per_length": 0.5})],
        joints=[Joint("j", "free", "boom")], constraints=[Constraint("c", "knife_edge", "boom")])
    assert any(p.startswith("constraints[0].body: 'boom' is flexible") for p in scene.problems())


@pytest.mark.parametrize("entry, path, message", [
    (dict(kind="rolling"), "constraints[0].radius", "needs the wheel's radius"),
    (dict(kind="skid", radius=0.3), "constraints[0].kind", "unknown constraint kind 'skid'"),
    (dict(kind="knife_edge", radius=0.3), "constraints[0].radius", "only rolling contacts have a radius"),
    (dict(kind="rolling", radius=-0.3), "constraints[0].radius", "must be positive"),
    (dict(kind="rolling", radius=0.3, normal=[0, 0, 0]), "constraints[0].normal", "must not be the zero vector"),
    (dict(kind="rolling", radius=0.3, axis=[0, 1]), "constraints[0].axis", "expected a 3-vector"),
    (dict(kind="rolling", radius=0.3, baumgarte=[-1, 0]), "constraints[0].baumgarte", "must not be negative"),
    (dict(kind="rolling", radius=0.3, body="wheel2"), "constraints[0].body", "unknown body 'wheel2'"),
])
def test_bad_constraint_entries_are_reported_with_their_path(entry, path, message):
    fields = {"name": "contact", "body": "wheel", **entry}
    scene = Scene("s", bodies=[Body("wheel", 1.0, (0.1, 0.2, 0.1))], joints=[Joint("j", "free", "wheel")],
                  constraints=[fields])
    problems = scene.problems()
    assert any(p.startswith(f"{path}:") and message in p for p in problems), problems


@pytest.mark.filterwarnings("error::linflex.AccuracyWarning")
def test_linearized_contact_forces_agree_across_methods():
    # The multipliers are outputs: their linearization (C, D of the restricted system) by Kane's
    # direct linearization, by automatic differentiation of the compiled model and by central
    # differences are three independent computations of the same matrices.
    model = compile_model(disk_scene(2.0))
    C = {m: constrained_linearization(model, method=m, allow_non_equilibrium=True).sys.C
         for m in ("kane", "autodiff", "central")}
    scale = np.max(np.abs(C["kane"]))
    assert scale > 1.0  # a lean moves the contact force (N per rad): the check is not vacuous
    assert np.max(np.abs(C["autodiff"] - C["kane"])) < 1e-12 * scale
    assert np.max(np.abs(C["central"] - C["kane"])) < 1e-7 * scale


def test_rolling_disk_example_finds_the_critical_speed(capsys, tmp_path):
    import importlib.util
    from pathlib import Path

    import linflex

    path = Path(__file__).resolve().parents[2] / "examples" / "scene_rolling_disk.py"
    spec = importlib.util.spec_from_file_location("scene_rolling_disk", path)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    critical, exact = example.main()
    # Where the lean pair's product changes sign, against Routh's closed form [m/s].
    assert critical == pytest.approx(exact, rel=1e-12)
    assert "closed form +0.000000+8.841655j" in capsys.readouterr().out
    scene = linflex.load_scene(example.SCENE)
    scene.save(tmp_path / "copy.toml")
    assert linflex.load_scene(tmp_path / "copy.toml") == scene


def test_simulated_rolling_conserves_energy_in_both_formulations():
    # A lean rate of 0.5 rad/s at 2 m/s (above the critical speed): the disk wobbles by 0.12 rad
    # and rolls on. Rolling without slip does no work, so the energy is conserved (to the
    # integrator's tolerance: measured 2e-13 and 7e-13 relative); the contact holds (the
    # constraints to 1e-10, Baumgarte-stabilized) and both formulations give one motion.
    scene = disk_scene(2.0)
    scene = scene.replace(joints=(Joint("float", "free", "hub", q0=[0, 0, 0.5, 1, 0, 0, 0],
                                        u0=[2.0, 0, 0, 0.5, 0, 0]), scene.joints[1]))
    t = np.linspace(0.0, 3.0, 301)
    runs = []
    for formulation in ("dense", "order-n"):
        model = compile_model(scene, formulation=formulation)
        # The initial speeds made consistent: the centre moves sideways as the disk leans [m/s].
        assert model.x0[model.states.index("float.vy")] == pytest.approx(-0.25, abs=1e-14)
        run = simulate(model, t, rtol=1e-11, atol=1e-13)
        energy = np.array([float(model.compiled.energy(x, 0.0)) for x in run.x])
        assert np.max(np.abs(energy - energy[0])) < 1e-11 * abs(energy[0])
        assert max(np.max(np.abs(np.concatenate(model.constraints.residual(x)))) for x in run.x) < 1e-9
        lean = 2 * np.arcsin(np.asarray(run["float.qx"]))
        assert 0.1 < np.max(np.abs(lean)) < 0.15  # [rad]: about 0.5 / 4.3 rad/s, the lean mode
        runs.append(np.asarray(run.x))
    assert np.max(np.abs(runs[0] - runs[1])) < 1e-8


def test_a_wheel_pushed_by_a_prescribed_carrier_turns_at_v_over_R():
    # The carrier slides at a prescribed 1 m/s (a ramp); the wheel's only freedom, its spin, is
    # fixed by the rolling constraint: 2 rad/s for R = 0.5 m, the normal and lateral rows
    # dependent (no multipliers), the constraint exact along the motion (time-dependent rows).
    scene = Scene("cart", effects=["gravity"],
                  bodies=[Body("carrier", 1.0, (0.1, 0.1, 0.1)), Body("wheel", 1.0, (0.1, 0.2, 0.1))],
                  joints=[Joint("slide", "prismatic", "carrier", axis=[1, 0, 0], parent_point=[0, 0, 0.5],
                                prescribed={"profile": "ramp", "offset": 0.0, "rate": 1.0}),
                          Joint("axle", "revolute", "wheel", parent="carrier", axis=[0, 1, 0])],
                  constraints=[Constraint("contact", "rolling", "wheel", radius=0.5)])
    model = compile_model(scene)
    assert model.x0[model.states.index("axle.rate")] == pytest.approx(2.0, rel=1e-15)
    assert model.constraints.independent_rows == (1,)
    run = simulate(model, np.linspace(0.0, 2.0, 21), rtol=1e-10, atol=1e-12)
    assert np.asarray(run["axle.angle"])[-1] == pytest.approx(4.0, rel=1e-8)  # [rad] after 2 m
