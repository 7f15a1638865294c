"""A three-axis flexible spacecraft, linearized by every method linflex offers.

The story: a rigid hub (quaternion attitude, body rates) carries a momentum wheel spinning at
100 rad/s and flexible appendages described by ``n_modes`` lightly damped modes (damping ratio
0.005) that couple to the hub's rotation through modal participation factors (hybrid
coordinates). Holding attitude with the wheel spinning is an equilibrium. We linearize it with

- python-control's ``linearize`` (forward differences, fixed absolute step 1e-6), the peer;
- linflex ``perturbation`` (the classic three-point fit with step halving);
- linflex ``central`` (central differences with Richardson extrapolation);
- linflex ``complex-step`` (on the numpy version of the model);
- linflex ``autodiff`` (exact, on the CasADi version),

and print, for each, the largest entry error against ``autodiff``, the error the method itself
estimated, the number of model evaluations and the time. Then the poles: the rigid-body modes
at the origin, the wheel's gyroscopic nutation, and the appendage modes.

Run: ``python examples/flexible_spacecraft.py [n_modes]``.

Equations (J hub inertia [kg m^2], L modal participation [sqrt(kg) m], Omega modal frequencies
[rad/s], zeta damping, h_w = I_w w_w wheel momentum [N m s] along axis a)::

    J w' + L^T eta'' = -w x (J w + L^T eta' + h_w a) + tau - tau_w a
    eta'' + L w' + 2 zeta Omega eta' + Omega^2 eta = 0
    I_w w_w' = tau_w,       q' = 1/2 q (x) [0, w]
"""

from __future__ import annotations

import sys
import time

import casadi as ca
import control
import numpy as np

from linflex import NonlinearModel, OperatingPoint
from linflex.linearize import linearize

HUB_INERTIA = np.diag([1200.0, 1500.0, 900.0])  # kg m^2
WHEEL_AXIS = np.array([0.0, 1.0, 0.0])  # momentum wheel on the pitch axis
WHEEL_INERTIA = 0.12  # kg m^2, spin axis
WHEEL_SPEED = 100.0  # rad/s at the operating point
DAMPING = 0.005


def appendage_modes(n_modes: int, seed: int = 7):
    """Modal frequencies [rad/s] and participation factors of the appendages (fixed seed)."""
    rng = np.random.default_rng(seed)
    omega = 0.8 * np.geomspace(1.0, 60.0, n_modes) if n_modes else np.zeros(0)
    L = rng.normal(size=(n_modes, 3)) / np.sqrt(np.arange(1, n_modes + 1))[:, None]
    if n_modes:
        # Keep the coupled mass matrix well conditioned: L^T L <= 0.4 J.
        ratio = np.linalg.eigvalsh(np.linalg.solve(np.sqrt(HUB_INERTIA), L.T @ L) @ np.linalg.inv(np.sqrt(HUB_INERTIA)))
        L *= np.sqrt(0.4 / max(ratio.max(), 1e-300))
    return omega, L


def state_names(n_modes: int) -> list[str]:
    return (["qw", "qx", "qy", "qz", "wx", "wy", "wz", "w_wheel"]
            + [f"eta{k}" for k in range(n_modes)] + [f"eta{k}_dot" for k in range(n_modes)])


def _equations(x, u, lib, omega_modes, L, J_eff_inv):
    """State derivative and outputs in numpy or CasADi (``lib`` supplies vertcat/cross)."""
    m = omega_modes.size
    q = x[0:4]
    w = x[4:7]
    w_wheel = x[7]
    eta = x[8:8 + m]
    eta_dot = x[8 + m:8 + 2 * m]
    tau, tau_w = u[0:3], u[3]
    qw, qv = q[0], q[1:4]
    h = HUB_INERTIA @ w + L.T @ eta_dot + WHEEL_INERTIA * w_wheel * WHEEL_AXIS
    F_w = -lib.cross(w, h) + tau - tau_w * WHEEL_AXIS
    F_eta = -2 * DAMPING * omega_modes * eta_dot - omega_modes**2 * eta
    # Schur complement of the constant mass matrix [[J, L^T], [L, I]]: O(m) per evaluation.
    w_dot = J_eff_inv @ (F_w - L.T @ F_eta)
    eta_ddot = F_eta - L @ w_dot
    q_dot = lib.concat([-0.5 * (qv[0] * w[0] + qv[1] * w[1] + qv[2] * w[2])], 0.5 * (qw * w + lib.cross(qv, w)))
    xdot = lib.concat(q_dot, w_dot, [tau_w / WHEEL_INERTIA], eta_dot, eta_ddot)
    y = lib.concat(2 * qv, w, [w_wheel])
    return xdot, y


class _Numpy:
    cross = staticmethod(np.cross)

    @staticmethod
    def concat(*parts):
        return np.concatenate([np.asarray(p).reshape(-1) for p in parts])


class _Casadi:
    @staticmethod
    def cross(a, b):
        return ca.cross(ca.vertcat(*[a[i] for i in range(3)]) if not isinstance(a, ca.SX) else a,
                        ca.vertcat(*[b[i] for i in range(3)]) if not isinstance(b, ca.SX) else b)

    @staticmethod
    def concat(*parts):
        return ca.vertcat(*[ca.vertcat(*p) if isinstance(p, list) else p for p in parts])


