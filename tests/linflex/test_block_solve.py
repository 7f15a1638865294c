"""The mass-matrix solve by blocks (linflex/compiler/_block_solve.py) against one dense solve."""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import linflex
from linflex.compiler._block_solve import MIN_CONSTANT_SPEEDS, constant_block

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def arrays():
    """The hub with two solar arrays (4 modes each, geometric stiffness): modal and wheel speeds
    have a constant mass block, the hub's rates do not."""
    scene = linflex.vary_scene(linflex.load_scene(ROOT / "examples" / "spacecraft_arrays.toml"),
                               {f"bodies.{b}.modes": 4 for b in ("array_left", "array_right")})
    model = linflex.compile_model(scene)
    b = model.equations.builder
    eq = model.equations
    M, rhs = b.assemble()
    dense = ca.Function("dense", [eq.x, eq.inputs, b.t], [ca.solve(M, rhs)])  # one LU of the whole matrix
    return model, b, eq, dense


def test_the_modal_and_wheel_speeds_form_the_constant_block(arrays):
    model, b, eq, _ = arrays
    J, Mb, _, _ = b.assemble_parts()
    F, D = constant_block(J, Mb, ca.vertcat(eq.x, eq.inputs, b.t))
    names = [b.u_names[j] for j in F]
    assert len(F) >= MIN_CONSTANT_SPEEDS
    assert sum(".eta" in n for n in names) == 8 and not any(n.startswith("attitude") for n in names)
    # Mass-normalized modes: the modal block is the identity (to the round-off of the modal data).
    modal = [k for k, n in enumerate(names) if ".eta" in n]
    np.testing.assert_allclose(D[np.ix_(modal, modal)], np.eye(len(modal)), atol=1e-12)


@settings(derandomize=True, max_examples=20, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_block_solve_equals_one_dense_solve(arrays, seed):
    # Independent computation: the SX mass matrix and right-hand side of the same builder solved
    # at once; agreement to 1e-10 of the accelerations' size at random states and inputs.
    model, b, eq, dense = arrays
    rng = np.random.default_rng(seed)
    x = model.x0 + rng.normal(scale=0.2, size=model.n_states)
    u = rng.normal(scale=5.0, size=model.n_inputs)
    n_q = b.q.numel()
    udot = np.asarray(model.f(x, u, 0.3), float).ravel()[n_q:n_q + b.u.numel()]
    expected = np.asarray(dense(x, u, 0.3), float).ravel()
    np.testing.assert_allclose(udot, expected, rtol=0, atol=1e-10 * max(1.0, np.max(np.abs(expected))))
