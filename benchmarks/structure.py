"""Structure and size (issue 20, targets 1 and 2): structured and large dense models, linflex against python-control and against one LAPACK eigendecomposition, measured in the same run.

1. ISS 12A (1412 states, 3x3; A has 2118 non-zeros in 706 diagonal 2x2 blocks) at 400
   frequencies from 0.1 to 100 rad/s: linflex ``frequency_response`` against python-control's
   ``frequency_response`` on the StateSpace (SLICOT TB05AD through slycot when installed, its
   fastest documented use). Error of each against dense complex solves (``numpy.linalg.solve``
   of ``j w I - A``, an independent computation) at 8 of the frequencies, normwise relative per
   frequency; linflex's own a-posteriori estimate beside it.
2. A random stable dense system of order 2000 (2 inputs, 2 outputs; a few modes at damping
   1e-3..1e-2, the rest 0.05..0.9, frequencies 0.1..100 rad/s, in coordinates of condition 10):
   the automatic-grid ``frequency_response``, ``stability_margins`` of the first channel's loop
   and ``zeros`` (beside python-control's ``StateSpace.zeros``, SLICOT AB08ND with slycot), each
   against one ``scipy.linalg.eig(A)`` of the same matrix. Errors: the response against dense
   solves at 3 grid frequencies; the zeros against the finite generalized eigenvalues of the
   Rosenbrock pencil (QZ of the (n+2)-square system matrix), as the largest distance of matched
   zeros relative to max(1, |z|); the margins against dense solves at their own frequencies
   (the Newton step of each crossing relative to its frequency and the error of each margin, as
   in the growth table, and the disk margin at its peak).

3. Sparse models (targets 1 and 5): a chain of masses and springs with Rayleigh damping in
   first-order form (``tests/mor.py: sparse_chain``; a banded ``scipy.sparse`` A of 2000 to
   20000 states with no block structure, 1 input, 1 output). Frequency response at 400
   frequencies from 0.1 to 100 rad/s: linflex on the sparse system against the machine's floor
   for it (one SuperLU factorization and solve of ``sI - A`` per point, ``splu`` alone on the same
   matrices) and, at 2000 states, python-control on the dense StateSpace; errors against the
   real 2n x 2n formulation ``[[-A, -w I], [w I, -A]]`` solved by ``scipy.sparse.linalg.spsolve``
   at 4 frequencies (an independent system). Balanced truncation to 20 states: linflex's
   low-rank ADI factors against python-control's ``balred`` (SLICOT AB09AD, dense) at 2000
   states, then ADI alone; the reduced models' error on 200 frequencies against the full
   response (largest absolute difference, a lower bound of the H-infinity error) beside
   linflex's bound ``2 sum(hsv[20:])``. Modal truncation of ISS 12A stored sparse (block by
   block) and of the chains (lowest modes by shift-invert), against one dense ``eig(A)`` and the
   whole-matrix path on the dense copy.
4. H-infinity norm (target 1): ISS 12A by ``hinf_norm`` (interval bounds on the block-modal form,
   dense and sparse storage) against python-control's ``norm(sys, p=inf)``; the dense order-2000
   system's against ``eig(A)``. Each value is checked against a dense solve at its frequency.

Times are median CPU seconds of this process (one BLAS thread): on the shared machine the
process's CPU time is what an idle machine's wall time would be.

Run: ``.venv/bin/python benchmarks/structure.py [--quick] [--part iss12a|dense|sparse]``
(``--quick``: order 300 instead of 2000, sparse chains of 400 and 1000 states, fewer
repetitions).
"""

import _timing  # noqa: F401  (one BLAS thread: before numpy)
from _timing import median_cpu_time  # noqa: E402

# isort: split

import argparse  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import _references as references  # noqa: E402
import control  # noqa: E402
import numpy as np  # noqa: E402
import scipy.linalg  # noqa: E402
from scipy.optimize import linear_sum_assignment  # noqa: E402

