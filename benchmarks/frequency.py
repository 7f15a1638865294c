"""Frequency-layer benchmark: linflex against python-control, measured in the same run.

1. Frequency response of ISS 12A (1412 states, 3x3) at 2000 frequencies, with the accuracy of
   each tool against dense complex solves at a subset of the frequencies.
2. Root locus of a flexible loop (rigid body + lightly damped modes, collocated PD) at 500 gains,
   orders 101, 201, 401; python-control's ``root_locus_map`` on the same loop, with the error of
   each tool's roots against ``numpy.linalg.eigvals`` of the closed loop at sampled gains.
3. Peak error against number of grid points: linflex's automatic grid and python-control's
   default grid, on a 1e-3-damped model and on ISS 1R.

Run: ``.venv/bin/python benchmarks/frequency.py [--quick] [--part locus ...]``. BLAS threads are
pinned to one.
"""


import _timing  # noqa: F401  (one BLAS thread: before numpy)
from _timing import median_cpu_time, median_time  # noqa: E402

# isort: split

import argparse  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import control  # noqa: E402
import numpy as np  # noqa: E402
from scipy.optimize import linear_sum_assignment, minimize_scalar  # noqa: E402

from linflex import LinearSystem  # noqa: E402
from linflex.frequency import frequency_response, root_locus  # noqa: E402

# The benchmark models are read by the tests' loader (one implementation, tests/mor.py).
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.hard.corpus import flexible_pd_loop as flexible_loop  # noqa: E402
from tests.mor import MOR_DIR  # noqa: E402
from tests.mor import load_mor as load  # noqa: E402


def direct(sys, omega):
    return np.array([sys.C @ np.linalg.solve(1j * w * np.eye(sys.n_states) - sys.A, sys.B) + sys.D for w in omega])


def rel_err(G, ref):
    return float(np.max(np.max(np.abs(G - ref), axis=(1, 2)) / np.max(np.abs(ref), axis=(1, 2))))


def table(title, header, rows):
    print(f"\n{title}")
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for r in rows:
        print("| " + " | ".join(str(x) for x in r) + " |")


