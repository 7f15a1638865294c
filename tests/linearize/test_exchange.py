"""Tests of the exchange of variables and the plant/controller partition."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ModelError
from linflex.linearize import exchange_variables, plant_controller_partition


def response(sys, s):
    """Reference: direct complex solve C (sI - A)^-1 B + D."""
    return sys.C @ np.linalg.solve(s * np.eye(sys.A.shape[0]) - sys.A, sys.B) + sys.D


def random_system(seed=0, n=7, m=2, p=3):
    rng = np.random.default_rng(seed)
    return LinearSystem(rng.normal(size=(n, n)), rng.normal(size=(n, m)), rng.normal(size=(p, n)))


def two_mass(m1=2.0, m2=3.0, c=0.4, k=5.0):
    """DISCOS report example (III-38 ff.): state (x1', x2', x1, x2), force F1 on mass 1."""
    A = [[-c / m1, c / m1, -k / m1, k / m1], [c / m2, -c / m2, k / m2, -k / m2], [1, 0, 0, 0], [0, 1, 0, 0]]
    return LinearSystem(
        A, [[1 / m1], [0], [0], [0]], [[0, 0, 1, -1], [1, 0, 0, 0]],
        states=["x1_dot", "x2_dot", "x1", "x2"], inputs=["F1"], outputs=["stretch", "rate1"],
    )


@pytest.mark.parametrize("method", ["pivot", "qr"])
def test_random_system_invariants(method):
    sys = random_system()
    res = exchange_variables(sys, ["y0", "y1", "y2"], method=method)
    n = sys.n_states
    # R^-1 R = I (1e-12: round-off of one LU solve of a 3x3 block)
    np.testing.assert_allclose(res.R_inv @ res.R, np.eye(n), atol=1e-12 * res.transform_condition)
    # eigenvalues invariant to round-off (scipy eigvals of both, 1e-10 relative)
    ev0 = np.sort_complex(np.linalg.eigvals(sys.A))
    ev1 = np.sort_complex(np.linalg.eigvals(res.sys.A))
    np.testing.assert_allclose(ev1, ev0, rtol=1e-10)
    # exchanged outputs equal the new states: their rows of C_z are unit vectors
    for k, name in enumerate(res.outputs):
        e = np.zeros(n)
        e[res.sys.states.index(name)] = 1.0
        np.testing.assert_allclose(res.sys.C[k], e, atol=1e-13)
    assert res.sys.states[-3:] == ("y0", "y1", "y2")
    assert len(set(res.exchanged) | set(res.retained)) == n
    # transfer function unchanged (direct complex solves at two points, 1e-10 relative)
    for s in (0.5j, 2.0 + 1.0j):
        np.testing.assert_allclose(response(res.sys, s), response(sys, s), rtol=1e-10)


def test_pivot_search_picks_largest_elements():
    # row 0 has its largest entry in column 4, then after elimination row 1 in column 1
    C = np.array([[0.1, 0.2, 0.0, 0.3, 5.0, 0.0], [0.0, 3.0, 0.1, 0.0, 1.0, 0.2]])
    sys = LinearSystem(-np.eye(6), np.ones((6, 1)), C)
    res = exchange_variables(sys, ["y0", "y1"])
    assert res.exchanged == ("x4", "x1")
    # the pivots: 5.0, then row 1 reduced by 1/5 of row 0: 3.0 - 0.2 * 0.2 = 2.96 (hand computation)
    np.testing.assert_allclose(res.pivots, [5.0, 2.96], rtol=1e-14)


def test_pivot_and_qr_agree_where_well_conditioned():
    # C strongly diagonal on states 0..2: both methods eliminate states 0, 1, 2 and give the same R
    rng = np.random.default_rng(1)
    n = 8
    C = np.hstack([np.diag([3.0, 2.0, 4.0]), 0.05 * rng.normal(size=(3, n - 3))])
    sys = LinearSystem(rng.normal(size=(n, n)), rng.normal(size=(n, 1)), C)
    a = exchange_variables(sys, ["y0", "y1", "y2"], method="pivot")
    b = exchange_variables(sys, ["y0", "y1", "y2"], method="qr")
    assert set(a.exchanged) == set(b.exchanged) == {"x0", "x1", "x2"}
    np.testing.assert_allclose(a.R, b.R, atol=1e-13)  # both are the unique R for this choice
    np.testing.assert_allclose(a.sys.A, b.sys.A, atol=1e-12)
    assert a.condition == pytest.approx(2.0, rel=0.1)  # cond(diag(3, 2, 4)) = 2 up to the 0.05 terms


def test_two_mass_example():
    sys = two_mass()
    res = exchange_variables(sys, ["stretch"])
    assert res.exchanged == ("x1",)  # largest element of row [0 0 1 -1]: the first one, x1
    # eigenvalues of the report: 0, 0, -0.1666667 +- 2.0344259j (DISCOS report Sec. 13 numbers)
    ev = np.sort_complex(np.linalg.eigvals(res.sys.A))
    ref = np.sort_complex(np.array([0, 0, -1 / 6 + 2.0344259j, -1 / 6 - 2.0344259j]))
    np.testing.assert_allclose(ev, ref, atol=2e-7)
    # the new state 'stretch' = x1 - x2 has transfer function m2 / (m1 m2 s^2 + (m1 + m2)(c s + k))
    # (closed form from the report's X1/F1 and X2/F1)
    m1, m2, c, k = 2.0, 3.0, 0.4, 5.0
    pick = LinearSystem(res.sys.A, res.sys.B, np.eye(4)[[res.sys.states.index("stretch")]])
    for s in (1.0j, 0.3 + 2.0j):
        ref = m2 / (m1 * m2 * s**2 + (m1 + m2) * (c * s + k))
        np.testing.assert_allclose(response(pick, s)[0, 0], ref, rtol=1e-12)
    # exchanging both outputs: rate1 = x1' is itself a state, so it replaces x1_dot exactly
    both = exchange_variables(sys, ["stretch", "rate1"])
    assert both.exchanged == ("x1", "x1_dot") and both.condition == pytest.approx(1.0)


@pytest.mark.parametrize("method", ["pivot", "qr"])
def test_dependent_outputs_refused(method):
    sys = random_system(seed=2)
    C = sys.C.copy()
    C[2] = 2 * C[0] - C[1]
    sys = sys.with_(C=C)
    with pytest.raises(ModelError, match="dependent|not independent"):
        exchange_variables(sys, ["y0", "y1", "y2"], method=method)


def plant_and_controller():
    """Two-mass plant (state x1', x2', x1, x2) with a strictly proper controller (2 states).

    Sensor s = x2 (plant states only); controller d' = Ac d + Bc s; actuator force
    beta = Cc d (controller states only); plant input F1 = beta.
    """
    p = two_mass()
    Ap, bp = p.A, p.B
    cs = np.array([[0.0, 0.0, 0.0, 1.0]])
    Ac = np.array([[-5.0, 1.0], [0.0, -3.0]])
    Bc = np.array([[0.0], [2.0]])
    Cc = np.array([[-1.5, 0.7]])
    A = np.block([[Ap, bp @ Cc], [Bc @ cs, Ac]])
    B = np.vstack([bp, np.zeros((2, 1))])  # external force on mass 1
    C = np.block([[cs, np.zeros((1, 2))], [np.zeros((1, 4)), Cc]])
    return LinearSystem(
        A, B, C, states=["x1_dot", "x2_dot", "x1", "x2", "d0", "d1"], inputs=["F_ext"], outputs=["s", "beta"],
    )


@pytest.mark.parametrize("method", ["pivot", "qr"])
def test_restricted_exchange_gives_plant_controller_structure(method):
    sys = plant_and_controller()
    among = {"s": ["x1_dot", "x2_dot", "x1", "x2"], "beta": ["d0", "d1"]}
    res = exchange_variables(sys, ["s", "beta"], method=method, among=among)
    assert res.exchanged[0] == "x2" and res.exchanged[1] in ("d0", "d1")
    part = plant_controller_partition(res, sensors=["s"], controller=[d for d in ("d0", "d1") if d in res.retained],
                                      actuators=["beta"])
    # a13 = a23 = a31 = a41 = 0 to round-off (DISCOS report Sec. 14 test 2)
    for name, value in part.structural_zeros.items():
        assert value < 1e-14, name
    # the closed-loop eigenvalues are unchanged (scipy eigvals, 1e-10 relative)
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(part.sys.A)),
                               np.sort_complex(np.linalg.eigvals(sys.A)), rtol=1e-10)
    # the couplings that must exist, in closed form: beta' = Cc (Ac d + Bc s) gives
    # a42 = Cc Bc = -1.5 * 0 + 0.7 * 2 = 1.4, and the force enters x1'' with 1/m1 = 0.5 (a14)
    np.testing.assert_allclose(part.blocks[3][1], [[1.4]], rtol=1e-12)
    np.testing.assert_allclose(part.blocks[0][3][:, 0], [0.5, 0.0, 0.0, 0.0][: part.blocks[0][3].shape[0]], atol=1e-14)


def test_unrestricted_exchange_can_break_structure():
    # without 'among' the pivot for beta = -1.5 d0 + 0.7 d1 is d0 anyway, but for a sensor that
    # also reads a controller state the structure breaks; the partition reports it
    sys = plant_and_controller()
    C = sys.C.copy()
    C[0, 4] = 10.0  # sensor now dominated by controller state d0
    sys = sys.with_(C=C)
    res = exchange_variables(sys, ["s", "beta"])
    assert res.exchanged[0] == "d0"
    part = plant_controller_partition(res, sensors=["s"], controller=[], actuators=["beta"])
    assert max(part.structural_zeros.values()) > 1e-3


def test_bad_arguments():
    sys = two_mass()
    with pytest.raises(ModelError, match="method"):
        exchange_variables(sys, "stretch", method="lu")
    with pytest.raises(ModelError, match="unknown signal"):
        exchange_variables(sys, "strech")
    with pytest.raises(ModelError, match="repeated"):
        exchange_variables(sys, ["stretch", "stretch"])
    with pytest.raises(ModelError, match="feedthrough"):
        exchange_variables(sys.with_(D=[[1.0], [0.0]]), "stretch")
    with pytest.raises(ModelError, match="identically zero"):
        exchange_variables(sys.with_(C=np.zeros((2, 4))), "stretch")
    with pytest.raises(ModelError, match="among"):
        exchange_variables(sys, "stretch", among={"rate1": ["x1"]})
    with pytest.raises(ModelError, match="not independent"):
        exchange_variables(sys, "stretch", among={"stretch": ["x1_dot"]})
    with pytest.raises(ModelError, match="already listed"):
        plant_controller_partition(sys, sensors=["x1"], controller=["x1"], actuators=[])


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 9), p=st.integers(1, 3), method=st.sampled_from(["pivot", "qr"]))
def test_property_exchange_is_a_similarity(seed, n, p, method):
    p = min(p, n)
    sys = random_system(seed=seed, n=n, m=1, p=p)
    res = exchange_variables(sys, list(sys.outputs), method=method)
    # invariants of a similarity: eigenvalues (scipy eigvals) and the transfer function (direct
    # solve) unchanged; tolerances scale with the condition of R (round-off amplification)
    tol = 1e-12 * res.transform_condition * max(1.0, np.linalg.norm(sys.A, 1))
    ev0 = np.sort_complex(np.linalg.eigvals(sys.A))
    ev1 = np.sort_complex(np.linalg.eigvals(res.sys.A))
    assert np.max(np.abs(ev1 - ev0)) <= 1e3 * tol * max(1.0, np.max(np.abs(ev0)))
    s = 0.37 + 1.3j
    g0, g1 = response(sys, s), response(res.sys, s)
    assert np.max(np.abs(g1 - g0)) <= 1e3 * tol * max(1.0, np.max(np.abs(g0))) * np.linalg.cond(s * np.eye(n) - sys.A)


@pytest.mark.parametrize("method", ["pivot", "qr"])
def test_iss_270_states_exchange(method):
    # order in the hundreds, damping 0.005 (ISS 1R, NICONET): exchanging the 3 outputs keeps every
    # eigenvalue (matched one-to-one with scipy eigvals of the original, 1e-10 relative) and the
    # response at the first resonance (direct solves, 1e-10 relative)
    import scipy.optimize

    from ..mor import load_mor

    sys = load_mor("iss1R")
    res = exchange_variables(sys, list(sys.outputs), method=method)
    ev0, ev1 = np.linalg.eigvals(sys.A), np.linalg.eigvals(res.sys.A)
    cost = np.abs(ev0[:, None] - ev1[None, :])
    i, j = scipy.optimize.linear_sum_assignment(cost)
    assert np.max(cost[i, j] / np.abs(ev0[i])) < 1e-10
    np.testing.assert_allclose(response(res.sys, 0.62j), response(sys, 0.62j), rtol=1e-10)
    assert res.condition < 10  # the largest-element and QR pivots pick well-conditioned C_E blocks
