"""The autodiff Jacobian function (linearize/_autodiff.py) against an independent computation.

Reference: CasADi's symbolic ``ca.jacobian`` of the same expressions, evaluated densely. Both are
exact algorithmic differentiation of the same graph, so they agree to round-off (1e-12 relative
to the largest entry of the block). The sweeps are exercised in both directions (forward over
column colours, reverse over row colours), with the last call of the map padded (colours not a
multiple of the directions per call), on SX graphs and on MX graphs with a linear solve node.
"""

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import linflex
from linflex import NonlinearModel
from linflex.linearize._autodiff import _build
from linflex.system._jacobians import DIRECTIONS_PER_CALL, REVERSE_SWEEP_COST

RTOL = 1e-12


def symbolic_jacobians(xdot, y, x, u):
    """The reference: ``ca.jacobian`` of the expressions, as a function of ``(x, u)``."""
    return ca.Function("reference", [x, u], [xdot, y, ca.jacobian(xdot, x), ca.jacobian(xdot, u),
                                             ca.jacobian(y, x), ca.jacobian(y, u)])


def assert_equal_to_round_off(got, reference):
    for a, b in zip(got, reference):
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        assert a.shape == b.shape
        scale = max(float(np.max(np.abs(b), initial=0.0)), 1e-300)
        assert float(np.max(np.abs(a - b), initial=0.0)) <= RTOL * scale


def sweep_direction(model) -> str:
    """Which sweeps ``_build`` picks for the model (its own rule, recomputed here)."""
    f_fun, h_fun = model.casadi_functions()
    nx = model.n_states
    z, p, t = ca.MX.sym("z", nx + model.n_inputs), ca.MX.sym("p", len(model.params)), ca.MX.sym("t")
    g = ca.Function("g", [z, p, t], [ca.vertcat(f_fun(z[:nx], z[nx:], p, t), h_fun(z[:nx], z[nx:], p, t))])
    sparsity = g.jac_sparsity(0, 0)
    rows, columns = sparsity.T.uni_coloring().size2(), sparsity.uni_coloring().size2()
    return "reverse" if REVERSE_SWEEP_COST * rows < columns else "forward"


@st.composite
def sparse_models(draw):
    """A random model whose rows depend on random subsets of the states and inputs (every row
    nonlinear in each variable it depends on), SX or MX; MX models may solve a dense linear
    system (a node of the graph), which makes every row depend on every state."""
    nx, nu, ny = draw(st.integers(2, 9)), draw(st.integers(0, 3)), draw(st.integers(0, 3))
    sym = draw(st.sampled_from(["SX", "MX"]))
    solve = sym == "MX" and draw(st.booleans())
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    density = draw(st.sampled_from([0.15, 0.4, 1.0]))
    S = getattr(ca, sym)
    x, u = S.sym("x", nx), S.sym("u", nu)
    z = ca.vertcat(x, u)

    def row(n_rows):
        mask = rng.random((n_rows, nx + nu)) < density
        mask[:, 0] |= ~mask.any(axis=1)  # no empty row
        out = []
        for i in range(n_rows):
            idx = np.flatnonzero(mask[i]).tolist()
            a, b = rng.uniform(0.5, 2.0, len(idx)), rng.uniform(-1.0, 1.0, len(idx))
            linear = sum(float(a[k]) * ca.sin(z[j] + float(b[k])) for k, j in enumerate(idx))
            out.append(linear * (1.0 + 0.1 * sum(z[j] ** 2 for j in idx)))
        return out

    xdot = ca.vertcat(*row(nx))
    if solve:
        M = ca.diag(2.0 + ca.sin(x)) + 0.1
        xdot = ca.solve(M, xdot)
    y = ca.vertcat(*row(ny)) if ny else S(0, 1)
    return x, u, xdot, y, rng.standard_normal(nx), rng.standard_normal(nu)


@settings(derandomize=True, max_examples=60, deadline=None)
@given(sparse_models())
def test_sweeps_equal_the_symbolic_jacobian_on_random_sparse_models(case):
    x, u, xdot, y, xv, uv = case
    model = NonlinearModel.from_casadi(xdot, x, u, y if y.numel() else None)
    got = _build(model)(xv, uv, [], 0.0)
    reference = symbolic_jacobians(xdot, y if y.numel() else ca.DM(0, 1), x, u)(xv, uv)
    assert_equal_to_round_off(got, reference)


