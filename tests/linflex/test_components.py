"""Component modes and reduction of structures, checked against the assembled full model."""

import numpy as np
import pytest

from linflex import (
    Beam,
    ModelError,
    assemble_beams,
    component_damping,
    constraint_modes,
    craig_bampton,
    frequency_filter,
    guyan,
    modal_effective_mass,
    modal_truncation_vectors,
    structural_modes,
    svd_component_reduction,
    synthesize,
)

PROPS = dict(EA=1e8, EIy=2e4, EIz=5e4, GJ=1e4, mass_per_length=1.5, torsional_inertia_per_length=0.01)


def free_dofs(structure, clamped_point):
    fixed = structure.dofs(clamped_point)
    return np.setdiff1d(np.arange(structure.K.shape[0]), fixed)


def clamped(structure, point):
    keep = free_dofs(structure, point)
    return structure.K[np.ix_(keep, keep)], structure.M[np.ix_(keep, keep)], keep


def full_cantilever(elements=20):
    s = assemble_beams(Beam((0, 0, 0), (10, 0, 0), elements=elements, **PROPS))
    return s, *clamped(s, (0, 0, 0))


def two_part_synthesis(n_modes, mtv=False):
    """Left part (0-5 m, clamped at 0) and right part (5-10 m), joined at x = 5 m."""
    left_s = assemble_beams(Beam((0, 0, 0), (5, 0, 0), elements=10, **PROPS))
    right_s = assemble_beams(Beam((5, 0, 0), (10, 0, 0), elements=10, **PROPS))
    Kl, Ml, keep_l = clamped(left_s, (0, 0, 0))
    interface_l = np.searchsorted(keep_l, left_s.dofs((5, 0, 0)))
    interface_r = right_s.dofs((5, 0, 0))
    left = craig_bampton(Kl, Ml, interface_l, n_modes, mtv=mtv)
    right = craig_bampton(right_s.K, right_s.M, interface_r, n_modes, mtv=mtv)
    # Interface compatibility: the six boundary coordinates (last columns) are equal.
    n_l, n_r = left.M.shape[0], right.M.shape[0]
    c = np.zeros((6, n_l + n_r))
    c[:, n_l - 6:n_l] = np.eye(6)
    c[:, n_l + n_r - 6:] = -np.eye(6)
    return synthesize([left.M, right.M], [left.K, right.K], c), left, right


def test_craig_bampton_two_part_beam_matches_the_full_model():
    # Issue 4: Craig-Bampton of a two-part beam reproduces the full model's low frequencies
    # within 0.5 %; Rayleigh-Ritz: from above.
    _, K, M, _ = full_cantilever()
    full = structural_modes(K, M, 8).frequencies
    synthesis, left, _ = two_part_synthesis(n_modes=8)
    reduced = synthesis.frequencies[:8]
    assert np.all(reduced >= full * (1 - 1e-10))
    np.testing.assert_allclose(reduced, full, rtol=5e-3)
    # Structure check: K_CB is block diagonal (modes | boundary).
    k = 8
    assert np.abs(left.K[:k, k:]).max() <= 1e-8 * np.abs(left.K).max()


def test_complete_component_bases_reproduce_the_full_model_exactly():
    _, K, M, _ = full_cantilever()
    full = structural_modes(K, M, 10).frequencies
    synthesis, _, _ = two_part_synthesis(n_modes=10 * 6 - 6)  # every interior freedom of the left part
    np.testing.assert_allclose(synthesis.frequencies[:10], full, rtol=1e-8)
    np.testing.assert_allclose(synthesis.S[synthesis.dependent].shape[0], 6)


def test_mtv_improves_craig_bampton_and_reproduces_static_response():
    _, K, M, _ = full_cantilever()
    full = structural_modes(K, M, 6).frequencies
    plain, _, _ = two_part_synthesis(n_modes=3)
    augmented, _, _ = two_part_synthesis(n_modes=3, mtv=True)
    err_plain = np.abs(plain.frequencies[:6] / full - 1).max()
    err_mtv = np.abs(augmented.frequencies[:6] / full - 1).max()
    assert err_mtv < err_plain


def test_modal_truncation_vectors_give_the_exact_static_response():
    s, K, M, keep = full_cantilever()
    modes = structural_modes(K, M, 3).shapes
    F = np.zeros((K.shape[0], 2))
    tip = np.searchsorted(keep, s.dofs((10, 0, 0)))
    F[tip[2], 0] = 1.0  # tip force along z
    F[tip[1] - 30, 1] = 1.0  # a force along y further in
    mtv, omega = modal_truncation_vectors(K, M, modes, F)
    basis = np.hstack([modes, mtv])
    # Orthogonality to the kept modes (M and K) and exact static response (reference section 6);
    # unit modal mass, so 1e-8 is round-off of solving K (condition ~1e12: EA against EI).
    assert np.abs(modes.T @ M @ mtv).max() < 1e-8
    assert np.abs(modes.T @ K @ mtv).max() < 1e-6 * np.abs(K).max()
    static = np.linalg.solve(K, F)
    reduced = basis @ np.linalg.solve(basis.T @ K @ basis, basis.T @ F)
    # Zero entries (axial, torsion) are judged against the largest deflection: round-off 1e-10.
    np.testing.assert_allclose(reduced, static, rtol=1e-8, atol=1e-10 * np.abs(static).max())
    assert omega.size == 2 and np.all(omega > structural_modes(K, M, 3).frequencies[-1])


