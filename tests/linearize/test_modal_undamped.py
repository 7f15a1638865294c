"""Modal truncation of undamped structural models in first-order form: undamped modes are
flexible modes like the others (they were kept whole, with the rigid-body part, and a request for
one mode of an undamped model failed with "0 flexible modes")."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linflex import LinearSystem, ModelError
from linflex.linearize import modal_truncation, split_stable


def undamped_model(freqs, n_rigid, seed):
    """Unit-mass modes of natural frequencies ``freqs`` [rad/s] plus ``n_rigid`` free
    (rigid-body) dofs, one input and one output through random modal gains, in first-order form
    under a random similarity (no block structure for the engine to find). Returns the system
    and the modal gains ``(b, c)`` of the flexible modes."""
    rng = np.random.default_rng(seed)
    w = np.concatenate([np.zeros(n_rigid), np.asarray(freqs, float)])
    n = w.size
    b, c = rng.uniform(0.5, 2.0, n), rng.uniform(0.5, 2.0, n)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.diag(w**2), np.zeros((n, n))]])
    B = np.concatenate([np.zeros(n), b])[:, None]
    C = np.concatenate([c, np.zeros(n)])[None, :]
    T = np.eye(2 * n) + 0.3 * rng.standard_normal((2 * n, 2 * n)) / np.sqrt(2 * n)
    Ti = np.linalg.inv(T)
    return LinearSystem(Ti @ A @ T, Ti @ B, C @ T, [[0.0]]), b[n_rigid:], c[n_rigid:]


@settings(max_examples=30, deadline=None)
@given(freqs=st.lists(st.floats(0.5, 50.0), min_size=2, max_size=6, unique=True).filter(
           lambda f: np.min(np.diff(np.sort(f))) > 0.05),
       n_rigid=st.integers(0, 1), seed=st.integers(0, 2**16), data=st.data())
def test_undamped_modes_are_truncated_with_the_static_correction(freqs, n_rigid, seed, data):
    """The reduction keeps the ``keep`` lowest undamped modes and the rigid-body part; its
    response equals the closed form: the rigid term ``c b / s^2``, the kept modes'
    ``c_i b_i / (s^2 + w_i^2)`` and the discarded ones' static gains ``c_i b_i / w_i^2``
    (first-order static correction), at frequencies between the poles (rtol 1e-7)."""
    sys, b, c = undamped_model(freqs, n_rigid, seed)
    keep = data.draw(st.integers(1, len(freqs) - 1))
    red = modal_truncation(sys, keep=keep)
    w = np.sort(np.asarray(freqs))
    assert red.sys.n_states == 2 * n_rigid + 2 * keep
    np.testing.assert_allclose(np.sort(red.frequencies[red.kept]), w[:keep], rtol=1e-9)
    order = np.argsort(freqs)
    kept, dropped = order[:keep], order[keep:]
    probe = np.array([0.3, 0.77, 3.3, 13.7, 71.0])
    probe = probe[np.min(np.abs(probe[:, None] - w[None, :]), axis=1) > 0.02]
    s = 1j * probe
    fw = np.asarray(freqs)
    expected = (sum(c[i] * b[i] / (s**2 + fw[i] ** 2) for i in kept)
                + sum(c[i] * b[i] / fw[i] ** 2 for i in dropped))
    if n_rigid:
        Ab, Bb, Cb = (np.asarray(m) for m in (sys.A, sys.B, sys.C))
        # the rigid dof's gain: the full response less every flexible mode's term (its closed form)
        G0 = np.array([(Cb @ np.linalg.solve(x * np.eye(sys.n_states) - Ab, Bb))[0, 0] for x in s])
        expected = expected + (G0 - sum(c[i] * b[i] / (s**2 + fw[i] ** 2) for i in range(len(fw))))
    Ar, Br, Cr, Dr = (np.asarray(m) for m in (red.sys.A, red.sys.B, red.sys.C, red.sys.D))
    got = np.array([(Cr @ np.linalg.solve(x * np.eye(Ar.shape[0]) - Ar, Br) + Dr)[0, 0] for x in s])
    np.testing.assert_allclose(got, expected, rtol=1e-7, atol=1e-9 * np.max(np.abs(expected)))


def test_discarded_undamped_mode_makes_the_error_infinite_at_its_frequency():
    sys, _, _ = undamped_model([2.0, 10.0, 30.0], 1, 0)
    res = modal_truncation(sys, keep=1, measure_error=True)
    assert res.measured_error.value == np.inf
    assert res.measured_error.omega == pytest.approx(10.0, rel=1e-9)   # the lowest discarded mode


def test_all_undamped_modes_kept_leaves_the_static_error_only():
    """Every mode kept: the error is the rounding of the decomposition, below 1e-10 of the gain
    (reference: zero, exactly)."""
    sys, b, c = undamped_model([2.0, 10.0], 0, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # a zero error is not certified to a relative tolerance
        res = modal_truncation(sys, keep=2, measure_error=True)
    assert res.measured_error.value <= 1e-10 * np.max(c * b / np.array([2.0, 10.0]) ** 2)


def test_split_stable_places_undamped_modes_where_asked():
    sys, _, _ = undamped_model([2.0, 10.0], 1, 5)
    assert split_stable(sys).n_unstable == 6                   # default: with the rigid part
    assert split_stable(sys, undamped="stable").n_unstable == 2   # the rigid-body pair only
    with pytest.raises(ModelError, match="undamped"):
        split_stable(sys, undamped="flexible")
