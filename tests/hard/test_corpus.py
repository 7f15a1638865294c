"""Every analysis on every hard case, each checked against an independent computation.

References (all dense, all independent of the algorithm under test):
- eigenvalues: ``numpy.linalg.eigvals`` of ``A``;
- frequency responses: direct complex solves ``C (jwI - A)^-1 B + D``;
- zeros: the rank drop of the system matrix ``[[A - zI, B], [C, D]]`` (smallest singular value);
- balanced truncation: the dense response error on a grid through every resonance, which must
  stay below Glover's bound, and the rigid-body poles kept exactly;
- margins: ``|L(jw)| = 1`` and the phase at every reported gain crossover by direct solves (SISO),
  closed-loop stability from the eigenvalues of ``A - B C``;
- root locus: ``eig(A - k B C)`` at sampled gains.
"""

import numpy as np
import pytest
import scipy.linalg

from linflex.frequency import frequency_response, root_locus, zeros
from linflex.linearize import balanced_truncation
from linflex.stability import modes, stability_margins

from .corpus import CASES

_BUILT = {}


def built(case):
    if case.name not in _BUILT:
        _BUILT[case.name] = case.build()
    return _BUILT[case.name]


def dense_response(sys, w):
    return sys.C @ np.linalg.solve(1j * w * np.eye(sys.n_states) - sys.A, sys.B) + sys.D


def nearest_distance(a, b):
    """For each of ``a``, the distance to the nearest of ``b``."""
    return np.min(np.abs(np.asarray(a)[:, None] - np.asarray(b)[None, :]), axis=1)


@pytest.fixture(params=CASES, ids=[c.name for c in CASES])
def case(request):
    return request.param


def test_modes_are_the_eigenvalues(case):
    L = built(case)
    table = modes(L)
    ev = np.linalg.eigvals(L.A)
    found = np.array([m.eigenvalue for m in table.modes])
    found = np.concatenate([found, np.conj(found[np.abs(found.imag) > 0])])  # a pair is listed once
    scale = np.linalg.norm(L.A, 1)
    # every eigenvalue has its mode, to 1e-9 of ||A|| (rigid double roots split by sqrt(eps ||A||))
    tol = 1e-9 * scale + (np.sqrt(np.finfo(float).eps * scale) if case.rigid else 0.0)
    assert np.max(nearest_distance(ev, found)) <= tol
    # the smallest damping ratio of the table is that of the eigenvalues (the corpus goes down to 7e-5)
    damped = [m.damping_ratio for m in table.modes if m.kind == "oscillatory"]
    osc = ev[(np.abs(ev.imag) > 1e-8 * np.abs(ev)) & (np.abs(ev) > 1e-6)]
    assert min(damped) == pytest.approx(np.min(-osc.real / np.abs(osc)), rel=1e-6)


@pytest.mark.parametrize("method", ["auto", "hessenberg"])
def test_frequency_response_agrees_with_dense_solves(case, method):
    L = built(case)
    fr = frequency_response(L, method=method)
    # the reference: dense solves in balanced coordinates (an exact diagonal similarity, so the
    # same G), whose backward error is eps ||A_bal|| whatever the scaling of the states
    _, (scale, _) = scipy.linalg.matrix_balance(L.A, permute=False, separate=True)
    Ab, Bb, Cb = L.A * (1 / scale)[:, None] * scale[None, :], L.B / scale[:, None], L.C * scale[None, :]
    normA = np.linalg.norm(Ab, 2)
    idx = np.unique(np.linspace(0, fr.omega.size - 1, 40).astype(int))
    for i in idx:
        w = fr.omega[i]
        R = np.linalg.inv(1j * w * np.eye(L.n_states) - Ab)
        ref = Cb @ R @ Bb + L.D
        g = max(np.linalg.norm(ref, 2), 1e-300)
        # forward-error bound of any backward-stable evaluation: eps ||A|| ||C R|| ||R B|| / ||G||,
        # large only at resonances of lightly damped modes and in deep notches; 1e-10 relative
        # elsewhere (the requirement), and 10 times the bound where it is larger
        bound = np.finfo(float).eps * normA * np.linalg.norm(Cb @ R, 2) * np.linalg.norm(R @ Bb, 2) / g
        assert np.linalg.norm(fr.response[i] - ref, 2) <= max(1e-10, 10 * bound) * g


