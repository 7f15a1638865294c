"""Growth table: the time of each main analysis against model order, dense and modal, beside python-control.

The loops are ``tests/hard/corpus.py``'s ``flexible_pd_loop(order)``: a rigid body and
``(order - 3) / 2`` collocated modes at damping 1e-3 between 0.5 and 50 rad/s under a filtered PD
law (``order`` states, one input, one output). "modal" is that loop as built: the plant in modal
coordinates (2x2 blocks) with the controller's state, about 4 non-zeros per row of ``A``.
"dense" is the same loop after an orthogonal change of coordinates (three Householder
reflections: every entry of ``A``, ``B`` and ``C`` non-zero, the transfer function unchanged).
In the modal form linflex finds the filter state as a hub fed by the plant's blocks
(``frequency/_modal_forms.block_components``): frequency response and root locus evaluate the
block-wise modal form, O(n) per point, and find zeros and closed-loop roots by the Aberth
iteration on its sums (``frequency/_modal_roots.py``, O(n) per root and step); margins, zeros
and balanced truncation of the closed loop still take dense O(n^3) steps.

Analyses, each with python-control's function on the same system where it has one:

- frequency response on the automatic grid: ``linflex.frequency.frequency_response(L)`` against
  ``control.frequency_response(L)`` (python-control's default grid);
- ``linflex.stability.stability_margins(L)`` against ``control.stability_margins(L)``;
- ``linflex.frequency.zeros(L)`` against ``control.zeros(L)``;
- root locus at 100 fixed gains (1e-3..1e2 times the design's): ``linflex.frequency.root_locus``
  against ``control.root_locus_map``;
- balanced truncation to order 20 of the closed loop ``L / (1 + L)`` (stable):
  ``linflex.linearize.balanced_truncation`` against ``control.balred`` (slycot).

Times are the CPU time of this process for one call (BLAS pinned to one thread, so CPU time is
what an idle machine's wall time would be); the median of three below 1 s. The orders are 101,
201, 401, 1001, 2001 and 4001; an analysis stops growing when its predicted time at the next
order exceeds the budget (``BUDGET``, 40 s; ``--quick``: orders 41 and 81, 2 s), so the table
shows what is practical. The prediction scales the last time by the order ratio to the power of
the local exponent (the slope between the last two orders run, clamped to [2, 3]; 3 after one
order): a structured analysis that grows like n^2 is not cut off by a cubic guess, a dense one
is predicted as cubic. The exponent is the least-squares slope of log time against log order
over the orders whose time is at least 0.05 s (at least two).

Run: ``.venv/bin/python benchmarks/growth.py`` (``--quick`` for a smoke run).
"""

from __future__ import annotations

import _timing  # noqa: F401  (one BLAS thread: before numpy)

# isort: split

import argparse  # noqa: E402
import os  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import control  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from linflex import LinearSystem  # noqa: E402
from linflex.frequency import frequency_response, root_locus, zeros  # noqa: E402
from linflex.linearize import balanced_truncation  # noqa: E402
from linflex.stability import stability_margins  # noqa: E402
from tests.hard.corpus import flexible_pd_loop  # noqa: E402

GAINS = np.geomspace(1e-3, 1e2, 100)


def dense_form(L: LinearSystem, seed: int = 0) -> LinearSystem:
    """``L`` in coordinates ``x' = T x`` with ``T`` a product of three Householder reflections
    (orthogonal, every entry non-zero; O(n^2) to apply)."""
    rng = np.random.default_rng(seed)
    A, B, C = np.array(L.A, float), np.array(L.B, float), np.array(L.C, float)
    for _ in range(3):
        v = rng.standard_normal(A.shape[0])
        v /= np.linalg.norm(v)
        # T = I - 2 v v^T (symmetric, its own inverse): A <- T A T, B <- T B, C <- C T
        A = A - 2.0 * np.outer(v, v @ A)
        A = A - 2.0 * np.outer(A @ v, v)
        B = B - 2.0 * np.outer(v, v @ B)
        C = C - 2.0 * np.outer(C @ v, v)
    return LinearSystem(A, B, C, np.array(L.D, float))


def closed_loop(L: LinearSystem) -> LinearSystem:
    """``L / (1 + L)`` of a one-input loop (negative unit feedback)."""
    A, B, C, D = (np.array(m, float) for m in (L.A, L.B, L.C, L.D))
    e = 1.0 / (1.0 + D[0, 0])
    return LinearSystem(A - e * B @ C, e * B, e * C, e * D)


def cpu_time(fn, fast: float = 1.0):
    """``(CPU seconds, result or error text)`` of ``fn()``: one call, the median of three when fast."""
    times, result = [], None
    for _ in range(3):
        start = time.process_time()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                result = fn()
        except Exception as err:  # noqa: BLE001 -- the table reports any failure of a tool
            return time.process_time() - start, f"{type(err).__name__}: {' '.join(str(err).split())[:50]}"
        times.append(time.process_time() - start)
        if times[-1] >= fast:
            break
    return statistics.median(times), result


