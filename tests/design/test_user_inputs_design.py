"""linflex.design on what a hurried user types: extreme roll-off requests, bad weights, a build that
always fails, tolerances and shapes that scipy would refuse obscurely (references named per test)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ModelError
from linflex.design import lqg, lqr, notch_at, pid_from_bandwidth, roll_off, tune
from linflex.frequency import Loop

FAST = dict(derandomize=True, deadline=None, max_examples=25)


def gain_db(sys, w):
    s = 1j * w
    g = (sys.C @ np.linalg.solve(s * np.eye(sys.n_states) - sys.A, sys.B) + sys.D)[0, 0]
    return 20 * np.log10(abs(g))


@settings(**FAST)
@given(att=st.floats(1e-3, 600.0), damping=st.one_of(st.none(), st.floats(0.7072, 1e8)), sections=st.integers(1, 3))
def test_roll_off_meets_any_finite_attenuation_and_damping(att, damping, sections):
    # Reference: the definition, -att dB at the frequency (20 log10 |G(j f)| of the realization);
    # 1e-9 dB + 1e-10 relative: rounding of the corner and of the evaluation. Before the fix a deep
    # attenuation (e.g. 400 dB) or a large damping (1e9) left brentq's bracket: a bare ValueError.
    f = roll_off(10.0, att, damping=damping, sections=sections)
    assert abs(gain_db(f, 10.0) + att) <= 1e-9 + 1e-10 * att


@pytest.mark.parametrize("damping", ["x", float("inf"), float("nan"), True])
def test_roll_off_damping_must_be_a_finite_number(damping):
    with pytest.raises(ModelError, match="damping must be a finite number"):
        roll_off(10.0, 20.0, damping=damping)


def test_roll_off_sections_is_not_a_bool():
    with pytest.raises(ModelError, match="sections must be a positive integer"):
        roll_off(10.0, 20.0, sections=True)


DOUBLE_INTEGRATOR = LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]])


@pytest.mark.parametrize("Q, R, message", [
    ([1.0, 1.0, 1.0], 1.0, r"Q must be a finite \(2, 2\) matrix or 2 diagonal entries, got shape \(3,\)"),
    ("a", 1.0, "Q must be a finite"),
    ([-1.0, 1.0], 1.0, "Q must be positive semidefinite; its smallest eigenvalue is -1"),
    ([1.0, 1.0], 0.0, "R must be positive definite; its smallest eigenvalue is 0"),
    ([1.0, 1.0], -1.0, "R must be positive definite"),
])
def test_lqr_weights_are_checked_and_named(Q, R, message):
    # A negative Q used to pass to python-control and return a gain for no optimal problem; a wrong
    # length raised numpy's broadcast error.
    with pytest.raises(ModelError, match=message):
        lqr(DOUBLE_INTEGRATOR, Q, R)


def test_lqr_scalar_and_one_entry_weights_broadcast():
    # Reference (closed form): the double integrator with unit weights, K = [1, sqrt(3)], 1e-12.
    for Q in (1.0, [1.0], [1.0, 1.0]):
        np.testing.assert_allclose(lqr(DOUBLE_INTEGRATOR, Q, [1.0]).K, [[1.0, np.sqrt(3.0)]], rtol=1e-12)


def test_lqg_measurement_noise_and_outputs_are_checked():
    with pytest.raises(ModelError, match="measurement_noise must be positive definite"):
        lqg(DOUBLE_INTEGRATOR, [1.0, 1.0], 1.0, 1.0, 0.0)
    with pytest.raises(ModelError, match="the plant has no outputs"):
        lqg(LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]]), [1.0, 1.0], 1.0, 1.0, [])


def rigid_pd_loop(w):
    plant = LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0 / 50.0]], [[1.0, 0.0], [0.0, 1.0]])
    g = pid_from_bandwidth([50.0], w)
    gain = LinearSystem(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), [[g.kp[0], g.kd[0]]])
    return Loop(plant, gain, sensors=["y0", "y1"], actuators=["u0"])


def test_tune_reports_a_build_that_always_fails_not_infeasible_requirements():
    # A loop that names a sensor the plant lacks: every margin computation fails with the same
    # ModelError. tune used to answer "no parameters within the bounds pass the requirements".
    def broken(w):
        loop = rigid_pd_loop(w)
        return Loop(loop.plant, loop.controller, sensors=["y0", "gyro"], actuators=["u0"])

    with pytest.raises(ModelError, match=r"could not be computed at any of the 17 parameters tried.*gyro"):
        tune(broken, (0.05, 20.0), {"delay_margin_s": 0.2})


@pytest.mark.parametrize("kwargs, message", [
    (dict(bounds=("a", 1.0)), "bounds must be"),
    (dict(xtol=0.0), r"xtol must be a relative tolerance in \(0, 1\), got 0.0"),
    (dict(xtol=-1.0), "xtol must be"),
    (dict(requirements={"phase_margin": 30.0}), "requirements: .*'phase_margin'; tune checks gain_margin_db"),
    (dict(bounds=[(0.05, 20.0), (0.0, 1.0)], x0=[1.0, 2.0, 3.0], objective=lambda x: -x[0]),
     r"x0 must hold one value per parameter, shape \(2,\), got shape \(3,\)"),
])
def test_tune_validates_its_options(kwargs, message):
    args = dict(bounds=(0.05, 20.0), requirements={"delay_margin_s": 0.2}) | kwargs
    build = (lambda x: rigid_pd_loop(x[0])) if np.ndim(args["bounds"]) == 2 else rigid_pd_loop
    with pytest.raises(ModelError, match=message):
        tune(build, args.pop("bounds"), args.pop("requirements"), **args)


def test_notch_at_and_pid_refuse_what_is_not_a_number():
    plant = LinearSystem([[0.0, 1.0], [-25.0, -0.05]], [[0.0], [1.0]], [[1.0, 0.0]])
    with pytest.raises(ModelError, match="width must be a real number, got 'wide'"):
        notch_at(plant, 5.0, width="wide")
    with pytest.raises(ModelError, match="mode must be an index, a state name or a frequency"):
        notch_at(plant, True)
    with pytest.raises(ModelError, match="bandwidth must be a real number, got True"):
        pid_from_bandwidth(50.0, True)
    with pytest.raises(ModelError, match="one axis at least"):
        pid_from_bandwidth([], 1.0)
    # Reference (closed form): kp = J w^2 = 200, kd = 2 z w J = 140 for J = 50, w = 2, z = 0.7; 1e-14.
    g = pid_from_bandwidth(50.0, 2.0)
    np.testing.assert_allclose([g.kp[0], g.kd[0]], [200.0, 140.0], rtol=1e-14)


def test_pid_controller_entry_takes_one_name_as_one_signal():
    # list("roll") used to make four sensors 'r', 'o', 'l', 'l' of a one-axis design.
    entry = pid_from_bandwidth(50.0, 2.0).controller("pd", inputs="roll", outputs="motor", rate_inputs="gyro")
    assert entry.inputs == ("roll",) and entry.outputs == ("motor",) and entry.rate_inputs == ("gyro",)
    with pytest.raises(ModelError, match=r"inputs must name one signal per axis \(2\), got \['roll'\]"):
        pid_from_bandwidth([50.0, 60.0], 2.0).controller("pd", inputs=["roll"], outputs=["m1", "m2"],
                                                          rate_inputs=["p", "q"])
