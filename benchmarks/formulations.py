"""Formulations: the dense mass-matrix solve against the order-n recursion on chains of N bodies.

The chain is ``linflex.rigid_segment_beam`` (N rigid segments of 0.1 m on revolute joints with
the book's spring constants, EI = 50 N m^2, 1 kg/m, joint damping 1e-3 N m s/rad) clamped to
the ground, with the ``joint_springs`` and ``gravity`` effects: 2N states. For each N and each
formulation (``compile_model(scene, formulation=...)``):

* compile time of ``compile_model``;
* right-hand-side cost: the time of one evaluation of ``model.f`` at a random state, measured
  inside CasADi (``f.map`` over many copies; median over batches) without Python's call
  overhead of some 30 us per call;
* the largest relative difference of the two right-hand sides (agreement);
* simulation time (full run, N <= ``--simulate-max``, default 50): ``simulate(method=
  "cvodes-adams")`` over 0.2 s from a deflected state (Adams with functional iteration: no
  Jacobian). The chain is stiff (joint frequencies of some 10^3 rad/s), so these runs take
  thousands of steps; above N = 50 they take minutes and the dense one at N = 200 grew past
  7 GB of memory, hence the limit.

A second table does the same (without simulation) for a chain of N flexible links (a 1 m beam
with 2 modes each, on revolute springs; 6N states), N = 5, 10, 20, 50.

A third table compares the linearization methods on the same scenes (rigid chains N = 5..50,
flexible chains N = 5, 10, and the example ``spacecraft_arrays.toml``): Kane's direct
linearization (``method="kane"``, from the partial velocities, with the second-order form and
the stiffness by origin), ``autodiff`` (exact Jacobians of the solved state derivative) and the
classic ``perturbation`` (6 digits), each with its first call (graph building included) and the
median of later calls (graphs reused), and the largest difference of ``A`` from ``autodiff``
relative to ``max |A|``.

Then the growth exponent of each formulation (least-squares slope of log time against log N over
N >= 20, where the call overhead no longer dominates) and the crossover N (where order-n becomes
faster, interpolated in log-log). The dense formulation is skipped above ``--dense-max``
(default 200: its compile is still affordable there, about 2 s).
Target of issue 5: order-n at least 5x faster than dense at N = 100, growth exponent <= 1.2.
Run: ``python benchmarks/formulations.py [--quick]``. BLAS threads are pinned to one.
"""

from __future__ import annotations

import _timing  # noqa: F401  (one BLAS thread: before numpy)
from _timing import median_time  # noqa: E402

# isort: split

import argparse  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from functools import partial  # noqa: E402

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import linflex  # noqa: E402

FORMULATIONS = ("dense", "order-n")


def chain(n: int) -> linflex.Scene:
    bodies, joints = linflex.rigid_segment_beam("beam", length=0.1 * n, EI=50.0, mass_per_length=1.0,
                                                segments=n, damping=1e-3, bending_axis=(0.0, 1.0, 0.0))
    return linflex.Scene(f"chain{n}", bodies=list(bodies), joints=list(joints), effects=["joint_springs", "gravity"])


def flexible_chain(n: int) -> linflex.Scene:
    data = linflex.beam_modal_data(linflex.Beam((0, 0, 0), (1.0, 0, 0), EA=1e6, EIy=30.0, EIz=50.0, GJ=40.0,
                                                mass_per_length=1.0, elements=4), 2, damping=0.01)
    bodies = [linflex.Body(f"link{k}", 0.2, [0.01, 0.01, 0.01], com=[0.1, 0, 0], type="flexible", modal_data=data)
              for k in range(n)]
    joints = [linflex.Joint(f"j{k}", "revolute", f"link{k}", parent="ground" if k == 0 else f"link{k - 1}",
                            axis=[0, 1, 0], parent_point=[0, 0, 0] if k == 0 else [1.0, 0, 0], stiffness=5.0,
                            damping=0.01) for k in range(n)]
    return linflex.Scene(f"flex{n}", bodies=bodies, joints=joints, effects=["joint_springs", "gravity"])


