"""Balanced truncation: linflex vs python-control's balred (SLICOT AB09AD/AB09MD through slycot).

Run from the repository root: ``.venv/bin/python benchmarks/reduction.py`` (``--quick``: ISS 1R
and the rigid-body case only, one repetition). BLAS is pinned to one
thread; both tools run in the same process on the same matrices. For every model and order it
prints the median CPU time of this process for each tool (one BLAS thread, so what an idle machine's
wall time would be; linflex with its default Lyapunov solver -- its real block recursion on a modal
Schur form, else SLICOT's SB03OD through slycot -- and with its complex Hammarling recursion
alone), their ratio, and the achieved H-infinity error of each
reduced model, measured by the same method for both (linflex's pole-aware sweep with local
refinement; certified by the Hamiltonian test only for error systems up to 500 states).

The rigid-body case is a spacecraft with a rigid double integrator and 100 lightly damped modes
(damping 1e-4 to 5e-3), reduced to 20 states; its error is the largest singular value of
``G - Gr`` over a pole-aware frequency grid from 1e-2 rad/s (direct complex solves), since the
rigid parts of the two reduced models differ by round-off and the error system is not stable.
"""


import _timing  # noqa: F401  (one BLAS thread: before numpy)
from _timing import median_cpu_time  # noqa: E402

# isort: split

import argparse  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy.io  # noqa: E402
import scipy.linalg  # noqa: E402
import scipy.sparse  # noqa: E402

from linflex.frequency._hinf import hinf_norm_stable  # noqa: E402
from linflex.linearize import balanced_truncation  # noqa: E402

# The benchmark models are read by the tests' loader (one implementation, tests/mor.py).
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.linearize.models import spacecraft  # noqa: E402
from tests.mor import MOR_DIR  # noqa: E402
from tests.mor import load_mor as load  # noqa: E402


def stable_error(full, A, B, C, D):
    """H-infinity norm of full - reduced, both stable (same method for both tools)."""
    Ae = scipy.linalg.block_diag(full.A, A)
    return hinf_norm_stable(Ae, np.vstack([full.B, B]), np.hstack([full.C, -C]), full.D - D)


def sweep_error(full, A, B, C, D):
    """max sigma(G(jw) - Gr(jw)) over a pole-aware grid from 1e-2 rad/s (direct solves)."""
    ev = np.linalg.eigvals(full.A)
    ev = ev[np.abs(ev) > 1e-3]
    w = np.concatenate([np.geomspace(1e-2, 1e3, 2000), np.abs(ev.imag), np.abs(ev.imag) + np.abs(ev.real)])
    w = np.unique(w[w >= 1e-2])
    n, r = full.A.shape[0], A.shape[0]
    best = 0.0
    for x in w:
        g = full.C @ np.linalg.solve(1j * x * np.eye(n) - full.A, full.B) + full.D
        gr = C @ np.linalg.solve(1j * x * np.eye(r) - A, B) + D
        best = max(best, float(np.linalg.norm(g - gr, 2)))
    return best


