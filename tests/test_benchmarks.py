"""Smoke run: every benchmark still executes in its --quick mode and prints its table.

Benchmarks are not tests (they assert nothing about speed); this only proves they still run.
"""

import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from .mor import MOR_DIR

ROOT = Path(__file__).resolve().parents[1]
NEEDS_SHARED_MODELS = {"reduction", "frequency"}
# Run with --quick and checked further by a test of their own below.
CHECKED_BELOW = {"growth"}


@pytest.mark.parametrize("name", sorted(p.stem for p in (ROOT / "benchmarks").glob("[a-z]*.py")
                                        if p.stem not in CHECKED_BELOW))
def test_benchmark_runs_quick(name):
    if name in NEEDS_SHARED_MODELS and not MOR_DIR.exists():
        pytest.skip(f"{name} needs the benchmark models of {MOR_DIR}")
    result = subprocess.run([sys.executable, str(ROOT / "benchmarks" / f"{name}.py"), "--quick"],
                            capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "|---|" in result.stdout  # a Markdown table was printed


# --- benchmarks/growth.py: accuracy columns against references independent of linflex ------------

def _benchmark_module(name: str):
    """A module of benchmarks/ (its helpers: the references, the error measures)."""
    import importlib

    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        return importlib.import_module(name)
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))


def _growth():
    """benchmarks/growth.py as a module."""
    return _benchmark_module("growth")


def test_growth_quick_prints_accuracy_columns_within_tolerances():
    """The --quick run (orders 41 and 81) prints, for every row linflex ran, its error against the
    reference, its own estimate and python-control's error; linflex's errors are at round-off
    level (the response's within eps times its condition number), its estimates bound them,
    balanced truncation's error lies between the lower bound hsv[20] and linflex's bound
    2 sum(hsv[20:]) (Glover's bounds), and python-control's balred
    (the same truncation) has the same error to 1 %."""
    import re

    from linflex.cli import bench_tool

    result = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "growth.py"), "--quick"],
                            capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert result.returncode == 0, result.stderr[-2000:]
    table = bench_tool().markdown_tables(result.stdout)[0]
    col = {h: k for k, h in enumerate(table.header)}
    for name in ("linflex error", "linflex estimate", "python-control error", "accuracy notes"):
        assert name in col
    tolerance = {"frequency response": 1e-8, "stability_margins": 1e-9, "zeros": 1e-10, "root locus": 1e-10,
                 "H-infinity norm": 1e-9}
    seen = set()
    for row in table.rows:
        analysis, ours_time, theirs_time = row[0], row[col["linflex CPU time [s]"]], row[col["python-control CPU time [s]"]]
        error, estimate = row[col["linflex error"]], row[col["linflex estimate"]]
        notes = row[col["accuracy notes"]]
        assert re.fullmatch(r"[0-9.]+", ours_time), row  # linflex ran at both quick orders
        assert "reference failed" not in notes, row
        if re.fullmatch(r"[0-9.]+", theirs_time):
            assert float(row[col["python-control error"]]) >= 0.0, row
        key = next(k for k in (*tolerance, "balanced truncation") if analysis.startswith(k))
        seen.add(key)
        linflex_notes = notes.split("python-control:")[0]
        if key == "balanced truncation":
            hsv = float(re.search(r"hsv\[20\] ([0-9.e+-]+)", notes).group(1))
            assert hsv <= float(error) <= float(estimate), row
            assert abs(float(row[col["python-control error"]]) / float(error) - 1) < 1e-2, row
            continue
        assert float(error) <= tolerance[key], row
        if key == "frequency response":
            normwise = float(re.search(r"linflex: normwise ([0-9.e+-]+)", notes).group(1))
            assert normwise <= float(estimate), row  # the estimate is normwise
            # within the problem's own sensitivity: eps cond (the dense form's data are rounded too)
            ratio = float(re.search(r"linflex: [^;]*<= ([0-9.e+-]+) eps cond", notes).group(1))
            assert ratio <= (10.0 if row[1] == "dense" else 1.0), row
        elif key == "stability_margins":
            found = re.search(r"linflex: (\d+) \+ (\d+) crossings \(grid (\d+) \+ (\d+)\)", notes).groups()
            assert found[:2] == found[2:], row  # every crossing the independent grid sees
            assert float(error) <= float(estimate), row
        elif key == "H-infinity norm":
            # certified at the quick orders: the bracket's gap within 2 rtol, and the reference's
            # peak within it (the value's relative difference below the gap)
            gap = float(re.fullmatch(r"gap ([0-9.e+-]+)", estimate).group(1))
            assert float(error) <= max(gap, 1e-12) <= 2e-6, row
        elif key == "root locus":
            assert float(error) <= float(estimate), row
            assert "linflex" not in linflex_notes, row  # right count, none twice, all converged, under estimate
        else:
            assert "linflex" not in linflex_notes, row
    assert seen == {*tolerance, "balanced truncation"}


