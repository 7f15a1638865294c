"""The exponential integrator's correction of the stages on fast eigenvalues of the frozen Jacobian.

References: :func:`~linflex.simulation._exponential.phi_matrices` (scaled Taylor series, checked
against 50-digit values in ``test_simulate_exponential.py``) on a projector known by
construction; ``scipy`` DOP853 at rtol 1e-12 on a model with a stiff, undamped mode forced by a
slow one.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from linflex import NonlinearModel, simulate
from linflex.simulation import _exponential
from linflex.simulation._exponential import _eigen, _fast_part, exponential_stepper, phi_matrices
from linflex.simulation._steppers import IntegratorCounts

# The model: a slow oscillator s (3 rad/s) whose stiffness the fast coordinate y changes, and y
# (300 rad/s, undamped) forced by s^2 and s'^2: at 0.1 s steps |lambda| h = 30.
W_SLOW, W_FAST, COUPLING, LOAD, RATE_LOAD = 3.0, 300.0, 300.0, 300.0, 30.0
X0 = np.array([1.0, 0.0, LOAD / W_FAST**2, 0.0])  # y at its quasi-static value


def rhs(x, u):
    s, sd, y, yd = x[0], x[1], x[2], x[3]
    return [sd, -W_SLOW**2 * s - COUPLING * y * s + u[0], yd, -W_FAST**2 * y + LOAD * s * s + RATE_LOAD * sd * sd]


def fast_mode_model() -> NonlinearModel:
    x, u, t = ca.SX.sym("x", 4), ca.SX.sym("u", 1), ca.SX.sym("t")
    return NonlinearModel(ca.Function("f", [x, u, t], [ca.vertcat(*rhs(x, u))]), states=["s", "sd", "y", "yd"],
                          inputs=["u"])


def numpy_rhs(x, u, t):
    return np.array(rhs(x, u), float)


def numpy_jacobian(x, u, t):
    s, sd, y, _ = x
    return np.array([[0.0, 1.0, 0.0, 0.0], [-W_SLOW**2 - COUPLING * y, 0.0, -COUPLING * s, 0.0],
                     [0.0, 0.0, 0.0, 1.0], [2.0 * LOAD * s, 2.0 * RATE_LOAD * sd, -W_FAST**2, 0.0]])


def dop853(times):
    r = solve_ivp(lambda t, x: numpy_rhs(x, [0.0], t), (times[0], times[-1]), X0, method="DOP853", rtol=1e-12,
                  atol=1e-14, t_eval=times)
    return r.y.T


def fixed_step_error(n_steps: int, fast_negligible: float = 0.0) -> float:
    """Largest error of s at ``n_steps`` fixed steps over 10 s (tolerances too loose to reject;
    by default the fast stages corrected wherever an eigenvalue is fast, as the tolerance is
    loose)."""
    times = np.linspace(0.0, 10.0, n_steps + 1)
    X = exponential_stepper(numpy_rhs, numpy_jacobian, 1e3, 1e3, IntegratorCounts(),
                            fast_negligible=fast_negligible)(times, X0, np.zeros((n_steps, 1)))
    return float(np.max(np.abs(X[:, 0] - dop853(times)[1:, 0])))


def test_fast_stages_cut_the_error_of_large_steps_against_dop853(monkeypatch):
    # At 0.1 s (|lambda| h = 30) the corrected stages bring s within 1.2e-3 of DOP853 (measured
    # 8.0e-4), Krogstad's stages alone leave 1.6e-2; at 0.025 s (|lambda| h = 7.5: not fast) both
    # are the same scheme.
    corrected = [fixed_step_error(n) for n in (100, 400)]
    # the default skips a correction within 1e-2 of the tolerance: all of them at tolerance 1e3
    skipped = fixed_step_error(100, fast_negligible=_exponential._FAST_NEGLIGIBLE)
    monkeypatch.setattr(_exponential, "_FAST", np.inf)
    plain = [fixed_step_error(n) for n in (100, 400)]
    assert corrected[0] <= 1.2e-3 and plain[0] >= 1e-2
    assert corrected[1] == plain[1] and skipped == plain[0]


def test_adaptive_runs_with_fast_stages_keep_their_tolerance_against_dop853():
    # simulate at rtol 1e-6, atol 1e-9: each state within 100 rtol of its peak (plus 100 atol),
    # with the fast correction taken on some steps (more than four evaluations per attempt).
    model = fast_mode_model()
    t = np.linspace(0.0, 10.0, 101)
    r = simulate(model, t, X0, method="exponential", rtol=1e-6, atol=1e-9)
    ref = dop853(t)
    err, peak = np.max(np.abs(r.x - ref), axis=0), np.max(np.abs(ref), axis=0)
    assert np.all(err <= 100 * 1e-6 * peak + 100 * 1e-9)
    assert r.n_evaluations > 4 * (r.n_steps + r.n_rejected) + 1


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_fast=st.integers(1, 3), n_slow=st.integers(0, 3),
       log_h=st.floats(-2.0, 0.0), damped=st.booleans())
def test_fast_part_is_phi_matrices_on_the_fast_subspace(seed, n_fast, n_slow, log_h, damped):
    # J = S blockdiag(fast pairs, slow pairs) S^-1 with |lambda| h of 12 to 300 on the fast pairs
    # and below 5 on the slow ones, so the fast projector is P_F = S [I 0; 0 0] S^-1; the scalar
    # functions on the eigenvalues (times P_F) equal phi_matrices' of J times P_F, to 1e-9 of
    # their largest entry.
    rng = np.random.default_rng(seed)
    h = 10.0**log_h
    w_fast = rng.uniform(12.0, 300.0, n_fast) / h
    w_slow = rng.uniform(0.1, 5.0, n_slow) / h
    zeta = rng.uniform(0.0, 0.3, n_fast + n_slow) if damped else np.zeros(n_fast + n_slow)
    blocks = [np.array([[-z * w, w], [-w, -z * w]]) for w, z in zip(np.concatenate([w_fast, w_slow]), zeta)]
    S = np.eye(2 * len(blocks)) + 0.3 * rng.standard_normal((2 * len(blocks),) * 2)
    J = S @ scipy.linalg.block_diag(*blocks) @ np.linalg.inv(S)
    P = S @ np.diag(np.r_[np.ones(2 * n_fast), np.zeros(2 * n_slow)]) @ np.linalg.inv(S)
    F = _fast_part(_eigen(J), h)
    assert F is not None and F.V.shape[1] == 2 * n_fast
    _, _, Q2h, _ = phi_matrices(J, 0.5 * h)
    _, _, Q2, Q3 = phi_matrices(J, h)
    wanted = {"ga": Q2h / (0.5 * h), "gc2": (2.0 / h) * Q2 - (8.0 / h**2) * Q3, "gc3": (4.0 / h**2) * Q3 - Q2 / h}
    eye = np.eye(J.shape[0])
    for name, M in wanted.items():
        got = np.column_stack([F.apply(getattr(F, name), e) for e in eye])
        want = P @ M
        assert np.max(np.abs(got - want)) <= 1e-9 * np.max(np.abs(want))


def test_no_fast_part_without_fast_eigenvalues_or_eigenvectors():
    # Below the threshold at every eigenvalue: none; a defective J (a Jordan block at 400 1/s):
    # the eigendecomposition is refused, and the integrator keeps Krogstad's stages (the exact
    # zero-order-hold recursion of this linear model, one step per sample).
    J = np.array([[0.0, 5.0], [-5.0, 0.0]])
    assert _fast_part(_eigen(J), 0.1) is None
    jordan = np.array([[-400.0, 1.0], [0.0, -400.0]])
    assert _eigen(jordan) is None
    x, u, t = ca.SX.sym("x", 2), ca.SX.sym("u", 1), ca.SX.sym("t")
    B = np.array([[0.0], [400.0]])
    model = NonlinearModel(ca.Function("f", [x, u, t], [ca.mtimes(ca.DM(jordan), x) + ca.mtimes(ca.DM(B), u)]),
                           states=["a", "b"], inputs=["u"])
    times = np.linspace(0.0, 1.0, 11)
    U = np.cos(times)[:, None]
    r = simulate(model, times, [1.0, -1.0], inputs=U, method="exponential", rtol=1e-10, atol=1e-12)
    M = np.zeros((3, 3))
    M[:2, :2], M[:2, 2:] = jordan * 0.1, B * 0.1
    E = scipy.linalg.expm(M)
    X = [np.array([1.0, -1.0])]
    for k in range(10):
        X.append(E[:2, :2] @ X[-1] + E[:2, 2] * U[k, 0])
    assert np.max(np.abs(r.x - np.array(X))) <= 1e-12 * np.max(np.abs(X))
    assert r.n_steps == 10
