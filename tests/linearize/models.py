"""Test models with closed-form Jacobians, shared by the linearization tests."""

import casadi as ca
import numpy as np

from linflex import NonlinearModel, SecondOrderSystem

MU_EARTH = 3.986004418e14  # m^3/s^2


def euler_equations(inertia, *, backend="numpy"):
    """Torque-free rigid body: omega' = I^-1 (-omega x I omega + tau), body-frame rates [rad/s]."""
    I = np.asarray(inertia, dtype=float)
    names = dict(states=["wx", "wy", "wz"], inputs=["tx", "ty", "tz"])
    if backend == "casadi":
        w = ca.SX.sym("w", 3)
        tau = ca.SX.sym("tau", 3)
        Iw = ca.DM(I) @ w
        rhs = ca.solve(ca.DM(I), -ca.cross(w, Iw) + tau)
        return NonlinearModel.from_casadi(rhs, w, tau, w, outputs=["gx", "gy", "gz"], **names)
    Iinv = np.linalg.inv(I)
    return NonlinearModel(lambda w, tau, t: Iinv @ (-np.cross(w, I @ w) + tau), lambda w, tau, t: w,
                          outputs=["gx", "gy", "gz"], **names)


def orbit_and_pitch(radius=7.0e6, k=0.5, *, backend="numpy"):
    """Planar circular orbit in polar coordinates with a gravity-gradient pitch attitude.

    States: r [m], r' [m/s], theta' [rad/s] (orbit rate), phi [rad] (pitch relative to the local
    vertical), phi' [rad/s]. Scales differ by 1e9 and more: r ~ 7e6 m beside theta' ~ 1e-3 rad/s.
    Input: radial thrust acceleration [m/s^2] and pitch torque per inertia [1/s^2].

        r''      = r theta'^2 - mu / r^2 + a_r
        theta''  = -2 r' theta' / r
        phi''    = -3 (mu / r^3) k sin(phi) cos(phi) - theta'' + tau      (k = (Ix - Iz) / Iy)
    """

    def rhs(x, u, lib):
        r, rd, thd, phi, phid = x[0], x[1], x[2], x[3], x[4]
        thdd = -2 * rd * thd / r
        return [rd,
                r * thd**2 - MU_EARTH / r**2 + u[0],
                thdd,
                phid,
                -3 * MU_EARTH / r**3 * k * lib.sin(phi) * lib.cos(phi) - thdd + u[1]]

    names = dict(states=["r", "r_dot", "theta_dot", "phi", "phi_dot"], inputs=["a_r", "tau"])
    if backend == "casadi":
        x = ca.SX.sym("x", 5)
        u = ca.SX.sym("u", 2)
        return NonlinearModel.from_casadi(ca.vertcat(*rhs(x, u, ca)), x, u, **names)
    return NonlinearModel(lambda x, u, t: np.array(rhs(x, u, np)), **names)


def orbit_and_pitch_jacobian(radius=7.0e6, k=0.5):
    """Closed-form A and B of :func:`orbit_and_pitch` at the circular orbit, phi = 0."""
    n = np.sqrt(MU_EARTH / radius**3)
    A = np.zeros((5, 5))
    A[0, 1] = 1.0
    A[1, 0] = n**2 + 2 * MU_EARTH / radius**3  # = 3 n^2
    A[1, 2] = 2 * radius * n
    A[2, 1] = -2 * n / radius
    A[3, 4] = 1.0
    A[4, 1] = 2 * n / radius
    A[4, 3] = -3 * n**2 * k
    B = np.zeros((5, 2))
    B[1, 0] = 1.0
    B[4, 1] = 1.0
    return A, B, n


def spacecraft(n_modes=100, zeta=(1e-4, 5e-3), seed=0):
    """Rigid-body double integrator plus lightly damped modes (damping 1e-4 to 5e-3), in a mixed
    (non-modal) basis: the reduction tests' and benchmark's spacecraft."""
    rng = np.random.default_rng(seed)
    w = np.sort(rng.uniform(0.5, 60.0, n_modes))
    z = np.exp(rng.uniform(np.log(zeta[0]), np.log(zeta[1]), n_modes))
    n = n_modes + 1
    K, D, M = np.diag(np.r_[0.0, w**2]), np.diag(np.r_[0.0, 2 * z * w]), np.eye(n)
    b = np.r_[1.0, rng.normal(0, 0.3, n_modes)][:, None]
    c = np.r_[1.0, rng.normal(0, 0.3, n_modes)][None, :]
    Q1, Q2 = np.linalg.qr(rng.normal(size=(n, n)))[0], np.linalg.qr(rng.normal(size=(n, n)))[0]
    P = np.linalg.inv(Q1 @ np.diag(rng.uniform(0.5, 2, n)) @ Q2)
    return SecondOrderSystem(P.T @ M @ P, P.T @ D @ P, P.T @ K @ P, P.T @ b, Cq=c @ P)
