"""Simulation: linflex ``simulate`` against python-control and against CasADi called directly.

Two models, each over 100 s with 1001 output samples:

* the three-axis flexible spacecraft of ``examples/flexible_spacecraft.py`` (rigid hub with
  quaternion attitude, a 100 rad/s momentum wheel, 4 appendage modes: 16 states), started
  from its equilibrium with a small body-rate error;
* the gyrostat scene ``examples/gyrostat.toml`` compiled with ``compile_model`` (three wheels,
  slosh pendulum, nutation damper: 16 states), spinning at 5 rpm.

Runners, all at the same tolerances (rtol 1e-8, atol 1e-10) on the same equations:

* linflex ``simulate(method="cvodes")`` (default chunks: 20 restarts with quaternion
  renormalization for the scene; one run for the plain model);
* linflex ``simulate(method="cvodes-adams")`` (Adams, functional iteration, no Jacobian);
* linflex ``simulate(method="scipy-RK45")``;
* python-control ``input_output_response`` (RK45 through ``solve_ivp``) with the equations as a
  numpy callback (the flexible spacecraft's numpy version; for the scene the compiled CasADi
  function called from numpy), the peer;
* CasADi's ``integrator("cvodes")`` called directly with the output grid, the floor.

Error: the largest state difference at the samples against ``scipy DOP853`` at rtol 1e-12.

Then the stiff-looking flexible case of issue 20 (:func:`arrays_case`): the hub with two
undamped solar arrays of 8 and 16 modes each after a yaw-wheel pulse, 30 s, linflex's default
(``method="auto"``), the exponential integrator, Adams and BDF against scipy's BDF with the
exact Jacobian and CasADi's CVODES called directly, in CPU seconds; and the cost of the same run
against the number of modes per array (:func:`modes_table`: 2 to 32) at fixed tolerances for the
exponential integrator and Adams, with the accuracy reached (tip deflection, each state over its
own scale, against DOP853 at rtol 1e-11) and where the cost goes (integrator steps,
re-linearizations, CPU time of one right-hand side), with the fitted exponents; then the
exponential integrator's work-precision sweep and its cost at fixed tip accuracy against the
number of modes (:func:`precision_table`), the error at fixed steps with the Jacobian frozen and
taken anew at every step (:func:`jacobian_age_table`: is the frozen Jacobian's age what the
axial mode costs?), the fixed-step error with the axial mode added to the 16-mode arrays, taken
out of the 24-mode ones, and damped (:func:`axial_mode_table`: is it that mode, and its free
oscillation?), and the same for the spin-up of a cantilever on a hub
(:func:`spinup_precision`: 4 to 24 modes, a prescribed, time-varying motion), with Adams, the
method ``"auto"`` takes there, beside it. The exponents are fitted over all numbers of modes and
separately over the models without and with an axial mode of the beams.

Run: ``python benchmarks/simulation.py [--quick] [--arrays 8 16] [--modes 2 4 8 16 24 32 48]``. BLAS
threads are pinned to one.
"""

from __future__ import annotations

import _timing  # noqa: F401  (one BLAS thread: before numpy)
from _axial import axial_forcing_table, fixed_steps  # noqa: E402
from _timing import median_time  # noqa: E402

# isort: split

import argparse  # noqa: E402
import importlib.util  # noqa: E402
import platform  # noqa: E402
import re  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import casadi as ca  # noqa: E402
import control  # noqa: E402
import numpy as np  # noqa: E402

import linflex  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RTOL, ATOL = 1e-8, 1e-10


