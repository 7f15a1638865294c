"""Property-based tests (hypothesis) of modes and stability_margins, and the docstring examples."""

from __future__ import annotations

import doctest

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import linflex.stability._margins as margins_module
import linflex.stability._modes as modes_module
from linflex import LinearSystem
from linflex.stability import modes, stability_margins


@settings(max_examples=25, deadline=None)
@given(
    wn=st.floats(1e-2, 1e3),
    zeta=st.floats(1e-4, 0.9),
    seed=st.integers(0, 2**31 - 1),
)
def test_modes_invariant_under_similarity(wn, zeta, seed):
    # Reference: closed form of an oscillator; a random well-conditioned similarity T leaves the
    # eigenvalues unchanged.
    A = np.array([[0.0, 1.0], [-(wn**2), -2 * zeta * wn]])
    rng = np.random.default_rng(seed)
    T = np.eye(2) + 0.3 * rng.standard_normal((2, 2))
    At = np.linalg.solve(T, A @ T)
    t = modes(LinearSystem(At, np.ones((2, 1))))
    assert len(t) == 1
    assert abs(t[0].natural_frequency - wn) <= 1e-9 * wn
    assert abs(t[0].damping_ratio - zeta) <= 1e-8 + 1e-7 * zeta


@settings(max_examples=20, deadline=None)
@given(kp=st.floats(0.05, 50.0), kd=st.floats(0.05, 50.0), seed=st.integers(0, 2**31 - 1))
def test_margins_of_pd_double_integrator_under_similarity(kp, kd, seed):
    # Reference: closed form of L = (kd s + kp)/s^2 (gain crossover and phase margin), for a
    # random similarity of the realization; never a spurious gain margin at w = 0.
    rng = np.random.default_rng(seed)
    T = np.eye(2) + 0.3 * rng.standard_normal((2, 2))
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([[0.0], [1.0]])
    C = np.array([[kp, kd]])
    L = LinearSystem(np.linalg.solve(T, A @ T), np.linalg.solve(T, B), C @ T)
    m = stability_margins(L)
    w = np.sqrt((kd**2 + np.sqrt(kd**4 + 4 * kp**2)) / 2)
    assert m.gain_crossovers.size == 1 and abs(m.gain_crossovers[0] - w) <= 1e-9 * w
    assert abs(m.phase_margins[0] - np.degrees(np.arctan(kd * w / kp))) <= 1e-7
    assert m.phase_crossovers.size == 0 and m.closed_loop_stable


def test_docstring_examples_run():
    for module in (modes_module, margins_module):
        failures, tried = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
        assert tried > 0 and failures == 0
