"""analyse_scene: from the example scene to margins and modes, against closed forms."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import linflex
from linflex import ModelError
from linflex.stability.report import analyse_scene

SCENE = Path(__file__).resolve().parents[2] / "examples" / "attitude_control.toml"
OMEGA_N, ZETA = 0.5, 0.7  # the scene's PD design per axis: kp = I wn^2, kd = 2 zeta wn I


def test_attitude_loop_margins_and_modes_match_the_pd_design():
    analysis = analyse_scene(SCENE)
    # Closed form for L = (wn^2 + 2 zeta wn s) / s^2 on each axis: crossover
    # wc^2 = wn^2 (2 zeta^2 + sqrt(4 zeta^4 + 1)), phase margin atan(2 zeta wc / wn).
    wc = OMEGA_N * np.sqrt(2 * ZETA**2 + np.sqrt(4 * ZETA**4 + 1))
    pm = np.degrees(np.arctan(2 * ZETA * wc / OMEGA_N))
    for loop in analysis.margins.loops:
        np.testing.assert_allclose(loop.gain_crossovers, [wc], rtol=1e-9)
        np.testing.assert_allclose(loop.phase_margins, [pm], rtol=1e-9)
        assert loop.phase_crossovers.size == 0  # a PD double-integrator loop never crosses -180
        # A disk margin never exceeds the classical margins (Seiler, Packard, Gahinet 2020).
        assert loop.disk_margin.phase_margin <= pm + 1e-9
    # Closed loop: three pairs at wn = 0.5 rad/s, zeta = 0.7 (the design), nothing else.
    np.testing.assert_allclose(analysis.closed_loop_modes.natural_frequencies, [OMEGA_N] * 3, rtol=1e-9)
    np.testing.assert_allclose(analysis.closed_loop_modes.damping_ratios, [ZETA] * 3, rtol=1e-9)
    assert analysis.closed_loop_stable and not analysis.trimmed
    # The quaternion's scalar part is isolated at the identity and left out of the loop.
    assert "attitude.qw" not in analysis.loop.plant.states
    assert analysis.plant.method == "kane" and analysis.plant.max_relative_error_estimate == 0.0
    assert set(analysis.costs) >= {"compile plant", "linearize (kane)", "margins", "modes"}
    assert not any("second linearization" in step for step in analysis.costs)  # Kane once: A, B, C, D and K
    # Ms of S = s^2 / (s^2 + 2 zeta wn s + wn^2): 1 / sqrt(1 - a^2) at wn / sqrt(a), a = 1 - 2 zeta^2
    # (d|S|^2/dw = 0 in closed form); the report's peak is the H-infinity norm, certified to 1e-6
    a = 1 - 2 * ZETA**2
    for channel in analysis.channels:
        peak, at = channel.sensitivity_peak
        assert peak == pytest.approx(1 / np.sqrt(1 - a**2), rel=2e-6) and peak <= 1 / np.sqrt(1 - a**2) * (1 + 1e-12)
        assert at == pytest.approx(OMEGA_N / np.sqrt(a), rel=1e-2)


def test_numerical_method_gives_the_same_margins():
    exact = analyse_scene(SCENE, figures=False)
    numerical = analyse_scene(SCENE, method="central", figures=False)
    for a, b in zip(exact.margins.loops, numerical.margins.loops):
        np.testing.assert_allclose(b.phase_margins, a.phase_margins, rtol=1e-6)  # central: ~1e-9 Jacobians


def test_kane_linearization_gives_the_same_margins():
    # Kane's direct linearization is exact like autodiff (tests/linearize/test_kane.py): the
    # margins agree to round-off.
    exact = analyse_scene(SCENE, method="autodiff", figures=False)
    direct = analyse_scene(SCENE, method="kane", figures=False)
    assert direct.plant.method == "kane" and direct.plant.second_order is not None
    for a, b in zip(exact.margins.loops, direct.margins.loops):
        np.testing.assert_allclose(b.phase_margins, a.phase_margins, rtol=1e-12)
        np.testing.assert_allclose(b.gain_crossovers, a.gain_crossovers, rtol=1e-12)


def test_scene_without_controllers_is_refused():
    scene = dataclasses.replace(linflex.load_scene(SCENE), controllers=(), effects=())
    with pytest.raises(ModelError, match="has no controllers"):
        analyse_scene(scene)


def test_spacecraft_with_flexible_arrays():
    # The README's example: a hub with two flexible arrays (first bending 1.55 rad/s, damping
    # 0.005) under a PD law designed for wn = 0.3 rad/s, zeta = 0.7 on the rigid inertia.
    analysis = analyse_scene(SCENE.parent / "spacecraft_arrays.toml")
    assert analysis.closed_loop_stable
    loops = {lm.channel: lm for lm in analysis.margins.loops}
    wn, zeta = 0.3, 0.7
    wc = wn * np.sqrt(2 * zeta**2 + np.sqrt(4 * zeta**4 + 1))
    rigid_pm = np.degrees(np.arctan(2 * zeta * wc / wn))  # 65.16 deg, the PD closed form
    # Pitch: the arrays' torsion barely couples; the rigid design holds to 0.1 deg (inertia
    # rounded in the gains).
    assert loops["motor_y"].min_phase_margin == pytest.approx(rigid_pm, abs=0.1)
    # Roll and yaw: the bending modes add crossings (flexible loops cross unity gain many times)
    # and cost about a degree at the rigid crossover.
    for channel in ("motor_x", "motor_z"):
        assert loops[channel].gain_crossovers.size >= 4
        assert loops[channel].min_phase_margin == pytest.approx(rigid_pm, abs=2.0)
    # The array modes keep their structural damping in closed loop (within 10 %).
    array_modes = [m for m in analysis.closed_loop_modes if 1.5 < m.natural_frequency < 1.6]
    assert len(array_modes) == 2 and all(m.damping_ratio == pytest.approx(0.005, rel=0.1) for m in array_modes)
    # Disk margins never exceed the classical ones.
    assert analysis.margins.disk_margin.phase_margin <= min(abs(lm.min_phase_margin) for lm in loops.values())
    # What makes the plant stiff: at rest only the arrays' structure (100 % of every elastic
    # mode's squared frequency), and the undamped frequencies are the plant's oscillatory modes'
    # (damping 0.005 moves |lambda| by zeta^2 ~ 3e-5; wheels at rest add no gyroscopic coupling).
    shares = analysis.stiffness
    elastic = shares.squared > 1e-9 * np.max(shares.squared)
    np.testing.assert_allclose(shares.shares["structure"][elastic], shares.squared[elastic], rtol=1e-10)
    plant_wn = sorted(m.natural_frequency for m in analysis.plant_modes if m.kind == "oscillatory")
    np.testing.assert_allclose(shares.frequencies[elastic], plant_wn, rtol=1e-4)


def test_undamped_arrays_keep_their_hidden_modes_out_of_the_margins():
    """The README's scene with undamped arrays: the antisymmetric bending of the two identical
    arrays is neither driven nor seen by the hub's loops (symmetry) and stays on the axis in
    closed loop. It is not the loops' instability: the closed loop is stable, the margins are
    those of the damped scene to the damping's effect (0.005: the disk margin within 1 %), and
    the hidden poles are plant modes (reference: the plant's own eigenvalues, 1e-8)."""
    from linflex.stability.report._summary import hidden_modes_text, stability_text

    damped = analyse_scene(SCENE.parent / "spacecraft_arrays.toml", figures=False)
    scene = linflex.load_scene(SCENE.parent / "spacecraft_arrays.toml")
    bodies = tuple(dataclasses.replace(b, beam={**b.beam, "damping": 0.0}) if b.beam else b for b in scene.bodies)
    undamped = analyse_scene(dataclasses.replace(scene, bodies=bodies), figures=False)
    m = undamped.margins
    assert undamped.closed_loop_stable and m.closed_loop_stable and m.closed_loop_unstable_poles == 0
    assert m.hidden_poles.size == 12   # six antisymmetric modes (1.554 and 9.738 rad/s twice, 24.06, 27.27), a pair each
    plant = np.array([md.eigenvalue for md in undamped.plant_modes])
    gap = np.min(np.abs(np.abs(m.hidden_poles.imag)[:, None] - np.abs(plant.imag)[None, :]), axis=1)
    assert np.max(gap) <= 1e-8 * np.max(np.abs(plant))
    assert m.disk_margin.alpha == pytest.approx(damped.margins.disk_margin.alpha, rel=0.01)
    assert "6 undamped mode(s) the loops neither drive nor see" in stability_text(undamped)
    assert hidden_modes_text(undamped).startswith("6 undamped mode(s)") and hidden_modes_text(damped) == ""
