"""Sampled-data simulation: linflex ``simulate`` against python-control's ``input_output_response``.

Two cases, each under a 10 Hz scene controller with a 20 ms computational delay, 60 s, 601
samples:

* a rigid body on a revolute joint (inertia 80 kg m^2 about the axis, a torque actuator, angle
  and rate sensors) under a PD with a second-order low-pass filter on its command (Tustin),
  stepping its angle reference by 0.1 rad;
* the flexible spacecraft ``examples/spacecraft_sampled.toml`` (hub, two arrays of 6 modes
  each, three wheels; 34 states) under its PD with the notch on the first array mode, stepping
  the roll reference by 1e-7 rad, where the nonlinear terms are below the integrators' errors
  (the torque limit is not reached).

Runners, at the same tolerances:

* linflex: the scene's sampled controller (``sample_time``, ``delay``, ``filters``) compiled with
  the plant, ``simulate`` with its default method (``"auto"``: CVODES) and with
  ``"scipy-RK45"`` (the peer's integrator): the plant integrated between the samples and the
  instants the commands take effect, the controller stepped at the samples;
* python-control: the continuous plant (``control.nlsys``) and the same discrete controller
  (``control.ss(..., dt=0.1)``). python-control refuses to interconnect them ("Systems have
  incompatible timebases"), and its own sampled-data example discretizes the plant at a fine
  step, which is exact only for a linear plant. The continuous plant is therefore integrated
  with ``input_output_response`` (``solve_ivp`` RK45) over each interval where the held command
  is constant (two per period: before and after the delayed command takes effect), and the
  discrete controller is stepped with its own ``dynamics`` and ``output`` methods.

Error: the largest difference of the measured roll (rigid: yaw) angle at the sample instants
from the exact sampled-data solution, relative to the step: the zero-order-hold recursion of
the linear dynamics with the fractional delay (``scipy.linalg.expm``) and the controller's
discrete chain. The rigid axis's dynamics are linear (``J theta'' = torque``) but its attitude
sensor measures ``sin(theta)`` (a direction-cosine component of the attitude matrix), which the
peer's output map and the reference apply too; the spacecraft's reference is the hold recursion
of its exact (Kane) linearization. Under a held torque the rigid angle is a quadratic in time,
which RK45 integrates exactly: there the RK45 runners reach round-off whatever the tolerance
and CVODES (variable-order Adams) stays at its tolerance. The spacecraft's modes make every
integrator work. Each table ends with the speed-up at equal accuracy: the fastest linflex run
at least as accurate as python-control at rtol 1e-8.

Run: ``python benchmarks/sampled.py [--quick]``. BLAS threads are pinned to one.
"""

from __future__ import annotations

import _timing  # noqa: F401  (one BLAS thread: before numpy)
from _timing import median_time  # noqa: E402

# isort: split

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import platform  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import control  # noqa: E402
import numpy as np  # noqa: E402
import scipy  # noqa: E402
import scipy.linalg  # noqa: E402

import linflex  # noqa: E402

INERTIA, T, TAU, STEP = 80.0, 0.1, 0.02, 0.1
BANDWIDTH, DAMPING = 0.3, 0.7
TOLERANCES = ((1e-8, 1e-10), (1e-10, 1e-12), (1e-12, 1e-14))
AMPLITUDE = 1e-7       # roll step of the flexible case [rad]: linear to round-off
# (rtol, atol per radian of the step): absolute tolerances scale with the tiny motion
FLEXIBLE_TOLERANCES = ((1e-8, 1e-10), (1e-10, 1e-12), (1e-12, 1e-14))
ROOT = Path(__file__).resolve().parents[1]

SCENE = f"""
name = "rigid_axis_sampled"
effects = ["control"]

[[bodies]]
name = "hub"
mass = 100.0
inertia = [50.0, 60.0, {INERTIA}]

[[joints]]
name = "yaw_joint"
type = "revolute"
child = "hub"
axis = [0.0, 0.0, 1.0]

[[sensors]]
name = "yaw"
type = "attitude"
body = "hub"
axis = [0.0, 0.0, 1.0]

[[sensors]]
name = "r"
type = "rate"
body = "hub"
axis = [0.0, 0.0, 1.0]

[[actuators]]
name = "tz"
type = "torque"
body = "hub"
axis = [0.0, 0.0, 1.0]

[[controllers]]
name = "pd"
type = "pid"
inputs = ["yaw"]
rate_inputs = ["r"]
outputs = ["tz"]
kp = [{INERTIA * BANDWIDTH**2}]
kd = [{2 * DAMPING * BANDWIDTH * INERTIA}]
reference = [{STEP}]
sample_time = {T}
delay = {TAU}
filters = [{{ kind = "low_pass", frequency = 3.0, damping = 0.7 }}]
"""


def load_scene():
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "rigid_axis_sampled.toml"
        path.write_text(SCENE, encoding="utf-8")
        return linflex.load_scene(path)