def test_guyan_is_exact_for_static_loads_on_the_active_set():
    s, K, M, keep = full_cantilever()
    active = np.searchsorted(keep, np.concatenate([s.dofs((5, 0, 0)), s.dofs((10, 0, 0))]))
    red = guyan(K, M, active)
    F = np.zeros(K.shape[0])
    F[active[2]] = 3.0
    F[active[7]] = -2.0
    np.testing.assert_allclose(red.T @ np.linalg.solve(red.K, red.T.T @ F), np.linalg.solve(K, F), rtol=1e-9)
    # Rayleigh-Ritz: the Guyan frequencies lie above the full model's.
    assert red.frequencies[0] >= structural_modes(K, M, 1).frequencies[0] * (1 - 1e-12)


def test_constraint_modes_of_a_determinate_boundary_are_rigid_body_modes():
    s = assemble_beams(Beam((0, 0, 0), (10, 0, 0), elements=6, **PROPS))
    Psi, R = constraint_modes(s.K, s.dofs((0, 0, 0)))
    assert np.abs(s.K @ Psi).max() < 1e-8 * np.abs(s.K).max()  # K Psi_c = 0
    assert np.abs(R).max() < 1e-8 * np.abs(s.K).max()  # R_bb = 0


def test_effective_masses_sum_to_the_attainable_total():
    s = assemble_beams(Beam((0, 0, 0), (10, 0, 0), elements=8, **PROPS))
    root = s.dofs((0, 0, 0))
    n_interior = s.K.shape[0] - 6
    em = modal_effective_mass(s.K, s.M, root)  # all fixed-interface modes
    # Corrected Eq. 7.24: all fixed-interface modes reach M_rr minus the boundary residual mass.
    np.testing.assert_allclose(em.per_mode.sum(axis=0), em.attainable, atol=1e-9 * np.abs(em.rigid_mass).max())
    # Rigid mass about the root: m L in translation, m L^3 / 3 about y and z (rod closed form).
    np.testing.assert_allclose(np.diagonal(em.rigid_mass)[:3], 15.0, rtol=1e-12)
    np.testing.assert_allclose(em.rigid_mass[4, 4], 1.5 * 10**3 / 3, rtol=1e-12)
    assert em.per_mode.shape[0] == n_interior
    np.testing.assert_allclose(em.fractions[-1][[0, 1, 2]], 1.0, rtol=1e-9)
    few = modal_effective_mass(s.K, s.M, root, 4)
    assert np.all(np.diff(few.fractions, axis=0) >= -1e-12)


def test_damping_synthesis_forms():
    _, K, M, _ = full_cantilever(elements=8)
    modes = structural_modes(K, M, 10)
    kept, zeta = slice(0, 4), np.array([0.01, 0.02, 0.005, 0.03])
    for form in ("mass-weighted", "pseudo-inverse"):
        C = component_damping(M, modes.shapes[:, kept], modes.frequencies[kept], zeta, form=form)
        np.testing.assert_allclose(modes.shapes[:, kept].T @ C @ modes.shapes[:, kept],
                                   np.diag(2 * zeta * modes.frequencies[kept]), atol=1e-9)
    C = component_damping(M, modes.shapes[:, kept], modes.frequencies[kept], zeta)
    # The mass-weighted form leaves the discarded modes undamped and uncoupled.
    assert np.abs(C @ modes.shapes[:, 4:]).max() < 1e-8 * np.abs(C).max()


def test_svd_reduction_keeps_the_projected_system_frequencies():
    synthesis, left, right = two_part_synthesis(n_modes=6)
    n_s = 5
    projected = synthesis.S @ synthesis.modes[:, :n_s]
    n_l = left.M.shape[0]
    bases = [svd_component_reduction(projected[:n_l])[0], svd_component_reduction(projected[n_l:])[0]]
    # Every non-zero singular direction kept: the n_s lowest synthesized frequencies reappear.
    mu = [U.T @ m @ U for U, m in zip(bases, (left.M, right.M))]
    kappa = [U.T @ k @ U for U, k in zip(bases, (left.K, right.K))]
    c = np.zeros((6, n_l + right.M.shape[0]))
    c[:, n_l - 6:n_l] = np.eye(6)
    c[:, -6:] = -np.eye(6)
    c_red = c @ np.block([[bases[0], np.zeros((n_l, bases[1].shape[1]))],
                          [np.zeros((right.M.shape[0], bases[0].shape[1])), bases[1]]])
    reduced = synthesize(mu, kappa, c_red)
    np.testing.assert_allclose(reduced.frequencies[:n_s], synthesis.frequencies[:n_s], rtol=1e-8)


def test_free_free_beam_has_six_rigid_body_modes():
    s = assemble_beams(Beam((0, 0, 0), (10, 0, 0), elements=10, **PROPS))
    w = structural_modes(s.K, s.M, 8).frequencies
    # Rigid-body eigenvalues vanish to round-off of the stiff K (~1e-10 of the first elastic one).
    assert np.all(w[:6] ** 2 < 1e-8 * w[6] ** 2)


def test_frequency_filter_keeps_static_gain():
    w, z, gains, w_max = frequency_filter([1.0, 50.0, 400.0], 0.01, time_step=0.01)
    assert w_max == pytest.approx(2 * np.pi / 0.01 / 10)
    np.testing.assert_allclose(gains / w**2, 1 / np.array([1.0, 50.0, 400.0]) ** 2)  # static gains kept
    assert w[2] == pytest.approx(w_max) and w[0] == 1.0


def test_bad_input():
    with pytest.raises(ModelError, match="K is not symmetric"):
        structural_modes([[1.0, 2.0], [0.0, 1.0]], np.eye(2))
    with pytest.raises(ModelError, match="square matrices of the same size"):
        structural_modes(np.eye(2), np.eye(3))
    with pytest.raises(ModelError, match="M is not positive definite"):
        structural_modes(np.eye(2), -np.eye(2))
    with pytest.raises(ModelError, match="boundary: indices must lie in 0..1"):
        constraint_modes(np.eye(2), [5])
