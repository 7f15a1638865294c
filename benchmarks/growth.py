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
  ``linflex.linearize.balanced_truncation`` against ``control.balred`` (slycot);
- the H-infinity norm of that closed loop: ``linflex.frequency.hinf_norm`` against
  ``control.norm(T, p="inf")`` (SLICOT AB13DD with slycot). The closed loop has no block
  structure (the feedback couples every mode): both forms take a dense eigendecomposition.

Times are the CPU time of this process for one call (BLAS pinned to one thread, so CPU time is
what an idle machine's wall time would be); the median of three below 1 s. The orders are 101,
201, 401, 1001, 2001 and 4001; an analysis stops growing when its predicted time at the next
order exceeds the budget (``BUDGET``, 40 s; ``--quick``: orders 41 and 81, 2 s), so the table
shows what is practical. The prediction scales the last time by the order ratio to the power of
the local exponent (the slope between the last two orders run, clamped to [2, 3]; 3 after one
order): a structured analysis that grows like n^2 is not cut off by a cubic guess, a dense one
is predicted as cubic. The exponent is the least-squares slope of log time against log order
over the orders whose time is at least 0.05 s (at least two).

Accuracy, for every row a tool ran, against references computed here, independently of linflex's
engine, after the timed calls (their cost is printed under the table, never in the times). The
reference is ``ModalReference``: ``L(s)`` and ``dL/ds`` from the modal form's own matrices, every
2x2 block inverted in closed form, in extended precision (numpy's ``longdouble``, eps 1.1e-19),
O(n) per point; the dense form has the same transfer function, so the same reference serves it.

- frequency response: the largest relative error ``|G - G_ref| / |G_ref|`` over the tool's grid
  (at most 4000 evenly spaced points of it); the notes give the normwise error ``max|G - G_ref| /
  max|G_ref|``, the measure of linflex's ``error_estimate`` printed beside it, and the largest
  ratio of the pointwise error to ``eps`` times the condition number below (under 1: the error
  is what the problem's own sensitivity allows a backward-stable method). For the dense form,
  points where the rounding of its matrices alone moves ``L(jw)`` by more than 1e-6 (``eps`` times
  ``||A||_F ||(sI - A)^-1 B|| ||C (sI - A)^-1|| / |L|``: below about 1e-3 rad/s, where the rigid
  body's Jordan block splits by ``sqrt(eps ||A||)``) are ill-posed, left out and counted;
- stability_margins: at each reported gain crossover the Newton step of ``|L| = 1`` relative to
  ``w`` and the phase margin's error against ``angle(-L(jw))`` [rad], at each phase crossover the
  Newton step of ``Im L = 0`` and the gain margin's relative error against ``1 / |L(jw)|``: the
  worst; beside linflex's ``evaluation_error``. The notes count the crossings reported and those a
  grid of the reference finds (20 000 log-spaced points and 41 across each resonance);
- zeros, root locus (at 4 of the 100 gains): the distance of each root to the exact root Newton's
  method in extended precision reaches from it (on ``d(s) f(s)``, ``d`` the nearest block's
  characteristic polynomial, so that a lightly damped pole beside the root does not throw it
  off), relative to ``max(1, |root|)``; the notes flag a wrong count, two roots that reach one
  exact root, or no convergence. Beside the root locus: linflex's worst ``error_estimate``
  (relative), and the notes count roots whose error exceeds their own estimate;
- balanced truncation: ``max |T - T_r|`` with ``T = L / (1 + L)`` from the reference and ``T_r``
  by dense solves of the reduced model, on 2000 log-spaced points plus the frequencies of every
  closed-loop pole (``scipy.linalg.eigvals``) and reduced pole: a lower bound of the H-infinity
  error that reaches the peaks; beside linflex's bound ``2 sum(hsv[20:])``, and in the notes
  ``hsv[20]``, a lower bound of any order-20 model's error;
- H-infinity norm: the relative difference of the value from the reference's peak of ``|T|``
  (``T`` from the reference on 2000 log-spaced points and the closed-loop poles' frequencies, the
  largest refined by a bounded search); beside linflex's certified gap ``upper / value - 1``.

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

import _references as references  # noqa: E402
import control  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from linflex import LinearSystem  # noqa: E402
from linflex.frequency import frequency_response, hinf_norm, root_locus, zeros  # noqa: E402
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


# --- accuracy against references computed here, independently of linflex's engine ----------------

CHUNK = 1 << 21  # points x blocks per vectorized step of the reference (memory ~ 100 MB)


class ModalReference:
    """``L(s)`` and ``dL/ds`` of a ``flexible_pd_loop`` from its modal matrices, block by block, in
    numpy's extended precision (``longdouble``: eps 1.1e-19 on x86-64).

    The modal form is a plant of 2x2 diagonal blocks (the rigid body first) feeding one controller
    state, the last: ``A = [[A_P, 0], [r, a_K]]``, ``B = [b; 0]``, ``C = [c, c_K]``, so
    ``L(s) = c (sI - A_P)^-1 b + c_K r (sI - A_P)^-1 b / (s - a_K) + D`` with every 2x2 inverse
    in closed form (its adjugate over its determinant): O(n) per point, exact in the loop's own
    data up to 1e-19 times the condition of the sum, and sharing nothing with linflex's evaluator
    (no eigenvalues, no Schur form). The "dense" form has the same transfer function (an
    orthogonal change of coordinates), so this is the reference of both forms.
    """

    def __init__(self, L: LinearSystem):
        A, B, C, D = (np.array(m, float) for m in (L.A, L.B, L.C, L.D))
        n = A.shape[0] - 1
        blocks = np.zeros_like(A[:n, :n], dtype=bool)
        for i in range(0, n, 2):
            blocks[i:i + 2, i:i + 2] = True
        if n % 2 or np.any(A[:n, :n][~blocks]) or np.any(A[:n, n]) or B[n, 0] != 0.0 or B.shape[1] != 1:
            raise ValueError("not the modal form of flexible_pd_loop (2x2 plant blocks, one controller state last)")
        ld = np.longdouble
        self.a11, self.a12 = A[0:n:2, 0:n:2].diagonal().astype(ld), A[0:n:2, 1:n:2].diagonal().astype(ld)
        self.a21, self.a22 = A[1:n:2, 0:n:2].diagonal().astype(ld), A[1:n:2, 1:n:2].diagonal().astype(ld)
        self.b1, self.b2 = B[0:n:2, 0].astype(ld), B[1:n:2, 0].astype(ld)
        self.c1, self.c2 = C[0, 0:n:2].astype(ld), C[0, 1:n:2].astype(ld)
        self.r1, self.r2 = A[n, 0:n:2].astype(ld), A[n, 1:n:2].astype(ld)
        self.a_k, self.c_k, self.d = ld(A[n, n]), ld(C[0, n]), ld(D[0, 0])
        self.n_states = n + 1
        self.norm_a = float(np.linalg.norm(A))  # Frobenius, the same in any orthogonal coordinates

    @staticmethod
    def _solve(S, blocks, v1, v2, row: bool = False):
        """``(sI - A_i)^-1 v`` per 2x2 block ``A_i = [[a11, a12], [a21, a22]]`` (``v (sI - A_i)^-1``
        when ``row``): its adjugate over its determinant."""
        a11, a12, a21, a22 = blocks
        det = (S - a11) * (S - a22) - a12 * a21
        if row:
            return (v1 * (S - a22) + v2 * a21) / det, (v1 * a12 + v2 * (S - a11)) / det
        return ((S - a22) * v1 + a12 * v2) / det, (a21 * v1 + (S - a11) * v2) / det

    def __call__(self, s, dtype=np.clongdouble):
        """``(L(s), dL/ds)`` at the complex points ``s`` as arrays of ``dtype`` (extended precision
        by default; ``complex`` is ten times faster, for counting sign changes)."""
        s = np.atleast_1d(np.asarray(s, dtype))
        real = np.longdouble if dtype == np.clongdouble else float
        a11, a12, a21, a22, b1, b2, c1, c2, r1, r2, a_k, c_k, d = (
            np.asarray(v, real) for v in (self.a11, self.a12, self.a21, self.a22, self.b1, self.b2, self.c1,
                                          self.c2, self.r1, self.r2, self.a_k, self.c_k, self.d))
        L, dL = np.empty_like(s), np.empty_like(s)
        step = max(1, CHUNK // a11.size)
        for k in range(0, s.size, step):
            S = s[k:k + step, None]
            x1, x2 = self._solve(S, (a11, a12, a21, a22), b1, b2)        # (sI - A_P)^-1 b
            y1, y2 = self._solve(S, (a11, a12, a21, a22), x1, x2)        # (sI - A_P)^-2 b
            hc, hr = (c1 * x1 + c2 * x2).sum(1), (r1 * x1 + r2 * x2).sum(1)
            dc, dr = -(c1 * y1 + c2 * y2).sum(1), -(r1 * y1 + r2 * y2).sum(1)
            q = 1 / (s[k:k + step] - a_k)
            L[k:k + step] = hc + c_k * hr * q + d
            dL[k:k + step] = dc + c_k * (dr - hr * q) * q
        return L, dL

    def poles(self):
        """``(poles, owner)``: the eigenvalues of every 2x2 block and the controller's, each with
        the index of its block (the controller: ``n_blocks``), in double precision."""
        tr, det = (self.a11 + self.a22).astype(float), (self.a11 * self.a22 - self.a12 * self.a21).astype(float)
        root = np.sqrt((tr * tr - 4 * det).astype(complex))
        poles = np.concatenate([(tr + root) / 2, (tr - root) / 2, [float(self.a_k)]])
        owner = np.concatenate([np.arange(tr.size), np.arange(tr.size), [tr.size]])
        return poles, owner

    def factor(self, s, owner):
        """``(d(s), d'(s))`` of the characteristic polynomial of block ``owner`` (the controller's
        ``s - a_K`` for ``owner = n_blocks``) at the points ``s`` (clongdouble)."""
        nb = self.a11.size
        block = np.minimum(owner, nb - 1)
        a11, a12, a21, a22 = self.a11[block], self.a12[block], self.a21[block], self.a22[block]
        ctrl = owner == nb
        d = np.where(ctrl, s - self.a_k, (s - a11) * (s - a22) - a12 * a21)
        dd = np.where(ctrl, np.ones_like(s), 2 * s - a11 - a22)
        return d, dd

    def condition(self, s):
        """``||A||_F ||(sI - A)^-1 B|| ||C (sI - A)^-1|| / |L(s)|`` at the points ``s``: the first-order
        relative change of ``L(s)`` per unit relative perturbation of ``A`` (2-norms, so the same in
        any orthogonal coordinates), in double precision."""
        s = np.atleast_1d(np.asarray(s, complex))
        out = np.empty(s.size)
        a11, a12, a21, a22 = (np.asarray(v, float) for v in (self.a11, self.a12, self.a21, self.a22))
        b1, b2, c1, c2, r1, r2 = (np.asarray(v, float) for v in (self.b1, self.b2, self.c1, self.c2, self.r1, self.r2))
        step = max(1, CHUNK // a11.size)
        for k in range(0, s.size, step):
            S = s[k:k + step, None]
            q = 1 / (S - float(self.a_k))
            x1, x2 = self._solve(S, (a11, a12, a21, a22), b1, b2)
            xk = q[:, 0] * (r1 * x1 + r2 * x2).sum(1)                               # (sI - A)^-1 B
            u1, u2 = c1 + float(self.c_k) * q * r1, c2 + float(self.c_k) * q * r2
            y1, y2 = self._solve(S, (a11, a12, a21, a22), u1, u2, row=True)          # C (sI - A)^-1
            yk = float(self.c_k) * q[:, 0]
            G = (c1 * x1 + c2 * x2).sum(1) + float(self.c_k) * xk + float(self.d)
            nx = np.sqrt((np.abs(x1) ** 2 + np.abs(x2) ** 2).sum(1) + np.abs(xk) ** 2)
            ny = np.sqrt((np.abs(y1) ** 2 + np.abs(y2) ** 2).sum(1) + np.abs(yk) ** 2)
            out[k:k + step] = self.norm_a * nx * ny / np.abs(G)
        return out


NEWTON_STEPS = 12  # at most, per root (roots already accurate converge in one or two)
SAMPLES = 4000  # the largest number of grid points checked against the reference per response


ILL_POSED = 1e-6  # the dense form's data define L(jw) only to eps * condition: points above are left out


def response_error(ref: ModalReference, omega, G, dense: bool) -> tuple[str, str]:
    """``(error, note)``: the largest relative error ``|G - G_ref| / |G_ref|`` over the grid (at most
    ``SAMPLES`` evenly spaced points of it). The note gives the normwise error ``max |G - G_ref| /
    max |G_ref|`` (the measure of linflex's estimate) and the largest ratio of the pointwise error
    to ``eps`` times :meth:`ModalReference.condition` (what a backward-stable evaluation may lose:
    below 1 the error is the problem's, not the method's). For the dense form the points where
    the rounding of its matrices alone can move ``L(jw)`` by more than ``ILL_POSED`` (near the
    rigid-body double pole, whose Jordan block rounding splits by ``sqrt(eps ||A||)``) are left
    out and counted."""
    omega, G = np.asarray(omega, float), np.asarray(G, complex).reshape(-1)
    idx = np.unique(np.linspace(0, omega.size - 1, min(omega.size, SAMPLES)).round().astype(int))
    notes = [] if idx.size == omega.size else [f"{idx.size} of {omega.size} points"]
    sensitivity = np.finfo(float).eps * ref.condition(1j * omega[idx])
    if dense:
        posed = sensitivity <= ILL_POSED
        if not posed.all():
            notes.append(f"{np.sum(~posed)} ill-posed points left out")
        idx, sensitivity = idx[posed], sensitivity[posed]
    if not idx.size:
        return "-", ", ".join(notes)
    G_ref = ref(1j * omega[idx])[0].astype(complex)
    diff = np.abs(G[idx] - G_ref)
    rel = diff / np.abs(G_ref)
    return f"{np.max(rel):.1e}", ", ".join([f"normwise {np.max(diff) / np.max(np.abs(G_ref)):.1e}",
                                            f"<= {np.max(rel / sensitivity):.2g} eps cond"] + notes)


def crossing_counts(ref: ModalReference) -> tuple[int, int]:
    """``(gain crossovers, phase crossovers)`` of the reference counted as sign changes of
    ``|L| - 1`` and of ``Im L`` (where ``Re L < 0`` at both ends) on a grid independent of
    linflex's: 20 000 log-spaced points in [1e-3, 1e4] rad/s and 41 points across each
    open-loop resonance (``w_i (1 + zeta_i t)``, ``|t| <= 20``). Crossings closer than the grid
    spacing can hide, so these are lower bounds; cached on ``ref``."""
    if not hasattr(ref, "counts"):
        poles = ref.poles()[0]
        poles = poles[(poles.imag > 0)]
        zeta = -poles.real / np.abs(poles)
        w = np.concatenate([np.geomspace(1e-3, 1e4, 20000),
                            (np.abs(poles)[:, None] * (1 + zeta[:, None] * np.linspace(-20, 20, 41))).ravel()])
        w = np.unique(w[w > 0])
        L = ref(1j * w, dtype=complex)[0]
        gain = np.sum(np.diff(np.sign(np.abs(L) - 1)) != 0)
        phase = np.sum((np.diff(np.sign(L.imag)) != 0) & (L.real[:-1] < 0) & (L.real[1:] < 0))
        ref.counts = int(gain), int(phase)
    return ref.counts


def margin_error(ref: ModalReference, gain_crossovers, phase_margins_deg, phase_crossovers,
                 gain_margins) -> tuple[str, str]:
    """``(error, note)``: the worst residual of the reported margins against ``ref``
    (:func:`_references.margin_error`: Newton steps of the crossings, errors of the margins); the
    note counts the gain + phase crossovers reported and those :func:`crossing_counts` finds."""
    worst = references.margin_error(ref, gain_crossovers, phase_margins_deg, phase_crossovers, gain_margins)
    gain, phase = crossing_counts(ref)
    return f"{worst:.1e}", f"{np.size(gain_crossovers)} + {np.size(phase_crossovers)} crossings (grid {gain} + {phase})"


def root_error(roots, f_and_df, expected: int, ref: ModalReference) -> tuple[np.ndarray, dict]:
    """Distance of each root to the exact root of ``f`` that Newton's method in extended precision
    converges to from it, relative to ``max(1, |root|)``, and counts of the issues: roots too many
    or missing against ``expected``, not finite, not converged, or leading to an exact root another
    root also leads to (one found twice, another missed). ``f`` has poles at the loop's open-loop poles; Newton
    runs on ``d(s) f(s)``, ``d`` the characteristic polynomial of the block whose pole is nearest
    to the root (nearly linear there, so it converges even from a root that a lightly damped pole
    next to it makes hard to reach)."""
    from scipy.spatial import cKDTree

    roots = np.asarray(roots, complex).reshape(-1)
    finite = roots[np.isfinite(roots)]
    s = finite.astype(np.clongdouble)
    scale = np.maximum(1.0, np.abs(finite))
    poles, owner = ref.poles()
    if finite.size:
        owner = owner[cKDTree(np.c_[poles.real, poles.imag]).query(np.c_[finite.real, finite.imag])[1]]

    def g(s, idx):
        f, df = f_and_df(s)
        d, dd = ref.factor(s, owner[idx])
        return d * f, dd * f + d * df

    live, last, first = np.ones(s.size, bool), np.full(s.size, np.inf), np.full(s.size, np.inf)
    for i in range(NEWTON_STEPS):
        idx = np.flatnonzero(live & (last > 1e-17 * scale))
        if not idx.size:
            break
        f, df = g(s[idx], idx)
        step = f / df
        size = np.abs(step).astype(float)
        if i == 0:
            first[idx] = size / scale[idx]
        wild = ~(np.isfinite(size) & (size < 0.5 * scale[idx]))  # such a root stays unconverged
        live[idx[wild]] = False
        s[idx[~wild]] -= step[~wild]
        last[idx[~wild]] = size[~wild]
    moved = np.abs(s - finite).astype(float) / scale
    converged = live & (last <= np.maximum(1e-3 * moved, 1e-15) * scale)
    rel = np.where(converged, moved, first)  # unconverged: the first Newton step, a first-order distance
    issues = {"too many": max(0, roots.size - expected), "missing": max(0, expected - roots.size),
              "not finite": roots.size - finite.size, "not converged": int(np.sum(~converged)), "lead to a shared exact root": 0}
    if np.sum(converged) > 1:
        exact = np.c_[s.real.astype(float), s.imag.astype(float)][converged]
        dist = cKDTree(exact).query(exact, k=2)[0][:, 1]
        issues["lead to a shared exact root"] = int(np.sum(dist <= 1e-9 * scale[converged]))
    return rel, issues


def issue_note(issues: dict) -> str:
    """The non-zero counts of :func:`root_error`'s issues, as text."""
    return ", ".join(f"{count} {what}" for what, count in issues.items() if count)


def zeros_error(ref: ModalReference, z) -> tuple[str, str]:
    """``(error, note)``, :func:`root_error` of the zeros of ``L`` (``n - 2`` of them: ``D = 0``, ``C B = 0``,
    ``C A B != 0``)."""
    rel, issues = root_error(z, ref, ref.n_states - 2, ref)
    return f"{np.max(rel):.1e}", issue_note(issues)


LOCUS_CHECKS = (0, 33, 66, 99)  # the gains of the 100 whose roots are checked


def locus_error(ref: ModalReference, roots, estimates=None) -> tuple[str, str]:
    """``(error, note)``, :func:`root_error` of the closed-loop roots at the gains ``GAINS[LOCUS_CHECKS]`` (roots of
    ``1 + k L(s)``, ``n`` of them per gain), the worst over those gains; with ``estimates`` (the
    roots' own error estimates [1/s]) a note counts the roots whose error exceeds theirs."""
    roots = np.asarray(roots, complex)
    worst, total = 0.0, {}
    for i in LOCUS_CHECKS:
        k = GAINS[i]

        def f(s, k=k):
            L, dL = ref(s)
            return 1 + k * L, k * dL

        rel, issues = root_error(roots[i], f, ref.n_states, ref)
        worst = max(worst, float(np.max(rel)))
        if estimates is not None and np.all(np.isfinite(roots[i])):
            issues["above their estimate"] = int(np.sum(rel > np.asarray(estimates[i]) / np.maximum(1.0, np.abs(roots[i]))))
        for what, count in issues.items():
            total[what] = total.get(what, 0) + count
    note = issue_note(total)
    return f"{worst:.1e}", (f"of the {len(LOCUS_CHECKS) * ref.n_states} roots checked: {note}" if note else "")


def locus_estimate(result) -> str:
    """linflex's worst root error estimate at the checked gains, relative to ``max(1, |root|)``."""
    roots = np.asarray(result.roots)[list(LOCUS_CHECKS)]
    est = np.asarray(result.error_estimate)[list(LOCUS_CHECKS)] / np.maximum(1.0, np.abs(roots))
    return f"{np.max(est):.1e}"


def truncation_error(ref: ModalReference, L: LinearSystem, reduced) -> tuple[str, str]:
    """``max |T(jw) - T_r(jw)|`` over a grid that holds the resonances: 2000 log-spaced points in
    [1e-3, 1e4] rad/s, the imaginary parts of the closed-loop poles (``scipy.linalg.eigvals`` of the
    closed loop's ``A``) and of the reduced model's; ``T = L / (1 + L)`` from the reference,
    ``T_r`` by dense solves of the reduced model. A lower bound of the H-infinity error that meets
    it where a peak sits at a pole's frequency. ``L`` is the loop in its modal form, ``reduced``
    the reduced model's ``(A, B, C, D)``."""
    import scipy.linalg

    cl = closed_loop(L).A
    Ar, Br, Cr, Dr = (np.array(m, float) for m in reduced)
    w = np.concatenate([np.geomspace(1e-3, 1e4, 2000), np.abs(scipy.linalg.eigvals(cl).imag),
                        np.abs(np.linalg.eigvals(Ar).imag)])
    w = np.unique(w[w > 0])
    L = ref(1j * w)[0]
    T = (L / (1 + L)).astype(complex)
    S = 1j * w[:, None, None] * np.eye(Ar.shape[0]) - Ar
    Tr = (Cr @ np.linalg.solve(S, np.broadcast_to(Br, (w.size,) + Br.shape)))[:, 0, 0] + Dr[0, 0]
    return f"{np.max(np.abs(T - Tr)):.2e}", ""


def closed_loop_peak(ref: ModalReference, L: LinearSystem) -> float:
    """``||T||_inf`` of ``T = L / (1 + L)`` from the reference: ``|T|`` on 2000 log-spaced points
    in [1e-3, 1e4] rad/s and at the imaginary parts of the closed-loop poles, the largest refined
    by a bounded scalar search in log-frequency between its neighbours (extended precision)."""
    import scipy.linalg
    import scipy.optimize

    w = np.concatenate([np.geomspace(1e-3, 1e4, 2000), np.abs(scipy.linalg.eigvals(closed_loop(L).A).imag)])
    w = np.unique(w[w > 0])

    def mag(x):
        Lx = ref(1j * np.atleast_1d(x))[0]
        return np.abs(Lx / (1 + Lx)).astype(float)

    t = mag(w)
    i = int(np.argmax(t))
    lo, hi = w[max(i - 1, 0)], w[min(i + 1, w.size - 1)]
    res = scipy.optimize.minimize_scalar(lambda u: -float(mag(np.exp(u))[0]), bounds=(np.log(lo), np.log(hi)),
                                         method="bounded", options={"xatol": 1e-12})
    return max(float(t[i]), -float(res.fun))


def norm_error(ref: ModalReference, L: LinearSystem, value: float) -> tuple[str, str]:
    """Relative difference of an H-infinity norm of the closed loop from :func:`closed_loop_peak`."""
    peak = closed_loop_peak(ref, L)
    return f"{abs(float(value) - peak) / peak:.1e}", ""


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
    """``(name, linflex call, python-control call, linflex check, python-control check)`` per
    analysis; a check maps ``(reference, modal loop, result)`` to the error cell (and for linflex
    ``(error cell, linflex's own estimate)``)."""
    def ss(r):
        return r.A, r.B, r.C, r.D

    def with_estimate(found, estimate, note=""):
        return found[0], estimate, "; ".join(n for n in (found[1], note) if n)

    return [
        ("frequency response, automatic grid",
         lambda L: frequency_response(L), lambda L: control.frequency_response(L.to_control()),
         lambda ref, L, r, dense: with_estimate(response_error(ref, r.omega, r.response[:, 0, 0], dense),
                                                f"{r.error_estimate:.1e}"),
         lambda ref, L, r, dense: response_error(ref, r.omega, r.frdata[0, 0], dense)),
        ("stability_margins",
         lambda L: stability_margins(L), lambda L: control.stability_margins(L.to_control(), returnall=True),
         lambda ref, L, r, dense: with_estimate(margin_error(ref, r.gain_crossovers, r.phase_margins,
                                                             r.phase_crossovers, r.gain_margins),
                                                f"{r.evaluation_error:.1e}"),
         lambda ref, L, r, dense: margin_error(ref, r[4], r[1], r[3], r[0])),
        ("zeros", lambda L: zeros(L), lambda L: control.zeros(L.to_control()),
         lambda ref, L, r, dense: with_estimate(zeros_error(ref, r), "-"),
         lambda ref, L, r, dense: zeros_error(ref, r)),
        ("root locus, 100 gains",
         lambda L: root_locus(L, gains=GAINS), lambda L: control.root_locus_map(L.to_control(), GAINS),
         lambda ref, L, r, dense: with_estimate(locus_error(ref, r.roots, r.error_estimate), locus_estimate(r)),
         lambda ref, L, r, dense: locus_error(ref, r.loci)),
        ("balanced truncation to 20 (closed loop)",
         lambda L: balanced_truncation(closed_loop(L), order=20),
         lambda L: control.balred(closed_loop(L).to_control(), 20),
         lambda ref, L, r, dense: with_estimate(truncation_error(ref, L, ss(r.sys)), f"{r.error_bound:.2e}",
                                                f"hsv[20] {r.hsv[20]:.2e}" if r.hsv.size > 20 else ""),
         lambda ref, L, r, dense: truncation_error(ref, L, ss(r))),
        ("H-infinity norm (closed loop)",
         lambda L: hinf_norm(closed_loop(L)), lambda L: control.norm(closed_loop(L).to_control(), p="inf"),
         lambda ref, L, r, dense: with_estimate(norm_error(ref, L, r.value),
                                                f"gap {r.upper / r.value - 1:.1e}" if r.certified else "not certified",
                                                r.method),
         lambda ref, L, r, dense: norm_error(ref, L, r)),
    ]


BUDGET = 40.0


def checked(check, ref, L, result, dense: bool, spent: list) -> tuple[str, str, str]:
    """``(error, estimate, note)`` of ``check`` (estimate ``-`` for python-control), its CPU time
    added to ``spent``; a failure of the reference itself is reported in the note."""
    start = time.process_time()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out = check(ref, L, result, dense)
    except Exception as err:  # noqa: BLE001 -- the table reports a failed reference
        out = ("-", "-", f"reference failed ({type(err).__name__}: {' '.join(str(err).split())[:40]})")
    spent.append(time.process_time() - start)
    return out if len(out) == 3 else (out[0], "-", out[1])


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
    references = {order: ModalReference(loops[order]["modal"]) for order in orders}
    print(f"flexible_pd_loop, orders {orders[0]}..{orders[-1]}; CPU time of one call [s] (one BLAS thread); "
          f"budget {budget:g} s per call; load average at start {os.getloadavg()[0]:.1f}; "
          f"python-control {control.__version__}{' with slycot' if control.slycot_check() else ''}")
    print()
    print("| analysis | form | states | linflex CPU time [s] | python-control CPU time [s] | speed vs python-control "
          "| linflex error | linflex estimate | python-control error | accuracy notes |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    growth, spent = [], []
    for name, ours, theirs, check_ours, check_theirs in analyses():
        for form in ("modal", "dense"):
            last = {"linflex": None, "python-control": None}
            points = {"linflex": [], "python-control": []}
            runs = {"linflex": [], "python-control": []}
            for order in orders:
                L = loops[order][form]
                cells, accuracy = [], []
                for tool, fn, check in (("linflex", ours, check_ours), ("python-control", theirs, check_theirs)):
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
                            # after the timed calls: the reference never counts in the times
                            accuracy.append((tool, checked(check, references[order], loops[order]["modal"],
                                                           result, form == "dense", spent)))
                acc = dict(accuracy)
                ratio = (f"{float(cells[1]) / float(cells[0]):.2f}x"
                         if all(c.replace(".", "", 1).isdigit() for c in cells) and float(cells[0]) > 0 else "-")
                mine, peer = acc.get("linflex", ("-", "-", "")), acc.get("python-control", ("-", "-", ""))
                notes = "; ".join(f"{tool}: {acc[tool][2]}" for tool in acc if acc[tool][2]) or "-"
                print(f"| {name} | {form} | {L.n_states} | {cells[0]} | {cells[1]} | {ratio} | {mine[0]} | {mine[1]} "
                      f"| {peer[0]} | {notes} |", flush=True)
            growth.append((name, form, exponent(points["linflex"]), exponent(points["python-control"]),
                           max((n for n, _ in points["linflex"]), default=0),
                           max((n for n, _ in points["python-control"]), default=0)))
    print()
    print(f"Accuracy checks: {len(spent)} cells, {sum(spent):.1f} s CPU in all, the longest {max(spent, default=0):.1f} s "
          "(not in the times above)")
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