@pytest.mark.parametrize("n, direction", [(6, "forward"), (7, "reverse"), (9, "reverse")])
def test_both_sweep_directions_with_a_padded_last_call(n, direction):
    # Banded rows: few column colours, forward sweeps. One dense row beside single-entry rows:
    # three row colours against n + 1 column colours, reverse sweeps. Colour counts of 3 and 3
    # are no multiple of the directions per call, so the last call carries zero seeds.
    x, u = ca.SX.sym("x", n), ca.SX.sym("u", 1)
    if direction == "forward":
        rows = [ca.sin(x[k]) * x[(k + 1) % n] + u[0] * x[k] ** 2 for k in range(n)]
    else:
        rows = [ca.sum1(ca.sin(x) * ca.cos(u[0])) * x[0]] + [ca.exp(x[k]) * x[k] for k in range(1, n)]
    xdot, y = ca.vertcat(*rows), ca.vertcat(x[0] * u[0], ca.cos(x[n - 1]))
    model = NonlinearModel.from_casadi(xdot, x, u, y)
    assert sweep_direction(model) == direction
    rng = np.random.default_rng(n)
    xv, uv = rng.standard_normal(n), rng.standard_normal(1)
    assert_equal_to_round_off(_build(model)(xv, uv, [], 0.0), symbolic_jacobians(xdot, y, x, u)(xv, uv))
    assert DIRECTIONS_PER_CALL > 1  # the padding above is exercised only with several directions per call


def model_reference(model, xv, uv):
    """``ca.jacobian`` of a compiled model's own f and h graphs (called on fresh symbols)."""
    f_fun, h_fun = model.casadi_functions()
    S = ca.SX if model.f.is_a("SXFunction") else ca.MX
    x, u = S.sym("x", model.n_states), S.sym("u", model.n_inputs)
    p = np.asarray(model.params, dtype=float) if len(model.params) else ca.DM(0, 1)
    xdot, y = f_fun(x, u, p, 0.0), h_fun(x, u, p, 0.0)
    return symbolic_jacobians(xdot, y, x, u)(xv, uv)


def chain(links, EI=50.0, formulation="order-n"):
    """The benchmark's model family (benchmarks/formulations.py): a rigid-segment beam on joint
    springs under gravity; order-n gives an SX graph, dense an MX graph with the mass-matrix
    solve as a node."""
    bodies, joints = linflex.rigid_segment_beam("beam", length=0.1 * links, EI=EI, mass_per_length=1.0,
                                                segments=links, damping=1e-3, bending_axis=(0.0, 1.0, 0.0))
    scene = linflex.Scene("chain", bodies=list(bodies), joints=list(joints), effects=["joint_springs", "gravity"])
    return linflex.compile_model(scene, formulation=formulation)


@settings(derandomize=True, max_examples=6, deadline=None)
@given(st.integers(2, 6), st.floats(10.0, 100.0), st.sampled_from(["order-n", "dense"]), st.integers(0, 2**32 - 1))
def test_compiled_chains_equal_the_symbolic_jacobian(links, EI, formulation, seed):
    model = chain(links, EI, formulation)
    rng = np.random.default_rng(seed)
    xv, uv = rng.uniform(-0.5, 0.5, model.n_states), rng.standard_normal(model.n_inputs)
    assert_equal_to_round_off(_build(model)(xv, uv, [], 0.0), model_reference(model, xv, uv))


@pytest.mark.parametrize("links", [30, pytest.param(90, marks=pytest.mark.slow)])
def test_long_chain_equals_the_symbolic_jacobian(links):
    # A dense Jacobian (every acceleration depends on every joint): links + 1 row colours, swept
    # in reverse over many calls, the last one padded (31 and 91 are no multiple of 4).
    model = chain(links)
    assert sweep_direction(model) == "reverse"
    xv = np.concatenate([0.01 * np.sin(np.arange(links)), 0.1 * np.cos(np.arange(links))])
    uv = np.zeros(model.n_inputs)
    assert_equal_to_round_off(_build(model)(xv, uv, [], 0.0), model_reference(model, xv, uv))


@pytest.mark.parametrize("name", ["gyrostat", "spacecraft_arrays"])
def test_example_scenes_equal_the_symbolic_jacobian(name):
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    model = linflex.compile_model(linflex.load_scene(root / "examples" / f"{name}.toml"))
    rng = np.random.default_rng(5)
    xv = np.asarray(model.x0, dtype=float) + 0.05 * rng.standard_normal(model.n_states)
    uv = 0.1 * rng.standard_normal(model.n_inputs)
    assert_equal_to_round_off(_build(model)(xv, uv, [], 0.0), model_reference(model, xv, uv))


@pytest.mark.parametrize("sym", ["SX", "MX"])
def test_a_model_without_structural_nonzeros_gives_zero_jacobians(sym):
    # No colours to sweep: the Jacobians are exact zeros and f, h still evaluate.
    S = getattr(ca, sym)
    x, u = S.sym("x", 3), S.sym("u", 2)
    xdot, y = ca.vertcat(1.0, 2.0, 3.0) + 0 * x, ca.vertcat(4.0, 5.0) + 0 * u
    model = NonlinearModel.from_casadi(xdot, x, u, y)
    got = _build(model)(np.ones(3), np.ones(2), [], 0.0)
    assert_equal_to_round_off(got, symbolic_jacobians(xdot, y, x, u)(np.ones(3), np.ones(2)))
    assert np.array_equal(np.asarray(got[0]).ravel(), [1.0, 2.0, 3.0])
    assert not np.any(np.asarray(got[2]))
