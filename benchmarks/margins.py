"""Stability margins of hub-plus-appendage attitude loops: linflex vs python-control.

The loops are those of the stability tests (``tests/stability/stab_models.py``): a rigid hub
``1/(J s^2)`` with ``n`` collocated appendage modes (damping 0.005 or 0.0005) and a PD controller
with a derivative filter, loop orders 51, 101, 201 and 401. The truth is a brute-force sweep of
the closed-form response (modal sum, itself checked against dense complex solves) on a uniform
log grid with steps of zeta/5, with bisection of every sign change.

For each loop the table gives the number of gain crossovers found, the error of the minimum
phase margin against the truth, the gain margins reported (the truth has none: the phase of a
collocated PD loop stays above -180 deg), and the median wall time of
``linflex.stability.stability_margins`` and of two python-control peers:
``control.stability_margins(sys, returnall=True)`` (python-control 0.10.x converts the
state-space loop to a transfer function and finds the crossings from polynomial roots) and the
same on ``control.frd(sys, omega)`` with 20000 log-spaced frequencies over 1e-2..1e4 rad/s (its
frequency-response-data path). BLAS threads are pinned to one.

First, the loops a user types first: a rigid axis under PD, with a derivative filter, with a
sensor lag (orders 2 to 4, given to both tools as the same python-control state-space system):
the phase margin against a log sweep of the closed form, and the time per call; then their
root locus with automatic gains against python-control's ``root_locus_map``, both tools' roots
checked against the roots of ``den + k num`` of the transfer function typed, in 50-digit
arithmetic, at their own gains.

Run: ``.venv/bin/python benchmarks/margins.py`` (``--quick``: order 51 only, one repetition).
"""

from __future__ import annotations

import _timing  # noqa: F401  (one BLAS thread: before numpy)
from _timing import median_time  # noqa: E402

# isort: split

import argparse  # noqa: E402
import sys  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import control  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # for tests.stability.stab_models

from linflex.stability import stability_margins  # noqa: E402
from tests.stability.stab_models import (  # noqa: E402
    brute_force_crossovers,
    direct_response,
    hub_loop,
    hub_loop_response,
)


def python_control_margins(L):
    """python-control's margins with every crossing; (wgc, pm, wpc, gm) or the error text."""
    sys_pc = L.to_control()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            gm, pm, _, wpc, wgc, _ = control.stability_margins(sys_pc, returnall=True)
        return np.atleast_1d(wgc), np.atleast_1d(pm), np.atleast_1d(wpc), np.atleast_1d(gm)
    except Exception as err:  # noqa: BLE001 - the benchmark reports any failure of the peer
        return f"{type(err).__name__}: {str(err)[:60]}"


