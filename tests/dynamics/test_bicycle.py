"""The benchmark bicycle as a scene (``examples/bicycle.toml``) against the published benchmark.

Reference: J. P. Meijaard, J. M. Papadopoulos, A. Ruina and A. L. Schwab, "Linearized dynamics
equations for the balance and steer of a bicycle: a benchmark and review", Proc. R. Soc. A 463
(2007) 1955-1982. Table 1 gives the parameters (in the scene), Table 2 the results: (a) the weave
speed 4.29238253634111 m/s and the capsize speed 6.02426201538837 m/s; (b, c) the eigenvalues of
the lean and steer dynamics at the forward speeds 0, 1, ..., 10 m/s to 14 decimals. The values
below are Table 2 as printed (transcribed as in D. L. Peterson's 2011 test of his gyrostat
formulation, which checks them to 1e-12 to 1e-14).

The scene knows nothing of bicycles: four bodies, a free joint, three hinges and two rolling
contacts; the linear equations come from the constraint multipliers and the restriction to the
independent coordinates and speeds (``linflex.linearize.constrained_linearization``).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import linflex

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
_spec = importlib.util.spec_from_file_location("scene_bicycle", EXAMPLES / "scene_bicycle.py")
bicycle = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bicycle)

#: Table 2 (b, c): v [m/s] -> the four eigenvalues [1/s] (weave pair as complex conjugates).
TABLE_2 = {
    0: [-5.53094371765393, -3.13164324790656, 3.13164324790656, 5.53094371765393],
    1: [-7.11008014637442, -3.13423125066578, 3.52696170990070 + 0.80774027519930j],
    2: [-8.67387984831735, -3.07158645641514, 2.68234517512745 + 1.68066296590675j],
    3: [-10.35101467245920, -2.63366137253667, 1.70675605663975 + 2.31582447384325j],
    4: [-12.15861426576450, -1.42944427361326, 0.41325331521125 + 3.07910818603206j],
    5: [-14.07838969279820, -0.32286642900409, -0.77534188219585 + 4.46486771378823j],
    6: [-16.08537123098030, -0.00406690076970, -1.52644486584142 + 5.87673060598709j],
    7: [-18.15788466125262, 0.10268170574766, -2.13875644258362 + 7.19525913329805j],
    8: [-20.27940894394569, 0.14327879765713, -2.69348683581097 + 8.46037971396931j],
    9: [-22.43788559040858, 0.15790184030917, -3.21675402252485 + 9.69377351531791j],
    10: [-24.62459635017404, 0.16105338653172, -3.72016840437287 + 10.90681139476287j],
}
WEAVE_SPEED, CAPSIZE_SPEED = 4.29238253634111, 6.02426201538837  # Table 2 (a) [m/s]


def published(v: int) -> np.ndarray:
    values = TABLE_2[v]
    full = values if v == 0 else values[:2] + [values[2], np.conj(values[2])]
    return np.sort_complex(np.array(full, complex))


@pytest.fixture(scope="module")
def models():
    return {form: bicycle.compile_bicycle(form) for form in ("dense", "order-n")}


@pytest.mark.parametrize("method", ["kane", "autodiff"])
@pytest.mark.parametrize("formulation", ["dense", "order-n"])
def test_eigenvalues_reproduce_table_2(models, method, formulation):
    # Exact derivatives: every eigenvalue to the 14 printed decimals, up to the last digit's
    # rounding and the eigenvalue solver's round-off (measured worst 6.0e-13 over the table) [1/s].
    for v in TABLE_2:
        got = bicycle.lean_steer_eigenvalues(models[formulation], float(v), method)
        assert np.max(np.abs(got - published(v))) < 3e-13 * max(1.0, np.max(np.abs(published(v)))), v


@pytest.mark.filterwarnings("error::linflex.AccuracyWarning")
@pytest.mark.parametrize("method", ["perturbation", "central"])
@pytest.mark.parametrize("formulation", ["dense", "order-n"])
def test_eigenvalues_by_differences(models, method, formulation):
    # Finite differences (the numerical methods) on this smooth model: measured worst 2.3e-12
    # (one-sided) and 5.9e-13 (central) over the table; no warning: the constrained model's
    # noise (its accelerations come from a solve) is measured, not mistaken for kinks or jumps.
    for v in (2, 5, 8):
        got = bicycle.lean_steer_eigenvalues(models[formulation], float(v), method)
        assert np.max(np.abs(got - published(v))) < 1e-10 * np.max(np.abs(published(v))), v


def test_weave_and_capsize_speeds(models):
    # The crossings of the largest real part through zero, by Brent's method on the exact
    # linearization: the published 14 decimals to 1e-12 m/s (measured 1.8e-15 and 2.0e-14).
    weave, capsize = bicycle.critical_speeds(models["dense"])
    assert weave == pytest.approx(WEAVE_SPEED, abs=1e-12)
    assert capsize == pytest.approx(CAPSIZE_SPEED, abs=1e-12)
    # And the self-stable range between them: every real part negative at 5 m/s, not at 4 or 7.
    assert np.max(bicycle.lean_steer_eigenvalues(models["dense"], 5.0).real) < 0
    assert np.max(bicycle.lean_steer_eigenvalues(models["dense"], 4.0).real) > 0
    assert np.max(bicycle.lean_steer_eigenvalues(models["dense"], 7.0).real) > 0


def test_contact_forces_carry_the_weight(models):
    # Steady running: no force along the ground; the normal forces split the weight by the
    # moments about the rear contact (scene z down: the ground pushes the wheels up) [N].
    model = models["dense"]
    _, y = model.evaluate(model.x0)
    force = dict(zip(model.outputs, y))
    masses = {"rear_frame": (85.0, 0.3), "rear_wheel": (2.0, 0.0), "front_frame": (4.0, 0.9), "front_wheel": (3.0, 1.02)}
    weight = 9.81 * sum(m for m, _ in masses.values())
    front = 9.81 * sum(m * x for m, x in masses.values()) / 1.02
    assert force["front_contact.force.z"] == pytest.approx(-front, rel=1e-12)
    assert force["rear_contact.force.z"] == pytest.approx(-(weight - front), rel=1e-12)
    for name in ("rear_contact", "front_contact"):
        assert abs(force[f"{name}.force.x"]) < 1e-9 and abs(force[f"{name}.force.y"]) < 1e-9


def test_the_example_prints_the_table_and_returns_the_critical_speeds(capsys):
    weave, capsize = bicycle.main()
    assert (weave, capsize) == pytest.approx((WEAVE_SPEED, CAPSIZE_SPEED), abs=1e-12)
    assert "v = 10.0 m/s: -24.624596" in capsys.readouterr().out


def test_scene_round_trips(tmp_path):
    scene = linflex.load_scene(bicycle.SCENE)
    scene.save(tmp_path / "copy.toml")
    assert linflex.load_scene(tmp_path / "copy.toml") == scene
    assert [c.kind for c in scene.constraints] == ["rolling", "rolling"]


def test_nonlinear_running_follows_the_linearization(models):
    # From upright running at 5 m/s (self-stable) with a lean rate eps [rad/s], consistent with the
    # constraints through the restriction's basis: the simulated lean angle differs from the
    # linear response by O(eps^3) (the bicycle is symmetric under a mirror, so no eps^2 term:
    # doubling eps multiplies the difference by 8), the rolling contacts do no work (energy
    # conserved to round-off) and the constraints hold to the integrator's accuracy.
    from linflex.linearize import constrained_linearization

    model = models["dense"]
    op = bicycle.operating_point(model, 5.0)
    lin = constrained_linearization(model, op, method="kane", allow_non_equilibrium=True,
                                    independent=bicycle.INDEPENDENT)
    t = np.linspace(0.0, 5.0, 501)
    differences = []
    for eps in (1e-3, 2e-3):
        dz = np.zeros(len(lin.independent))
        dz[lin.independent.index("frame.wx")] = eps
        run = linflex.simulate(model, t, x0=op.x + lin.basis @ dz, rtol=1e-12, atol=1e-14)
        linear = linflex.initial_response(lin.sys, t, dz)
        lean, lean_linear = 2 * np.asarray(run["frame.qx"]), 2 * np.asarray(linear["frame.qx"])  # [rad]
        assert abs(lean_linear[-1]) < 0.05 * np.max(np.abs(lean_linear))  # it decays (stable at 5 m/s)
        differences.append(np.max(np.abs(lean - lean_linear)))
        energy = np.array([float(model.compiled.energy(x, 0.0)) for x in run.x])
        assert np.max(np.abs(energy - energy[0])) < 1e-12 * abs(energy[0])
        assert max(np.max(np.abs(np.concatenate(model.constraints.residual(x)))) for x in run.x) < 1e-9
    assert differences[0] < 1e-6 * 2.1e-4  # measured 7.4e-11 rad against a 2.1e-4 rad lean
    assert differences[1] / differences[0] == pytest.approx(8.0, rel=0.01)


#: The published coefficient matrices (Meijaard et al. 2007, eq. A 1 / section 5: M q'' + v C1 q'
#: + (g K0 + v^2 K2) q = f with q = (lean, steer)), to the printed 14 decimals.
M_PUB = np.array([[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]])
C1_PUB = np.array([[0.0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]])
K0_PUB = np.array([[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]])
K2_PUB = np.array([[0.0, 76.59734589573222], [0.0, 2.65431523794604]])


@pytest.mark.parametrize("v", [1.5, 5.0])
def test_lean_and_steer_equations_match_the_published_matrices(models, v):
    # Entry by entry, not only the eigenvalues: the rows of the lean and steer accelerations of
    # the restricted linearization are -M^-1 (g K0 + v^2 K2) on (lean, steer) and -v M^-1 C1 on
    # their rates (lean = 2 qx to first order, its rate wx); measured 1.5e-14 and 2.7e-14 relative.
    from linflex.linearize import constrained_linearization

    lin = constrained_linearization(models["dense"], bicycle.operating_point(models["dense"], v), method="kane",
                                    allow_non_equilibrium=True, independent=bicycle.INDEPENDENT)
    names = list(lin.sys.states)
    rows = [names.index("frame.wx"), names.index("steer.rate")]
    A = lin.sys.A
    stiffness = -A[np.ix_(rows, [names.index("frame.qx"), names.index("steer.angle")])] * np.array([0.5, 1.0])
    damping = -A[np.ix_(rows, [names.index("frame.wx"), names.index("steer.rate")])]
    want_K = np.linalg.solve(M_PUB, 9.81 * K0_PUB + v**2 * K2_PUB)
    want_C = np.linalg.solve(M_PUB, v * C1_PUB)
    assert np.max(np.abs(stiffness - want_K)) < 1e-11 * np.max(np.abs(want_K))
    assert np.max(np.abs(damping - want_C)) < 1e-11 * np.max(np.abs(want_C))


# -- any bicycle: the scene against the benchmark paper's closed-form coefficients ------------------

#: Table 1 of the paper, its names: wheelbase w, trail c, steer axis tilt lam, rear (R) and front
#: (F) wheel radii, masses, moments; rear frame (B) and front frame (H) mass centres (x, z) [m],
#: masses [kg] and moments [kg m^2]; z down.
BENCHMARK = dict(w=1.02, c=0.08, lam=np.pi / 10, g=9.81, rR=0.3, mR=2.0, IRxx=0.0603, IRyy=0.12, xB=0.3, zB=-0.9,
                 mB=85.0, IBxx=9.2, IByy=11.0, IBzz=2.8, IBxz=2.4, xH=0.9, zH=-0.7, mH=4.0, IHxx=0.05892, IHyy=0.06,
                 IHzz=0.00708, IHxz=-0.00756, rF=0.35, mF=3.0, IFxx=0.1405, IFyy=0.28)


def canonical(p: dict) -> tuple[np.ndarray, ...]:
    """``M, C1, K0, K2`` of the linearized lean and steer equations from the parameters, by the
    closed forms of the paper's Appendix A (total mass and inertia of the whole bicycle and of the
    front assembly about the steer axis, the gyrostatic coefficients ``S``)."""
    sl, cl = np.sin(p["lam"]), np.cos(p["lam"])
    w, c, rR, rF = p["w"], p["c"], p["rR"], p["rF"]
    mR, mB, mH, mF = p["mR"], p["mB"], p["mH"], p["mF"]
    xB, zB, xH, zH = p["xB"], p["zB"], p["xH"], p["zH"]
    mT = mR + mB + mH + mF
    xT = (xB * mB + xH * mH + w * mF) / mT
    zT = (-rR * mR + zB * mB + zH * mH - rF * mF) / mT
    ITxx = p["IRxx"] + p["IBxx"] + p["IHxx"] + p["IFxx"] + mR * rR**2 + mB * zB**2 + mH * zH**2 + mF * rF**2
    ITxz = p["IBxz"] + p["IHxz"] - mB * xB * zB - mH * xH * zH + mF * w * rF
    ITzz = p["IRxx"] + p["IBzz"] + p["IHzz"] + p["IFxx"] + mB * xB**2 + mH * xH**2 + mF * w**2
    mA = mH + mF
    xA, zA = (xH * mH + w * mF) / mA, (zH * mH - rF * mF) / mA
    IAxx = p["IHxx"] + p["IFxx"] + mH * (zH - zA) ** 2 + mF * (rF + zA) ** 2
    IAxz = p["IHxz"] - mH * (xH - xA) * (zH - zA) + mF * (w - xA) * (rF + zA)
    IAzz = p["IHzz"] + p["IFxx"] + mH * (xH - xA) ** 2 + mF * (w - xA) ** 2
    uA = (xA - w - c) * cl - zA * sl
    IAll = mA * uA**2 + IAxx * sl**2 + 2 * IAxz * sl * cl + IAzz * cl**2
    IAlx = -mA * uA * zA + IAxx * sl + IAxz * cl
    IAlz = mA * uA * xA + IAxz * sl + IAzz * cl
    mu = c / w * cl
    SR, SF = p["IRyy"] / rR, p["IFyy"] / rF
    ST, SA = SR + SF, mA * uA + mu * mT * xT
    M = np.array([[ITxx, IAlx + mu * ITxz], [IAlx + mu * ITxz, IAll + 2 * mu * IAlz + mu**2 * ITzz]])
    C1 = np.array([[0.0, mu * ST + SF * cl + ITxz / w * cl - mu * mT * zT],
                   [-(mu * ST + SF * cl), IAlz / w * cl + mu * (SA + ITzz / w * cl)]])
    K0 = np.array([[mT * zT, -SA], [-SA, -SA * sl]])
    K2 = np.array([[0.0, (ST - mT * zT) / w * cl], [0.0, (SA + SF * sl) / w * cl]])
    return M, C1, K0, K2


def bicycle_scene(p: dict, v: float) -> linflex.Scene:
    """The scene of ``examples/bicycle.toml`` for the parameters ``p``, running at ``v`` [m/s]."""
    w, c, rR, rF = p["w"], p["c"], p["rR"], p["rF"]

    def inertia(k):
        return [[p[f"I{k}xx"], 0, p[f"I{k}xz"]], [0, p[f"I{k}yy"], 0], [p[f"I{k}xz"], 0, p[f"I{k}zz"]]]

    return linflex.Scene(
        "bicycle", effects=["gravity"], environment={"gravity": [0, 0, p["g"]]},
        bodies=[linflex.Body("rear_frame", p["mB"], inertia("B"), com=[p["xB"], 0, p["zB"] + rR]),
                linflex.Body("rear_wheel", p["mR"], (p["IRxx"], p["IRyy"], p["IRxx"])),
                linflex.Body("front_frame", p["mH"], inertia("H"), com=[p["xH"] - w - c, 0, p["zH"]]),
                linflex.Body("front_wheel", p["mF"], (p["IFxx"], p["IFyy"], p["IFxx"]))],
        joints=[linflex.Joint("frame", "free", "rear_frame", q0=[0, 0, -rR, 1, 0, 0, 0], u0=[v, 0, 0, 0, 0, 0]),
                linflex.Joint("rear_hub", "revolute", "rear_wheel", parent="rear_frame", axis=[0, 1, 0], u0=-v / rR),
                linflex.Joint("steer", "revolute", "front_frame", parent="rear_frame",
                              axis=[np.sin(p["lam"]), 0, np.cos(p["lam"])], parent_point=[w + c, 0, rR]),
                linflex.Joint("front_hub", "revolute", "front_wheel", parent="front_frame", axis=[0, 1, 0],
                              parent_point=[-c, 0, -rF], u0=-v / rF)],
        constraints=[linflex.Constraint("rear_contact", "rolling", "rear_wheel", radius=rR, normal=[0, 0, -1]),
                     linflex.Constraint("front_contact", "rolling", "front_wheel", radius=rF, normal=[0, 0, -1])])


def test_the_closed_forms_give_the_published_matrices():
    for got, want in zip(canonical(BENCHMARK), (M_PUB, C1_PUB, K0_PUB, K2_PUB)):
        assert np.max(np.abs(got - want)) < 1e-13 * np.max(np.abs(want))
    # The example's scene is this builder's at the benchmark parameters (to the decimals written).
    toml, built = linflex.load_scene(bicycle.SCENE), bicycle_scene(BENCHMARK, 5.0)
    for a, b in zip(toml.bodies, built.bodies):
        assert (a.name, a.mass) == (b.name, b.mass)
        assert np.allclose(np.array(a.inertia, float), np.array(b.inertia, float), rtol=0, atol=1e-15)
        assert np.allclose(a.com, b.com, rtol=0, atol=1e-15)
    for a, b in zip(toml.joints, built.joints):
        for key in ("axis", "parent_point", "q0", "u0"):
            assert np.allclose(np.array(getattr(a, key) or 0.0, float), np.array(getattr(b, key) or 0.0, float),
                               rtol=1e-15, atol=1e-15), (a.name, key)


@settings(derandomize=True, max_examples=8, deadline=None)
@given(scales=st.lists(st.floats(0.8, 1.25), min_size=16, max_size=16), lam=st.floats(0.1, 0.5),
       v=st.floats(0.0, 10.0))
def test_any_bicycle_matches_the_closed_forms(scales, lam, v):
    # Geometry, masses and mass centres scaled one by one, each body's moments together (so that
    # they stay a physical inertia), the steer axis tilted anywhere from 6 to 29 deg: the restricted
    # linearization of the scene against the paper's closed forms, entry by entry.
    from linflex.linearize import constrained_linearization

    p = dict(BENCHMARK, lam=lam)
    for key, s in zip(("w", "c", "rR", "rF", "mR", "mB", "mH", "mF", "xB", "zB", "xH", "zH"), scales):
        p[key] *= s
    for body, s in zip("RBHF", scales[12:]):
        for key in [k for k in BENCHMARK if k.startswith(f"I{body}")]:
            p[key] *= s
    model = linflex.compile_model(bicycle_scene(p, v))
    lin = constrained_linearization(model, method="kane", allow_non_equilibrium=True,
                                    independent=bicycle.INDEPENDENT)
    names = list(lin.sys.states)
    rows = [names.index("frame.wx"), names.index("steer.rate")]
    A = lin.sys.A
    stiffness = -A[np.ix_(rows, [names.index("frame.qx"), names.index("steer.angle")])] * np.array([0.5, 1.0])
    damping = -A[np.ix_(rows, [names.index("frame.wx"), names.index("steer.rate")])]
    M, C1, K0, K2 = canonical(p)
    want_K, want_C = np.linalg.solve(M, p["g"] * K0 + v**2 * K2), np.linalg.solve(M, v * C1)
    assert np.max(np.abs(stiffness - want_K)) < 1e-11 * np.max(np.abs(want_K))
    # [1/s]; scaled by the damping or, as it vanishes with v, by the square root of the stiffness.
    assert np.max(np.abs(damping - want_C)) < 1e-11 * max(np.max(np.abs(want_C)), np.sqrt(np.max(np.abs(want_K))))
