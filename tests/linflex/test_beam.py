"""Beam finite elements and modal data, checked against beam theory and classical results."""

import numpy as np
import pytest

from linflex import Beam, ModalData, ModelError, beam_modal_data, load_modal_data

EI, MASS, LENGTH = 2.0e4, 1.5, 10.0  # N m^2, kg/m, m
# Roots of 1 + cos(b) cosh(b) = 0: cantilever bending (Euler-Bernoulli, e.g. Blevins, Formulas
# for Natural Frequency and Mode Shape, table 8-1).
BETA_L = np.array([1.8751040687, 4.6940911330, 7.8547574382])


def cantilever(elements=20, **kw):
    props = dict(EA=1e9, EIy=EI, EIz=3 * EI, GJ=1e4, mass_per_length=MASS, elements=elements)
    props.update(kw)
    return Beam((0.0, 0.0, 0.0), (LENGTH, 0.0, 0.0), **props)


def modes_along(md, axis):
    """Indices of the modes whose largest translation is along body ``axis``."""
    size = np.abs(md.translations).max(axis=0)  # (3, M)
    return [k for k in range(md.n_modes) if np.argmax(size[:, k]) == axis]


def test_cantilever_bending_frequencies():
    md = beam_modal_data(cantilever(), 8)
    for axis, stiffness in ((2, EI), (1, 3 * EI)):  # z displacement bends about y (EIy)
        found = md.frequencies[modes_along(md, axis)][:3]
        exact = BETA_L**2 * np.sqrt(stiffness / (MASS * LENGTH**4))
        # Cubic Hermite elements converge as h^4: 20 elements give 5e-5 on the third mode.
        np.testing.assert_allclose(found, exact, rtol=5e-5)


def test_axial_and_torsional_frequencies():
    # Fixed-free rod: omega_n = (2n - 1) pi / 2 sqrt(EA / (m L^2)); torsion likewise with GJ
    # and the polar inertia per length. Linear elements: error ~ (k h)^2 / 24, 6e-4 for the
    # second torsion mode with 40 elements.
    stiff = dict(EIy=1e9, EIz=1e9, EA=4e6, GJ=3e3, torsional_inertia_per_length=0.02)  # bending far above
    md = beam_modal_data(cantilever(elements=40, **stiff), 3)
    axial = np.pi / 2 * np.sqrt(4e6 / (MASS * LENGTH**2))
    torsion = np.pi / 2 * np.sqrt(3e3 / (0.02 * LENGTH**2))
    np.testing.assert_allclose(md.frequencies, [torsion, 3 * torsion, axial], rtol=1e-3)


def test_uniform_rod_integrals_and_modal_mass():
    md = beam_modal_data(cantilever(torsional_inertia_per_length=0.01), 6)
    ints = md.integrals()
    # Closed forms for a uniform rod along x from the origin: mass m L, first moment m L^2 / 2,
    # inertia m L^3 / 3 about y and z (rotary inertia only about x: rho J L).
    assert ints.mass == pytest.approx(MASS * LENGTH, rel=1e-14)
    np.testing.assert_allclose(ints.s0, [MASS * LENGTH**2 / 2, 0, 0], atol=1e-12)
    np.testing.assert_allclose(np.diag(ints.I0), [0, MASS * LENGTH**3 / 3, MASS * LENGTH**3 / 3], rtol=1e-14,
                               atol=1e-12)
    assert ints.W1[0, 0] == pytest.approx(0.01 * LENGTH, rel=1e-14)
    # Mass-normalized modes: translational plus rotary modal mass is the identity (round-off).
    np.testing.assert_allclose(ints.e + ints.W9, np.eye(6), atol=1e-12)


