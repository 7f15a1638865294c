"""Sampled-data simulation: linflex ``simulate`` against python-control's ``input_output_response``.

The case: a rigid body on a revolute joint (inertia 80 kg m^2 about the axis, a torque actuator,
angle and rate sensors) under a 10 Hz discrete PD with a second-order low-pass filter on its
command (Tustin) and a 20 ms computational delay, stepping its angle reference by 0.1 rad;
60 s, 600 samples.

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

The plant's dynamics are linear (``J theta'' = torque``); its attitude sensor is not: it measures
``sin(theta)`` (a direction-cosine component of the body's attitude matrix), which the peer's
output map and the reference apply too. Error: the largest difference of the measured angle at
the sample instants from the exact sampled-data solution (the zero-order-hold recursion of the
linear dynamics with the fractional delay, from ``scipy.linalg.expm``, and the sensor's
``sin``), relative to its largest value. Under a held torque the angle is a quadratic in time, which
RK45 integrates exactly: the RK45 runners reach round-off whatever the tolerance, so the speed
ratio at equal accuracy is the one between the two RK45 rows; CVODES (variable-order Adams)
stays at its tolerance.

Run: ``python benchmarks/sampled.py [--quick]``. BLAS threads are pinned to one.
"""

from __future__ import annotations

import _timing  # noqa: F401  (one BLAS thread: before numpy)
from _timing import median_time  # noqa: E402

# isort: split

import argparse  # noqa: E402
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


def linflex_runner(model, timepts, rtol, atol, method):
    index = list(model.outputs).index("yaw")

    def run():
        return linflex.simulate(model, timepts, rtol=rtol, atol=atol, method=method, progress=False).y[:, index]
    return run


def python_control_runner(K, timepts, rtol, atol):
    A, B = plant_matrices()
    plant = control.nlsys(lambda t, x, u, params: A @ x + B @ u, lambda t, x, u, params: measure(x),
                          states=2, inputs="tz", outputs=["yaw", "r"], name="plant")
    controller = control.ss(K.A, K.B, K.C, K.D, dt=T, name="pd")
    kwargs = {"solve_ivp_method": "RK45", "solve_ivp_kwargs": {"rtol": rtol, "atol": atol}}

    def run():
        x, xc, u_prev = np.zeros(2), np.zeros(K.n_states), np.zeros(1)
        angles = np.empty(timepts.size)
        for k, t in enumerate(timepts):
            y = measure(x)
            angles[k] = y[0]
            if k == timepts.size - 1:
                break
            e = y - np.array([STEP, 0.0])
            u = controller.output(t, xc, e)
            xc = controller.dynamics(t, xc, e)
            for t0, t1, held in ((t, t + TAU, u_prev), (t + TAU, t + T, u)):
                res = control.input_output_response(plant, [t0, t1], np.repeat(np.reshape(held, (1, 1)), 2, axis=1),
                                                    X0=x, **kwargs)
                x = res.states[:, -1]
            u_prev = u
        return angles
    return run


def main(quick: bool = False) -> None:
    print(f"python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
          f"control {control.__version__}, linflex {linflex.__version__}")
    duration = 10.0 if quick else 60.0
    repeats = 1 if quick else 5
    timepts = np.arange(0.0, duration + T / 2, T)
    scene = load_scene()
    model = linflex.compile_model(scene)
    K = linflex.controller_chain(scene.controllers[0], delay=False)   # discrete, command sign, dt = T
    exact = exact_angles(K, timepts.size)
    scale = np.max(np.abs(exact))
    print(f"\nrigid axis, {INERTIA:g} kg m^2, 10 Hz PD with a low-pass on the command and a {1e3 * TAU:g} ms "
          f"delay, {duration:g} s, {timepts.size} samples; error: angle at the samples against the exact "
          "hold recursion, relative")
    print("| runner | rtol / atol | median time [s] | error at the samples | python-control time / this |")
    print("|---|---|---|---|---|")
    for rtol, atol in TOLERANCES:
        t_pc, y_pc = median_time(python_control_runner(K, timepts, rtol, atol), repeats)
        rows = [("python-control input_output_response (RK45), per hold interval", t_pc, y_pc)]
        for method in ("auto", "scipy-RK45"):
            t_lf, y_lf = median_time(linflex_runner(model, timepts, rtol, atol, method), repeats)
            rows.append((f"linflex simulate ({method})", t_lf, y_lf))
        for label, seconds, angles in rows:
            error = np.max(np.abs(angles - exact)) / scale
            print(f"| {label} | {rtol:g} / {atol:g} | {seconds:.4f} | {error:.1e} | {t_pc / seconds:.1f}x |")

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a 10 s run, one repeat (smoke test)")
    main(parser.parse_args().quick)
