"""compare_linear_nonlinear: the difference is the linearization's, of second order in the amplitude."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import linflex  # noqa: E402
from linflex import ModelError, NonlinearModel, OperatingPoint  # noqa: E402
from linflex.linearize import compare_linear_nonlinear  # noqa: E402


def quadratic_model():
    # x' = -x + x^2 + u, y = x: linear part -x + u, a quadratic term.
    return NonlinearModel(lambda x, u, t: np.array([-x[0] + x[0] ** 2 + u[0]]), lambda x, u, t: x[:1],
                          states=["x"], inputs=["u"], outputs=["y"])


def test_difference_is_second_order_in_the_amplitude():
    # Reference: for x' = -x + x^2 + a, the first-order response is a (1 - exp(-t)) and the error of
    # the linear model is a^2 e(t) + O(a^3): halving a divides the difference by 4 (to O(a)).
    t = np.linspace(0.0, 4.0, 81)
    big = compare_linear_nonlinear(quadratic_model(), t, [0.02], op=OperatingPoint([0.0], [0.0]), method="scipy-DOP853")
    small = compare_linear_nonlinear(quadratic_model(), t, [0.01], op=OperatingPoint([0.0], [0.0]), method="scipy-DOP853")
    ratio = np.abs(big.difference).max() / np.abs(small.difference).max()
    assert 3.8 < ratio < 4.2
    # The linear response itself: a (1 - exp(-t)) held input, exact (closed form).
    np.testing.assert_allclose(big.linear.y[:, 0], 0.02 * (1 - np.exp(-t)), atol=1e-12)
    # The second-order term: e(t) solves e' = -e + (1 - exp(-t))^2, e(0) = 0; at t = 4 (closed form
    # e = 1 - 2 t exp(-t) - exp(-2t), evaluated) times a^2.
    e4 = 1 - 2 * 4 * np.exp(-4) - np.exp(-8)
    np.testing.assert_allclose(big.difference[-1, 0], 0.02**2 * e4, rtol=0.05)


def test_example_spacecraft_small_command_and_plot():
    scene = linflex.load_scene("examples/spacecraft_arrays.toml")
    model = linflex.compile_model(scene)
    t = np.linspace(0.0, 10.0, 101)
    c = compare_linear_nonlinear(model, t, {"motor_x": 0.05}, x0_offset={"attitude.qz": 1e-3})
    # A 0.05 N m roll command and a 2 mrad yaw offset on a 3000 kg m^2 vehicle: the motion is small
    # and the linear model (exact Jacobian) follows the nonlinear one on every output it moves, to
    # second order (relative 1e-6 here); pitch moves only through the nonlinear (gyroscopic,
    # kinematic) coupling of roll and yaw: the linear model leaves it at 0, and the nonlinear
    # deviation is of the order of the product of the two angles (2e-4 * 2e-3 = 4e-7).
    linear_peak = np.abs(c.linear.y).max(axis=0)
    driven = linear_peak > 1e-6 * linear_peak.max()
    assert driven.sum() == 6
    assert np.max(c.relative_difference[driven]) < 1e-5
    pitch = c.outputs.index("pitch")
    assert not driven[pitch] and np.abs(c.deviation[:, pitch]).max() < 4e-7
    h = c.plot(["roll", "yaw"])
    assert len(h.axes) == 4 and len(h.lines) == 6
    plt.close(h.figure)


def test_bad_input_is_named():
    t = np.linspace(0.0, 1.0, 11)
    with pytest.raises(ModelError, match="x0_offset: unknown state 'z'"):
        compare_linear_nonlinear(quadratic_model(), t, op=OperatingPoint([0.0], [0.0]), x0_offset={"z": 1.0})
    c = compare_linear_nonlinear(quadratic_model(), t, [0.01], op=OperatingPoint([0.0], [0.0]), method="scipy-DOP853")
    with pytest.raises(ModelError, match="unknown output 'q'"):
        c.plot(["q"])