def brute_force_integrals(md):
    """Section 6.1 of the reference notes, literally: one Python loop over points and modes."""
    M = md.n_modes
    out = {k: 0 for k in ("b", "c", "d", "e", "N", "P", "I0", "W4", "W9")}
    out.update(b=np.zeros((3, M)), c=np.zeros((3, M)), d=np.zeros((M, M, 3)), e=np.zeros((M, M)),
               N=np.zeros((M, 3, 3)), P=np.zeros((M, M, 3, 3)), I0=np.zeros((3, 3)), W4=np.zeros((3, M)),
               W9=np.zeros((M, M)))
    for m, r, Phi, Psi, J in zip(md.masses, md.positions, md.translations, md.rotations, md.inertias):
        out["I0"] += m * (r @ r * np.eye(3) - np.outer(r, r))
        for l in range(M):
            out["b"][:, l] += m * Phi[:, l]
            out["c"][:, l] += m * np.cross(r, Phi[:, l])
            out["N"][l] += m * (r @ Phi[:, l] * np.eye(3) - np.outer(r, Phi[:, l]))
            out["W4"][:, l] += J @ Psi[:, l]
            for k in range(M):
                out["d"][l, k] += m * np.cross(Phi[:, l], Phi[:, k])
                out["e"][l, k] += m * Phi[:, l] @ Phi[:, k]
                out["P"][l, k] += m * (Phi[:, l] @ Phi[:, k] * np.eye(3) - np.outer(Phi[:, l], Phi[:, k]))
                out["W9"][l, k] += Psi[:, l] @ J @ Psi[:, k]
    return out


def test_integrals_equal_brute_force_sums_on_random_data():
    rng = np.random.default_rng(3)
    n, M = 7, 3
    A = rng.normal(size=(n, 3, 3))
    md = ModalData(positions=rng.normal(size=(n, 3)), masses=rng.uniform(0.5, 2, n),
                   inertias=A @ np.transpose(A, (0, 2, 1)), translations=rng.normal(size=(n, 3, M)),
                   rotations=rng.normal(size=(n, 3, M)), frequencies=[1.0, 2.0, 3.0], damping=[0.01] * 3)
    ints = md.integrals()
    for name, value in brute_force_integrals(md).items():
        np.testing.assert_allclose(getattr(ints, name), value, rtol=1e-12, atol=1e-12, err_msg=name)
    np.testing.assert_allclose(ints.d, -np.transpose(ints.d, (1, 0, 2)), atol=1e-12)  # d_lk = -d_kl
    # The deformed inertia stays symmetric (Eq. 5.40).
    I = ints.inertia(np.array([0.1, -0.2, 0.05]))
    np.testing.assert_allclose(I, I.T, atol=1e-12)


def test_southwell_coefficient_of_a_spinning_cantilever():
    # A cantilever spinning at Omega about z (root on the axis): the flapwise (z) frequency
    # obeys omega^2 = omega_0^2 + K Omega^2 with the Southwell coefficient K1 = 1.1932 of a
    # uniform beam (Wright, Smith, Thresher and Wang, J. Appl. Mech. 1982); in the plane of
    # rotation the centrifugal softening -Omega^2 leaves K1 - 1. Steady spin about b3 gives
    # A4 = A8 = -Omega^2 (reference notes section 5.8), and the modal row's velocity term
    # -omega^T D_k omega adds -Omega^2 P_lk[2, 2] q_l (section 6.2).
    md = beam_modal_data(cantilever(elements=40), 6)
    S, P = md.geometric_stiffness, md.integrals().P
    added = -(S[3] + S[7]) - P[:, :, 2, 2]  # stiffness per Omega^2, Rayleigh quotient per mode
    flap, lag = modes_along(md, 2)[0], modes_along(md, 1)[0]
    assert added[flap, flap] == pytest.approx(1.1932, abs=1e-3)
    assert added[lag, lag] == pytest.approx(0.1932, abs=1e-3)


def test_greenhill_buckling_under_axial_acceleration():
    # A cantilever accelerated along its axis away from its tip is compressed by its own
    # inertia like a heavy column: buckling at q L^3 / EI = 7.837 (Greenhill 1881; Timoshenko
    # and Gere, Theory of Elastic Stability, section 2.10), with q = m a. The modal stiffness is
    # Lambda + a S^(1) (A1 = a, section 5.8); find where its smallest eigenvalue vanishes.
    md = beam_modal_data(cantilever(elements=30, EIz=1e9), 6)
    lam = np.diag(md.frequencies**2)
    S1 = md.geometric_stiffness[0]
    a_exact = 7.837 * EI / (MASS * LENGTH**3)
    ratio = np.linalg.eigvals(np.linalg.solve(-S1, lam)).real
    a_cr = np.min(ratio[ratio > 0])
    assert a_cr == pytest.approx(a_exact, rel=2e-3)  # 6 modes: Ritz converges from above