def flexible_table(ns, batches: int, calls: int) -> None:
    rng = np.random.default_rng(1)
    print("\nChain of N flexible links (2 modes each; joint springs, gravity): compile and right-hand side")
    print("| N | states | dense compile [s] | order-n compile [s] | dense f [us] | order-n f [us] | "
          "order-n speed-up | max rel. difference of f |")
    print("|---|---|---|---|---|---|---|---|")
    times = {f: [] for f in FORMULATIONS}
    for n in ns:
        scene = flexible_chain(n)
        row = {}
        x = np.concatenate([rng.uniform(-0.3, 0.3, 3 * n), rng.uniform(-1.0, 1.0, 3 * n)])
        for form in FORMULATIONS:
            build, model = median_time(partial(linflex.compile_model, scene, formulation=form), 1)
            u = np.zeros(model.n_inputs)
            per_call = rhs_time(model, x, u, batches, calls)
            times[form].append(per_call)
            row[form] = (build, per_call, np.asarray(model.f(x, u, 0.0), float).ravel())
        (bd, td, fd), (bo, to, fo) = row["dense"], row["order-n"]
        diff = float(np.max(np.abs(fd - fo)) / np.max(np.abs(fd)))
        print(f"| {n} | {6 * n} | {bd:.3f} | {bo:.3f} | {td * 1e6:.1f} | {to * 1e6:.1f} | {td / to:.1f}x | {diff:.1e} |",
              flush=True)
    print(f"\nFlexible chain growth exponents of f (N >= 20 or all): dense {fit_exponent(ns, times['dense']):.2f}, "
          f"order-n {fit_exponent(ns, times['order-n']):.2f}; crossover "
          f"{crossover(ns, times['dense'], times['order-n'])}")


def rhs_time(model, x, u, batches: int, calls: int) -> float:
    """Median over ``batches`` of the time of one evaluation of ``f`` [s], measured inside
    CasADi: ``f.map(calls)`` evaluates ``calls`` copies in one call, so Python's call overhead
    (tens of us per call, the same for both formulations) does not hide the graph's cost."""
    fmap = model.f.map(calls)
    X, U = np.tile(x[:, None], (1, calls)), np.tile(u[:, None], (1, calls))
    T = np.zeros((1, calls))
    fmap(X, U, T)
    times = []
    for _ in range(batches):
        start = time.perf_counter()
        fmap(X, U, T)
        times.append((time.perf_counter() - start) / calls)
    return statistics.median(times)


def fit_exponent(ns, ts) -> float:
    """Least-squares slope of log t against log N over N >= 20 (all points if fewer than two)."""
    pts = [(n, t) for n, t in zip(ns, ts) if n >= 20 and t is not None]
    if len(pts) < 2:
        pts = [(n, t) for n, t in zip(ns, ts) if t is not None]
    if len(pts) < 2:
        return float("nan")
    return float(np.polyfit(np.log([p[0] for p in pts]), np.log([p[1] for p in pts]), 1)[0])


def crossover(ns, dense, order_n) -> str:
    """The N from which on order-n stays faster than dense (log-log interpolation between the
    last N where it is not faster and the next one)."""
    pairs = [(n, d, o) for n, d, o in zip(ns, dense, order_n) if d is not None]
    if not pairs:
        return "not measured"
    slower = [k for k, (_, d, o) in enumerate(pairs) if o >= d]
    if not slower:
        return f"at or below N = {pairs[0][0]} (order-n faster at every N measured)"
    k = slower[-1]
    if k == len(pairs) - 1:
        return f"above N = {pairs[-1][0]} (dense still faster there)"
    (n0, d0, o0), (n1, d1, o1) = pairs[k], pairs[k + 1]
    r0, r1 = np.log(o0 / d0), np.log(o1 / d1)
    s = r0 / (r0 - r1)
    return f"N = {np.exp(np.log(n0) + s * (np.log(n1) - np.log(n0))):.0f}"


def linearization_table(quick: bool) -> None:
    from pathlib import Path

    from linflex.linearize import linearize

    cases = [(f"rigid chain N = {n}", chain(n)) for n in ([5, 10] if quick else [5, 10, 20, 50])]
    cases += [(f"flexible chain N = {n}", flexible_chain(n)) for n in ([5] if quick else [5, 10])]
    cases.append(("spacecraft_arrays.toml",
                  linflex.load_scene(Path(__file__).resolve().parents[1] / "examples" / "spacecraft_arrays.toml")))
    print("\nLinearization of the same scenes: Kane's direct linearization, autodiff, perturbation (first call "
          "with graph building; median of 3 later calls that reuse the graphs; A's largest difference from "
          "autodiff relative to max |A|)")
    print("| scene | states | method | first call [s] | later calls [s] | max rel. error of A vs autodiff |")
    print("|---|---|---|---|---|---|")
    for name, scene in cases:
        model = linflex.compile_model(scene)
        op = linflex.OperatingPoint(model.x0, np.zeros(model.n_inputs))
        rows = {}
        for method in ("kane", "autodiff", "perturbation"):
            run = partial(linearize, model, op, method=method, allow_non_equilibrium=True)
            first, lin = median_time(run, 1)
            later, _ = median_time(run, 1 if method == "perturbation" else 3)
            rows[method] = (first, later, lin.sys.A)
        ref = rows["autodiff"][2]
        for method, (first, later, A) in rows.items():
            error = "0 (reference)" if method == "autodiff" else f"{np.max(np.abs(A - ref)) / np.max(np.abs(ref)):.1e}"
            print(f"| {name} | {model.n_states} | {method} | {first:.4f} | {later:.4f} | {error} |", flush=True)