def load_flexible_example():
    spec = importlib.util.spec_from_file_location("flexible_spacecraft", ROOT / "examples" / "flexible_spacecraft.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module



def direct_casadi(model, timepts, x0):
    f, _ = model.casadi_functions()
    x = ca.MX.sym("x", model.n_states)
    u = np.zeros(model.n_inputs)
    ode = f(x, u, model.param_values, 0.0)
    F = ca.integrator("F", "cvodes", {"x": x, "ode": ode}, 0.0, timepts.tolist(),
                      {"abstol": ATOL, "reltol": RTOL, "max_num_steps": 1_000_000})
    return lambda: np.asarray(F(x0=x0)["xf"], float).T


def python_control_runner(fun, n_states, n_inputs, timepts, x0):
    sys_nl = control.NonlinearIOSystem(lambda t, x, u, params: fun(x, u, t), None, states=n_states,
                                       inputs=n_inputs, outputs=n_states, name="peer")
    U = np.zeros((n_inputs, timepts.size))

    def run():
        res = control.input_output_response(sys_nl, timepts, U, x0, solve_ivp_method="RK45",
                                            solve_ivp_kwargs={"rtol": RTOL, "atol": ATOL})
        return np.asarray(res.states).T
    return run


def bench_case(name, model, numpy_fun, x0, timepts, repeats):
    reference = linflex.simulate(model, timepts, x0, method="scipy-DOP853", rtol=1e-12, atol=1e-13).x
    runners = {
        "linflex simulate cvodes": lambda: linflex.simulate(model, timepts, x0, method="cvodes", rtol=RTOL, atol=ATOL).x,
        "linflex simulate cvodes-adams": lambda: linflex.simulate(model, timepts, x0, method="cvodes-adams", rtol=RTOL, atol=ATOL).x,
        "linflex simulate exponential": lambda: linflex.simulate(model, timepts, x0, method="exponential", rtol=RTOL, atol=ATOL).x,
        "linflex simulate scipy-RK45": lambda: linflex.simulate(model, timepts, x0, method="scipy-RK45", rtol=RTOL, atol=ATOL).x,
        "python-control input_output_response (RK45)": python_control_runner(numpy_fun, model.n_states, model.n_inputs, timepts, x0),
        "CasADi integrator cvodes, direct": direct_casadi(model, timepts, x0),
    }
    # Round-robin repeats so that load from other processes hits every runner alike; the slow
    # peer runs in half of the rounds.
    for fn in runners.values():
        fn()  # warm-up (integrator construction caches, imports)
    times: dict[str, list[float]] = {label: [] for label in runners}
    results: dict[str, object] = {}
    for k in range(repeats):
        for label, fn in runners.items():
            if "python-control" in label and k >= max(1, (repeats + 1) // 2):
                continue
            start = time.perf_counter()
            results[label] = fn()
            times[label].append(time.perf_counter() - start)
    rows = {}
    for label in runners:
        err = float(np.max(np.abs(np.asarray(results[label])[-timepts.size:] - reference)))
        rows[label] = (statistics.median(times[label]), err)
    peer = rows["python-control input_output_response (RK45)"][0]
    floor = rows["CasADi integrator cvodes, direct"][0]
    print(f"\n{name}: {model.n_states} states, {timepts[-1]:g} s, {timepts.size} samples, rtol {RTOL:g}, atol {ATOL:g}")
    print("| runner | median time [s] | max state error | speed vs python-control | time vs CasADi direct |")
    print("|---|---|---|---|---|")
    for label, (t, err) in rows.items():
        print(f"| {label} | {t:.4f} | {err:.1e} | {peer / t:.1f}x | {t / floor:.2f}x |")
    return rows


def main(quick: bool = False) -> None:
    print(f"python {platform.python_version()}, casadi {ca.__version__}, control {control.__version__}, "
          f"numpy {np.__version__}; BLAS threads pinned to 1")
    repeats = 1 if quick else 5
    duration = 10.0 if quick else 100.0
    timepts = np.linspace(0.0, duration, 1001)

    fx = load_flexible_example()
    n_modes = 4
    cas = fx.build_model(n_modes, backend="casadi")
    num = fx.build_model(n_modes, backend="numpy")
    x0 = np.array(fx.operating_point(n_modes).x, dtype=float)
    x0[4:7] += [1e-3, -2e-3, 1.5e-3]
    bench_case("Flexible spacecraft (examples/flexible_spacecraft.py)", cas,
               lambda x, u, t: np.asarray(num.f(x, u, t), float), x0, timepts, repeats)

    scene = linflex.load_scene(ROOT / "examples" / "gyrostat.toml")
    model = linflex.compile_model(scene)
    f = model.f

    def scene_numpy(x, u, t):
        return np.asarray(f(x, u, t), float).reshape(-1)
    bench_case("Gyrostat scene (examples/gyrostat.toml, compile_model)", model, scene_numpy, model.x0, timepts, repeats)
    t_build, _ = median_time(lambda: linflex.compile_model(scene), repeats)
    print(f"\ncompile_model(gyrostat): median {t_build:.3f} s")
    tolerance_table(model, model.x0, timepts, [1e-4, 1e-8] if quick else [1e-4, 1e-6, 1e-8, 1e-10, 1e-12],
                    repeats)


def cpu_median(fn, repeats: int):
    """``(median CPU seconds of this process, last result)``: on a shared machine the CPU time of a
    single-threaded run (BLAS pinned to one thread) is what an idle machine's wall time would be."""
    times, result = [], None
    for _ in range(max(1, int(repeats))):
        start = time.process_time()
        result = fn()
        times.append(time.process_time() - start)
    return statistics.median(times), result


ARRAY_NAMES = ("array_left", "array_right")
# The yaw wheel's motor pulse of ArraysCase: 50 N m from t = 0 to this time [s].
PULSE_END = 2.0
ADAMS = {"linear_multistep_method": "adams", "nonlinear_solver_iteration": "functional"}


class ArraysCase:
    """The hub with two undamped solar arrays of ``n_modes`` modes each after a 50 N m, 2 s pulse
    of the yaw wheel's motor (``duration`` s, samples every 0.1 s), with runners on the compiled
    right-hand side: scipy's ``solve_ivp`` and CasADi's CVODES called directly."""

    def __init__(self, n_modes: int, duration: float = 30.0, modes=None, damping=None):
        """``modes``: which of the arrays' lowest ``n_modes`` modes to keep (all by default);
        ``damping``: damping ratios of some of them, ``{index: ratio}`` (all undamped by default)."""
        import dataclasses

        scene = linflex.vary_scene(linflex.load_scene(ROOT / "examples" / "spacecraft_arrays.toml"),
                                   {f"bodies.{b}.modes": n_modes for b in ARRAY_NAMES})
        bodies = tuple(dataclasses.replace(b, beam={**b.beam, "damping": 0.0}) if b.beam else b for b in scene.bodies)
        if modes is not None or damping:
            bodies = tuple(dataclasses.replace(b, beam=None, modes=None,
                                               modal_data=_modified(b.resolved_modal_data(), modes, damping or {}))
                           if b.beam else b for b in bodies)
        self.scene = dataclasses.replace(scene, bodies=bodies)
        self.n_modes = n_modes if modes is None else len(modes)
        self.model = model = linflex.compile_model(self.scene)
        self.timepts = timepts = np.linspace(0.0, duration, int(round(duration * 10)) + 1)
        self.k = model.input_index("motor_z")
        self.pulse = np.zeros(model.n_inputs)
        self.pulse[self.k] = 50.0
        end = int(timepts.searchsorted(PULSE_END - 1e-9))  # the sample where the pulse ends
        self.segments = [(timepts[:end + 1], self.pulse), (timepts[end:], np.zeros(model.n_inputs))]
        f, _ = model.casadi_functions()
        self.x, self.u = ca.MX.sym("x", model.n_states), ca.MX.sym("u", model.n_inputs)
        self.ode = f(self.x, self.u, model.param_values, 0.0)
        self.jac = ca.Function("jacobian_x", [self.x, self.u], [ca.jacobian(self.ode, self.x)])
        self.fnum = ca.Function("f", [self.x, self.u], [self.ode])

    def scipy_run(self, method, rtol, atol):
        from scipy.integrate import solve_ivp

        def run():
            xs, out = self.model.x0, [self.model.x0]
            for grid, uk in self.segments:
                extra = {"jac": lambda t, xx, uk=uk: self.jac(xx, uk).full()} if method == "BDF" else {}
                r = solve_ivp(lambda t, xx, uk=uk: self.fnum(xx, uk).full().ravel(), (grid[0], grid[-1]), xs,
                              method=method, t_eval=grid, rtol=rtol, atol=atol, **extra)
                out.append(r.y.T[1:])
                xs = r.y[:, -1]
            return np.vstack(out)
        return run

    def casadi_run(self, opts, stats=None):
        """CVODES called directly; ``stats`` (a dict) receives the step and evaluation counts."""
        F = [ca.integrator("F", "cvodes", {"x": self.x, "u": self.u, "ode": self.ode}, 0.0,
                           (grid - grid[0]).tolist(), {"abstol": ATOL, "reltol": RTOL, "max_num_steps": 1_000_000, **opts})
             for grid, _ in self.segments]

        def run():
            xs, out = self.model.x0, [self.model.x0]
            steps = fevals = 0
            for Fk, (_, uk) in zip(F, self.segments):
                xk = np.asarray(Fk(x0=xs, u=uk)["xf"], float).T[1:]
                out.append(xk)
                xs = xk[-1]
                steps, fevals = steps + Fk.stats()["nsteps"], fevals + Fk.stats()["nfevals"]
            if stats is not None:
                stats.update(steps=steps, fevals=fevals)
            return np.vstack(out)
        return run

    def held(self, times) -> np.ndarray:
        """The inputs held from each of ``times`` [s], shape (len(times), n_inputs): the pulse
        before :data:`PULSE_END`, nothing after."""
        return np.where((np.asarray(times) < PULSE_END - 1e-9)[:, None], self.pulse[None, :], 0.0)

    def inputs(self) -> dict:
        """``simulate``'s ``inputs`` for the sample times: the motor's torque [N m]."""
        return {"motor_z": self.held(self.timepts)[:, self.k]}

    def tips(self, X):
        """In-plane (hub x) tip deflections of both arrays [m], shape (n_time, 2)."""
        cols = []
        for name in ARRAY_NAMES:
            body = next(b for b in self.scene.bodies if b.name == name)
            _, tip, _ = body.resolved_modal_data().node("0.end")
            idx = [self.model.states.index(f"{name}.eta{j}") for j in range(self.n_modes)]
            cols.append(X[:, idx] @ tip[0])
        return np.column_stack(cols)

    def highest_frequency(self):
        """The arrays' highest modal frequency [rad/s]."""
        return max(float(np.max(b.resolved_modal_data().frequencies)) for b in self.scene.bodies if b.beam)

    def first_axial_frequency(self) -> float | None:
        """The arrays' first axial mode [rad/s] (:func:`first_axial_frequency`), None without one."""
        return first_axial_frequency(self.scene)


def _modified(data, modes, damping):
    """``data`` with the modes ``modes`` only (all if None), and the damping ratios ``damping``
    (``{index in data: ratio}``)."""
    import dataclasses

    zeta = data.damping.copy()
    for k, ratio in damping.items():
        zeta[k] = ratio
    data = dataclasses.replace(data, damping=zeta)
    return data if modes is None else data.selected(modes)


def axial_index(scene) -> int | None:
    """The index of the first axial mode (:func:`axial_frequency`) of the scene's first beam."""
    body = next(b for b in scene.bodies if b.beam)
    data = body.resolved_modal_data()
    w = axial_frequency(data, body.beam["direction"])
    return None if w is None else int(np.flatnonzero(data.frequencies == w)[0])


def first_axial_frequency(scene) -> float | None:
    """The lowest :func:`axial_frequency` over the scene's beams (their ``direction``), None where
    no mode of any is axial."""
    found = [axial_frequency(b.resolved_modal_data(), b.beam["direction"]) for b in scene.bodies if b.beam]
    return min((w for w in found if w is not None), default=None)


def axial_frequency(data, axis) -> float | None:
    """The lowest frequency [rad/s] of a mode of a beam along ``axis`` whose tip (node ``0.end``)
    moves more along the beam than across it, and by at least 1e-3 of the largest tip motion of
    any mode (an axial mode: its stiffness EA, not EI; torsion modes leave the tip in place),
    None where no mode does."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    tip = np.asarray(data.node("0.end")[1], float)  # (3, modes) translation of the tip
    along = np.abs(axis @ tip)
    across = np.linalg.norm(tip - np.outer(axis, axis @ tip), axis=0)
    floor = 1e-3 * float(np.max(np.linalg.norm(tip, axis=0)))
    return min((float(w) for w, a, c in zip(data.frequencies, along, across) if a > max(c, floor)), default=None)


def arrays_case(n_modes: int, repeats: int) -> None:
    """The hub with two solar arrays (``examples/spacecraft_arrays.toml``, undamped arrays with
    ``n_modes`` modes each, PD attitude loop) after a 50 N m, 2 s pulse of the yaw wheel's motor,
    30 s with 301 samples at rtol 1e-8, atol 1e-10. Peers on the same compiled right-hand side:
    scipy's ``solve_ivp`` BDF with the exact Jacobian from the graph, and CasADi's CVODES
    integrator called directly (BDF, its default, and Adams). Error: largest state difference
    against ``solve_ivp`` DOP853 at rtol 1e-11 on the same model. Times are CPU seconds
    (:func:`cpu_median`), after one warm-up run of each runner."""
    case = ArraysCase(n_modes)
    model, timepts = case.model, case.timepts
    scipy_run, casadi_run = case.scipy_run, case.casadi_run
    inputs = case.inputs()
    start = time.perf_counter()
    reference = scipy_run("DOP853", 1e-11, 1e-13)()
    ref_seconds = time.perf_counter() - start
    runners = {
        "linflex simulate (auto)": lambda: linflex.simulate(model, timepts, inputs=inputs).x,
        "linflex simulate exponential": lambda: linflex.simulate(model, timepts, inputs=inputs, method="exponential").x,
        "linflex simulate cvodes-adams": lambda: linflex.simulate(model, timepts, inputs=inputs, method="cvodes-adams").x,
        "linflex simulate cvodes (BDF)": lambda: linflex.simulate(model, timepts, inputs=inputs, method="cvodes").x,
        "CasADi integrator cvodes (BDF), direct": casadi_run({}),
        "CasADi integrator cvodes (Adams), direct": casadi_run(ADAMS),
        "scipy solve_ivp BDF, exact Jacobian": scipy_run("BDF", RTOL, ATOL),
        # The same accuracy as linflex's default (its error is about 10x smaller at equal tolerances).
        "scipy solve_ivp BDF, exact Jacobian, rtol 1e-9, atol 1e-11": scipy_run("BDF", RTOL / 10, ATOL / 10),
    }
    rows = {}
    for label, fn in runners.items():
        if "scipy" not in label:
            fn()  # warm-up: integrators and Jacobians are built once per model
        reps = 1 if ("scipy" in label or "BDF" in label) else repeats
        t, states = cpu_median(fn, reps)
        rows[label] = (t, float(np.max(np.abs(states - reference))))
    peer = rows["scipy solve_ivp BDF, exact Jacobian"][0]
    floor = min(rows["CasADi integrator cvodes (BDF), direct"][0], rows["CasADi integrator cvodes (Adams), direct"][0])
    chosen = linflex.simulate(model, timepts, inputs=inputs).method
    print(f"\nHub with two undamped solar arrays, {n_modes} modes each ({model.n_states} states), yaw-wheel pulse, "
          f"30 s, rtol {RTOL:g}, atol {ATOL:g}; auto chose {chosen}; reference DOP853 rtol 1e-11 in {ref_seconds:.1f} s")
    print("| runner | median CPU time [s] | max state error | speed vs scipy BDF | time vs fastest CasADi direct |")
    print("|---|---|---|---|---|")
    for label, (t, err) in rows.items():
        print(f"| {label} | {t:.3f} | {err:.1e} | {peer / t:.1f}x | {t / floor:.2f}x |", flush=True)


def state_kind(name: str) -> str:
    """States compared on one scale: modal coordinates, modal rates, quaternions, body rates, ..."""
    last = re.sub(r"\d+", "#", name.rsplit(".", 1)[-1])
    return last[0] if re.fullmatch(r"q[wxyz]|w[xyz]", last) else last


def own_scales(states, reference):
    """Each state's own scale: its peak in the reference, at least 1e-6 of the largest peak of its
    kind (the out-of-plane and torsion modes a yaw manoeuvre leaves at 1e-11 have no scale of
    their own)."""
    peak = np.max(np.abs(reference), axis=0)
    kinds = [state_kind(n) for n in states]
    floor = {k: max(float(np.max([p for p, kk in zip(peak, kinds) if kk == k])), 1e-300) for k in set(kinds)}
    return np.maximum(peak, [1e-6 * floor[k] for k in kinds])


def own_scale_errors(states, X, reference):
    """Largest error of each state over its own scale (:func:`own_scales`)."""
    return np.max(np.abs(X - reference), axis=0) / own_scales(states, reference)


# (method, atol) of the cost-against-modes table: the exponential integrator at the common
# tolerances and at an atol ten times looser (where its errors stay at or below those of Adams
# at the common tolerances: the same accuracy, as the accuracy columns show), and Adams.
MODES_RUNS = (("exponential", ATOL), ("exponential", ATOL * 10), ("cvodes-adams", ATOL))


def run_label(method: str, atol: float) -> str:
    return method if atol == ATOL else f"{method}, atol {atol:g}"


def modes_row(n_modes: int, repeats: int, duration: float):
    """The rows of :func:`modes_table` for one number of modes: one per run of
    :data:`MODES_RUNS`, each ``(n_modes, states, highest mode, method, steps,
    re-linearizations, f evaluation [us], CPU [s], tip error, state error, reference CPU [s],
    chosen by auto, first axial mode [rad/s] or None)``."""
    case = ArraysCase(n_modes, duration)
    model, timepts = case.model, case.timepts
    start = time.process_time()
    reference = case.scipy_run("DOP853", 1e-11, 1e-13)()
    ref_seconds = time.process_time() - start
    inputs = case.inputs()
    chosen = linflex.simulate(model, timepts, inputs=inputs).method
    highest, axial = case.highest_frequency(), case.first_axial_frequency()
    # One right-hand side inside CasADi (200 states near x0 in one mapped call: no Python overhead).
    xs = model.x0[:, None] + 1e-3 * np.random.default_rng(0).standard_normal((model.n_states, 200))
    fmap, us = case.fnum.map(200), np.tile(case.pulse[:, None], (1, 200))
    f_us = cpu_median(lambda: [fmap(xs, us) for _ in range(10)], 5)[0] / 2000 * 1e6
    tip_ref = case.tips(reference)
    rows = []
    for method, atol in MODES_RUNS:
        def run(method=method, atol=atol):
            return linflex.simulate(model, timepts, inputs=inputs, method=method, rtol=RTOL, atol=atol)
        first = run()  # warm-up (integrator construction) and the counts
        slow = method == "cvodes-adams" and n_modes > 16
        cpu, response = cpu_median(lambda: run().x, 1 if slow else repeats)
        tip_err = float(np.max(np.abs(case.tips(response) - tip_ref)) / np.max(np.abs(tip_ref)))
        errors = own_scale_errors(model.states, response, reference)
        state_err = f"{float(np.max(errors)):.1e} ({model.states[int(np.argmax(errors))]})"
        relin = first.n_linearizations - 1 if method == "exponential" else "-"
        rows.append((n_modes, model.n_states, highest, run_label(method, atol), first.n_steps, relin, f_us,
                     cpu, tip_err, state_err, ref_seconds, "yes" if (method == chosen and atol == ATOL) else "", axial))
    return rows, (case, reference)


def modes_table(modes, repeats: int, duration: float = 30.0) -> None:
    """Cost against the number of modes per array at fixed tolerances (rtol 1e-8, atol 1e-10),
    with the accuracy reached beside it, and where the cost goes: accepted steps (as the
    integrator reports them in ``TimeResponse.n_steps``), re-linearizations
    and the CPU time of one right-hand side; for the runs of :data:`MODES_RUNS` (the exponential
    integrator, also at a ten times looser atol, and Adams, the method ``"auto"`` chose before
    it), the row ``"auto"`` takes marked."""
    results = [modes_row(n_modes, repeats, duration) for n_modes in modes]
    rows = [row for group, _ in results for row in group]
    print(f"\nCost against modes at fixed accuracy: hub with two undamped solar arrays, yaw-wheel pulse, "
          f"{duration:g} s, linflex simulate at rtol {RTOL:g}, atol {ATOL:g}; errors against DOP853 at "
          "rtol 1e-11; steps: the integrator's accepted steps (TimeResponse.n_steps)")
    print("| modes per array | states | highest mode [rad/s] | first axial mode [rad/s] | method | auto | steps "
          "| re-linearizations | f evaluation [us] | median CPU time [s] | CPU per step [us] | max tip error / peak "
          "| max state error / own scale | reference CPU [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n_modes, n_states, w, method, steps, relin, f_us, cpu, tip_err, state_err, ref_seconds, auto, axial in rows:
        print(f"| {n_modes} | {n_states} | {w:.1f} | {'-' if axial is None else f'{axial:.1f}'} | {method} | {auto} "
              f"| {steps} | {relin} | {f_us:.1f} | {cpu:.3f} "
              f"| {cpu / steps * 1e6:.1f} | {tip_err:.1e} | {state_err} | {ref_seconds:.1f} |", flush=True)
    if len(results) >= 2:
        def slope(a, b):
            return float(np.polyfit(np.log(a), np.log(b), 1)[0])

        def column(method, i):
            return np.array([r[i] for r in rows if r[3] == method], float)
        labels = [run_label(*r) for r in MODES_RUNS]
        n = column(labels[0], 0)
        last = slice(-3, None) if n.size >= 3 else slice(None)
        auto_cpu = np.array([r[7] for r in rows if r[11] == "yes"], float)
        parts = [f"auto CPU time ~ modes^{slope(n, auto_cpu):.2f} [{slope(n[last], auto_cpu[last]):.2f}]"]
        for method in labels:
            cpu, steps = column(method, 7), column(method, 4)
            parts.append(f"{method}: CPU time ~ modes^{slope(n, cpu):.2f} [{slope(n[last], cpu[last]):.2f}], "
                         f"steps ~ modes^{slope(n, steps):.2f} [{slope(n[last], steps[last]):.2f}]")
        w, f_us = column(labels[0], 2), column(labels[0], 6)
        parts.append(f"highest mode ~ modes^{slope(n, w):.2f}; f evaluation ~ modes^{slope(n, f_us):.2f} "
                     f"[{slope(n[last], f_us[last]):.2f}]")
        print("\nFitted exponents (least squares on logs, all rows; last three numbers of modes in brackets): "
              + "; ".join(parts))
    precision_table([pair for _, pair in results], repeats)
    jacobian_age_table([pair for _, pair in results])
    known = {case.n_modes: (case, ref) for _, (case, ref) in results}
    if duration >= 30.0:
        axial_mode_table([pair for _, pair in results], duration=duration)
        if 24 in known:
            case, ref = known[24]
            axial_forcing_table(case, ref, axial_index(case.scene), case.first_axial_frequency())
    else:  # a quick run: the same tables on 4 modes, the last one standing in for the axial mode
        axial_mode_table([pair for _, pair in results], base=4, core=3, duration=duration, mode=3)
        case, ref = known[4]
        array = next(b for b in case.scene.bodies if b.name == ARRAY_NAMES[0])
        axial_forcing_table(case, ref, 3, float(array.resolved_modal_data().frequencies[3]), window=(4.0, duration))
    largest = max(results, key=lambda r: r[0][0][0] if r[0][0][0] <= 16 else -1)
    tolerance_sensitivity(*largest[1], repeats)


# (rtol, atol) of the work-precision sweep of :func:`precision_table`, loosest first.
PRECISION_RUNS = ((1e-6, 1e-6), (1e-7, 1e-8), (3e-8, 3e-9), (1e-8, 1e-9), (1e-8, 1e-10), (1e-9, 1e-11))
# Tip accuracies at which precision_table reads the cost off the sweep.
PRECISION_LEVELS = (1e-6, 1e-7, 1e-8, 5e-9)


def precision_table(cases, repeats: int) -> None:
    """Cost at fixed accuracy of the tip deflection: the exponential integrator over a sweep of
    tolerances (:data:`PRECISION_RUNS`) for each number of modes; for each accuracy of
    :data:`PRECISION_LEVELS` the cheapest run whose tip error (largest over the run, over the
    peak) is within it, and the exponent of that cost against the number of modes. ``cases``:
    ``(ArraysCase, reference)`` pairs of :func:`modes_row`."""
    print("\nWork-precision of the exponential integrator (the same runs at other tolerances): tip error "
          "against CPU time")
    print("| run | rtol | atol | steps | median CPU time [s] | max tip error / peak |")
    print("|---|---|---|---|---|---|")
    sweeps = []
    for case, reference in cases:
        model, timepts = case.model, case.timepts
        inputs = case.inputs()
        tip_ref = case.tips(reference)
        runs = []
        for rtol, atol in PRECISION_RUNS:
            def run(rtol=rtol, atol=atol, model=model, timepts=timepts, inputs=inputs):
                return linflex.simulate(model, timepts, inputs=inputs, method="exponential", rtol=rtol, atol=atol)
            start = time.process_time()
            first = run()
            once = time.process_time() - start
            cpu, X = cpu_median(lambda: run().x, 1 if once > 2.0 else repeats)
            tip_err = float(np.max(np.abs(case.tips(X) - tip_ref)) / np.max(np.abs(tip_ref)))
            runs.append((cpu, tip_err))
            print(f"| {case.n_modes} modes per array | {rtol:g} | {atol:g} | {first.n_steps} | {cpu:.3f} | {tip_err:.1e} |",
                  flush=True)
        sweeps.append((case.n_modes, runs))
    axial = np.array([case.first_axial_frequency() is not None for case, _ in cases])
    fixed_accuracy_table("", " per array", sweeps, axial)


def fixed_accuracy_table(label: str, unit: str, sweeps, axial) -> None:
    """For each tip accuracy of :data:`PRECISION_LEVELS`, the cheapest run of each number of modes
    within it and the exponent of that cost against the number of modes. ``sweeps``: ``(modes,
    [(CPU [s], tip error), ...])`` per number of modes; ``axial``: whether that model has an
    axial mode (the exponent is also fitted over those without and those with one); ``label``
    names the case, ``unit`` what the modes are counted per."""
    print(f"\n{label}Cost at fixed tip accuracy (the cheapest run of the sweep within it; exponent: least squares on "
          "logs over the numbers of modes that reach it: all of them, those whose beams have no axial mode, "
          "those whose beams have one)")
    print("| tip accuracy (of the peak) | " + " | ".join(f"{n} modes{unit}: CPU [s]" for n, _ in sweeps)
          + " | CPU ~ modes^k, all | without axial mode | with axial mode |")
    print("|---|" + "---|" * (len(sweeps) + 3))
    n = np.array([m for m, _ in sweeps], float)
    axial = np.asarray(axial, bool)
    for level in PRECISION_LEVELS:
        best = np.array([min((cpu for cpu, err in runs if err <= level), default=np.nan) for _, runs in sweeps])

        def exponent(rows, best=best):
            ok = rows & np.isfinite(best)
            return f"{float(np.polyfit(np.log(n[ok]), np.log(best[ok]), 1)[0]):.2f}" if ok.sum() >= 2 else "-"
        cells = " | ".join("not reached" if not np.isfinite(b) else f"{b:.3f}" for b in best)
        print(f"| {level:g} | {cells} | {exponent(np.ones_like(axial))} | {exponent(~axial)} | {exponent(axial)} |",
              flush=True)


def spinup_precision(modes, repeats: int) -> None:
    """The spin-up of a cantilever on a hub (``benchmarks/flexible.py``: 10 m beam, hub spun to
    6 rad/s in 15 s by a prescribed profile, 30 s, 301 samples) with ``modes`` modes: the
    exponential integrator over the tolerances of :data:`PRECISION_RUNS` and Adams (the method
    ``"auto"`` takes for this time-varying model) at rtol 1e-8 and 1e-10, their in-plane tip
    error against scipy's DOP853 at rtol 1e-12 on the same model, and the cost at fixed tip
    accuracy against the number of modes for each method."""
    from flexible import TIMEPTS, spinup_scene

    print("\nSpin-up of a cantilever on a hub (benchmarks/flexible.py), 30 s: work-precision against the "
          "number of modes; tip error against scipy DOP853 at rtol 1e-12 on the same model")
    print("| modes | states | highest mode [rad/s] | first axial mode [rad/s] | method | auto | rtol | atol "
          "| steps | median CPU time [s] | max tip error / peak |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    runs = {"exponential": PRECISION_RUNS, "cvodes-adams": ((RTOL, ATOL), (1e-10, 1e-12))}
    sweeps = {method: [] for method in runs}
    axial = []
    for n_modes in modes:
        scene, data = spinup_scene(n_modes)
        model = linflex.compile_model(scene)
        tip = data.node("0.end")[1][1]
        idx = [model.states.index(f"beam.eta{k}") for k in range(n_modes)]
        reference = linflex.simulate(model, TIMEPTS, method="scipy-DOP853", rtol=1e-12, atol=1e-14).x[:, idx] @ tip
        peak = float(np.max(np.abs(reference)))
        w_axial = axial_frequency(data, (1.0, 0.0, 0.0))
        axial.append(w_axial is not None)
        chosen = linflex.simulate(model, TIMEPTS).method
        for method, settings in runs.items():
            found = []
            for rtol, atol in settings:
                def run(method=method, rtol=rtol, atol=atol, model=model):
                    return linflex.simulate(model, TIMEPTS, method=method, rtol=rtol, atol=atol)
                start = time.process_time()
                first = run()
                once = time.process_time() - start
                cpu, X = cpu_median(lambda: run().x, 1 if once > 2.0 else repeats)
                err = float(np.max(np.abs(X[:, idx] @ tip - reference))) / peak
                found.append((cpu, err))
                print(f"| {n_modes} | {model.n_states} | {float(np.max(data.frequencies)):.1f} "
                      f"| {'-' if w_axial is None else f'{w_axial:.1f}'} | {method} | {'yes' if method == chosen else ''} "
                      f"| {rtol:g} | {atol:g} | {first.n_steps} | {cpu:.3f} | {err:.1e} |", flush=True)
            sweeps[method].append((n_modes, found))
    for method, sweep in sweeps.items():
        fixed_accuracy_table(f"Spin-up, {method}. ", "", sweep, axial)


def fixed_step_errors(case, reference, sub: int, fresh: bool = False) -> tuple[float, float]:
    """``(tip error / peak, CPU per step [s])`` of the exponential integrator in the momentum form
    at fixed steps of the sample interval over ``sub`` (:func:`_axial.fixed_steps`: one frozen
    Jacobian, or with ``fresh`` one taken at every step)."""
    from linflex.simulation._momentum import momentum_form

    model, pv = case.model, case.model.param_values
    form = momentum_form(model)
    z0 = form.to_z(model.x0, pv, case.timepts[0])
    times = np.linspace(case.timepts[0], case.timepts[-1], sub * (case.timepts.size - 1) + 1)
    U = case.held(times[:-1])
    start = time.process_time()
    Z = fixed_steps(form, pv, times, z0, U, fresh)
    per_step = (time.process_time() - start) / U.shape[0]
    X = form.to_x(np.vstack([z0, Z]), pv, times)[::sub]
    tip_ref = case.tips(reference)
    return float(np.max(np.abs(case.tips(X) - tip_ref)) / np.max(np.abs(tip_ref))), per_step


def jacobian_age_table(cases, modes=(8, 16, 24)) -> None:
    """Where the exponential integrator's error at a fixed step comes from: the same fixed steps
    (the sample interval over 1, 2, 4) with one Jacobian frozen at the start and with one taken
    anew at every step (:func:`fixed_step_errors`). If the frozen Jacobian's age were the cause
    of the axial mode's cost, the second column would bring the models with an axial mode to the
    error of those without. ``cases``: ``(ArraysCase, reference)`` pairs of :func:`modes_row`;
    those with ``modes`` per array are run (all in a quick run without them)."""
    from linflex.simulation._exponential import phi_matrices
    from linflex.simulation._momentum import momentum_form

    # the models the integrator steps in the momentum form (2 modes per array has none)
    stepped = [c for c in cases if momentum_form(c[0].model) is not None]
    chosen = [c for c in stepped if c[0].n_modes in modes] or stepped
    print("\nFixed steps, frozen Jacobian against one taken at every step: tip error / peak against DOP853 at "
          "rtol 1e-11 (the exponential integrator in the momentum form, no step rejected); CPU of a Jacobian and "
          "its matrix functions against that of a step")
    print("| modes per array | states | first axial mode [rad/s] | steps | step [s] | tip error, one Jacobian "
          "| tip error, a Jacobian per step | CPU per step [ms] | CPU of a Jacobian + matrix functions [ms] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for case, reference in chosen:
        model, pv = case.model, case.model.param_values
        form = momentum_form(model)
        z0 = form.to_z(model.x0, pv, case.timepts[0])
        J = form.jacobian(z0, case.pulse, pv, 0.0).full()
        h0 = float(case.timepts[1] - case.timepts[0])
        start = time.process_time()
        for _ in range(5):
            form.jacobian(z0, case.pulse, pv, 0.0).full()
            phi_matrices(J, h0 / 2**4)
        refresh = (time.process_time() - start) / 5
        axial = case.first_axial_frequency()
        for sub in (1, 2, 4):
            frozen, per_step = fixed_step_errors(case, reference, sub)
            fresh, _ = fixed_step_errors(case, reference, sub, fresh=True)
            print(f"| {case.n_modes} | {model.n_states} | {'-' if axial is None else f'{axial:.1f}'} "
                  f"| {sub * (case.timepts.size - 1)} | {h0 / sub:g} | {frozen:.1e} | {fresh:.1e} "
                  f"| {per_step * 1e3:.2f} | {refresh * 1e3:.1f} |", flush=True)


def axial_mode_table(cases, base: int = 24, core: int = 16, duration: float = 30.0, mode: int | None = None) -> None:
    """Is it the axial mode? The fixed-step errors (:func:`fixed_step_errors`, one frozen Jacobian)
    of the arrays with ``core`` modes, with those and the first axial mode of the ``base``-mode
    model, with the ``base`` modes but that one, with all ``base``; and of the ``core`` modes plus
    the axial mode damped at 5 % (its free oscillation gone within 0.1 s of any excitation: if the
    step's error came from the remainder's sampling of that oscillation, this row would fall to
    the ``core`` row). Each against DOP853 at rtol 1e-11 on its own model. ``cases``:
    ``(ArraysCase, reference)`` pairs of :func:`modes_row`, reused where they match a row;
    ``mode``: the mode to treat as the axial one (a quick run's smoke test)."""
    known = {c.n_modes: (c, ref) for c, ref in cases if c.timepts[-1] == duration}
    ax = mode if mode is not None else axial_index((known[base][0] if base in known else ArraysCase(base, duration)).scene)
    if ax is None:
        print(f"\n(no axial mode among the {base} modes per array: the axial-mode table is not run)")
        return
    lowest = list(range(core))
    rows = [(f"{core} modes", None, None), (f"{core} modes and the axial mode", lowest + [ax], None),
            (f"{base} modes but the axial mode", [k for k in range(base) if k != ax], None),
            (f"{base} modes", None, None), (f"{core} modes and the axial mode damped at 5 %", lowest + [ax], {ax: 0.05})]
    print("\nThe axial mode alone: fixed steps, one frozen Jacobian, tip error / peak against DOP853 at rtol 1e-11 "
          "on each model (" + (f"mode {ax} of the {base}-mode arrays stands in for an axial mode)" if mode is not None
                                else f"the first axial mode of the {base}-mode arrays is their mode {ax})"))
    intervals = int(round(duration * 10))   # ArraysCase's samples, every 0.1 s
    print("| model (per array) | states | " + " | ".join(f"{sub * intervals} steps" for sub in (1, 2, 4)) + " |")
    print("|---|---|---|---|---|")
    for label, modes, damping in rows:
        n = core if label == f"{core} modes" else base
        if modes is None and n in known:
            case, reference = known[n]
        else:
            case = ArraysCase(n, duration, modes=modes, damping=damping)
            reference = case.scipy_run("DOP853", 1e-11, 1e-13)()
        errors = [fixed_step_errors(case, reference, sub)[0] for sub in (1, 2, 4)]
        print(f"| {label} | {case.model.n_states} | " + " | ".join(f"{e:.1e}" for e in errors) + " |", flush=True)


def tolerance_sensitivity(case, reference, repeats: int) -> None:
    """Does the absolute tolerance make the integrator resolve modes of negligible amplitude?
    The same run with one atol for every state, and with one per state at 1e-8 of the state's
    own scale (its peak in the reference, floored as in :func:`own_scale_errors`: an oracle of
    the states' natural scales), for Adams and BDF; CVODES's steps from the same options called
    directly on the states scaled by atol (simulate's Notes)."""
    model, timepts = case.model, case.timepts
    inputs = case.inputs()
    scale = own_scales(model.states, reference)
    tip_ref = case.tips(reference)
    print(f"\nAbsolute tolerance and cost, {case.n_modes} modes per array ({model.n_states} states), rtol {RTOL:g}: "
          "one atol for all states against one per state at 1e-8 of its own scale")
    print("| method | atol | median CPU time [s] | max tip error / peak | max state error / own scale |")
    print("|---|---|---|---|---|")
    for method in ("exponential", "cvodes-adams", "cvodes"):
        for label, atol in (("1e-10", ATOL), ("1e-8", 1e-8), ("1e-8 x own scale", 1e-8 * scale)):
            def run(method=method, atol=atol):
                return linflex.simulate(model, timepts, inputs=inputs, method=method, rtol=RTOL, atol=atol).x
            run()
            cpu, X = cpu_median(run, 1 if method == "cvodes" else repeats)
            tip_err = float(np.max(np.abs(case.tips(X) - tip_ref)) / np.max(np.abs(tip_ref)))
            err = float(np.max(own_scale_errors(model.states, X, reference)))
            print(f"| {method} | {label} | {cpu:.3f} | {tip_err:.1e} | {err:.1e} |", flush=True)


def tolerance_table(model, x0, timepts, rtols, repeats):
    """Error against time over the integrator tolerance (atol = rtol / 100), one row per method and rtol."""
    reference = linflex.simulate(model, timepts, x0, method="scipy-DOP853", rtol=1e-13, atol=1e-15).x
    print(f"\nIntegrator tolerance, gyrostat scene: max state error against scipy DOP853 at rtol 1e-13, "
          f"{timepts[-1]:g} s")
    print("| method | rtol | median time [s] | max state error |")
    print("|---|---|---|---|")
    for method in ("cvodes", "cvodes-adams", "scipy-DOP853", "scipy-RK45"):
        for rtol in rtols:
            if method == "scipy-RK45" and rtol < 1e-10:
                continue  # RK45 at rtol 1e-12 takes minutes: the table shows the trend without it
            def run(method=method, rtol=rtol):
                return linflex.simulate(model, timepts, x0, method=method, rtol=rtol, atol=rtol / 100).x
            t, states = median_time(run, repeats)
            err = float(np.max(np.abs(states - reference)))
            print(f"| linflex simulate {method} | {rtol:.0e} | {t:.4f} | {err:.1e} |", flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short smoke run")
    parser.add_argument("--arrays", type=int, nargs="*", metavar="MODES",
                        help="only the solar-array cases with these numbers of modes per array (e.g. 8 16)")
    parser.add_argument("--modes", type=int, nargs="*", metavar="MODES",
                        help="only the cost-against-modes table with these numbers of modes per array")
    args = parser.parse_args()
    if args.arrays or args.modes:
        for n_modes in args.arrays or ():
            arrays_case(n_modes, 1 if args.quick else 3)
        if args.modes:
            modes_table(args.modes, 1 if args.quick else 3)
    else:
        main(args.quick)
        for n_modes in (4,) if args.quick else (8, 16):
            arrays_case(n_modes, 1 if args.quick else 3)
        modes_table((2, 4) if args.quick else (2, 4, 8, 16, 24, 32, 48), 1 if args.quick else 3,
                    10.0 if args.quick else 30.0)
        spinup_precision((2, 4) if args.quick else (4, 8, 16, 24), 1 if args.quick else 3)