def plant_matrices():
    """The plant's dynamics ``x = [angle, rate]``: a double integrator of ``INERTIA``."""
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([[0.0], [1.0 / INERTIA]])
    return A, B


def measure(x):
    """The sensors: the attitude sensor's ``sin(angle)`` and the rate."""
    return np.array([np.sin(x[0]), x[1]])


def hold(A, B, h):
    """``(Phi, Gamma)`` of a constant input held over ``h`` seconds (Van Loan's block exponential)."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = scipy.linalg.expm(M * h)
    return E[:n, :n], E[:n, n:]


def exact_angles(K, n_samples):
    """Measured angle at the sample instants: the hold recursion with the fractional delay."""
    A, B = plant_matrices()
    before, after = hold(A, B, TAU), hold(A, B, T - TAU)
    x, xc, u_prev = np.zeros(2), np.zeros(K.n_states), np.zeros(1)
    angles = np.empty(n_samples)
    for k in range(n_samples):
        y = measure(x)
        angles[k] = y[0]
        e = y - np.array([STEP, 0.0])
        u = K.C @ xc + K.D @ e
        xc = K.A @ xc + K.B @ e
        x = before[0] @ x + before[1] @ u_prev
        x = after[0] @ x + after[1] @ u
        u_prev = u
    return angles


def linflex_runner(model, timepts, rtol, atol, method, output):
    index = list(model.outputs).index(output)

    def run():
        return linflex.simulate(model, timepts, rtol=rtol, atol=atol, method=method, progress=False).y[:, index]
    return run


def python_control_runner(plant, sensors, x0, K, setpoint, timepts, rtol, atol):
    """python-control's run: ``plant`` (``control.nlsys``) by ``input_output_response`` over each hold
    interval, the discrete controller ``control.ss(K, dt=T)`` stepped at the samples; returns the
    first controller input (the measured angle) at the samples. ``sensors(x)`` gives the
    controller's inputs from the plant state."""
    controller = control.ss(K.A, K.B, K.C, K.D, dt=T, name="controller")
    kwargs = {"solve_ivp_method": "RK45", "solve_ivp_kwargs": {"rtol": rtol, "atol": atol}}
    n_u = K.n_outputs

    def run():
        x, xc, u_prev = np.array(x0, float), np.zeros(K.n_states), np.zeros(n_u)
        angles = np.empty(timepts.size)
        for k, t in enumerate(timepts):
            y = sensors(x)
            angles[k] = y[0]
            if k == timepts.size - 1:
                break
            e = y - setpoint
            u = controller.output(t, xc, e)
            xc = controller.dynamics(t, xc, e)
            for t0, t1, held in ((t, t + TAU, u_prev), (t + TAU, t + T, u)):
                U = np.repeat(np.reshape(held, (n_u, 1)), 2, axis=1)
                x = control.input_output_response(plant, [t0, t1], U, X0=x, **kwargs).states[:, -1]
            u_prev = u
        return angles
    return run


def rigid_case(duration):
    """The rigid axis: sampled model, peer runner factory, exact measured angles, scale [rad]."""
    timepts = np.arange(0.0, duration + T / 2, T)
    scene = load_scene()
    model = linflex.compile_model(scene)
    K = linflex.controller_chain(scene.controllers[0], delay=False)   # discrete, command sign, dt = T
    A, B = plant_matrices()
    plant = control.nlsys(lambda t, x, u, params: A @ x + B @ u, lambda t, x, u, params: measure(x),
                          states=2, inputs="tz", outputs=["yaw", "r"], name="plant")
    peer = lambda rtol, atol: python_control_runner(plant, measure, np.zeros(2), K, np.array([STEP, 0.0]),  # noqa: E731
                                                    timepts, rtol, atol)
    exact = exact_angles(K, timepts.size)
    return timepts, model, "yaw", peer, exact, STEP