def test_growth_reference_is_the_loops_transfer_function():
    """The modal reference against dense LU solves of the loop's own matrices (scipy.linalg.solve)
    at 25 frequencies, and its derivative and condition number against a finite difference and the
    same solves."""
    import numpy as np
    import scipy.linalg

    growth = _growth()
    L = growth.flexible_pd_loop(41)
    ref = growth.ModalReference(L)
    n = L.n_states
    s = 1j * np.geomspace(0.05, 200.0, 25)
    G, dG = ref(s)
    for k, sk in enumerate(s):
        X = scipy.linalg.solve(sk * np.eye(n) - L.A, np.c_[L.B, np.eye(n)])
        G_lu = (L.C @ X[:, :1])[0, 0]
        assert abs(complex(G[k]) - G_lu) <= 1e-11 * abs(G_lu)
        dG_lu = -(L.C @ X[:, 1:] @ X[:, :1])[0, 0]  # -C (sI - A)^-2 B
        assert abs(complex(dG[k]) - dG_lu) <= 1e-9 * abs(dG_lu)
        kappa = np.linalg.norm(L.A) * np.linalg.norm(X[:, :1]) * np.linalg.norm(L.C @ X[:, 1:]) / abs(G_lu)
        assert abs(ref.condition(sk)[0] / kappa - 1) < 1e-9


@settings(derandomize=True, max_examples=15, deadline=None)
@given(st.integers(0, 38), st.floats(-10.0, -5.0), st.floats(0.0, 6.28))
def test_growth_root_error_measures_the_distance_to_the_exact_root(index, log_delta, angle):
    """``root_error`` of the zeros found by scipy's QZ on the Rosenbrock pencil (an independent
    method), each moved by ``delta max(1, |z|)`` in a random direction: it reports ``delta`` for the
    moved zero (to 1 %) and round-off for the others."""
    import numpy as np
    import scipy.linalg

    growth = _growth()
    L = growth.flexible_pd_loop(41)
    ref = growth.ModalReference(L)
    n = L.n_states
    pencil = np.block([[L.A, L.B], [L.C, L.D]]), scipy.linalg.block_diag(np.eye(n), np.zeros((1, 1)))
    z = scipy.linalg.eigvals(*pencil)
    z = np.sort_complex(z[np.isfinite(z)])
    assert z.size == n - 2
    delta = 10.0 ** log_delta
    moved = z.copy()
    moved[index] += delta * max(1.0, abs(z[index])) * np.exp(1j * angle)
    rel, issues = growth.root_error(moved, ref, n - 2, ref)
    assert not any(issues.values()), issues
    assert abs(rel[index] / delta - 1) < 1e-2
    assert np.max(np.delete(rel, index)) < 1e-11


def test_growth_locus_and_margin_checks_see_a_wrong_answer():
    """The root-locus check against scipy.linalg.eigvals(A - k B C) at the checked gains (round-off,
    then one root moved by 1e-6 and one root dropped: both reported); the margin check at gain
    crossovers found by Brent's method on the reference (round-off, then 1e-7 off: reported)."""
    import numpy as np
    import scipy.linalg
    import scipy.optimize

    growth = _growth()
    L = growth.flexible_pd_loop(41)
    ref = growth.ModalReference(L)
    roots = np.zeros((growth.GAINS.size, L.n_states), complex)
    for i in growth.LOCUS_CHECKS:
        roots[i] = scipy.linalg.eigvals(L.A - growth.GAINS[i] * L.B @ L.C)
    assert float(growth.locus_error(ref, roots)[0]) < 1e-10  # eig: round-off, sqrt(eps) near the double pole
    k, j = growth.LOCUS_CHECKS[2], 7
    roots[k, j] += 1e-6 * max(1.0, abs(roots[k, j]))
    assert abs(float(growth.locus_error(ref, roots)[0]) / 1e-6 - 1) < 1e-2
    error, note = growth.locus_error(ref, roots[:, 1:])
    assert f"{len(growth.LOCUS_CHECKS)} missing" in note  # one per checked gain

    w = np.geomspace(0.1, 100.0, 4000)
    mag = np.abs(ref(1j * w, dtype=complex)[0]) - 1
    brackets = np.flatnonzero(np.diff(np.sign(mag)) != 0)[:3]
    wgc = np.array([scipy.optimize.brentq(lambda x: abs(complex(ref(1j * x)[0][0])) - 1, w[b], w[b + 1], xtol=1e-15)
                    for b in brackets])
    pm = np.angle(-ref(1j * wgc)[0].astype(complex), deg=True)
    assert float(growth.margin_error(ref, wgc, pm, [], [])[0]) < 1e-12
    off = wgc * (1 + 1e-7)
    pm_off = np.angle(-ref(1j * off)[0].astype(complex), deg=True)  # the phase there: only w is off
    assert abs(float(growth.margin_error(ref, off, pm_off, [], [])[0]) / 1e-7 - 1) < 0.05
    assert float(growth.margin_error(ref, wgc, pm + 1e-4, [], [])[0]) >= np.radians(1e-4) * 0.95  # printed to 2 digits


