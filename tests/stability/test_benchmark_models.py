"""Modes and margins of the ISS 1R benchmark model (SLICOT collection, tests/data/mor)."""

from __future__ import annotations

import numpy as np
import pytest

from linflex import LinearSystem
from linflex.stability import modes, stability_margins

from ..mor import load_mor
from .test_margins import _hamiltonian_unity_gain_frequencies, _mu_lower_bound


def _iss1r() -> LinearSystem:
    return load_mor("iss1R")


def test_iss1r_modes():
    # Reference: the collection's description (tests/data/mor/README.md): 270 states, every
    # mode damped at 0.005, lowest modes near 0.62 and 0.78 rad/s; no rigid-body modes.
    t = modes(_iss1r())
    assert t.n_rigid == 0 and len(t) == 135 and all(m.kind == "oscillatory" for m in t)
    np.testing.assert_allclose(t.damping_ratios, 0.005, atol=1e-12)
    assert t[0].natural_frequency == pytest.approx(0.62, abs=0.01)
    assert t[1].natural_frequency == pytest.approx(0.78, abs=0.01)


def test_iss1r_three_loop_margins():
    # A 3x3 loop: the ISS 1R structure with a static gain of 1000 in every channel (velocity
    # feedback). References: Hamiltonian eigenvalues of each loop broken with the others closed
    # (gain crossovers), the exact structured singular value at the reported peak (multi-loop
    # disk margin), and the eigenvalue counts (Nyquist count; a disagreement would raise the
    # AccuracyWarning that the test configuration turns into an error).
    G = _iss1r()
    L = LinearSystem(G.A, 1000.0 * np.asarray(G.B), G.C)
    m = stability_margins(L)
    assert m.closed_loop_stable and m.nyquist_encirclements == 0 and m.open_loop_unstable_poles == 0
    A, B, C = (np.asarray(x) for x in (L.A, L.B, L.C))
    for i, lp in enumerate(m.loops):
        o = [j for j in range(3) if j != i]
        Li = LinearSystem(A - B[:, o] @ C[o, :], B[:, [i]], C[[i], :])
        w_ham = _hamiltonian_unity_gain_frequencies(Li)
        assert lp.gain_crossovers.size == w_ham.size >= 6
        np.testing.assert_allclose(lp.gain_crossovers, w_ham, rtol=1e-8)
        # velocity feedback on a structure: no phase crossover with |L| inside 1e-10..1e10
        assert lp.phase_crossovers.size == 0
    dm = m.disk_margin
    M = np.linalg.inv(np.eye(3) + (C @ np.linalg.solve(1j * dm.frequency * np.eye(270) - A, B))) - 0.5 * np.eye(3)
    assert 1 / dm.alpha == pytest.approx(_mu_lower_bound(M), rel=1e-6)
    assert m.unstructured_disk_margin.alpha <= dm.alpha <= min(lp.disk_margin.alpha for lp in m.loops) + 1e-12
    # a-posteriori bound of the evaluation at the crossings and the disk peak (frequency/_evaluate.py)
    assert m.evaluation_error < 1e-8