def bench_iss12a(quick):
    sys = load("ISS12A.mat")
    sysc = sys.to_control()
    omega = np.logspace(-2, 3, 100 if quick else 2000)
    check = omega[:: len(omega) // 20]
    ref = direct(sys, check)
    # CPU seconds of this process (one BLAS thread): the shared machine's load does not enter
    t_lf, fr = median_cpu_time(lambda: frequency_response(sys, omega), 1 if quick else 5)
    idx = np.searchsorted(omega, check)
    err_lf = rel_err(fr.response[idx], ref)
    t_pc, resp = median_cpu_time(lambda: control.frequency_response(sysc, omega), 1)
    G_pc = np.asarray(resp.frdata).transpose(2, 0, 1)
    err_pc = rel_err(G_pc[idx], ref)
    slycot = "with slycot" if control.slycot_check() else "without slycot"
    rows = [
        [f"python-control {control.__version__} frequency_response ({slycot})", f"{t_pc:.3f}", f"{err_pc:.1e}", "1.0x"],
        [f"linflex frequency_response ({fr.method})", f"{t_lf:.3f}", f"{err_lf:.1e}", f"{t_pc / t_lf:.1f}x"],
    ]
    table(f"ISS 12A (n = {sys.n_states}, 3x3), {len(omega)} frequencies; error vs dense solves at {len(check)} of them",
          ["tool", "median CPU time [s]", "max normwise rel. error", "speed-up"], rows)


def roots_error(L, gains, roots):
    errs = []
    for k, row in zip(gains, roots):
        ref = np.linalg.eigvals(L.A - k * L.B @ np.linalg.solve(np.eye(1) + k * L.D, L.C))
        row = np.asarray(row)
        if row.shape != ref.shape or not np.all(np.isfinite(row)):
            return float("inf")
        cost = np.abs(ref[:, None] - row[None, :])
        r, c = linear_sum_assignment(cost)
        errs.append(np.max(cost[r, c]) / max(1.0, np.max(np.abs(ref))))
    return float(max(errs))


def bench_locus(quick):
    rows = []
    orders = (101,) if quick else (101, 201, 401)
    for order in orders:
        L = flexible_loop(order)
        gains = np.r_[0.0, np.logspace(-3, 2, 499)]
        sample = slice(0, None, 50)
        t_lf, rl = median_time(lambda L=L, gains=gains: root_locus(L, gains=gains), 1 if quick or order > 101 else 3)
        err_lf = roots_error(L, gains[sample], rl.roots[sample])
        if order <= 201:
            try:
                t_pc, res = median_time(lambda L=L, gains=gains: control.root_locus_map(L.to_control(), gains), 1)
                roots_pc = np.asarray(res.loci)
                err_pc = roots_error(L, gains[sample], roots_pc[sample])
                pc = (f"{t_pc:.2f}", f"{err_pc:.1e}", f"{t_pc / t_lf:.1f}x")
            except Exception as exc:  # the peer failing is a result to report
                pc = ("failed", type(exc).__name__, "-")
        else:
            pc = ("not run", "-", "-")
        rows.append([L.n_states, f"{t_lf:.2f}", rl.n_evaluations, f"{err_lf:.1e}", *pc])
    table("Root locus of a flexible loop (rigid body, modes at zeta 1e-3, PD), 500 gains; "
          "error = max root distance to eig(A - k b c) at 10 sampled gains, relative to max(1, |root|)",
          ["order", "linflex time [s]", "linflex eig solves", "linflex error", "python-control root_locus_map [s]",
           "python-control error", "speed-up"], rows)


def true_peak_errors(sys, omega, G, channels):
    """Peak error [dB] of a grid against the refined true peak near each lightly damped pole."""
    lam = np.linalg.eigvals(sys.A)
    lam = lam[(lam.imag > 1e-6)]
    lam = lam[-lam.real / np.abs(lam) < 0.3]
    V_lam, V = np.linalg.eig(sys.A)
    CV, WB = sys.C @ V, np.linalg.solve(V, sys.B)

    def g(w, o, i):
        return abs(np.sum(CV[o] * WB[:, i] / (1j * w - V_lam)))

    worst = 0.0
    for lm in lam:
        h = abs(lm.real)
        a, b = lm.imag - 2 * h, lm.imag + 2 * h
        for o, i in channels:
            res = minimize_scalar(lambda w, o=o, i=i: -g(w, o, i), bounds=(a, b), method="bounded",
                                  options={"xatol": 1e-6 * h})
            if not (a + 0.01 * h < res.x < b - 0.01 * h) or -res.fun < max(g(a, o, i), g(b, o, i)):
                continue
            near = (omega >= res.x - 3 * h) & (omega <= res.x + 3 * h)
            grid = np.max(np.abs(G[near, o, i])) if np.any(near) else np.max(
                np.abs(G[np.argmin(np.abs(omega - res.x)), o, i]))
            worst = max(worst, 20 * np.log10(-res.fun / grid))
    return worst


def bench_grid(quick):
    rows = []
    rng = np.random.default_rng(3)
    n_modes = 40
    w = np.sort(np.exp(rng.uniform(np.log(0.5), np.log(50.0), n_modes)))
    A = np.zeros((2 * n_modes, 2 * n_modes))
    for i, wi in enumerate(w):
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[0.0, 1.0], [-wi**2, -2e-3 * wi]]
    B = np.zeros((2 * n_modes, 1))
    B[1::2, 0] = rng.uniform(0.2, 1.0, n_modes)
    C = np.zeros((1, 2 * n_modes))
    C[0, 0::2] = B[1::2, 0]
    models = [("40 modes, zeta 1e-3, SISO", LinearSystem(A, B, C), [(0, 0)])]
    if not quick:
        every = [(o, i) for o in range(3) for i in range(3)]
        models.append(("ISS 1R (270 states, 3x3), all channels", load("iss1R.mat"), every))
        models.append(("ISS 12A (1412 states, 3x3), all channels", load("ISS12A.mat"), every))
    for name, model, channels in models:
        fr = frequency_response(model)
        resp = control.frequency_response(model.to_control())
        G_pc = np.asarray(resp.frdata)
        G_pc = G_pc.reshape(model.n_outputs, model.n_inputs, -1).transpose(2, 0, 1)
        e_lf = true_peak_errors(model, fr.omega, fr.response, channels)
        e_pc = true_peak_errors(model, np.asarray(resp.omega), G_pc, channels)
        rows.append([name, "python-control default", len(resp.omega), f"{e_pc:.2f}"])
        rows.append([name, "linflex automatic", len(fr.omega), f"{e_lf:.3f}"])
    table("Worst resonance-peak error of the grid against the refined true peak",
          ["model", "grid", "points", "worst peak error [dB]"], rows)
    # peak error against the number of points, on the SISO model
    name, model, channels = models[0]
    sweep = []
    for n_pts in (1000, 2000) if quick else (1000, 2000, 5000, 20000):
        resp = control.frequency_response(model.to_control(), omega_num=n_pts)
        G_pc = np.asarray(resp.frdata).reshape(1, 1, -1).transpose(2, 0, 1)
        sweep.append(["python-control, log grid", len(resp.omega),
                      f"{true_peak_errors(model, np.asarray(resp.omega), G_pc, channels):.3f}"])
    for ppd in (10, 20, 40):
        fr = frequency_response(model, points_per_decade=ppd)
        sweep.append([f"linflex automatic, {ppd} points/decade base", len(fr.omega),
                      f"{true_peak_errors(model, fr.omega, fr.response, channels):.3f}"])
    table(f"Peak error against number of points ({name})", ["grid", "points", "worst peak error [dB]"], sweep)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller problems, for a smoke run")
    parser.add_argument("--part", action="append", choices=["grid", "locus", "iss12a"],
                        help="run only this part (repeatable); default: all three")
    args = parser.parse_args(argv)
    parts = args.part or ["grid", "locus", "iss12a"]
    if not MOR_DIR.exists():
        print(f"benchmark models not found at {MOR_DIR}", file=sys.stderr)
        return 1
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, control {control.__version__}, "
          f"slycot {'yes' if control.slycot_check() else 'no'}; BLAS threads pinned to 1")
    if "grid" in parts:
        bench_grid(args.quick)
    if "locus" in parts:
        bench_locus(args.quick)
    if "iss12a" in parts:
        bench_iss12a(args.quick)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
