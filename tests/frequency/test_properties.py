"""Property-based tests (hypothesis): invariants of zeros and frequency responses."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem
from linflex.frequency import frequency_response, zeros


def system(seed, n, m, p):
    rng = np.random.default_rng(seed)
    return LinearSystem(rng.normal(size=(n, n)) - 1.5 * np.eye(n), rng.normal(size=(n, m)), rng.normal(size=(p, n)))


def match(a, b):
    from scipy.optimize import linear_sum_assignment

    if len(a) != len(b):
        return np.inf
    if len(a) == 0:
        return 0.0
    cost = np.abs(np.asarray(a)[:, None] - np.asarray(b)[None, :])
    r, c = linear_sum_assignment(cost)
    return float(np.max(cost[r, c]))


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(2, 9), m=st.integers(1, 3), p=st.integers(1, 3),
       log_scale=st.floats(-3, 3))
def test_zeros_and_response_invariant_under_similarity(seed, n, m, p, log_scale):
    # theory: invariant zeros and G(s) do not depend on the state coordinates
    sys = system(seed, n, m, p)
    rng = np.random.default_rng(seed + 1)
    T = rng.normal(size=(n, n)) + 3 * np.eye(n)
    T = T @ np.diag(10.0 ** np.linspace(-log_scale, log_scale, n))
    Ti = np.linalg.inv(T)
    other = LinearSystem(Ti @ sys.A @ T, Ti @ sys.B, sys.C @ T)
    za, zb = zeros(sys), zeros(other)
    scale = max(1.0, float(np.max(np.abs(za))) if len(za) else 1.0)
    assert match(za, zb) < 1e-6 * scale
    w = np.array([0.05, 0.9, 7.0])
    ga = frequency_response(sys, w).response
    gb = frequency_response(other, w).response
    rel = np.max(np.abs(ga - gb)) / np.max(np.abs(ga))
    assert rel < 1e-8 * np.linalg.cond(T)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 8))
def test_square_zero_count_with_invertible_first_markov_parameter(seed, n):
    # theory: a square m x m system with CB invertible and D = 0 has exactly n - m finite zeros
    m = 1 if n < 3 else 2
    sys = system(seed, n, m, m)
    if abs(np.linalg.det(sys.C @ sys.B)) < 1e-3:
        return
    assert len(zeros(sys)) == n - m
