"""Test models for the stability tests: hub-plus-appendage attitude loops and helpers.

The hub-plus-appendage loop is a rigid hub ``1/(J s^2)`` with ``n`` collocated appendage modes
``phi_i^2 / (s^2 + 2 zeta w_i s + w_i^2)``, attitude measured, and a PD controller with a
first-order derivative filter ``C(s) = kp + kd s / (tau s + 1)``. The loop is broken at the
plant input (negative feedback), so ``L(s) = C(s) P(s)`` has order ``2 + 2 n + 1``.
"""

from __future__ import annotations

import numpy as np

from linflex import LinearSystem

J, KP, KD, TAU = 1.0, 1.0, 1.4, 0.02


def hub_parameters(order: int, zeta: float, seed: int = 7):
    """Modal frequencies [rad/s], modal gains phi_i^2 and damping of the appendage modes."""
    n = (order - 3) // 2
    if 2 * n + 3 != order:
        raise ValueError(f"order must be odd and >= 3, got {order}")
    rng = np.random.default_rng(seed)
    w = np.geomspace(0.7, 300.0, n) * np.exp(rng.uniform(-0.05, 0.05, n))
    gains = 0.15 * rng.uniform(0.3, 1.0, n) / (1.0 + np.arange(n)) ** 0.3
    return w, gains, np.full(n, zeta)


def hub_loop(order: int, zeta: float, seed: int = 7) -> LinearSystem:
    """State-space open loop L = C P of the hub-plus-appendage PD loop (see module docstring)."""
    w, g, z = hub_parameters(order, zeta, seed)
    n = w.size
    N = 2 + 2 * n + 1
    A = np.zeros((N, N))
    B = np.zeros((N, 1))
    A[0, 1] = 1.0
    B[1, 0] = 1.0 / J
    c_theta = np.zeros(N)
    c_theta[0] = 1.0
    for i in range(n):
        k = 2 + 2 * i
        phi = np.sqrt(g[i])
        A[k, k + 1] = 1.0
        A[k + 1, k] = -w[i] ** 2
        A[k + 1, k + 1] = -2 * z[i] * w[i]
        B[k + 1, 0] = phi
        c_theta[k] = phi
    f = N - 1  # derivative filter state: f' = (theta - f) / tau
    A[f, :] += c_theta / TAU
    A[f, f] -= 1.0 / TAU
    C = ((KP + KD / TAU) * c_theta)[None, :].copy()
    C[0, f] -= KD / TAU
    states = ["hub_angle", "hub_rate"] + [s for i in range(n) for s in (f"q{i}", f"q{i}_dot")] + ["filter"]
    return LinearSystem(A, B, C, np.zeros((1, 1)), states=states, inputs=["torque"], outputs=["control"])


def hub_loop_response(omega, order: int, zeta: float, seed: int = 7):
    """L(j omega) of :func:`hub_loop` in closed form (modal sum times the PD law)."""
    w, g, z = hub_parameters(order, zeta, seed)
    s = 1j * np.asarray(omega, dtype=float)
    plant = 1.0 / (J * s**2)
    for wi, gi, zi in zip(w, g, z):
        plant = plant + gi / (s**2 + 2 * zi * wi * s + wi**2)
    return (KP + KD * s / (TAU * s + 1.0)) * plant


def bisect(f, a: float, b: float, iters: int = 80) -> float:
    """Plain bisection on a sign change of f in [a, b] (in whatever variable f takes)."""
    fa = f(a)
    for _ in range(iters):
        m = 0.5 * (a + b)
        fm = f(m)
        if (fm > 0) == (fa > 0):
            a, fa = m, fm
        else:
            b = m
    return 0.5 * (a + b)


def brute_force_gain_crossovers(resp, lo: float, hi: float, rel_step: float):
    """All sign changes of log|L| on a uniform log grid of relative step ``rel_step``, bisected."""
    x = np.arange(np.log(lo), np.log(hi), rel_step)
    g = np.log(np.abs(resp(np.exp(x))))
    idx = np.flatnonzero(np.sign(g[:-1]) != np.sign(g[1:]))
    out = []
    for i in idx:
        xr = bisect(lambda t: float(np.log(np.abs(resp(np.exp(np.array([t])))[0]))), x[i], x[i + 1])
        out.append(np.exp(xr))
    return np.array(out)