def test_collinear_members_equal_one_member():
    one = beam_modal_data(cantilever(elements=20), 4)
    half = dict(EA=1e9, EIy=EI, EIz=3 * EI, GJ=1e4, mass_per_length=MASS, elements=10)
    two = beam_modal_data([Beam((0, 0, 0), (LENGTH / 2, 0, 0), **half),
                           Beam((LENGTH / 2, 0, 0), (LENGTH, 0, 0), **half)], 4)
    np.testing.assert_allclose(two.frequencies, one.frequencies, rtol=1e-12)
    pos, trans, _ = two.node("1.end")
    np.testing.assert_allclose(pos, [LENGTH, 0, 0])
    assert trans.shape == (3, 4)


def test_l_frame_assembly_is_joined():
    props = dict(EA=1e8, EIy=EI, EIz=EI, GJ=1e4, mass_per_length=MASS, elements=8)
    frame = [Beam((0, 0, 0), (5, 0, 0), **props), Beam((5, 0, 0), (5, 5, 0), **props)]
    md = beam_modal_data(frame, 4, nodes={"tip": (5, 5, 0)})
    assert md.integrals().mass == pytest.approx(10 * MASS)
    # A joined frame has no zero-frequency mode; an unjoined second member would.
    assert md.frequencies[0] > 0.1
    assert md.node("tip")[0].tolist() == [5.0, 5.0, 0.0]


@pytest.mark.parametrize("suffix", [".npz", ".json"])
def test_file_round_trip(tmp_path, suffix):
    md = beam_modal_data(cantilever(elements=4), 3, damping=0.005)
    back = load_modal_data(md.save(tmp_path / f"body{suffix}"))
    for name in ("positions", "masses", "inertias", "translations", "rotations", "frequencies", "damping",
                 "node_positions", "geometric_stiffness"):
        np.testing.assert_array_equal(getattr(back, name), getattr(md, name), err_msg=name)
    assert back.node_names == md.node_names


def test_bad_input():
    with pytest.raises(ModelError, match="EIy must be positive"):
        cantilever(EIy=0.0)
    with pytest.raises(ModelError, match="start and end coincide"):
        Beam((1, 1, 1), (1, 1, 1), EA=1, EIy=1, EIz=1, GJ=1, mass_per_length=1)
    with pytest.raises(ModelError, match="not restrained"):
        beam_modal_data(cantilever(elements=2), 2, clamped=())
    with pytest.raises(ModelError, match="is not a node of the beam mesh"):
        beam_modal_data(cantilever(elements=2), 2, clamped=[(0.1, 0, 0)])
    with pytest.raises(ModelError, match="did you mean '0.end'"):
        beam_modal_data(cantilever(elements=2), 2).node("0.edn")
    with pytest.raises(ModelError, match=r"translations has shape \(2, 3, 1\) but \(2, 3, 2\)"):
        ModalData(np.zeros((2, 3)), np.ones(2), np.zeros((2, 3, 3)), np.zeros((2, 3, 1)), np.zeros((2, 3, 2)),
                  [1.0, 2.0], [0.0, 0.0])