def flexible_case(duration):
    """``examples/spacecraft_sampled.toml`` with a roll step of ``AMPLITUDE``: linear to round-off.

    The reference: the hold recursion of the plant's exact (Kane) linearization with the
    controller's discrete chain; at this amplitude the nonlinear terms are of relative size
    ``1e-7`` times the linear ones' deviation, below the integrators' errors.
    """
    from linflex.linearize import linearize

    timepts = np.arange(0.0, duration + T / 2, T)
    scene = linflex.load_scene(ROOT / "examples" / "spacecraft_sampled.toml")
    ctrl = dataclasses.replace(scene.controllers[0], reference=[AMPLITUDE, 0.0, 0.0])
    scene = dataclasses.replace(scene, controllers=(ctrl,))
    model = linflex.compile_model(scene)
    plant_model = linflex.compile_model(dataclasses.replace(scene, effects=tuple(e for e in scene.effects
                                                                                 if e != "control")))
    K = linflex.controller_chain(ctrl, delay=False)
    sensors = list(ctrl.inputs) + list(ctrl.rate_inputs)
    setpoint = np.array([AMPLITUDE] + [0.0] * (len(sensors) - 1))
    f, h = plant_model.casadi_functions()
    p = np.asarray(plant_model.param_values)
    index = [list(plant_model.outputs).index(name) for name in sensors]
    measured = lambda x: np.asarray(h(x, np.zeros(plant_model.n_inputs), p, 0.0), float).ravel()[index]  # noqa: E731
    plant = control.nlsys(lambda t, x, u, params: np.asarray(f(x, u, p, t), float).ravel(),
                          lambda t, x, u, params: np.asarray(h(x, u, p, t), float).ravel(),
                          states=plant_model.n_states, inputs=plant_model.n_inputs,
                          outputs=plant_model.n_outputs, name="plant")
    peer = lambda rtol, atol: python_control_runner(plant, measured, plant_model.x0, K, setpoint,  # noqa: E731
                                                    timepts, rtol, atol)
    lin = linearize(plant_model, linflex.OperatingPoint(plant_model.x0, np.zeros(plant_model.n_inputs)),
                    method="kane").sys
    before, after = hold(lin.A, lin.B, TAU), hold(lin.A, lin.B, T - TAU)
    y0 = measured(np.asarray(plant_model.x0, float))
    x, xc, u_prev = np.zeros(lin.n_states), np.zeros(K.n_states), np.zeros(K.n_outputs)
    exact = np.empty(timepts.size)
    for k in range(timepts.size):
        y = y0 + lin.C[index] @ x
        exact[k] = y[0]
        e = y - setpoint
        u = K.C @ xc + K.D @ e
        xc = K.A @ xc + K.B @ e
        x = after[0] @ (before[0] @ x + before[1] @ u_prev) + after[1] @ u
        u_prev = u
    return timepts, model, sensors[0], peer, exact, AMPLITUDE


def run_case(title, case, tolerances, methods, repeats, peer_runs=None):
    """Time and check every runner at every tolerance (python-control at the first ``peer_runs``)."""
    timepts, model, output, peer, exact, scale = case
    print(f"\n{title}, {timepts[-1]:g} s, {timepts.size} samples; error: the measured angle at the samples "
          "against the exact hold recursion, relative to the step")
    print("| runner | rtol / atol | median time [s] | error at the samples | python-control (rtol 1e-8) time / this |")
    print("|---|---|---|---|---|")
    rows = []
    for k, (rtol, atol) in enumerate(tolerances):
        if peer_runs is None or k < peer_runs:
            t_pc, y_pc = median_time(peer(rtol, atol), repeats)
            rows.append(("python-control input_output_response (RK45), per hold interval", rtol, atol, t_pc, y_pc))
        for method in methods:
            t_lf, y_lf = median_time(linflex_runner(model, timepts, rtol, atol, method, output), repeats)
            rows.append((f"linflex simulate ({method})", rtol, atol, t_lf, y_lf))
    rows = [(label, rtol, atol, seconds, np.max(np.abs(y - exact)) / scale) for label, rtol, atol, seconds, y in rows]
    peer_time, peer_error = rows[0][3], rows[0][4]
    for label, rtol, atol, seconds, error in rows:
        print(f"| {label} | {rtol:g} / {atol:g} | {seconds:.4f} | {error:.1e} | {peer_time / seconds:.1f}x |")
    # Equal accuracy: the fastest linflex run at least as accurate as the peer's at rtol 1e-8.
    better = [r for r in rows if r[0].startswith("linflex") and r[4] <= peer_error]
    if better:
        best = min(better, key=lambda r: r[3])
        print(f"\nat equal accuracy ({peer_error:.1e} or better): {best[0]} at rtol {best[1]:g} takes "
              f"{best[3]:.4f} s, python-control {peer_time:.4f} s: {peer_time / best[3]:.1f}x")
    else:
        print(f"\nno linflex run reached the peer's accuracy at rtol 1e-8 ({peer_error:.1e})")


def main(quick: bool = False) -> None:
    print(f"python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
          f"control {control.__version__}, linflex {linflex.__version__}")
    duration = 10.0 if quick else 60.0
    repeats = 1 if quick else 5
    run_case(f"rigid axis, {INERTIA:g} kg m^2, 10 Hz PD with a low-pass on the command and a {1e3 * TAU:g} ms "
             f"delay, a {STEP:g} rad step", rigid_case(duration), TOLERANCES, ("auto", "scipy-RK45"), repeats)
    flexible = flexible_case(duration)
    tolerances = [(rtol, AMPLITUDE * a) for rtol, a in FLEXIBLE_TOLERANCES]
    run_case(f"flexible spacecraft (examples/spacecraft_sampled.toml, {flexible[1].n_states} states: 10 Hz PD, "
             f"notch, 20 ms delay), a {AMPLITUDE:g} rad roll step; python-control at the first "
             f"{1 if quick else 2} tolerances only (seconds per run)", flexible,
             tolerances[:2] if quick else tolerances, ("auto",), 1 if quick else 3, peer_runs=1 if quick else 2)

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a 10 s run, one repeat (smoke test)")
    main(parser.parse_args().quick)