def python_control_frd_margins(L, omega):
    """python-control's margins from frequency-response data on a fixed grid (its FRD path)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            frd = control.frd(L.to_control(), omega)
            gm, pm, _, wpc, wgc, _ = control.stability_margins(frd, returnall=True)
        return np.atleast_1d(wgc), np.atleast_1d(pm), np.atleast_1d(wpc), np.atleast_1d(gm)
    except Exception as err:  # noqa: BLE001
        return f"{type(err).__name__}: {str(err)[:60]}"


def min_abs(x):
    x = np.asarray(x, dtype=float)
    return float(x[np.argmin(np.abs(x))]) if x.size else float("inf")


# The small loops of small_loops_table: a rigid axis 1/(J s^2) [J in kg m^2] under PD (kp [N m/rad],
# kd [N m s/rad]), then with a derivative filter of time constant tau [s], then also a first-order
# sensor lag [s].
SMALL_J, SMALL_KP, SMALL_KD, SMALL_TAU, SMALL_LAG = 100.0, 40.0, 200.0, 0.05, 0.1


def small_loops(transfer_functions: bool = False):
    """``(name, L as a python-control state-space system, closed-form L(j w))`` of the small loops
    (orders 2, 3 and 4), the form a user types them in; ``transfer_functions``: ``L`` as the
    python-control transfer function it was typed as (exact coefficients: the state-space
    conversion leaves rounding-level entries, 1e-16, where the double integrator has zeros)."""
    J, kp, kd, tau, lag = SMALL_J, SMALL_KP, SMALL_KD, SMALL_TAU, SMALL_LAG
    plant = control.tf([1.0], [J, 0.0, 0.0])
    pd = control.tf([kd, kp], [1.0])
    filtered = control.tf([kp * tau + kd, kp], [tau, 1.0])
    sensor = control.tf([1.0], [lag, 1.0])
    loops = (("rigid axis, PD (order 2)", plant * pd, lambda s: (kp + kd * s) / (J * s * s)),
             ("rigid axis, filtered PD (order 3)", plant * filtered,
              lambda s: (kp + kd * s / (tau * s + 1.0)) / (J * s * s)),
             ("rigid axis, filtered PD, sensor lag (order 4)", plant * filtered * sensor,
              lambda s: (kp + kd * s / (tau * s + 1.0)) / (J * s * s * (lag * s + 1.0))))
    return [(name, L if transfer_functions else control.ss(L), resp) for name, L, resp in loops]


def small_loops_table(repeats: int) -> None:
    """The small loops' phase margin against the truth (a log sweep of the closed form with
    bisection) and the time of each tool on the same python-control system."""
    print("Small loops (a rigid axis J = 100 kg m^2 under PD kp = 40 N m/rad, kd = 200 N m s/rad; a derivative "
          "filter of 0.05 s; a sensor lag of 0.1 s), given as python-control state-space systems: phase margin "
          "and time per call")
    print("| loop | PM truth [deg] | linflex PM error [deg] | linflex [ms] | python-control PM error [deg] "
          "| python-control [ms] | linflex / python-control |")
    print("|---|---|---|---|---|---|---|")
    for name, L, resp in small_loops():
        wgc, _ = brute_force_crossovers(lambda w, resp=resp: resp(1j * np.atleast_1d(np.asarray(w, float))), 1e-3, 1e3,
                                        1e-3)
        pm_true = min_abs(np.degrees(np.angle(-resp(1j * wgc))))
        stability_margins(L)  # the first call imports and compiles what later calls reuse
        t_lin, m = median_time(lambda L=L: stability_margins(L), repeats)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t_pc, pc = median_time(lambda L=L: control.stability_margins(L, returnall=True), repeats)
        pm_pc = min_abs(np.atleast_1d(pc[1]))
        print(f"| {name} | {pm_true:.6f} | {m.min_phase_margin - pm_true:+.1e} | {1e3 * t_lin:.2f} "
              f"| {pm_pc - pm_true:+.1e} | {1e3 * t_pc:.2f} | {t_lin / t_pc:.1f} |")
    print()


def _exact_locus_roots(tf, gains) -> list:
    """Closed-loop roots at each gain of the loop typed as the transfer function ``tf = num /
    den``: the roots of ``den + k num`` in 50-digit arithmetic (mpmath), the reference of
    :func:`small_locus_table`."""
    import mpmath

    num, den = (np.atleast_1d(np.squeeze(c)).astype(float) for c in (tf.num[0][0], tf.den[0][0]))
    num = np.r_[np.zeros(den.size - num.size), num]
    out = []
    with mpmath.workdps(50):
        for k in gains:
            coeffs = [mpmath.mpf(float(d)) + mpmath.mpf(float(k)) * mpmath.mpf(float(c)) for d, c in zip(den, num)]
            out.append(np.array([complex(r) for r in mpmath.polyroots(coeffs, maxsteps=200, extraprec=200)]))
    return out


def _locus_error(gains, roots, tf, every: int = 1) -> float:
    """Largest error ``|r - r_exact| / max(|r_exact|, 1 rad/s)`` of a locus's roots at its non-zero
    gains, every ``every``-th of them (rows matched to the 50-digit roots at the same gain): relative, but absolute below the
    loops' bandwidth (0.6 to 0.8 rad/s), where roots of 1e-8 rad/s leave the double pole at gains
    of 1e-16 and the state-space conversion's rounding (1e-16 entries of ``A``) moves them by as
    much in both tools."""
    from scipy.optimize import linear_sum_assignment

    worst = 0.0
    gains, roots = np.asarray(gains, dtype=float), np.asarray(roots)
    roots = roots[gains != 0][::every]   # not the open-loop poles (the double pole at 0: no relative error)
    for row, exact in zip(roots, _exact_locus_roots(tf, gains[gains != 0][::every])):
        row = np.asarray(row, dtype=complex)
        row = row[np.isfinite(row)]
        M = np.abs(row[:, None] - exact[None, :])
        i, j = linear_sum_assignment(M)
        worst = max(worst, float(np.max(M[i, j] / np.maximum(np.abs(exact[j]), 1.0), initial=0.0)))
    return worst


def small_locus_table(repeats: int, every: int = 1) -> None:
    """The small loops' root locus with automatic gains (both tools given the same state-space
    system): time and the roots' largest error against the 50-digit roots of ``den + k
    num`` of the transfer function typed, at each tool's own gains (every ``every``-th of them:
    ``--quick`` checks one in ten)."""
    from linflex.frequency import root_locus

    print("Small loops (as above): root locus with automatic gains, time per call, gains chosen, and the roots' "
          "largest error (relative, or absolute in rad/s below 1 rad/s) against the roots of den + k num of the "
          "transfer function typed, in 50-digit arithmetic (mpmath), at the same gains"
          + ("" if every == 1 else f" (every {every}th)"))
    print("| loop | linflex [ms] | linflex gains | linflex error | python-control root_locus_map [ms] "
          "| python-control gains | python-control error | linflex / python-control |")
    print("|---|---|---|---|---|---|---|---|")
    for (name, L, _), (_, tf, _) in zip(small_loops(), small_loops(transfer_functions=True)):
        root_locus(L)
        t_lin, rl = median_time(lambda L=L: root_locus(L), repeats)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t_pc, pc = median_time(lambda L=L: control.root_locus_map(L), repeats)
        e_lin = _locus_error(rl.gains, rl.roots, tf, every)
        e_pc = _locus_error(pc.gains, pc.loci, tf, every)
        print(f"| {name} | {1e3 * t_lin:.1f} | {rl.gains.size} | {e_lin:.1e} | {1e3 * t_pc:.1f} | {pc.gains.size} "
              f"| {e_pc:.1e} | {t_lin / t_pc:.1f} |")
    print()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="order 51 only, one repetition")
    args = parser.parse_args()
    orders = (51,) if args.quick else (51, 101, 201, 401)
    small_loops_table(5 if args.quick else 21)
    small_locus_table(3 if args.quick else 11, 10 if args.quick else 1)
    rows = []
    for order in orders:
        for zeta in (0.005, 0.0005):
            L = hub_loop(order, zeta)

            def resp(w, order=order, zeta=zeta):
                return hub_loop_response(w, order, zeta)

            wchk = np.array([0.05, 0.9, 7.0, 60.0])
            chk = np.max(np.abs(resp(wchk) - direct_response(L, wchk)[:, 0, 0]) / np.abs(resp(wchk)))
            wgc_true, wpc_true = brute_force_crossovers(resp, 1e-2, 1e4, zeta / 5)
            pm_true = np.degrees(np.angle(-resp(wgc_true)))
            pm_min_true = min_abs(pm_true)
            repeats = 1 if args.quick else 3 if order <= 201 else 2
            t_lin, m = median_time(lambda L=L: stability_margins(L), repeats)
            t_pc, pc = median_time(lambda L=L: python_control_margins(L), repeats)
            omega = np.geomspace(1e-2, 1e4, 20000)
            t_frd, frd = median_time(lambda L=L, omega=omega: python_control_frd_margins(L, omega), repeats)
            rows.append((order, zeta, wgc_true.size, pm_min_true, chk, m, t_lin, pc, t_pc, frd, t_frd))
            print(f"order {order} zeta {zeta}: done", file=sys.stderr)

    print("Hub-plus-appendage PD loops: every gain crossover and the minimum phase margin")
    print("| order | zeta | crossings (truth) | min PM truth [deg] | method | crossings found | min PM error [deg] "
          "| gain margins | median time [s] | time / linflex |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for order, zeta, n_true, pm_true, _chk, m, t_lin, pc, t_pc, frd, t_frd in rows:
        gm_lin = "none" if m.gain_margins.size == 0 else f"{m.min_gain_margin:.4g}"
        print(f"| {order} | {zeta} | {n_true} | {pm_true:.4f} | linflex | {m.gain_crossovers.size} "
              f"| {m.min_phase_margin - pm_true:+.1e} | {gm_lin} | {t_lin:.3f} | 1.00 |")
        for name, res, t in (("python-control (polynomial)", pc, t_pc),
                             ("python-control FRD, 20000 log points", frd, t_frd)):
            if isinstance(res, str):
                print(f"| {order} | {zeta} | {n_true} | {pm_true:.4f} | {name} | failed: {res} | - | - | {t:.3f} | - |")
                continue
            wgc, pm, _, gm = res
            gms = "none" if gm.size == 0 else ", ".join(f"{g:.3g}" for g in gm[:2]) + (" ..." if gm.size > 2 else "")
            print(f"| {order} | {zeta} | {n_true} | {pm_true:.4f} | {name} | {wgc.size} "
                  f"| {min_abs(pm) - pm_true:+.1e} | {gms} | {t:.3f} | {t / t_lin:.2f} |")
    print()
    print("Closed-form response vs dense complex solves (max rel. difference at 4 frequencies): "
          + ", ".join(f"{r[0]}/{r[1]}: {r[4]:.1e}" for r in rows))
    print("linflex evaluation_error (fast L(jw) vs dense solves at the crossings): "
          + ", ".join(f"{r[0]}/{r[1]}: {r[5].evaluation_error:.1e}" for r in rows))


if __name__ == "__main__":
    main()