def test_zeros_make_the_system_matrix_lose_rank(case):
    L = built(case)
    z = zeros(L)
    z = z[np.isfinite(z)]
    assert z.size > 0
    S = np.block([[L.A, L.B], [L.C, L.D]])
    n, m = L.n_states, L.n_inputs
    scale = np.linalg.norm(S, 2)
    E = np.zeros_like(S)
    E[:n, :n] = np.eye(n)
    worst = 0.0
    for zk in z[np.argsort(np.abs(z))][:60]:
        sv = np.linalg.svd(S - zk * E, compute_uv=False)
        worst = max(worst, sv[-1] / (scale + abs(zk)))
    # a zero is where [[A - zI, B], [C, D]] loses rank: smallest singular value at round-off
    # (1e-8 relative: the pencil's backward error times the zeros' condition, measured <= 1e-11
    # except on the 1e9-scaled case)
    assert worst <= 1e-8
    assert z.size <= n - (0 if np.any(L.D) else 1) * m + n  # no more zeros than the pencil can have


def test_balanced_truncation_error_below_the_bound_and_rigid_part_exact(case):
    from linflex.linearize import split_stable

    L = built(case)
    n_u = split_stable(L).n_unstable
    res = balanced_truncation(L, order=n_u + 12)
    r = res.order - res.n_unstable
    # frequencies: a log grid plus every pole's frequency (where the error of a discarded mode peaks)
    ev = np.linalg.eigvals(L.A)
    w = np.unique(np.concatenate([np.geomspace(1e-2, 1e4, 200), np.abs(ev.imag[ev.imag > 1e-6])]))
    err = max(np.linalg.norm(dense_response(L, x) - dense_response(res.sys, x), 2) for x in w)
    assert err <= res.error_bound * (1 + 1e-6) + 1e-9 * np.max(np.abs(res.hsv))  # Glover's bound
    if case.rigid:
        assert res.n_unstable >= 2
        rigid = np.linalg.eigvals(res.sys.A[: res.n_unstable, : res.n_unstable])
        assert np.max(np.abs(rigid)) <= 1e-6 * max(1.0, np.linalg.norm(L.A, 1)) ** 0.5  # kept at the origin
    assert r == 12


def test_margins_crossings_and_stability_against_dense_solves(case):
    L = built(case)
    m = stability_margins(L)
    A_cl = L.A - L.B @ np.linalg.solve(np.eye(L.n_inputs) + L.D, L.C)
    assert m.closed_loop_stable == bool(np.max(np.linalg.eigvals(A_cl).real) < 0)
    if L.n_inputs > 1:
        return
    loop = m.loops[0]
    assert loop.gain_crossovers.size > 0
    for w, pm in zip(loop.gain_crossovers, loop.phase_margins):
        Ljw = dense_response(L, w)[0, 0]
        assert abs(abs(Ljw) - 1.0) <= 1e-8  # crossings refined to 1e-12 in log|L|
        ref_pm = np.degrees(np.angle(-Ljw))
        assert abs(((pm - ref_pm) + 180.0) % 360.0 - 180.0) <= 1e-6


def test_root_locus_against_eigenvalues(case):
    L = built(case)
    gains = np.geomspace(1e-2, 1e2, 60)
    rl = root_locus(L, gains)
    for i in (0, 17, 33, 59):
        ref = np.linalg.eigvals(L.A - gains[i] * L.B @ L.C)
        d = nearest_distance(ref, rl.roots[i])
        # Newton continuation polished to round-off: 1e-8 relative to max(1, |root|)
        assert np.max(d / np.maximum(1.0, np.abs(ref))) <= 1e-8