def test_bad_modal_data_is_refused_with_what_and_where():
    def data(**changes):
        fields = dict(positions=np.zeros((2, 3)), masses=np.ones(2), inertias=np.zeros((2, 3, 3)),
                      translations=np.zeros((2, 3, 2)), rotations=np.zeros((2, 3, 2)), frequencies=[1.0, 2.0],
                      damping=[0.0, 0.0])
        fields.update(changes)
        return ModalData(**fields)

    with pytest.raises(ModelError, match="frequencies must be non-negative"):
        data(frequencies=[-1.0, 2.0])
    with pytest.raises(ModelError, match="masses must be non-negative"):
        data(masses=np.array([1.0, -1.0]))
    with pytest.raises(ModelError, match="damping must be non-negative"):
        data(damping=[0.01, -0.01])
    skew = np.zeros((2, 3, 3))
    skew[1] = [[1.0, 0.2, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    with pytest.raises(ModelError, match=r"inertias\[1\] is not symmetric"):
        data(inertias=skew)
    indefinite = np.zeros((2, 3, 3))
    indefinite[0] = np.diag([1.0, -0.5, 1.0])
    with pytest.raises(ModelError, match=r"inertias\[0\] is not positive semi-definite .*-0.5 kg m\^2"):
        data(inertias=indefinite)


def test_bad_files(tmp_path):
    with pytest.raises(ModelError, match="no such modal-data file"):
        load_modal_data(tmp_path / "missing.npz")
    (tmp_path / "x.json").write_text('{"format": "other"}')
    with pytest.raises(ModelError, match="not a linflex-modal-data file"):
        load_modal_data(tmp_path / "x.json")
    (tmp_path / "y.json").write_text('{"format": "linflex-modal-data", "version": 1, "masses": [1]}')
    with pytest.raises(ModelError, match="missing fields"):
        load_modal_data(tmp_path / "y.json")


def test_cantilever_with_tip_mass():
    # Closed form (Euler-Bernoulli cantilever with a tip point mass M = mu m L, e.g. Blevins
    # table 8-8): 1 + cos b cosh b + mu b (cos b sinh b - sin b cosh b) = 0, omega = b^2
    # sqrt(EI / (m L^4)).
    from scipy.optimize import brentq

    from linflex import PointMassAt

    mu = 1.0

    def characteristic(b):
        return 1 + np.cos(b) * np.cosh(b) + mu * b * (np.cos(b) * np.sinh(b) - np.sin(b) * np.cosh(b))

    beta = brentq(characteristic, 0.5, 1.875)
    tip = PointMassAt((LENGTH, 0.0, 0.0), mu * MASS * LENGTH)
    md = beam_modal_data(cantilever(), 4, point_masses=[tip])
    exact = beta**2 * np.sqrt(EI / (MASS * LENGTH**4))
    assert md.frequencies[modes_along(md, 2)[0]] == pytest.approx(exact, rel=1e-6)
    ints = md.integrals()
    assert ints.mass == pytest.approx(2 * MASS * LENGTH, rel=1e-14)
    np.testing.assert_allclose(ints.e + ints.W9, np.eye(4), atol=1e-12)  # tip mass is a mass point too
    with pytest.raises(ModelError, match="mass must be positive"):
        PointMassAt((0, 0, 0), 0.0)


def test_selected_modes_keep_their_shapes_frequencies_and_geometric_stiffness():
    # A cantilever's axial mode left out (the other 7 of 8, in reverse order): every per-mode array
    # is the full data's at those indices, the geometric stiffness and the modal integrals their
    # sub-blocks; the lowest k are truncated(k).
    md = beam_modal_data(cantilever(EA=1e5), 8)  # axial mode at 40.6 rad/s, the fourth
    axial = [k for k in range(md.n_modes) if np.argmax(np.abs(md.translations).max(axis=0)[:, k]) == 0]
    keep = [k for k in range(md.n_modes) if k not in axial][::-1]
    sel = md.selected(keep)
    assert axial and sel.n_modes == len(keep)
    np.testing.assert_array_equal(sel.frequencies, md.frequencies[keep])
    np.testing.assert_array_equal(sel.translations, md.translations[..., keep])
    np.testing.assert_array_equal(sel.node_rotations, md.node_rotations[..., keep])
    np.testing.assert_array_equal(sel.geometric_stiffness, md.geometric_stiffness[:, keep][:, :, keep])
    full, part = md.integrals(), sel.integrals()   # the modal integrals: sums over the mass points
    np.testing.assert_allclose(part.e, full.e[np.ix_(keep, keep)], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(part.d, full.d[np.ix_(keep, keep)], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(part.b, full.b[:, keep], rtol=1e-12, atol=1e-12)
    low = md.selected(range(3))
    np.testing.assert_array_equal(low.translations, md.truncated(3).translations)
    for bad in ([], [0, 0], [8], [-1], ["a"], [1.5], [True]):
        with pytest.raises(ModelError, match="distinct indices from 0 to 7"):
            md.selected(bad)
