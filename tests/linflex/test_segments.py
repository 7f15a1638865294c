"""The rigid-segment beam: spring constants and small-deflection frequencies against beam theory."""

import numpy as np
import pytest

import linflex
from linflex import ModelError, rigid_segment_beam, segment_spring_constants
from linflex.linearize import linearize

EI, MASS, LENGTH = 1.4e4, 1.2, 10.0  # the spinning-beam benchmark of issue 4: first mode 3.8 rad/s
BETA_L = np.array([1.8751040687, 4.6940911330])  # cantilever roots of 1 + cos b cosh b = 0


@pytest.mark.parametrize("n", [3, 7, 20])
def test_tip_load_deflections_are_exact_at_joints_two_to_n(n):
    # Reference notes section 9.1: with the book's constants a tip load P reproduces the
    # Euler-Bernoulli deflection P x^2 (3 l - x) / (6 EI) exactly at joints 2..n. Joint i at
    # x_i = (i - 1/2) L carries the moment P (l - x_i) = sigma_i theta_i.
    L = LENGTH / n
    x = (np.arange(1, n + 1) - 0.5) * L
    P = 7.0
    theta = P * (LENGTH - x) / segment_spring_constants(n, EI, L)
    # Small rotations: a joint's deflection is the sum of the inboard joints' rotations times
    # their lever arms.
    deflection = np.array([np.sum(theta[:j] * (x[j] - x[:j])) for j in range(n)])
    exact = P * x**2 * (3 * LENGTH - x) / (6 * EI)
    np.testing.assert_allclose(deflection[1:], exact[1:], rtol=1e-12)


def scene_frequencies(n):
    bodies, joints = rigid_segment_beam("beam", length=LENGTH, EI=EI, mass_per_length=MASS, segments=n)
    scene = linflex.Scene(name="segmented_beam", effects=("joint_springs",), bodies=bodies, joints=joints)
    model = linflex.compile_model(scene)
    lin = linearize(model, linflex.OperatingPoint(model.x0, np.zeros(model.n_inputs)))
    return np.sort(np.abs(np.linalg.eigvals(lin.sys.A).imag))[::2][:2]


def test_frequencies_converge_to_the_cantilever():
    exact = BETA_L**2 * np.sqrt(EI / (MASS * LENGTH**4))
    errors = [np.abs(scene_frequencies(n) / exact - 1) for n in (10, 20, 40)]
    # Second order in the segment length: the first-mode error drops about fourfold per doubling.
    assert errors[0][0] / errors[1][0] > 3.5 and errors[1][0] / errors[2][0] > 3.5
    assert errors[2][0] < 2e-4 and errors[2][1] < 2e-3


def test_bad_input():
    with pytest.raises(ModelError, match="segments must be at least 2"):
        segment_spring_constants(1, EI, 1.0)
    with pytest.raises(ModelError, match="normal to the beam direction"):
        rigid_segment_beam("b", length=1.0, EI=1.0, mass_per_length=1.0, segments=3, bending_axis=(1.0, 0.0, 0.0))