from linflex import AccuracyWarning, LinearSystem  # noqa: E402
from linflex.frequency import frequency_response, hinf_norm, zeros  # noqa: E402
from linflex.stability import stability_margins  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.mor import (
    MOR_DIR,  # noqa: E402
    sparse_chain,  # noqa: E402
)
from tests.mor import load_mor as load  # noqa: E402


def table(title, header, rows):
    print(f"\n{title}")
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for r in rows:
        print("| " + " | ".join(str(x) for x in r) + " |")


def dense_solves(sys, omega):
    """Independent reference: one dense complex solve per frequency."""
    n = sys.n_states
    return np.array([sys.C @ np.linalg.solve(1j * w * np.eye(n) - sys.A, sys.B) + sys.D for w in omega])


def normwise(G, ref):
    return float(np.max(np.max(np.abs(G - ref), axis=(1, 2)) / np.max(np.abs(ref), axis=(1, 2))))


def bench_iss12a(quick):
    full = load("ISS12A.mat")
    sysc = full.to_control()
    omega = np.logspace(-1, 2, 400)
    check = omega[::50]
    ref = dense_solves(full, check)
    idx = np.searchsorted(omega, check)
    t_lf, fr = median_cpu_time(lambda: frequency_response(full, omega), 3 if quick else 9)
    t_pc, resp = median_cpu_time(lambda: control.frequency_response(sysc, omega), 1 if quick else 3)
    G_pc = np.asarray(resp.frdata).transpose(2, 0, 1)
    slycot = "with slycot" if control.slycot_check() else "without slycot"
    rows = [
        [f"python-control {control.__version__} frequency_response ({slycot})", f"{t_pc:.4f}",
         f"{normwise(G_pc[idx], ref):.1e}", "-", "1.0x"],
        [f"linflex frequency_response ({fr.method})", f"{t_lf:.4f}", f"{normwise(fr.response[idx], ref):.1e}",
         f"{fr.error_estimate:.1e}", f"{t_pc / t_lf:.1f}x"],
    ]
    table(f"ISS 12A (n = {full.n_states}, 3x3, {np.count_nonzero(full.A)} non-zeros in A), {len(omega)} "
          f"frequencies 0.1-100 rad/s; error vs dense solves at {len(check)} of them (normwise relative)",
          ["tool", "median CPU time [s]", "max rel. error", "error estimate", "speed vs python-control"], rows)
    bench_hinf("iss1R.mat" if quick else "ISS12A.mat", quick)


def bench_hinf(name, quick):
    """H-infinity norm of ISS 12A (``--quick``: ISS 1R, 270 states, where python-control's 35 s
    on ISS 12A would be most of the quick run): linflex's interval bounds on the block-modal form
    (dense and sparse storage) against python-control's ``norm(sys, p=inf)`` (SLICOT AB13DD with
    slycot, its default; else its Hamiltonian bisection). Accuracy: sigma_max of a dense complex
    solve at each tool's frequency (a lower bound of the true norm that each value must not exceed
    beyond rounding), and linflex's certified bracket."""
    full, sparse = load(name), load(name, sparse=True)
    sysc = full.to_control()
    t_d, hd = median_cpu_time(lambda: hinf_norm(full), 3 if quick else 5)
    t_s, hs = median_cpu_time(lambda: hinf_norm(sparse), 3 if quick else 5)
    t_pc, v_pc = median_cpu_time(lambda: control.norm(sysc, p="inf"), 1)
    attained = float(np.linalg.svd(dense_solves(full, [hs.omega])[0], compute_uv=False)[0])
    way = "SLICOT AB13DD" if control.slycot_check() else "Hamiltonian bisection"
    rows = [
        [f"python-control {control.__version__} norm(sys, p=inf) ({way})", f"{t_pc:.3f}", f"{float(v_pc):.10g}",
         f"{float(v_pc) / attained - 1:+.1e}", "-", "1.0x"],
        [f"linflex hinf_norm, dense A ({hd.n_evaluations} evaluations)", f"{t_d:.3f}", f"{hd.value:.10g}",
         f"{hd.value / attained - 1:+.1e}", f"{hd.upper / hd.value - 1:.1e}", f"{t_pc / t_d:.1f}x"],
        [f"linflex hinf_norm, sparse A ({hs.n_evaluations} evaluations)", f"{t_s:.3f}", f"{hs.value:.10g}",
         f"{hs.value / attained - 1:+.1e}", f"{hs.upper / hs.value - 1:.1e}", f"{t_pc / t_s:.1f}x"],
    ]
    table(f"{name.removesuffix('.mat').upper()} ({full.n_states} states) H-infinity norm (rtol 1e-6); 'vs attained': value / sigma_max(G(j w*)) - 1 with G by a dense "
          f"solve at linflex's peak w* = {hs.omega:.6g} rad/s (a value above it by more than rounding is not "
          "attained; below it, short of the norm)",
          ["tool", "median CPU time [s]", "value", "vs attained", "certified gap (upper/value - 1)",
           "speed vs python-control"], rows)


