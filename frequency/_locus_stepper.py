"""Gain stepping of the root locus: adaptive steps, continuation or dense solves, substeps.

The stepper moves the closed-loop roots from gain to gain. Each step is solved by the Newton
continuation (:class:`._locus_tracker._NewtonTracker`, SISO) or a dense eigenvalue solve
matched to the previous roots, and accepted when the displacement test passes (reference
notes section 10.2); otherwise it is split into hidden substeps. Everything a run carries
from one gain to the next is in :class:`_StepState`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from linflex import LinearSystem, ModelError

from ._locus_breakaway import _any_between, _breakaway_near, _double_root_guess, _isolated_pair, _local_breakaway
from ._locus_steps import _Displacement, _match, _predict, _shortens
from ._locus_tracker import _NewtonTracker, _Solved, _tangents
from ._modal_roots import modal_roots


def _coincident(roots: NDArray) -> bool:
    """Whether two roots agree to 1e-10 of their size (a root found twice)."""
    if roots.size < 2:
        return False
    import scipy.spatial

    tree = scipy.spatial.cKDTree(np.column_stack([roots.real, roots.imag]))
    dist, _ = tree.query(np.column_stack([roots.real, roots.imag]), k=2)
    return bool(np.any(dist[:, 1] <= 1e-10 * np.maximum(np.abs(roots), 1e-300)))


class _ClosedLoop:
    """Dense eigenvalues of the closed loop ``A - k B (I + k D)^-1 C`` at gain ``k``, counted."""

    def __init__(self, L: LinearSystem) -> None:
        self.A, self.B, self.C, self.D = L.A, L.B, L.C, L.D
        self.count = 0
        self.I = np.eye(L.n_inputs)

    def matrix(self, k: float) -> NDArray[np.float64]:
        if k == 0:
            return self.A
        try:
            KC = np.linalg.solve(self.I + k * self.D, self.C) * k
        except np.linalg.LinAlgError:
            raise ModelError(f"the loop is ill-posed at gain {k}: I + k D is singular") from None
        return self.A - self.B @ KC

    def eig(self, k: float) -> NDArray[np.complex128]:
        self.count += 1
        M = self.matrix(k)
        if not np.all(np.isfinite(M)):
            raise ModelError(f"the closed-loop matrix at gain {k} is not finite (its entries overflow, or I + k D is nearly singular)")
        try:
            return scipy.linalg.eigvals(M, overwrite_a=bool(k != 0), check_finite=False)
        except np.linalg.LinAlgError as err:
            raise ModelError(f"the closed-loop eigenvalues at gain {k} did not converge ({err})") from err


@dataclass
class _StepState:
    """What one root-locus run carries from gain to gain (mutable, owned by its stepper)."""

    hint_gains: NDArray[np.float64]        # known breakaway gains: the pencil's, then those located
    hint_points: NDArray[np.complex128]    # and their double roots
    accepted: list = field(default_factory=list)   # last two accepted (gain, roots, dsdk or None)
    last: _Solved | None = None   # the latest solve: its derivatives go with its roots if accepted
    fails: int = 0       # continuation steps failed in a row
    skip: int = 0        # gains left to take by dense solves alone
    rejected: int = 0    # continuation steps rejected, in all
    n_newton: int = 0    # continuation steps accepted
    worst: float = 0.0   # largest accepted displacement [-]
    dense: dict = field(default_factory=dict)   # id -> roots of every dense solve (kept alive)


class _Stepper:
    """Roots of the closed loop along a sequence of gains, branch by branch: :meth:`given`
    for requested gains, :meth:`automatic` for an adaptive sequence; the state that one run
    carries is :attr:`state`, the configuration is fixed at construction."""

    def __init__(self, L: LinearSystem, cl: _ClosedLoop, tracker: _NewtonTracker | None, bpts, bgains, *,
                 s_ref: float, max_displacement: float, max_steps: int) -> None:
        self.n, self.cl, self.tracker, self.L = L.n_states, cl, tracker, L
        self.max_displacement, self.max_steps = max_displacement, max_steps
        self.displacement = _Displacement(s_ref)
        # the gain where the loop is ill-posed (1 + k d = 0): a root passes through infinity
        d_loop = float(L.D[0, 0]) if L.shape == (1, 1) else 0.0
        self.k_inf = np.array([-1.0 / d_loop]) if d_loop != 0 else np.zeros(0)
        self.state = _StepState(np.asarray(bgains, dtype=float), np.asarray(bpts, dtype=complex))

    def budget(self) -> bool:
        """Whether gain steps (dense solves plus continuation steps) are left."""
        return self.cl.count + self.state.n_newton < self.max_steps

    def newton_usable(self) -> bool:
        """Whether the next step may try the continuation (SISO, not in a dense-only spell)."""
        return self.tracker is not None and self.state.skip == 0

    def accept(self, k: float, r: NDArray) -> None:
        """Take the roots ``r`` at gain ``k`` as the next point of the predictor (with their
        derivatives and spacing when they are the latest solve's)."""
        st = self.state
        info = st.last if st.last is not None and st.last.roots is r else None
        st.accepted.append((k, r, None if info is None else info.dsdk))
        if info is not None and info.spacing is not None:
            self.displacement.local(r, info.spacing)
        st.last = None
        del st.accepted[:-2]

    def record(self, ok: bool) -> None:
        # a loop where the continuation keeps failing (checks not met at most gains) is
        # cheaper with dense solves alone: after three failures in a row the continuation is
        # skipped for a number of gains that doubles with every further failure (up to 32)
        st = self.state
        if ok:
            st.fails = 0
        else:
            st.fails += 1
            st.rejected += 1
            if st.fails >= 3:
                st.skip = min(32, 1 << (st.fails - 3))

    def solve_newton(self, k_cur: float, r_cur: NDArray, k_try: float, pair=None, big=None):
        """``(roots, guess)``: roots at k_try in the order of r_cur by Newton continuation
        (``None`` when a check fails), and the prediction it started from."""
        tracker, st = self.tracker, self.state
        guess = r_cur
        if k_cur == 0:
            # leaving the open-loop poles: first-order guesses (a multiple pole by its local
            # model); the checks and the displacement test decide as for any other step
            guess = tracker.leave_poles(r_cur, k_try)
            if guess is None:
                return None, r_cur
        elif st.accepted and st.accepted[-1][0] == k_cur and st.accepted[-1][1] is r_cur:
            # predictor along the branches; Newton corrects it, the checks and the
            # displacement test reject a bad one (the roots away from a double root are
            # analytic in k across it, so the predictor holds for them there too)
            guess = _predict(st.accepted, k_try)
        loose = None
        if pair is not None:
            two, k_b, s_b = pair
            guess = guess.copy()
            guess[two] = _double_root_guess(tracker, r_cur[two], k_cur, k_try, k_b, s_b)
            if (k_try - k_b) * (k_cur - k_b) <= 0:
                # real roots turn into a conjugate pair or back: these two are iterated on
                # their own, the other conjugate pairs of r_cur carry over
                loose = two
        if big is not None:
            # the root through infinity (1 + k d = 0 at k_inf): from the trace of the
            # closed-loop matrix, A - k b c / (1 + k d), less the other roots' guesses
            guess = guess.copy()
            with np.errstate(all="ignore"):   # at 1 + k d = 0 exactly: inf, rejected below
                trace = tracker.traceA - k_try * tracker.cb / (1.0 + k_try * tracker.d.real)
            guess[big] = trace - (np.sum(guess) - guess[big])
        with np.errstate(all="ignore"):
            solved = tracker.step(guess, k_try, r_cur, loose) if np.all(np.isfinite(guess)) else None
        self.record(solved is not None)
        if solved is None:
            return None, guess
        st.n_newton += 1
        st.last = solved
        return solved.roots, guess

    def solve_dense(self, r_cur: NDArray, k_try: float) -> NDArray:
        """Roots at k_try in the order of r_cur: dense eigenvalues and linear assignment. With a
        block-wise modal form (``tracker.modal``), the roots of ``1/k + L`` by the Aberth
        iteration on its sums from ``r_cur`` (O(n^2), no dense matrix; :mod:`._modal_roots`),
        when every root converges; they are then estimated like continuation roots."""
        st = self.state
        if st.skip:
            st.skip -= 1
        found = self._structured_roots(r_cur, k_try)
        if found is not None:
            r_new = _match(r_cur, found)
        else:
            r_new = _match(r_cur, self.cl.eig(k_try))
            st.dense[id(r_new)] = r_new
        st.last = None
        if self.tracker is not None and k_try != 0:
            # the branch tangents at the dense solution, for the predictor of the next step
            with np.errstate(all="ignore"):
                dsdk = _tangents(*self.tracker.values(r_new, second=True))
            if np.all(np.isfinite(dsdk)):
                st.last = _Solved(r_new, dsdk)
        return r_new

    def _structured_roots(self, r_cur: NDArray, k_try: float) -> NDArray | None:
        tracker = self.tracker
        if tracker is None or tracker.modal is None or k_try == 0 or 1.0 + k_try * tracker.d.real == 0:
            return None
        with np.errstate(all="ignore"):
            roots = modal_roots(tracker.modal, self.L, 1.0 / k_try, start=r_cur)
        if roots.size != self.n:
            return None
        # distinct, and their sum the trace of the closed-loop matrix (the continuation's checks)
        trace = tracker.traceA - k_try * tracker.cb / (1.0 + k_try * tracker.d.real)
        scale = float(np.sum(np.abs(roots))) + abs(trace)
        if abs(np.sum(roots) - trace) > 1e-8 * scale or _coincident(roots):
            return None
        self.cl.count += 1
        return roots

    def add_hint(self, found) -> bool:
        """Record a breakaway ``(k_b, s_b)`` located by the continuation; False if none or
        already known (the caller then bisects instead: no step is retried without progress)."""
        st = self.state
        if found is None or np.any(np.abs(st.hint_gains - found[0]) <= 1e-9 * abs(found[0])):
            return False
        st.hint_gains = np.append(st.hint_gains, found[0])
        st.hint_points = np.append(st.hint_points, found[1])
        return True

    def _double_root_ahead(self, k_cur: float, r_cur: NDArray, k_try: float):
        """``(pair, k_sub)``: a known double root ``s_b`` at gain ``k_b`` inside the step or
        just behind it, as ``pair = (its two roots, k_b, s_b)`` once they are isolated near it
        (the others at least twice as far), or a substep ``k_sub`` towards it before then."""
        st = self.state
        b = _breakaway_near(st.hint_gains, k_cur, k_try) if (self.n > 1 and k_cur != 0) else None
        if b is None or not self.budget():
            return None, None
        # the two roots meeting at s_b move like s_b +- a sqrt(k - k_b), too fast for the
        # displacement test near k_b. Isolated, they are exempt from it: the others pass it, so
        # every other root keeps its identity and the two left over are the pair (which of the
        # two continues which branch across k_b is a convention: offsets turned by 90 degrees).
        # Until then, approach k_b geometrically, k_b - 0.3 (k_b - k).
        k_b, s_b = st.hint_gains[b], st.hint_points[b]
        two = _isolated_pair(r_cur, s_b)
        if two is not None:
            return (two, k_b, s_b), None
        k_new = k_b - 0.3 * (k_b - k_cur)
        if (k_try - k_b) * (k_cur - k_b) <= 0 and _shortens(k_new, k_cur, k_try):
            return None, k_new
        return None, None

    def _locate(self, r_cur, r_try, k_cur, k_try, ahead=1.0) -> bool:
        """Look for an unknown double root next to the root that moved most (Newton on
        ``L'(s) = 0``) and record it; True if one was found (the step is then retried)."""
        if _breakaway_near(self.state.hint_gains, k_cur, k_try) is not None:
            return False
        local = self.displacement.local(r_cur)
        return self.add_hint(_local_breakaway(self.tracker, r_cur, r_try, local, k_cur, k_try, ahead))

    def track(self, k_from: float, r_from: NDArray, k_to: float) -> NDArray:
        """Roots at k_to matched to r_from, with hidden substeps when the jump is too large."""
        st = self.state
        st.last = None
        pending = [k_to]
        k_cur, r_cur = k_from, r_from
        retried = None   # the gain of a substep proposed after a failed continuation step
        while pending:
            k_try = pending[-1]
            budget = self.budget()
            pair, k_sub = self._double_root_ahead(k_cur, r_cur, k_try)
            if k_sub is not None:
                pending.append(k_sub)
                k_try = k_sub
            big = self._through_infinity(k_cur, r_cur, k_try)
            r_try = None
            if self.newton_usable():
                r_try, guess = self.solve_newton(k_cur, r_cur, k_try, pair, big)
                if r_try is None and budget and pair is None and k_cur != 0:
                    # a double root ahead that is not known yet makes the iterates of the two
                    # roots meeting there collide: look for it; else, once after continuation
                    # steps that passed, retry from half the step (an avoided crossing: two
                    # roots passing close by, turning faster than the predictor follows)
                    if self._locate(r_cur, guess, k_cur, k_try):
                        continue
                    k_mid = 0.5 * (k_cur + k_try)
                    if st.fails == 1 and retried is None and _shortens(k_mid, k_cur, k_try):
                        retried = k_mid
                        pending.append(k_mid)
                        continue
            if r_try is None:
                r_try = self.solve_dense(r_cur, k_try)
            d = self._step_displacement(r_cur, r_try, pair, big)
            if d > self.max_displacement and _shortens(0.5 * (k_cur + k_try), k_cur, k_try) and budget:
                # a breakaway the pencil did not give (not computed, or missed)
                if self.tracker is not None and k_cur != 0 and pair is None and \
                        self._locate(r_cur, r_try, k_cur, k_try, ahead=3.0):
                    continue
                # from the open loop (dense eig only) shrink geometrically: roots leave a
                # multiple pole like k^(1/m), so halving alone would need many dense solves
                pending.append(k_try * 1e-3 if k_cur == 0 else 0.5 * (k_cur + k_try))
                continue
            st.worst = max(st.worst, d)
            pending.pop()
            k_cur, r_cur = k_try, r_try
            self.accept(k_cur, r_cur)
        return r_cur

    def _through_infinity(self, k_cur: float, r_cur: NDArray, k_try: float, window: float = 3.0) -> int | None:
        """The root of largest modulus when the gain where ``1 + k d = 0`` lies inside the step
        or within ``window`` steps of it: a root passes through infinity there, and its motion
        is unbounded. It is exempt from the displacement test; the others pass it and keep
        their identities, so the one left over is that root."""
        if self.k_inf.size and self.n and _breakaway_near(self.k_inf, k_cur, k_try, window) is not None:
            return int(np.argmax(np.abs(r_cur)))
        return None

    def _step_displacement(self, r_cur: NDArray, r_try: NDArray, pair, big) -> float:
        """The displacement test's measure, with the pair crossing a double root and the root
        through infinity exempt (inf if the pair did not stay isolated)."""
        exempt = []
        if pair is not None:
            two_new = _isolated_pair(r_try, pair[2])
            if two_new is None or set(two_new.tolist()) != set(pair[0].tolist()):
                return np.inf
            exempt.extend(pair[0].tolist())
        if big is not None and int(np.argmax(np.abs(r_try))) == big:
            exempt.append(big)
        return self.displacement(r_cur, r_try, exempt=np.array(exempt, dtype=int) if exempt else None)

    def given(self, g: NDArray, poles: NDArray) -> list:
        """Roots at the sorted gains ``g`` (rows), from the open-loop ``poles``."""
        if g[0] == 0:
            rows = [poles]
        elif self.n and (g[0] > 0 or g[-1] <= 0):
            # from the open loop, when 0 lies before the first gain: branches ordered by pole
            rows = [self.track(0.0, poles, g[0])]
        else:
            rows = [self.cl.eig(g[0])]
            self.state.dense[id(rows[0])] = rows[0]
        i, block = 1, 4
        while i < len(g):
            G = max(0, min(block, len(g) - i, self.max_steps - (self.cl.count + self.state.n_newton)))
            n_ok = self._batch(g[i - 1], rows, g[i:i + G])
            if n_ok is not None:
                i += n_ok
                block = min(2 * block, 8) if n_ok == G else max(2, n_ok)
                if n_ok:
                    continue
            rows.append(self.track(g[i - 1], rows[-1], g[i]))
            i += 1
        return rows

    def _batch(self, k_prev: float, rows: list, ks: NDArray) -> int | None:
        """Several requested gains at once: predicted along the branches, corrected by one
        vectorized Newton iteration, then each checked like a single step (convergence,
        distinct roots, trace, displacement from the row before); the rows up to the first
        failure are appended and counted, the rest goes through :meth:`track`. ``None`` when
        the batch does not apply (no two accepted steps with derivatives to predict from, a
        breakaway or the root through infinity ahead)."""
        st, r_prev, G, n = self.state, rows[-1], len(ks), self.n
        acc = st.accepted
        if not (self.newton_usable() and st.fails == 0 and G >= 2 and k_prev != 0 and np.all(ks * k_prev > 0)
                and len(acc) == 2 and acc[-1][1] is r_prev and acc[0][2] is not None and acc[1][2] is not None
                and not _any_between(st.hint_gains, acc[0][0], ks[-1])
                and _breakaway_near(self.k_inf, k_prev, ks[-1]) is None):
            return None
        S, dS, spacing, _, ok = self.tracker.step_many(_predict(acc, ks[:, None]), ks, r_prev)
        # the displacement test of every row against the row before, at once (the local
        # spacing of a row from its Newton spacing, as _Displacement.local)
        s_ref = self.displacement.s_ref
        loc = np.empty((G, n))
        loc[0] = self.displacement.local(r_prev)
        np.minimum(spacing[:-1], np.abs(S[:-1]) + s_ref, out=loc[1:])
        loc[1:] += s_ref
        step_d = np.abs(np.diff(S, axis=0, prepend=r_prev[None]))
        step_d /= loc
        d = np.max(step_d, axis=1) if n else np.zeros(G)
        good = ok & (d <= self.max_displacement)
        n_ok = G if good.all() else int(np.argmin(good))
        if n_ok:
            new_rows = [S[j] for j in range(n_ok)]
            rows.extend(new_rows)
            st.n_newton += n_ok
            st.worst = max(st.worst, float(np.max(d[:n_ok])))
            last = new_rows[-1]
            self.tracker.remember(r_prev, last)
            if n_ok >= 2:
                acc[:] = [(ks[n_ok - 2], new_rows[-2], dS[n_ok - 2])]
            acc.append((ks[n_ok - 1], last, dS[n_ok - 1]))
            del acc[:-2]
            self.displacement.local(last, spacing[n_ok - 1])
        return n_ok

    def automatic(self, k_max: float, sign: float, poles: NDArray, forced: list) -> tuple[NDArray, list]:
        """Adaptive gains from 0 to ``sign k_max`` through the gains ``forced`` (magnitudes):
        a step doubles after a displacement below a quarter of the limit, halves above it."""
        k, r = 0.0, poles
        out_g, rows = [0.0], [poles]
        step = k_max * 1e-8
        while k < k_max and self.budget():
            k_next = min(k + step if k == 0 else max(k * (1 + step / max(k, 1e-300)), k + step), k_max)
            if forced and k < forced[0] <= k_next:
                k_next = forced[0]
            # the adaptive steps approach 1 + k d = 0 geometrically (the root there grows like
            # 1/(k_inf - k), a step at most a quarter of the distance): a wider window
            big = self._through_infinity(sign * k, r, sign * k_next, window=10.0)
            r_try = None
            if self.newton_usable() and k != 0:
                r_try, _ = self.solve_newton(sign * k, r, sign * k_next, big=big)
            if r_try is None:
                r_try = self.solve_dense(r, sign * k_next)
            d = self._step_displacement(r, r_try, None, big)
            if d > self.max_displacement and k_next - k > 1e-10 * k_next and self.budget():
                step = 0.5 * (k_next - k)
                continue
            self.state.worst = max(self.state.worst, d)
            k, r = k_next, r_try
            self.accept(sign * k, r)
            out_g.append(k)
            rows.append(r)
            while forced and forced[0] <= k:
                forced.pop(0)
            step = (k_next - out_g[-2]) * (2.0 if d < self.max_displacement / 4 else 1.0)
        return sign * np.array(out_g), rows