def analyses():
    """``(name, linflex call, python-control call or None)`` per analysis."""
    return [
        ("frequency response, automatic grid",
         lambda L: frequency_response(L), lambda L: control.frequency_response(L.to_control())),
        ("stability_margins",
         lambda L: stability_margins(L), lambda L: control.stability_margins(L.to_control(), returnall=True)),
        ("zeros", lambda L: zeros(L), lambda L: control.zeros(L.to_control())),
        ("root locus, 100 gains",
         lambda L: root_locus(L, gains=GAINS), lambda L: control.root_locus_map(L.to_control(), GAINS)),
        ("balanced truncation to 20 (closed loop)",
         lambda L: balanced_truncation(closed_loop(L), order=20),
         lambda L: control.balred(closed_loop(L).to_control(), 20)),
    ]


BUDGET = 40.0


def predicted(points, order: int) -> float:
    """The time [s] predicted at ``order`` from the ``(order, seconds)`` run so far (see the
    module docstring)."""
    (n1, t1) = points[-1]
    k = 3.0
    if len(points) >= 2 and points[-2][1] >= 0.05:
        n0, t0 = points[-2]
        k = min(max(np.log(t1 / t0) / np.log(n1 / n0), 2.0), 3.0)
    return t1 * (order / n1) ** k


def exponent(points) -> str:
    """Least-squares slope of log time against log order over times >= 0.05 s."""
    pts = [(n, t) for n, t in points if t >= 0.05]
    if len(pts) < 2:
        return "-"
    n, t = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return f"{np.polyfit(n, t, 1)[0]:.2f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="orders 41 and 81, budget 2 s per call (a smoke run)")
    quick = parser.parse_args().quick
    orders = (41, 81) if quick else (101, 201, 401, 1001, 2001, 4001)
    budget = 2.0 if quick else BUDGET
    loops = {}
    for order in orders:
        L = flexible_pd_loop(order)
        loops[order] = {"modal": L, "dense": dense_form(L)}
    print(f"flexible_pd_loop, orders {orders[0]}..{orders[-1]}; CPU time of one call [s] (one BLAS thread); "
          f"budget {budget:g} s per call; load average at start {os.getloadavg()[0]:.1f}; "
          f"python-control {control.__version__}{' with slycot' if control.slycot_check() else ''}")
    print()
    print("| analysis | form | states | linflex CPU time [s] | python-control CPU time [s] | speed vs python-control |")
    print("|---|---|---|---|---|---|")
    growth = []
    for name, ours, theirs in analyses():
        for form in ("modal", "dense"):
            last = {"linflex": None, "python-control": None}
            points = {"linflex": [], "python-control": []}
            runs = {"linflex": [], "python-control": []}
            for order in orders:
                L = loops[order][form]
                cells = []
                for tool, fn in (("linflex", ours), ("python-control", theirs)):
                    prev = last[tool]
                    if fn is None:
                        cells.append("-")
                    elif prev is not None and prev[1] is None:
                        cells.append("not run (failed or over budget below)")
                    elif prev is not None and predicted(runs[tool], order) > budget:
                        cells.append(f"over budget (predicted {predicted(runs[tool], order):.0f} s)")
                        last[tool] = (order, None)
                    else:
                        seconds, result = cpu_time(lambda fn=fn, L=L: fn(L))
                        if isinstance(result, str):
                            cells.append(f"fails ({result})")
                            last[tool] = (order, None)
                        else:
                            cells.append(f"{seconds:.3f}")
                            last[tool] = (order, seconds)
                            runs[tool].append((order, seconds))
                            points[tool].append((L.n_states, seconds))
                ratio = (f"{float(cells[1]) / float(cells[0]):.2f}x"
                         if all(c.replace(".", "", 1).isdigit() for c in cells) and float(cells[0]) > 0 else "-")
                print(f"| {name} | {form} | {L.n_states} | {cells[0]} | {cells[1]} | {ratio} |", flush=True)
            growth.append((name, form, exponent(points["linflex"]), exponent(points["python-control"]),
                           max((n for n, _ in points["linflex"]), default=0),
                           max((n for n, _ in points["python-control"]), default=0)))
    print()
    print("Growth exponents (time ~ order^k, least squares over the orders run with times >= 0.05 s)")
    print()
    print("| analysis | form | linflex exponent | python-control exponent | largest order run, linflex | "
          "largest order run, python-control |")
    print("|---|---|---|---|---|---|")
    for name, form, ours, theirs, n_ours, n_theirs in growth:
        print(f"| {name} | {form} | {ours} | {theirs} | {n_ours or '-'} | {n_theirs or '-'} |")


if __name__ == "__main__":
    main()