def dense_system(n, seed=0, n_light=4):
    """Random stable dense system: modes with frequencies 0.1..100 rad/s, a few lightly damped,
    in random coordinates of condition 10 (2 inputs, 2 outputs)."""
    rng = np.random.default_rng(seed)
    n_pairs = n // 2
    wn = np.exp(rng.uniform(np.log(0.1), np.log(100.0), n_pairs))
    zeta = rng.uniform(0.05, 0.9, n_pairs)
    zeta[:n_light] = 10.0 ** rng.uniform(-3, -2, n_light)
    J = np.zeros((n, n))
    for i, (w, z) in enumerate(zip(wn, zeta)):
        wd = w * np.sqrt(1 - z * z)
        J[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[-z * w, wd], [-wd, -z * w]]
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    T = Q * np.exp(rng.uniform(0, np.log(10.0), n))[None, :]
    A = T @ J @ np.linalg.inv(T)
    return LinearSystem(A, rng.normal(size=(n, 2)), rng.normal(size=(2, n)))


def pencil_zeros(sys):
    """Finite generalized eigenvalues of the square Rosenbrock pencil (independent of linflex)."""
    n, m = sys.n_states, sys.n_inputs
    S = np.block([[sys.A, sys.B], [sys.C, sys.D]])
    E = scipy.linalg.block_diag(np.eye(n), np.zeros((m, m)))
    a, b = scipy.linalg.eigvals(S, E, homogeneous_eigvals=True)
    finite = np.abs(b) > 1e-8 * np.abs(a)
    return a[finite] / b[finite]


def matched_error(z, ref):
    if len(z) != len(ref):
        return f"{len(z)} vs {len(ref)} zeros"
    cost = np.abs(z[:, None] - ref[None, :])
    r, c = linear_sum_assignment(cost)
    return f"{float(np.max(cost[r, c] / np.maximum(1.0, np.abs(ref[c])))):.1e}"


def margin_accuracy(loop, mg) -> str:
    """The reported margins of a SISO loop against dense solves at their frequencies
    (:class:`_references.DenseReference`): the worst Newton step of a crossing relative to its
    frequency and error of a margin (:func:`_references.margin_error`, as the growth table), and
    the disk margin against ``1 / |S(j w) - 1/2|`` at its frequency (skew 0), relative."""
    ref = references.DenseReference(loop)
    worst = references.margin_error(ref, mg.gain_crossovers, mg.phase_margins, mg.phase_crossovers, mg.gain_margins)
    parts = [f"crossings and margins {worst:.1e}"]
    disk = mg.disk_margin
    if np.isfinite(disk.frequency) and 0 < disk.frequency < np.inf:
        S = 1.0 / (1.0 + ref(1j * disk.frequency)[0][0])
        parts.append(f"disk {abs(1.0 / abs(S - 0.5) - disk.alpha) / disk.alpha:.1e}")
    return "; ".join(parts)