@pytest.mark.parametrize("method", ["perturbation", "central"])
def test_linearization_methods_agree_with_autodiff_on_the_stiff_chain(method):
    from linflex.linearize import linearize

    from .corpus import stiff_chain_model

    model, op = stiff_chain_model()
    exact = linearize(model, op, method="autodiff")
    lin = linearize(model, op, method=method)
    ref, got = exact.sys.A, lin.sys.A
    row_scale = np.maximum(np.max(np.abs(ref), axis=1, keepdims=True), 1e-300)
    err = np.abs(got - ref)
    # against the exact Jacobian: the requested accuracy (perturbation: 6 digits by default;
    # central: ~1e-9 after Richardson) relative to each row's largest entry, on springs from
    # 3.6e3 to 1e2 N m/rad and segment inertias 1e-2 kg m^2
    assert np.max(err / row_scale) <= (1e-5 if method == "perturbation" else 1e-8)
    # and each entry's own error estimate covers its true error above the model's evaluation
    # noise: the chain's state derivative goes through a mass-matrix solve whose round-off (about
    # 1e-12 of a row here, measured) the estimates' eps * |f| term does not see, so 1e-10 of the
    # row is the floor of this check
    est = lin.error_estimate.A
    assert np.all(err <= est + 1e-10 * row_scale)


def test_kane_equals_autodiff_on_the_stiff_chain():
    from linflex.linearize import linearize

    from .corpus import stiff_chain_model

    model, op = stiff_chain_model()
    exact = linearize(model, op, method="autodiff")
    direct = linearize(model, op, method="kane")
    ref = exact.sys.A
    row_scale = np.maximum(np.max(np.abs(ref), axis=1, keepdims=True), 1e-300)
    # Both exact: they differ by the round-off of the mass-matrix solve (its condition number
    # times eps, about 1e-12 of a row here); 1e-10 relative per row as the issue demands.
    assert np.max(np.abs(direct.sys.A - ref) / row_scale) <= 1e-10
    # The second-order form of joint angles is the first-order system itself, and its stiffness
    # is the springs' (symmetric, positive semidefinite: the chain's first joint carries no
    # spring) plus the inertia forces' (zero at rest).
    so = direct.second_order
    np.testing.assert_allclose(so.to_state_space().A, direct.sys.A, rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))
    np.testing.assert_allclose(direct.stiffness["inertia"], 0.0, atol=1e-12 * np.max(np.abs(so.K)))
    springs = direct.stiffness["joint_springs"]
    np.testing.assert_allclose(springs, springs.T, atol=0)
    assert np.min(np.linalg.eigvalsh(springs)) >= -1e-12 * np.max(np.abs(springs))


def test_report_pipeline_on_the_stiff_chain_scene(tmp_path):
    # the whole report pipeline on a hard scene: PD at the hub of the spring chain (rate from a
    # gyro), margins from the compiled scene, checked by dense evaluation of the report's own loop
    import dataclasses

    import linflex
    from linflex.stability.report import analyse_scene, stability_report

    from .corpus import stiff_chain_scene

    scene = stiff_chain_scene()
    scene = dataclasses.replace(
        scene, effects=(*scene.effects, "control"),
        sensors=(*scene.sensors, linflex.Sensor(name="rate", type="rate", body="hub", axis=(0.0, 0.0, 1.0))),
        controllers=(linflex.Controller(name="pd", type="pid", inputs=("angle",), rate_inputs=("rate",),
                                        outputs=("torque",), kp=200.0, kd=300.0),),
    ).validate()
    analysis = analyse_scene(scene)
    assert analysis.closed_loop_stable
    L = analysis.open_loop
    loop = analysis.margins.loops[0]
    assert loop.gain_crossovers.size > 0
    for w, pm in zip(loop.gain_crossovers, loop.phase_margins):
        Ljw = dense_response(L, w)[0, 0]
        assert abs(abs(Ljw) - 1.0) <= 1e-8
        assert abs(((pm - np.degrees(np.angle(-Ljw))) + 180.0) % 360.0 - 180.0) <= 1e-6
    report = stability_report(analysis)
    html = report.to_html(tmp_path / "report.html")
    assert html.stat().st_size > 20_000
    assert f"{loop.min_phase_margin:.1f}" in report.to_markdown()
