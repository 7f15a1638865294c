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
#: Optional second-order roll-off filter of the controller: frequency [rad/s] and damping.
W_ROLL, Z_ROLL = 12.0, 0.5


def hub_parameters(order: int, zeta: float, seed: int = 7, rolloff: bool = False):
    """Modal frequencies [rad/s], modal gains phi_i^2 and damping of the appendage modes."""
    extra = 5 if rolloff else 3
    n = (order - extra) // 2
    if 2 * n + extra != order or n < 1:
        raise ValueError(f"order must be odd and >= 3, got {order}")
    rng = np.random.default_rng(seed)
    w = np.geomspace(0.7, 300.0, n) * np.exp(rng.uniform(-0.05, 0.05, n))
    gains = 0.15 * rng.uniform(0.3, 1.0, n) / (1.0 + np.arange(n)) ** 0.3
    return w, gains, np.full(n, zeta)


def hub_loop(order: int, zeta: float, seed: int = 7, rolloff: bool = False) -> LinearSystem:
    """State-space open loop L = C P of the hub-plus-appendage PD loop (see module docstring).

    With ``rolloff`` the controller output passes through ``1 / (s^2/W^2 + 2 Z s/W + 1)``
    (two more states), whose phase lag makes the loop cross -180 deg at many appendage modes.
    """
    w, g, z = hub_parameters(order, zeta, seed, rolloff)
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
    L = LinearSystem(A, B, C, np.zeros((1, 1)), states=states, inputs=["torque"], outputs=["control"])
    if not rolloff:
        return L
    # series roll-off R(s) after C P: states r, r_dot with r'' = W^2 (y - r) - 2 Z W r'
    Ar = np.zeros((N + 2, N + 2))
    Ar[:N, :N] = A
    Ar[N, N + 1] = 1.0
    Ar[N + 1, :N] = W_ROLL**2 * C[0]
    Ar[N + 1, N] = -(W_ROLL**2)
    Ar[N + 1, N + 1] = -2 * Z_ROLL * W_ROLL
    Br = np.vstack([B, np.zeros((2, 1))])
    Cr = np.zeros((1, N + 2))
    Cr[0, N] = 1.0
    return LinearSystem(Ar, Br, Cr, np.zeros((1, 1)), states=states + ["rolloff", "rolloff_dot"],
                        inputs=["torque"], outputs=["control"])


def hub_loop_response(omega, order: int, zeta: float, seed: int = 7, rolloff: bool = False):
    """L(j omega) of :func:`hub_loop` in closed form (modal sum times the PD law)."""
    w, g, z = hub_parameters(order, zeta, seed, rolloff)
    s = 1j * np.atleast_1d(np.asarray(omega, dtype=float))
    out = np.empty(s.shape, complex)
    for a in range(0, s.size, 4096):
        sc = s[a:a + 4096, None]
        plant = 1.0 / (J * sc[:, 0] ** 2) + (g / (sc**2 + 2 * z * w * sc + w**2)).sum(axis=1)
        out[a:a + 4096] = (KP + KD * sc[:, 0] / (TAU * sc[:, 0] + 1.0)) * plant
    if rolloff:
        out = out / (s**2 / W_ROLL**2 + 2 * Z_ROLL * s / W_ROLL + 1.0)
    return out


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


def brute_force_crossovers(resp, lo: float, hi: float, rel_step: float):
    """Gain and phase crossovers by a uniform log sweep of relative step ``rel_step`` + bisection.

    Gain crossovers: sign changes of log|L|. Phase crossovers: sign changes of Im L where
    Re L < 0 (checked at the bisected point). Returns (w_gc, w_pc) in rad/s.
    """
    x = np.arange(np.log(lo), np.log(hi), rel_step)
    v = resp(np.exp(x))
    g = np.log(np.abs(v))
    idx = np.flatnonzero(np.sign(g[:-1]) != np.sign(g[1:]))
    wgc = [np.exp(bisect(lambda t: float(np.log(np.abs(resp(np.exp(t))[0]))), x[i], x[i + 1])) for i in idx]
    idx = np.flatnonzero((np.sign(v.imag[:-1]) != np.sign(v.imag[1:])) & ((v.real[:-1] < 0) | (v.real[1:] < 0)))
    wpc = []
    for i in idx:
        xr = bisect(lambda t: float(resp(np.exp(t))[0].imag), x[i], x[i + 1])
        val = resp(np.exp(xr))[0]
        if val.real < 0 and abs(val.imag) < 1e-8 * abs(val):
            wpc.append(np.exp(xr))
    return np.array(wgc), np.array(wpc)


def gyro_loop(h: float = 30.0) -> LinearSystem:
    """3-axis attitude loop with a pitch momentum wheel and one flexible array mode.

    Rigid body, linearized about zero rate with stored wheel momentum ``h_B = [0, -h, 0]``
    [N m s]: ``J w' = u + [h x] w`` (gyroscopic coupling of roll and yaw, nutation at
    ``h / sqrt(Jx Jz)``), ``theta' = w``; a solar-array mode (1.8 rad/s, zeta 0.002) driven by
    roll and yaw torques and seen in roll and yaw; per-axis PD controllers with derivative
    filters. Open loop broken at the three torque inputs (negative feedback): order 6 + 2 + 3.
    """
    Jd = np.array([1200.0, 900.0, 1500.0])
    hv = np.array([0.0, -h, 0.0])
    hx = np.array([[0, -hv[2], hv[1]], [hv[2], 0, -hv[0]], [-hv[1], hv[0], 0]])
    wf, zf = 1.8, 0.002
    phi = np.array([6.0, 0.0, 4.0])  # modal participation of the array in roll and yaw
    n = 6 + 2 + 3
    A = np.zeros((n, n))
    B = np.zeros((n, 3))
    A[0:3, 3:6] = np.eye(3)
    A[3:6, 3:6] = hx / Jd[:, None]
    B[3:6, :] = np.diag(1 / Jd)
    A[6, 7] = 1.0
    A[7, 6], A[7, 7] = -(wf**2), -2 * zf * wf
    B[7, :] = phi / Jd  # the array responds to the hub torques
    C_att = np.zeros((3, n))
    C_att[:, 0:3] = np.eye(3)
    C_att[:, 6] = phi / 50.0  # attitude sensor sees the array deflection
    kp = 4.0 * Jd * 0.1**2 * 10
    kd = 2 * 0.7 * 0.3 * Jd
    tau = 0.2
    for i in range(3):  # filter states f_i' = (theta_i - f_i) / tau
        A[8 + i, :] += C_att[i] / tau
        A[8 + i, 8 + i] -= 1 / tau
    C = (kp + kd / tau)[:, None] * C_att
    for i in range(3):
        C[i, 8 + i] -= kd[i] / tau
    return LinearSystem(A, B, C, np.zeros((3, 3)),
                        states=["roll", "pitch", "yaw", "wx", "wy", "wz", "array", "array_dot", "fx", "fy", "fz"],
                        inputs=["Tx", "Ty", "Tz"], outputs=["ux", "uy", "uz"])


def direct_response(sys: LinearSystem, omega) -> np.ndarray:
    """L(j omega) by dense complex solves C (jw I - A)^-1 B + D, shape (n_omega, p, m)."""
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    n = sys.n_states
    M = 1j * w[:, None, None] * np.eye(n) - np.asarray(sys.A)[None]
    X = np.linalg.solve(M, np.broadcast_to(np.asarray(sys.B, dtype=complex), (w.size, n, sys.n_inputs)))
    return np.asarray(sys.C) @ X + np.asarray(sys.D)