def main(quick: bool = False, dense_max: int = 200, simulate_max: int = 50) -> None:
    print(f"python {platform.python_version()}, casadi {ca.__version__}, linflex {linflex.__version__}, "
          f"{platform.machine()}")
    ns = [5, 10, 20] if quick else [5, 10, 20, 50, 100, 200]
    batches, calls = (3, 20) if quick else (15, 100)
    rng = np.random.default_rng(0)
    rows, times = [], {f: [] for f in FORMULATIONS}
    sim_times = {f: [] for f in FORMULATIONS}
    for n in ns:
        scene = chain(n)
        results = {}
        # n joint angles, then n rates (the chain's state order).
        x = np.concatenate([rng.uniform(-0.3, 0.3, n), rng.uniform(-1.0, 1.0, n)])
        u = np.zeros(0)
        for form in FORMULATIONS:
            if form == "dense" and n > dense_max:
                times[form].append(None)
                sim_times[form].append(None)
                continue
            build, model = median_time(partial(linflex.compile_model, scene, formulation=form), 1)
            per_call = rhs_time(model, x, u, batches, calls)
            results[form] = np.asarray(model.f(x, u, 0.0), float).ravel()
            times[form].append(per_call)
            sim = None
            if not quick and n <= simulate_max:
                x0 = np.array(model.x0)
                x0[: model.n_coordinates] = 0.02
                sim, _ = median_time(partial(linflex.simulate, model, np.linspace(0.0, 0.2, 21), x0,
                                             method="cvodes-adams", progress=False), 1)
            sim_times[form].append(sim)
            rows.append((n, form, model.n_states, build, per_call, model.graph_size, sim))
        if len(results) == 2:
            d, o = results["dense"], results["order-n"]
            rows.append((n, "difference", None, None, float(np.max(np.abs(d - o)) / np.max(np.abs(d))), None, None))
        print(f"N = {n} done", flush=True)

    print("\nChain of N rigid segments (joint springs, gravity): compile, right-hand side, simulation")
    print("| N | formulation | states | compile [s] | f evaluation [us] | graph size | simulate 0.2 s [s] | "
          "order-n speed-up |")
    print("|---|---|---|---|---|---|---|---|")
    for k, n in enumerate(ns):
        d, o = times["dense"][k], times["order-n"][k]
        for row in rows:
            if row[0] != n:
                continue
            _, form, states, build, per_call, size, sim = row
            if form == "difference":
                print(f"| {n} | max rel. difference of f | - | - | {per_call:.1e} | - | - | - |")
                continue
            speed = f"{d / o:.1f}x" if (form == "order-n" and d is not None) else "-"
            print(f"| {n} | {form} | {states} | {build:.3f} | {per_call * 1e6:.1f} | {size} | "
                  f"{'-' if sim is None else f'{sim:.3f}'} | {speed} |")
        if d is None:
            print(f"| {n} | dense | {2 * n} | skipped (above --dense-max {dense_max}) | - | - | - | - |")

    print("\nGrowth and crossover (right-hand-side cost)")
    print("| quantity | dense | order-n |")
    print("|---|---|---|")
    print(f"| growth exponent of f (N >= 20) | {fit_exponent(ns, times['dense']):.2f} | "
          f"{fit_exponent(ns, times['order-n']):.2f} |")
    if not quick:
        print(f"| growth exponent of simulate (N = 20..{simulate_max}) | {fit_exponent(ns, sim_times['dense']):.2f} | "
              f"{fit_exponent(ns, sim_times['order-n']):.2f} |")
    print(f"| crossover | {crossover(ns, times['dense'], times['order-n'])} | |")
    if 100 in ns and times["dense"][ns.index(100)] is not None:
        k = ns.index(100)
        ratio = times["dense"][k] / times["order-n"][k]
        slope = fit_exponent(ns, times["order-n"])
        met = "met" if ratio >= 5 and slope <= 1.2 else "not met"
        print(f"\nTarget (order-n >= 5x faster at N = 100, exponent <= 1.2): {met} ({ratio:.1f}x, {slope:.2f})")
    flexible_table([5, 10] if quick else [5, 10, 20, 50], batches, 20 if quick else 50)
    linearization_table(quick)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short smoke run")
    parser.add_argument("--dense-max", type=int, default=200, help="largest N compiled with the dense formulation")
    parser.add_argument("--simulate-max", type=int, default=50, help="largest N simulated")
    args = parser.parse_args()
    main(args.quick, args.dense_max, args.simulate_max)