def bench_dense(quick):
    n = 300 if quick else 2000
    full = dense_system(n)
    loop = LinearSystem(full.A, full.B[:, :1], full.C[:1])
    reps = 3 if quick else 2
    t_eig, _ = median_cpu_time(lambda: scipy.linalg.eig(full.A), reps)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        t_fr, fr = median_cpu_time(lambda: frequency_response(full), reps)
        t_m, mg = median_cpu_time(lambda: stability_margins(loop), 1)
    t_z, z = median_cpu_time(lambda: zeros(full), 1)
    sysc = full.to_control()
    t_zpc, z_pc = median_cpu_time(lambda: sysc.zeros(), 1)
    t_h, h = median_cpu_time(lambda: hinf_norm(full), 1)
    attained = float(np.linalg.svd(dense_solves(full, [h.omega])[0], compute_uv=False)[0])
    pick = np.linspace(0, len(fr.omega) - 1, 3).astype(int)
    err_fr = normwise(fr.response[pick], dense_solves(full, fr.omega[pick]))
    ref_z = pencil_zeros(full)
    err_z = matched_error(np.asarray(z), ref_z)
    err_zpc = matched_error(np.asarray(z_pc, dtype=complex), ref_z)
    rows = [
        ["scipy.linalg.eig(A) (eigenvalues and vectors)", f"{t_eig:.3f}", "-", "-", "1.00"],
        [f"frequency_response, automatic grid ({len(fr.omega)} points, {fr.method})", f"{t_fr:.3f}",
         f"{err_fr:.1e}", f"{fr.error_estimate:.1e}", f"{t_fr / t_eig:.2f}"],
        [f"stability_margins, loop of channel 1 ({mg.n_evaluations} evaluations)", f"{t_m:.3f}",
         margin_accuracy(loop, mg), f"{mg.evaluation_error:.1e}", f"{t_m / t_eig:.2f}"],
        [f"zeros ({len(z)})", f"{t_z:.3f}", err_z, "-", f"{t_z / t_eig:.2f}"],
        [f"python-control {control.__version__} StateSpace.zeros ({len(z_pc)}; "
         f"{'SLICOT AB08ND' if control.slycot_check() else 'QZ'})", f"{t_zpc:.3f}", err_zpc, "-", f"{t_zpc / t_eig:.2f}"],
        [f"hinf_norm ({h.method}; {h.n_evaluations} evaluations)", f"{t_h:.3f}",
         f"value vs dense solve at its peak {h.value / attained - 1:+.1e}",
         f"certified gap {h.upper / h.value - 1:.1e}" if h.certified else "not certified", f"{t_h / t_eig:.2f}"],
    ]
    table(f"Dense random stable system, order {n}, 2x2 (load average {os.getloadavg()[0]:.1f} at the end)",
          ["work", "median CPU time [s]", "error vs independent", "error estimate", "time / eig(A)"], rows)


def real_formulation_solves(A, B, C, omega):
    """Independent reference for a sparse system: ``(jwI - A) x = B`` as the real system
    ``[[-A, -w I], [w I, -A]] [xr; xi] = [B; 0]``, solved by ``scipy.sparse.linalg.spsolve``."""
    import scipy.sparse
    import scipy.sparse.linalg

    n = A.shape[0]
    out = []
    for w in omega:
        M = scipy.sparse.bmat([[-A, -w * scipy.sparse.identity(n)], [w * scipy.sparse.identity(n), -A]], format="csc")
        x = scipy.sparse.linalg.spsolve(M, np.vstack([B, np.zeros_like(B)]))
        x = np.reshape(x, (2 * n, -1))
        out.append(C @ (x[:n] + 1j * x[n:]))
    return np.array(out)


def splu_floor(A, B, omega):
    """The machine's floor for a sparse frequency response: one SuperLU factorization of
    ``j w I - A`` and one solve per frequency, nothing else."""
    import scipy.sparse
    import scipy.sparse.linalg

    A = scipy.sparse.csc_matrix(A)
    eye = scipy.sparse.identity(A.shape[0], dtype=complex, format="csc")
    Bc = B.astype(complex)
    for w in omega:
        scipy.sparse.linalg.splu((1j * w * eye - A).tocsc()).solve(Bc)