def test_dense_reference_margin_check_against_closed_form_margins():
    # L(s) = 10 / (s (s + 1) (s + 2)) (companion realization): L(jw) = 10 / (-3 w^2 + j w (2 - w^2))
    # is real at w = sqrt(2), where L = -10/6: the phase crossover and a gain margin of 6/10 in
    # closed form; the gain crossover from |L(jw)| = 1 by brentq. The shared check (structure.py's margins row, growth.py's) passes the exact values and
    # measures a planted error of 1e-6 in a crossover frequency.
    import numpy as np
    import scipy.optimize

    from linflex import LinearSystem

    references = _benchmark_module("_references")
    loop = LinearSystem(np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, -2.0, -3.0]]),
                        np.array([[0.0], [0.0], [1.0]]), np.array([[10.0, 0.0, 0.0]]), np.zeros((1, 1)))
    ref = references.DenseReference(loop)
    wgc = scipy.optimize.brentq(lambda w: abs(ref(1j * w)[0][0]) - 1.0, 0.5, 3.0, xtol=1e-15)
    pm = float(np.angle(-ref(1j * wgc)[0][0], deg=True))
    exact = references.margin_error(ref, [wgc], [pm], [np.sqrt(2.0)], [0.6])
    assert exact < 1e-12
    planted = references.margin_error(ref, [wgc], [pm], [np.sqrt(2.0) * (1 + 1e-6)], [0.6])
    assert 0.5e-6 < planted < 2e-6  # the Newton step of Im L = 0, relative to w


def test_first_axial_mode_of_the_arrays_is_the_clamped_free_rod_frequency():
    # benchmarks/simulation.py's column "first axial mode": none among 16 modes per array (bending
    # and torsion only, up to 171.7 rad/s); with 24 the first axial mode of the 8 m array,
    # against the closed form of a clamped-free rod's first longitudinal mode, (pi / 2L)
    # sqrt(EA / m): 16 finite elements are stiffer by under 0.1 %.
    import numpy as np

    import linflex

    simulation = _benchmark_module("simulation")
    base = linflex.load_scene(ROOT / "examples" / "spacecraft_arrays.toml")

    def scene(modes):
        return linflex.vary_scene(base, {f"bodies.{b}.modes": modes for b in simulation.ARRAY_NAMES})
    assert simulation.first_axial_frequency(scene(16)) is None
    beam = next(b.beam for b in base.bodies if b.beam)
    rod = np.pi / (2 * beam["length"]) * np.sqrt(beam["EA"] / beam["mass_per_length"])
    found = simulation.first_axial_frequency(scene(24))
    assert 0 <= found / rod - 1 < 1e-3


def test_first_axial_mode_of_the_spin_up_beam_is_the_clamped_free_rod_frequency():
    # The spin-up's cantilever (benchmarks/flexible.py: 10 m, EA = 2.8e7 N, 1.2 kg/m, 24
    # elements): no axial mode among its 8 lowest modes, and among 16 the rod's (pi / 2L)
    # sqrt(EA / m) = 758.8 rad/s, found within 0.1 % (the element mesh is slightly stiffer).
    import numpy as np

    simulation = _benchmark_module("simulation")
    flexible = _benchmark_module("flexible")
    rod = np.pi / (2 * flexible.LENGTH) * np.sqrt(flexible.EA / flexible.MASS)
    assert simulation.axial_frequency(flexible.spinup_scene(8)[1], (1.0, 0.0, 0.0)) is None
    found = simulation.axial_frequency(flexible.spinup_scene(16)[1], (1.0, 0.0, 0.0))
    assert 0 <= found / rod - 1 < 1e-3


def test_load_line_says_above_the_core_count_only_when_it_is():
    bench = _benchmark_module("_bench")
    assert bench.load_line((0.9, 0.8, 0.8), 2).endswith("on 2 cores: within the core count")
    assert "above the core count" in bench.load_line((2.5, 2.0, 1.5), 2)
