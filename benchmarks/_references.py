"""Checks of reported stability margins against an independent evaluation of the loop, shared by
the benchmarks (``growth.py``: an extended-precision modal reference; ``structure.py``: dense
solves, for a random dense loop without a modal form)."""

from __future__ import annotations

import numpy as np
import scipy.linalg


class DenseReference:
    """``(L(s), dL/ds)`` of a SISO loop ``(A, B, C, D)`` by one dense LU of ``sI - A`` per point:
    ``L = C X + D`` with ``X = (sI - A)^-1 B`` and ``dL/ds = -C (sI - A)^-1 X`` (independent of
    linflex's evaluator: no Schur or modal form, no error estimate)."""

    def __init__(self, loop):
        self.A, self.B, self.C, self.D = (np.asarray(m, float) for m in (loop.A, loop.B, loop.C, loop.D))
        if self.B.shape[1] != 1 or self.C.shape[0] != 1:
            raise ValueError("DenseReference: a SISO loop was expected")

    def __call__(self, s):
        s = np.atleast_1d(np.asarray(s, complex))
        n = self.A.shape[0]
        L, dL = np.empty_like(s), np.empty_like(s)
        for k, sk in enumerate(s):
            lu = scipy.linalg.lu_factor(sk * np.eye(n) - self.A)
            X = scipy.linalg.lu_solve(lu, self.B[:, 0].astype(complex))
            L[k] = self.C[0] @ X + self.D[0, 0]
            dL[k] = -(self.C[0] @ scipy.linalg.lu_solve(lu, X))
        return L, dL


def margin_error(ref, gain_crossovers, phase_margins_deg, phase_crossovers, gain_margins) -> float:
    """The worst residual of reported margins against ``ref`` (``s -> (L(s), dL/ds)``): at each
    gain crossover the Newton step of ``|L| = 1`` relative to ``w`` and the phase margin's error
    against ``angle(-L(jw))`` [rad]; at each phase crossover (``w > 0``) the Newton step of
    ``Im L = 0`` relative to ``w`` and the gain margin's relative error against ``1 / |L(jw)|``."""
    worst = 0.0
    wgc = np.asarray(gain_crossovers, float)
    if wgc.size:
        L, dL = ref(1j * wgc)
        slope = np.real(np.conj(L) * 1j * dL) / np.abs(L)                  # d|L|/dw
        pm = np.angle(-L.astype(complex), deg=True)
        dpm = (np.asarray(phase_margins_deg, float) - pm + 180.0) % 360.0 - 180.0
        worst = max(worst, float(np.max(np.abs((np.abs(L) - 1) / slope) / wgc)), float(np.max(np.abs(np.radians(dpm)))))
    wpc = np.asarray(phase_crossovers, float)
    gm = np.asarray(gain_margins, float)
    keep = wpc > 0  # w = 0 is a crossing only for a finite negative L(0)
    if np.any(keep):
        L, dL = ref(1j * wpc[keep])
        step = np.abs(L.imag / dL.real) / wpc[keep]                          # d Im L / dw = Re dL/ds
        worst = max(worst, float(np.max(step)), float(np.max(np.abs(gm[keep] * np.abs(L) - 1))))
    return worst