def build_model(n_modes: int = 4, backend: str = "casadi") -> NonlinearModel:
    """The spacecraft as a :class:`~linflex.NonlinearModel` with ``8 + 2 n_modes`` states.

    Parameters
    ----------
    n_modes : int
        Number of appendage modes.
    backend : {"casadi", "numpy"}
        CasADi expressions (for ``autodiff``) or numpy callables (complex-step safe).
    """
    omega_modes, L = appendage_modes(n_modes)
    J_eff_inv = np.linalg.inv(HUB_INERTIA - L.T @ L)
    names = dict(states=state_names(n_modes), inputs=["tx", "ty", "tz", "tau_wheel"],
                 outputs=["att_x", "att_y", "att_z", "gyro_x", "gyro_y", "gyro_z", "wheel_speed"])
    if backend == "numpy":
        def f(x, u, t):
            return _equations(x, u, _Numpy, omega_modes, L, J_eff_inv)[0]

        def h(x, u, t):
            return _equations(x, u, _Numpy, omega_modes, L, J_eff_inv)[1]

        return NonlinearModel(f, h, **names)
    if backend != "casadi":
        raise ValueError(f"backend must be 'casadi' or 'numpy', got {backend!r}")
    x = ca.SX.sym("x", 8 + 2 * n_modes)
    u = ca.SX.sym("u", 4)
    xdot, y = _equations(x, u, _Casadi, omega_modes, ca.DM(L), ca.DM(J_eff_inv))
    return NonlinearModel.from_casadi(xdot, x, u, y, **names)


def operating_point(n_modes: int) -> OperatingPoint:
    """Attitude held (identity quaternion), wheel at ``WHEEL_SPEED``, appendages at rest."""
    x = np.zeros(8 + 2 * n_modes)
    x[0] = 1.0
    x[7] = WHEEL_SPEED
    return OperatingPoint(x, np.zeros(4))


def python_control_linearization(model: NonlinearModel, op: OperatingPoint):
    """python-control's ``linearize`` on the same numpy model (forward differences, eps=1e-6)."""
    sys_nl = control.nlsys(lambda t, x, u, params: model.f(x, u, t), lambda t, x, u, params: model.h(x, u, t),
                           states=model.n_states, inputs=model.n_inputs, outputs=model.n_outputs)
    return control.linearize(sys_nl, op.x, op.u)


def compare_methods(n_modes: int = 4):
    """Linearize with every method; return rows (method, max error, estimate, evaluations, s)."""
    casadi_model = build_model(n_modes, "casadi")
    numpy_model = build_model(n_modes, "numpy")
    op = operating_point(n_modes)
    exact = linearize(casadi_model, op, method="autodiff")
    J_exact = np.block([[exact.sys.A, exact.sys.B], [exact.sys.C, exact.sys.D]])
    # Row scale (one equation each); a row that is exactly zero is judged in absolute terms.
    scale = np.max(np.abs(J_exact), axis=1, keepdims=True)
    scale[scale == 0] = 1.0

    def error(J):
        return float(np.max(np.abs(J - J_exact) / scale))

    rows = []
    start = time.perf_counter()
    peer = python_control_linearization(numpy_model, op)
    peer_seconds = time.perf_counter() - start
    rows.append(("python-control linearize", error(np.block([[peer.A, peer.B], [peer.C, peer.D]])),
                 float("nan"), 2 * (numpy_model.n_states + numpy_model.n_inputs) + 2, peer_seconds))
    for method in ("perturbation", "central", "complex-step"):
        lin = linearize(numpy_model, op, method=method)
        J = np.block([[lin.sys.A, lin.sys.B], [lin.sys.C, lin.sys.D]])
        rows.append((f"linflex {method}", error(J), lin.max_relative_error_estimate, lin.n_evaluations, lin.seconds))
    rows.append(("linflex autodiff", 0.0, exact.max_relative_error_estimate, exact.n_evaluations, exact.seconds))
    return rows, exact


def main(n_modes: int = 4) -> float:
    """Print the accuracy/cost table and the poles; return the perturbation method's error."""
    rows, exact = compare_methods(n_modes)
    n = exact.sys.n_states
    print(f"Flexible spacecraft: {n} states, {exact.sys.n_inputs} inputs, {exact.sys.n_outputs} outputs, "
          f"{n_modes} appendage modes (damping {DAMPING}), wheel at {WHEEL_SPEED} rad/s\n")
    print("Errors are the largest |J - J_autodiff| over each row's largest |J_autodiff| entry.")
    print(f"{'method':<28}{'max error':>12}{'estimated':>12}{'evaluations':>13}{'seconds':>10}")
    for name, err, estimate, evaluations, seconds in rows:
        est = "-" if np.isnan(estimate) else f"{estimate:.1e}"
        print(f"{name:<28}{err:>12.1e}{est:>12}{evaluations:>13d}{seconds:>10.4f}")
    eig = np.linalg.eigvals(exact.sys.A)
    eig = eig[np.argsort(np.abs(eig))]
    print("\nPoles (upper half plane and real):")
    print(f"{'real':>14}{'imag':>14}{'wn [rad/s]':>12}{'damping':>10}")
    for lam in eig[eig.imag >= 0]:
        wn = abs(lam)
        zeta = -lam.real / wn if wn > 1e-9 else float("nan")
        print(f"{lam.real:>14.6f}{lam.imag:>14.6f}{wn:>12.5f}{zeta:>10.4f}")
    return rows[1][1]


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 4)