def bench_sparse(quick):

    from linflex.frequency._evaluate import TransferEvaluator
    from linflex.linearize import balanced_truncation

    sizes = (200, 500) if quick else (1000, 4000, 10000)
    peer_masses = sizes[0] if quick else 1000     # python-control (dense) at 400 or 2000 states
    omega = np.logspace(-1, 2, 400)
    check = omega[[0, 133, 266, 399]]
    reps = 1 if quick else 3
    rows, times = [], []
    for masses in sizes:
        A, B, C = sparse_chain(masses, damping=1e-2)
        sys_ = LinearSystem(A, B, C)
        t_lf, fr = median_cpu_time(lambda sys_=sys_: frequency_response(sys_, omega), reps)
        t_floor, _ = median_cpu_time(lambda A=A, B=B: splu_floor(A, B, omega), reps)
        err = normwise(fr.response[np.searchsorted(omega, check)], real_formulation_solves(A, B, C, check))
        pc = ["-", "-"]
        if masses == peer_masses:
            sysc = control.ss(A.toarray(), B, C, 0)
            t_pc, _ = median_cpu_time(lambda sysc=sysc: control.frequency_response(sysc, omega), 1)
            pc = [f"{t_pc:.3f}", f"{t_pc / t_lf:.1f}x"]
        times.append((2 * masses, t_lf))
        rows.append([2 * masses, A.nnz, f"{t_lf:.3f}", f"{1e3 * t_lf / omega.size:.2f}", f"{t_floor:.3f}",
                     f"{t_lf / t_floor:.2f}", *pc, f"{err:.1e}", f"{fr.error_estimate:.1e}", fr.method])
    n_, t_ = np.array(times, float).T
    slope = float(np.polyfit(np.log(n_), np.log(t_), 1)[0]) if len(times) > 1 else float("nan")
    table(f"Sparse chain (banded A, no block structure, 1x1), frequency response at {omega.size} frequencies 0.1-100 "
          f"rad/s; floor: one splu of jwI - A and a solve per frequency; python-control on the dense StateSpace "
          f"{'(with slycot)' if control.slycot_check() else ''}; linflex time ~ states^{slope:.2f}",
          ["states", "non-zeros of A", "linflex [s]", "per frequency [ms]", "floor [s]", "linflex / floor",
           "python-control [s]", "speed vs python-control", "error vs real 2n spsolve", "error estimate", "path"],
          rows)

    rows, times = [], []
    grid = np.logspace(-2, 2.5, 200)
    for masses in sizes:
        A, B, C = sparse_chain(masses, damping=1e-2)
        sys_ = LinearSystem(A, B, C)
        G = TransferEvaluator(sys_)(grid)[:, 0, 0]
        t_bt, bt = median_cpu_time(
            lambda sys_=sys_: balanced_truncation(sys_, order=20, lyapunov_solver="adi"), 1)
        err_bt = float(np.max(np.abs(G - TransferEvaluator(bt.sys)(grid)[:, 0, 0])))
        times.append((2 * masses, t_bt))
        rows.append([2 * masses, "linflex balanced_truncation (ADI)", f"{t_bt:.3f}", "1.0x", f"{err_bt:.3e}",
                     f"{bt.error_bound:.3e}", f"{bt.hsv[20]:.3e}",
                     f"{max(bt.lyapunov_residuals):.1e}", "yes" if err_bt <= bt.error_bound else "no"])
        if masses == peer_masses:
            sysc = control.ss(A.toarray(), B, C, 0)
            t_pc, red = median_cpu_time(lambda sysc=sysc: control.balred(sysc, 20), 1)
            Gpc = np.array([np.asarray(red(1j * w)).reshape(-1)[0] for w in grid])
            err_pc = float(np.max(np.abs(G - Gpc)))
            rows.append([2 * masses, "python-control balred (SLICOT AB09AD, dense)", f"{t_pc:.3f}",
                         f"{t_pc / t_bt:.1f}x", f"{err_pc:.3e}", "-", "-", "-", "-"])
    n_, t_ = np.array(times, float).T
    slope_bt = float(np.polyfit(np.log(n_), np.log(t_), 1)[0]) if len(times) > 1 else float("nan")
    table(f"Sparse chain, balanced truncation to 20 states (linflex: low-rank ADI gramian factors, time ~ "
          f"states^{slope_bt:.2f}); error: largest |G - G_r| on 200 frequencies 0.01-316 rad/s",
          ["states", "tool", "CPU [s]", "speed of linflex", "error on the grid", "bound 2 sum(hsv[20:])",
           "hsv[20] (lower bound)", "Lyapunov residual", "error within bound"], rows)

    # modal truncation: a modal model block by block, a banded one from its lowest modes
    from linflex.linearize import modal_truncation

    def chain_dc(m):
        """The chain's static displacement per unit force, K^-1 in closed form (fixed-fixed chain of
        m masses, springs 1e3 N/m: i (m + 1 - j) / ((m + 1) k) between masses i <= j, 1-indexed)."""
        i, j = sorted((m // 2 + 1, m // 2 + 3))
        return np.array([[i * (m + 1 - j) / ((m + 1) * 1e3)]])

    rows = []
    iss = load("ISS12A.mat", sparse=True)
    cases = [("ISS 12A, sparse (706 modal blocks)", iss, 40, -iss.C @ np.linalg.solve(iss.A, iss.B))]
    cases += [(f"sparse chain, {2 * m} states", LinearSystem(*sparse_chain(m, damping=1e-2)), 20, chain_dc(m))
              for m in sizes]
    for label, sys_, keep, dc in cases:
        t_mt, mt = median_cpu_time(lambda sys_=sys_, keep=keep: modal_truncation(sys_, keep=keep), reps)
        r = mt.sys
        scale = np.max(np.abs(dc)) if np.max(np.abs(dc)) > 0 else np.max(np.abs(TransferEvaluator(sys_)(grid)))
        err_dc = float(np.max(np.abs(-r.C @ np.linalg.solve(r.A, r.B) + r.D - dc)) / scale)
        row = [label, keep, f"{t_mt:.3f}", f"{err_dc:.1e}"]
        if sys_.n_states <= (400 if quick else 2000):     # the dense references: 20 s at 2000 states
            dense = LinearSystem(sys_.A, sys_.B, sys_.C)
            t_eig, _ = median_cpu_time(lambda dense=dense: scipy.linalg.eig(dense.A), 1)
            t_whole, ref = median_cpu_time(
                lambda dense=dense, keep=keep: modal_truncation(dense, keep=keep, rigid_tol=0.0), 1)
            G1, G2 = TransferEvaluator(r)(grid), TransferEvaluator(ref.sys)(grid)
            row += [f"{t_eig:.3f}", f"{t_mt / t_eig:.3f}", f"{t_whole:.3f}",
                    f"{float(np.max(np.abs(G1 - G2)) / np.max(np.abs(G2))):.1e}"]
        else:
            row += ["-", "-", "-", "-"]
        rows.append(row)
    table("Modal truncation of sparse models (a modal A block by block; any other from its lowest modes by "
          "shift-invert); DC error against the chain's K^-1 in closed form (ISS 12A: a dense solve of A), relative to "
          "the DC gain (to the peak gain where it is 0); beside it one dense scipy.linalg.eig(A) and "
          "the whole-matrix path (rigid_tol=0.0 forces it) on the dense copy, with the largest difference of the two "
          "reduced responses on 200 frequencies",
          ["model", "modes kept", "linflex [s]", "DC error", "eig(A) [s]", "linflex / eig(A)", "whole-matrix path [s]",
           "difference to it"], rows)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="order 300 instead of 2000, fewer repetitions")
    parser.add_argument("--part", action="append", choices=["iss12a", "dense", "sparse"], help="run only this part")
    args = parser.parse_args(argv)
    parts = args.part or ["iss12a", "dense", "sparse"]
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, scipy {scipy.__version__}, "
          f"control {control.__version__}, slycot {'yes' if control.slycot_check() else 'no'}; "
          f"BLAS threads pinned to 1; load average {os.getloadavg()[0]:.1f}")
    if "iss12a" in parts:
        if not MOR_DIR.exists():
            print(f"benchmark models not found at {MOR_DIR}", file=sys.stderr)
            return 1
        bench_iss12a(args.quick)
    if "dense" in parts:
        bench_dense(args.quick)
    if "sparse" in parts:
        bench_sparse(args.quick)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
