"""TransferEvaluator remembers the points it evaluated (frequency/_evaluate.py ``at``)."""

import numpy as np

from linflex import LinearSystem
from linflex.frequency._evaluate import MEMO_CALL, TransferEvaluator
from linflex.frequency._spectrum import classify


def dense(sys, s):
    """Independent reference: one dense complex solve per point."""
    n = sys.n_states
    return np.array([sys.C @ np.linalg.solve(x * np.eye(n) - sys.A, sys.B) + sys.D for x in s])


def test_a_point_asked_for_again_is_remembered_not_evaluated():
    # the values at 7 frequencies against dense solves (1e-12), then a call mixing two of them
    # with a new point: bit-identical values and estimates for the known points, one new
    # evaluation counted, the new point against a dense solve
    rng = np.random.default_rng(4)
    n = 30
    A = rng.normal(size=(n, n)) / np.sqrt(n) - 1.5 * np.eye(n)
    sys = LinearSystem(A, rng.normal(size=(n, 2)), rng.normal(size=(2, n)))
    ev = TransferEvaluator(sys)
    w = np.logspace(-1, 1, 7)
    G1 = ev(w)
    e1 = ev.last_error.copy()
    assert ev.n_evaluations == 7
    ref = dense(sys, 1j * w)
    assert np.max(np.abs(G1 - ref)) < 1e-12 * np.max(np.abs(ref))
    G2 = ev(np.array([w[3], 5.5, w[0]]))
    assert ev.n_evaluations == 8
    assert np.array_equal(G2[0], G1[3]) and np.array_equal(G2[2], G1[0])
    assert ev.last_error[0] == e1[3] and ev.last_error[2] == e1[0]
    assert np.max(np.abs(G2[1] - dense(sys, [5.5j])[0])) < 1e-12 * np.max(np.abs(G2[1]))
    # a dense sweep larger than MEMO_CALL is evaluated as it is, and not remembered
    ev = TransferEvaluator(sys)
    sweep = np.linspace(0.1, 10.0, MEMO_CALL + 1)
    ev(sweep)
    ev(sweep[:3])
    assert ev.n_evaluations == MEMO_CALL + 4


def test_snapping_poles_onto_the_axis_forgets_the_remembered_values():
    # an undamped mode perturbed to -1e-9 +- 2j: beside it the value depends on the snap; after
    # snap_axis the point is evaluated again, equal to the exactly undamped system's dense solve
    eps_re = -1e-9
    A = np.array([[eps_re, 2.0], [-2.0, eps_re]])
    sys = LinearSystem(A, [[0.0], [1.0]], [[1.0, 0.0]])
    exact = LinearSystem(np.array([[0.0, 2.0], [-2.0, 0.0]]), [[0.0], [1.0]], [[1.0, 0.0]])
    ev = TransferEvaluator(sys)
    w = np.array([2.0 + 1e-7])
    before = ev(w)[0, 0, 0]
    assert abs(before - dense(sys, 1j * w)[0, 0, 0]) < 1e-6 * abs(before)
    spec = classify(sys.A, 1e-8, B=sys.B, C=sys.C)
    assert ev.snap_axis(spec) == 2
    after = ev(w)[0, 0, 0]
    ref = dense(exact, 1j * w)[0, 0, 0]
    assert abs(after - ref) < 1e-6 * abs(ref)
    assert abs(after - before) > 1e-3 * abs(ref)   # the snap changed the value (it was not remembered)
    assert ev.n_evaluations == 2