def main():
    import control

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="ISS 1R and the rigid-body case, one repetition")
    quick = parser.parse_args().quick

    try:
        import slycot  # noqa: F401
    except ImportError:
        sys.exit("python-control's balred needs slycot: pip install slycot")
    if not MOR_DIR.exists():
        sys.exit(f"benchmark models not found in {MOR_DIR}")
    rows = []
    cases = [("iss1R", [10, 20, 40], 1)] if quick else [("iss1R", [10, 20, 40], 21), ("ISS12A", [10, 20, 40], 3)]
    for name, orders, repeats in cases:
        full = load(name)
        peer_sys = full.to_control()
        for r in orders:
            t_ours, ours = median_cpu_time(lambda: balanced_truncation(full, order=r), repeats)  # noqa: B023
            t_hamm, _ = median_cpu_time(
                lambda: balanced_truncation(full, order=r, lyapunov_solver="hammarling"), repeats)  # noqa: B023
            t_peer, peer = median_cpu_time(lambda: control.balred(peer_sys, r), repeats)  # noqa: B023
            e_ours = stable_error(full, ours.sys.A, ours.sys.B, ours.sys.C, ours.sys.D)
            e_peer = stable_error(full, peer.A, peer.B, peer.C, peer.D)
            rows.append((
                f"{name} ({full.n_states})", r, t_ours, t_hamm, t_peer, t_peer / t_ours, e_ours.value, e_peer.value,
                ours.hsv[r], ours.error_bound, e_ours.certified and e_peer.certified,
            ))
            print(_fmt(rows[-1]), flush=True)
    full = spacecraft().to_state_space()
    peer_sys = full.to_control()
    reps = 1 if quick else 5
    t_ours, ours = median_cpu_time(lambda: balanced_truncation(full, order=20), reps)
    t_hamm, _ = median_cpu_time(lambda: balanced_truncation(full, order=20, lyapunov_solver="hammarling"), reps)
    try:
        control.hsvd(peer_sys)
        hsvd_note = "control.hsvd: accepted"
    except ValueError as err:
        hsvd_note = f"control.hsvd: refused ({err})"
    e_ours = sweep_error(full, ours.sys.A, ours.sys.B, ours.sys.C, ours.sys.D)
    # balred picks AB09MD (alpha-stable split) only when its own eigenvalues of the two rigid-body
    # poles come out with real part >= 0; when round-off puts them just left of the axis it calls
    # AB09AD, which refuses the system: a refusal is a result here, not a crash
    try:
        t_peer, peer = median_cpu_time(lambda: control.balred(peer_sys, 20), reps)
        e_peer = sweep_error(full, peer.A, peer.B, peer.C, peer.D)
        balred_note = "control.balred: accepted"
    except (ValueError, ArithmeticError) as err:
        t_peer, e_peer = float("nan"), float("nan")
        balred_note = f"control.balred: refused ({type(err).__name__}: {' '.join(str(err).split())})"
    rows.append((
        f"spacecraft rigid+100 modes ({full.n_states})", 20, t_ours, t_hamm, t_peer, t_peer / t_ours, e_ours, e_peer,
        ours.hsv[18], ours.error_bound, False,
    ))
    print(_fmt(rows[-1]), flush=True)
    rows.append(loop_1001(quick, control))
    print(_fmt(rows[-1]), flush=True)
    print()
    print("| model (states) | order | linflex CPU [s] | linflex, Hammarling recursion [s] | balred CPU [s] | balred/linflex "
          "| error linflex | error balred | first discarded HSV | bound 2*sum | certified |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for row in rows:
        print(_fmt(row))
    print()
    print(f"rigid-body case: {hsvd_note}; {balred_note}")
    print(f"numpy {np.__version__}, scipy {scipy.__version__}, control {control.__version__}, BLAS threads pinned to 1")


def loop_1001(quick, control):
    """Issue 20, target 5: the root-locus benchmark's flexible loop (rigid body, modes at zeta 1e-3,
    PD with a filter; tests/hard/corpus.py) at 1001 states (101 with --quick), reduced to 20 states.
    Times are median CPU seconds of this process (one BLAS thread; the shared machine's load does
    not enter). Error: the largest singular value of ``G - Gr`` over a pole-aware grid (the full
    model by linflex's modal evaluator with its own error estimate, the reduced ones by dense
    solves): the rigid bodies of the reduced models differ by round-off, so the error system is
    not stable and the Hamiltonian test does not apply."""
    from linflex.frequency import frequency_response
    from tests.hard.corpus import flexible_pd_loop

    order = 101 if quick else 1001
    full = flexible_pd_loop(order)
    peer_sys = full.to_control()
    reps = 1 if quick else 3
    t_ours, ours = median_cpu_time(lambda: balanced_truncation(full, order=20), reps)
    t_hamm, _ = median_cpu_time(lambda: balanced_truncation(full, order=20, lyapunov_solver="hammarling"), reps)
    try:
        t_peer, peer = median_cpu_time(lambda: control.balred(peer_sys, 20), reps)
    except (ValueError, ArithmeticError) as err:
        print(f"balred refused the {order}-state loop: {err}")
        t_peer, peer = float("nan"), None
    lam = np.linalg.eigvals(full.A)
    lam = lam[np.abs(lam) > 1e-3]
    w = np.concatenate([np.geomspace(1e-2, 1e4, 1000), np.abs(lam.imag), np.abs(lam.imag) + np.abs(lam.real)])
    w = np.unique(w[w >= 1e-2])
    fr = frequency_response(full, w)

    def error(A, B, C, D):
        r = A.shape[0]
        Gr = np.array([C @ np.linalg.solve(1j * x * np.eye(r) - A, B) + D for x in fr.omega])
        return float(np.max(np.linalg.norm(fr.response - Gr, 2, axis=(1, 2))))

    e_ours = error(ours.sys.A, ours.sys.B, ours.sys.C, ours.sys.D)
    e_peer = error(peer.A, peer.B, peer.C, peer.D) if peer is not None else float("nan")
    print(f"loop {order}: linflex solver {ours.lyapunov_solver}, error {e_ours:.4g} <= bound {ours.error_bound:.4g}: "
          f"{e_ours <= ours.error_bound}; full-model evaluation error estimate {fr.error_estimate:.1e}")
    return (f"flexible PD loop ({full.n_states})", 20, t_ours, t_hamm, t_peer, t_peer / t_ours, e_ours,
            e_peer, ours.hsv[20 - ours.n_unstable], ours.error_bound, False)


def _fmt(row):
    name, r, t1, t1h, t2, ratio, e1, e2, h, bound, cert = row
    return (f"| {name} | {r} | {t1:.3f} | {t1h:.3f} | {t2:.3f} | {ratio:.2f} | {e1:.4g} | {e2:.4g} | {h:.4g} | {bound:.4g} | "
            f"{'yes' if cert else 'no'} |")


if __name__ == "__main__":
    main()
