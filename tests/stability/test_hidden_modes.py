"""Undamped modes the loop neither drives nor sees (the antisymmetric bending of two identical
undamped arrays under a hub's control) are eigenvalues of every closed loop on the imaginary
axis. They are in no transfer function of the loop: the margins must be those of the loop
without them (they made the closed loop "unstable" and every disk margin 0)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem
from linflex.stability import stability_margins


def pd_loops(kp, kd, m):
    """``m`` decoupled loops ``(kd s + kp) / s^2``: a PD on a unit double integrator each."""
    A = np.kron(np.eye(m), [[0.0, 1.0], [0.0, 0.0]])
    B = np.kron(np.eye(m), [[0.0], [1.0]])
    C = np.kron(np.eye(m), [[kp, kd]])
    return A, B, C


def with_hidden(A, B, C, freqs, unseen, seed):
    """The loop with undamped modes at ``freqs`` [rad/s] appended, each not seen (zero output
    row) or not driven (zero input column), under a random similarity of the whole state."""
    rng = np.random.default_rng(seed)
    m = B.shape[1]
    blocks, Bh, Ch = [], [], []
    for w, hide_out in zip(freqs, unseen):
        blocks.append(np.array([[0.0, w], [-w, 0.0]]))
        b, c = rng.uniform(0.5, 2.0, (2, m)), rng.uniform(0.5, 2.0, (m, 2))
        Bh.append(b if hide_out else np.zeros((2, m)))
        Ch.append(np.zeros((m, 2)) if hide_out else c)
    n0, nh = A.shape[0], 2 * len(freqs)
    Af = np.zeros((n0 + nh, n0 + nh))
    Af[:n0, :n0] = A
    for k, blk in enumerate(blocks):
        Af[n0 + 2 * k:n0 + 2 * k + 2, n0 + 2 * k:n0 + 2 * k + 2] = blk
    Bf, Cf = np.vstack([B, *Bh]), np.hstack([C, *Ch])
    T = np.eye(n0 + nh) + 0.2 * rng.standard_normal((n0 + nh, n0 + nh)) / np.sqrt(n0 + nh)
    Ti = np.linalg.inv(T)
    return LinearSystem(Ti @ Af @ T, Ti @ Bf, Cf @ T, np.zeros((m, m)))


@settings(max_examples=20, deadline=None)
@given(kp=st.floats(0.05, 5.0), zeta=st.floats(0.3, 1.0), m=st.integers(1, 2),
       freqs=st.lists(st.floats(0.3, 30.0), min_size=1, max_size=3), seed=st.integers(0, 2**16), data=st.data())
def test_hidden_undamped_modes_leave_the_margins_of_the_loop(kp, zeta, m, freqs, seed, data):
    """Reference: the same loop without the hidden modes (its margins, its closed loop stable,
    Nyquist N = 0), and the hidden modes' own frequencies, to 1e-8."""
    kd = 2 * zeta * np.sqrt(kp)
    A, B, C = pd_loops(kp, kd, m)
    unseen = data.draw(st.lists(st.booleans(), min_size=len(freqs), max_size=len(freqs)))
    bare = stability_margins(LinearSystem(A, B, C, np.zeros((m, m))))
    full = stability_margins(with_hidden(A, B, C, freqs, unseen, seed))
    assert full.closed_loop_stable and full.closed_loop_unstable_poles == 0
    assert full.nyquist_encirclements == bare.nyquist_encirclements == 0
    np.testing.assert_allclose(np.sort(np.abs(full.hidden_poles.imag)), np.sort(np.repeat(freqs, 2)), rtol=1e-8)
    np.testing.assert_allclose(full.disk_margin.alpha, bare.disk_margin.alpha, rtol=1e-6)
    for a, b in zip(full.loops, bare.loops):
        np.testing.assert_allclose(a.phase_margins, b.phase_margins, rtol=1e-7, atol=1e-7)
        np.testing.assert_allclose(a.disk_margin.alpha, b.disk_margin.alpha, rtol=1e-6)


def test_a_seen_and_driven_undamped_closed_loop_pole_still_counts():
    """``1 / s^2`` under unit gain: its closed-loop poles ``+-j`` are the loop's own (seen and
    driven), so the closed loop is not asymptotically stable, as before (closed form)."""
    res = stability_margins(LinearSystem([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]]))
    assert not res.closed_loop_stable and res.closed_loop_unstable_poles == 2
    assert res.hidden_poles.size == 0
