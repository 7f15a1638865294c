"""What a hurried user types into linflex.frequency: option values, channel choices and case lists
that used to crash with a numpy traceback, be silently ignored or give a blank plot.

Each test pins one defect: the exact linflex error (class and a fragment of its message), or a
value checked against an independent computation (closed form or a dense solve) with its
tolerance next to it.
"""

import matplotlib

matplotlib.use("Agg")

import control  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from linflex import AccuracyWarning, LinearSystem, ModelError, ShapeError  # noqa: E402
from linflex.frequency import (  # noqa: E402
    Loop,
    bode_envelope_plot,
    bode_form,
    bode_plot,
    frequency_grid,
    frequency_response,
    hinf_norm,
    lambda_shift_zpk,
    nichols_plot,
    nyquist_plot,
    nyquist_response,
    realize_polynomial,
    root_locus,
    sigma_plot,
    transfer_function,
    zpk,
)


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def _double_integrator():
    return LinearSystem([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])   # 1/s^2


def _pd_loop():
    return control.tf([2, 1], [1, 0, 0])                          # (2s + 1)/s^2: PD on a rigid body


def _oscillators():
    """Three oscillators of 1 kg, stiffness 0.8, 1 and 1.2 N/m, damping 0.2 N s/m."""
    return [LinearSystem([[0, 1], [-k, -0.2]], [[0], [1]], [[1, 0]]) for k in (0.8, 1.0, 1.2)]


# ----------------------------------------------------------------------------------------------
# frequency_response / frequency_grid options


@pytest.mark.parametrize("kwargs, fragment", [
    ({"max_refinements": 2.5}, "max_refinements must be a non-negative integer"),
    ({"max_refinements": -1}, "max_refinements must be a non-negative integer"),
    ({"resolution_db": -1.0}, "resolution_db must be a finite positive number"),
    ({"resolution_db": np.nan}, "resolution_db must be a finite positive number"),
    ({"rtol": -1.0}, "rtol must be a finite positive number"),
    ({"rtol": np.nan}, "rtol must be a finite positive number"),
])
def test_frequency_response_options_are_checked(kwargs, fragment):
    # before: a float max_refinements crashed in range() (TypeError); the others were accepted
    # silently (a NaN rtol switched the backward-stable re-check off)
    with pytest.raises(ModelError, match=fragment):
        frequency_response(_double_integrator(), **kwargs)


def test_frequency_response_zero_refinements_still_evaluates():
    # max_refinements=0 is a legitimate "base grid only"; 1/s^2 at 1 rad/s is -1 (closed form)
    fr = frequency_response(_double_integrator(), max_refinements=0)
    k = int(np.argmin(np.abs(fr.omega - 1.0)))
    assert fr.omega[k] == pytest.approx(1.0, rel=1e-12)
    assert fr.response[k, 0, 0] == pytest.approx(-1.0, abs=1e-14)   # rounding only


def test_frequency_grid_negative_zeta_max_is_refused():
    # before: zeta_max=-1 silently dropped every resonance cluster
    with pytest.raises(ModelError, match="zeta_max must be a finite non-negative number"):
        frequency_grid(([1.0], [1.0, 0.02, 1.0]), zeta_max=-1.0)


# ----------------------------------------------------------------------------------------------
# plots


@pytest.mark.parametrize("value", [0.0, -1.0, np.inf])
def test_nyquist_plot_max_magnitude_must_be_positive(value):
    # before: max_magnitude=0 or < 0 made every point NaN: an empty plot and no error
    with pytest.raises(ModelError, match="max_magnitude must be a finite positive number"):
        nyquist_plot(_pd_loop(), max_magnitude=value)
    with pytest.raises(ModelError, match="max_magnitude must be a finite positive number"):
        nyquist_response(_pd_loop()).plot(max_magnitude=value)


def test_nyquist_plot_draws_finite_points():
    h = nyquist_plot(_pd_loop(), max_magnitude=5.0)
    drawn = np.concatenate([h.lines[0].get_xdata(), h.lines[1].get_xdata()])
    assert np.any(np.isfinite(drawn))


def test_bode_envelope_mixed_responses_and_systems():
    # before: a FrequencyResponse among systems was fed to frequency_grid/frequency_response
    # (a misleading "sys must be a LinearSystem ... got FrequencyResponse") or, with nominal=1,
    # reached numpy with ragged arrays (ValueError)
    cases = _oscillators()
    w = np.logspace(-1, 1, 40)
    fr0 = frequency_response(cases[0], w)
    for nominal in (0, 1):
        h = bode_envelope_plot([fr0, cases[1], cases[2]], nominal=nominal)
        assert all(np.array_equal(fr.omega, w) for fr in h.data)
        # the nominal line against the closed form 1/(k - w^2 + 0.2 j w) [dB]; rounding only
        k = (0.8, 1.0, 1.2)[nominal]
        ref = 20 * np.log10(np.abs(1 / (k - w**2 + 0.2j * w)))
        np.testing.assert_allclose(h.lines[0].get_ydata(), ref, rtol=0, atol=1e-9)


def test_bode_envelope_mixed_with_other_omega_is_refused():
    cases = _oscillators()
    fr0 = frequency_response(cases[0], np.logspace(-1, 1, 40))
    with pytest.raises(ModelError, match="response 1 has other frequencies than response 0"):
        bode_envelope_plot([fr0, cases[1]], [1.0, 2.0])


@pytest.mark.parametrize("kwargs, fragment", [
    ({"nominal": 1.5}, "nominal must be an integer index"),
    ({"output": 0.5}, "output must be an integer index"),
    ({"input": True}, "input must be an integer index"),
])
def test_bode_envelope_indices_must_be_integers(kwargs, fragment):
    # before: nominal=1.5 raised a TypeError from list indexing; output=0.5 passed the range test
    with pytest.raises(ModelError, match=fragment):
        bode_envelope_plot(_oscillators(), **kwargs)


def test_bode_envelope_of_one_system_says_so():
    # before: TypeError "'LinearSystem' object is not iterable"
    with pytest.raises(ModelError, match="results must be a sequence of cases"):
        bode_envelope_plot(_oscillators()[0])


def test_bode_envelope_channel_checked_on_every_case():
    siso = _oscillators()[0]
    mimo = LinearSystem(np.diag([-1.0, -2.0]), np.eye(2), np.eye(2))
    with pytest.raises(ModelError, match=r"channel \(1, 1\) outside the \(1, 1\) response 1"):
        bode_envelope_plot([mimo, siso], [1.0, 2.0], output=1, input=1)


# ----------------------------------------------------------------------------------------------
# zpk, lambda_shift_zpk, bode_form


@pytest.mark.parametrize("fn", [zpk, lambda_shift_zpk, bode_form])
def test_siso_functions_need_the_whole_channel(fn):
    # before: zpk(G, output=1) on a 2x2 system silently took input 0: the channel y1 <- u0 of
    # diag(1/(s+1), 1/(s+2)) is zero, and a zero gain came back without a word
    G = LinearSystem(np.diag([-1.0, -2.0]), np.eye(2), np.eye(2))
    with pytest.raises(ModelError, match="sys has 2 inputs: pass input= too"):
        fn(G, output=1)
    with pytest.raises(ModelError, match="sys has 2 outputs: pass output= too"):
        fn(G, input=1)


def test_single_input_system_still_takes_output_alone():
    # one input: output= alone names the channel; (2s + 3)/((s + 1)(s + 2)) has gain 2, zero -1.5
    G = LinearSystem([[-1, 0], [0, -2]], [[1], [1]], [[1, 1], [1, 0]])
    z = zpk(G, output=0)
    assert z.gain == pytest.approx(2.0, rel=1e-12)                  # rounding of one solve
    assert z.zeros.real.tolist() == pytest.approx([-1.5], rel=1e-12)


@pytest.mark.parametrize("lam, fragment", [
    (np.nan, "lam must be a finite complex number"),
    (complex(np.inf, 1.0), "lam must be a finite complex number"),
    ("a", "lam must be a complex number"),
])
def test_lambda_shift_checks_the_shift(lam, fragment):
    # before: a NaN shift reached LAPACK geev ("illegal value in argument 4"); a string a numpy
    # UFuncTypeError
    with pytest.raises(ModelError, match=fragment):
        lambda_shift_zpk(_pd_loop(), lam=lam)


@pytest.mark.parametrize("value", [-1.0, np.nan])
def test_bode_form_origin_tol_checked(value):
    # before: origin_tol=-1 returned gain=inf and time constants -inf for (2s + 1)/s^2
    with pytest.raises(ModelError, match="origin_tol must be a finite non-negative number"):
        bode_form(_pd_loop(), origin_tol=value)


# ----------------------------------------------------------------------------------------------
# realize_polynomial


def test_realize_polynomial_refuses_complex_numpy_coefficients():
    # before: np.array([1j, 1]) was cast to [0, 1] with only a numpy ComplexWarning: a silently
    # different controller
    with pytest.raises(ShapeError, match="num must hold real coefficients"):
        realize_polynomial(np.array([1j, 1.0]), [1.0, 1.0, 1.0])
    with pytest.raises(ShapeError, match="den must hold real coefficients"):
        realize_polynomial([1.0], np.array([1.0, 0.5 + 0.1j]))


@settings(deadline=None, max_examples=30)
# coefficients as typed: three decimals (0 or at least 1e-3 in modulus)
@given(num=st.lists(st.floats(-10, 10).map(lambda x: round(x, 3)), min_size=1, max_size=4),
       den=st.lists(st.floats(-10, 10).map(lambda x: round(x, 3)), min_size=4, max_size=5).filter(
           lambda d: abs(d[0]) > 1e-2),
       w=st.floats(0.05, 20.0))
def test_realize_polynomial_matches_polyval(num, den, w):
    # reference: P(jw)/Q(jw) by Horner (numpy.polyval); a small companion realization
    s = 1j * w
    q = np.polyval(den, s)
    if abs(q) < 1e-3 * max(1.0, np.max(np.abs(den))) * max(1.0, w) ** (len(den) - 1):
        return  # too near a pole on the axis for a meaningful relative comparison
    ref = np.polyval(num, s) / q
    got = frequency_response(realize_polynomial(num, den), [w], method="direct").response[0, 0, 0]
    # the balanced companion form of order <= 4, coefficients within [-10, 10]: relative error of
    # a dense solve, cond(Q(jw)) times eps, well below 1e-8 away from the axis poles
    assert abs(got - ref) <= 1e-8 * max(abs(ref), 1e-6 * np.max(np.abs(num) + 1e-300))


# ----------------------------------------------------------------------------------------------
# root_locus, nyquist_response, hinf_norm


def test_root_locus_negative_k_max_is_refused():
    # before: k_max=-5 was silently taken as +5 (the complementary locus is negative=True)
    with pytest.raises(ModelError, match="k_max must be a finite positive number"):
        root_locus(_pd_loop(), k_max=-5.0)


def test_root_locus_k_max_positive_reaches_it():
    # (2s + 1)/s^2 under k: s^2 + 2ks + k = 0; at k = 4 the roots are -4 +- sqrt(12) (closed form)
    rl = root_locus(_pd_loop(), k_max=4.0)
    assert rl.gains[-1] == pytest.approx(4.0, rel=1e-12)
    ref = np.sort(np.array([-4 - np.sqrt(12.0), -4 + np.sqrt(12.0)]))
    np.testing.assert_allclose(np.sort(rl.roots[-1].real), ref, rtol=1e-9)   # polished roots


def test_root_locus_of_a_system_without_channels():
    # before: ValueError "zero-size array to reduction operation maximum" from numpy
    with pytest.raises(ShapeError, match="loop has 0 outputs and 0 inputs"):
        root_locus(LinearSystem([[-1.0]], np.zeros((1, 0)), np.zeros((0, 1))))


def test_root_locus_max_displacement_type():
    # before: TypeError "'<' not supported between instances of 'int' and 'str'"
    with pytest.raises(ModelError, match="max_displacement must be a real number"):
        root_locus(_pd_loop(), max_displacement="big")


@pytest.mark.parametrize("value", [2.5, -2])
def test_nyquist_max_refinements_checked(value):
    # before: 2.5 crashed in range() with a TypeError; -2 was accepted as 0
    with pytest.raises(ModelError, match="max_refinements must be a non-negative integer"):
        nyquist_response(_pd_loop(), max_refinements=value)


def test_hinf_norm_accepts_numpy_float32_rtol():
    # before: "rtol must be a number in (0, 0.1], got np.float32(0.001)", a misleading refusal.
    # A mode at 2 rad/s with zeta = 0.01: peak 1/(2 zeta sqrt(1 - zeta^2)) (closed form)
    res = hinf_norm(([4.0], [1.0, 0.04, 4.0]), rtol=np.float32(1e-3))
    assert res.value == pytest.approx(1 / (2 * 0.01 * np.sqrt(1 - 0.01**2)), rel=1e-3)   # rtol asked


# ----------------------------------------------------------------------------------------------
# Loop and transfer_function


def _named_loop():
    P = LinearSystem(np.diag([-1.0, -2.0]), np.eye(2), np.eye(2), inputs=["a", "b"], outputs=["x", "y"])
    K = LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[5.0]])
    return Loop(P, K, sensors="y", actuators="b")


def test_quasi_open_loop_names_the_actuators_in_its_message():
    # before: "opened: unknown signal 'a'; the plant has ['b']" while the plant has 'a'
    with pytest.raises(ModelError, match=r"opened: unknown signal 'a'; the loop's actuators are \['b'\]"):
        transfer_function(_named_loop(), "quasi_open_loop", opened="a")


def test_at_input_for_a_kind_without_sides_is_refused():
    # before: at="input" was ignored for every kind but the sensitivities
    with pytest.raises(ModelError, match="at='input' applies to kinds 'sensitivity' and"):
        transfer_function(_named_loop(), "closed_loop", at="input")


def test_sensitivity_at_input_value():
    # S_i of 1/(s + 2) under the gain 5: (s + 2)/(s + 7) (closed form), rounding only
    S = transfer_function(_named_loop(), "sensitivity", at="input")
    w = np.array([0.3, 1.0, 3.0])
    got = frequency_response(S, w, method="direct").response[:, 0, 0]
    np.testing.assert_allclose(got, (1j * w + 2) / (1j * w + 7), rtol=1e-12)


# ----------------------------------------------------------------------------------------------
# phase with a pole on a grid point


def test_phase_survives_a_pole_on_a_grid_point():
    # 1/(s^2 + 1) at 0.5, 1, 2, 3 rad/s: the point on the pole is NaN (documented); before, the
    # phase of every later frequency was NaN too (numpy.unwrap carries a NaN forward), in
    # FrequencyResponse.phase, the Bode phase line and the Nichols curve
    with pytest.warns(AccuracyWarning):
        fr = frequency_response(([1.0], [1.0, 0.0, 1.0]), [0.5, 1.0, 2.0, 3.0])
    assert np.isnan(fr.phase[1])
    # closed form: 1/(1 - w^2) is real, positive below 1 rad/s and negative above: |phase| 0, pi
    np.testing.assert_allclose(np.abs(fr.phase[[0, 2, 3]]), [0.0, np.pi, np.pi], atol=1e-12)
    bode_phase = bode_plot(fr).lines[1].get_ydata()
    np.testing.assert_allclose(np.abs(bode_phase[[0, 2, 3]]), [0.0, 180.0, 180.0], atol=1e-10)
    nichols_phase = nichols_plot(fr).lines[0].get_xdata()
    np.testing.assert_allclose(np.abs(nichols_phase[[0, 2, 3]]), [0.0, 180.0, 180.0], atol=1e-10)


@settings(deadline=None, max_examples=40)
@given(slope=st.floats(-20.0, 20.0), n=st.integers(3, 60), data=st.data())
def test_phase_with_a_gap_unwraps_the_rest(slope, n, data):
    # reference: numpy.unwrap of the finite values alone
    from linflex.frequency._draw import unwrapped_phase

    g = 2.0 * np.exp(1j * slope * np.linspace(0.0, 1.0, n))
    k = data.draw(st.integers(0, n - 1))
    g[k] = complex(np.nan, np.nan)
    got = unwrapped_phase(g)
    keep = np.arange(n) != k
    assert np.isnan(got[k])
    np.testing.assert_allclose(got[keep], np.unwrap(np.angle(g[keep])), rtol=0, atol=0)   # the same operations


def test_singular_values_with_a_pole_on_a_grid_point():
    # before: numpy.linalg.LinAlgError "SVD did not converge" from singular_values() and
    # sigma_plot as soon as one point was NaN (1/(s^2 + 1) at 1 rad/s)
    G = LinearSystem([[0, 1], [-1, 0]], [[0], [1]], [[1, 0]])
    with pytest.warns(AccuracyWarning):
        fr = frequency_response(G, [0.5, 1.0, 2.0])
    sv = fr.singular_values()
    assert np.isnan(sv[1, 0])
    # closed form |1/(1 - w^2)|: 4/3 and 1/3; rounding only
    np.testing.assert_allclose(sv[[0, 2], 0], [4 / 3, 1 / 3], rtol=1e-13)
    db = sigma_plot(fr).lines[0].get_ydata()
    np.testing.assert_allclose(db[[0, 2]], 20 * np.log10([4 / 3, 1 / 3]), rtol=1e-12)


def test_html_summary_peak_at_a_pole_is_infinite():
    # before: the NaN point was reported as a peak of -inf dB (NaN compared as "not > 0")
    G = LinearSystem([[0, 1], [-1, 0]], [[0], [1]], [[1, 0]])
    with pytest.warns(AccuracyWarning):
        html = frequency_response(G, [0.5, 1.0, 2.0])._repr_html_()
    assert "-inf" not in html and ">inf<" in html


def test_nichols_plot_of_mimo_points_to_subsystem():
    # before: "use .channel(output, input) to pick one", an array nichols_plot does not accept
    G = LinearSystem(np.diag([-1.0, -2.0]), np.eye(2), np.eye(2))
    with pytest.raises(ModelError, match=r"nichols_plot draws one channel: .* sys.subsystem"):
        nichols_plot(G)
    h = nichols_plot(G.subsystem(outputs=[1], inputs=[1]))
    # 1/(s + 2): gain [dB] against the closed form, rounding only
    w = h.data.omega
    np.testing.assert_allclose(h.lines[0].get_ydata(), 20 * np.log10(np.abs(1 / (1j * w + 2))), atol=1e-10)


def test_bode_envelope_phase_band_does_not_wrap():
    # (s + a)/(s^2 (s + b)) with (a, b) = (1, 2) and (2, 1): phases -180 +- 0.29 deg at 0.01 rad/s
    # (closed form -180 + atan(w/a) - atan(w/b)). Before, the second case, wrapped to +179.7,
    # made the phase band 360 deg wide.
    cases = [([1.0, a], [1.0, b, 0.0, 0.0]) for a, b in ((1.0, 2.0), (2.0, 1.0))]
    w = np.logspace(-2, 2, 50)
    h = bode_envelope_plot(cases, w)
    band = h.axes[1].collections[0].get_paths()[0].vertices[:, 1]
    ref = [-180 + np.degrees(np.arctan(w / a) - np.arctan(w / b)) for a, b in ((1.0, 2.0), (2.0, 1.0))]
    np.testing.assert_allclose([band.min(), band.max()], [np.min(ref), np.max(ref)], atol=1e-9)   # rounding


def test_nichols_critical_point_next_to_a_lagging_rigid_body_loop():
    # L = 1/(s^2 (0.01 s + 1)): phase -180 - atan(0.01 w) deg, unwrapped from +179.9 deg; its
    # gain crossover (w ~ 1 rad/s, closed form) is 0.57 deg from the critical point. Before, the
    # only marker sat at -180 deg, a full turn from the curve drawn near +180 deg.
    h = nichols_plot(([1.0], [0.01, 1.0, 0.0, 0.0]))
    phase, gain = h.lines[0].get_xdata(), h.lines[0].get_ydata()
    k = int(np.argmin(np.abs(gain)))
    crit = h.lines[1].get_xdata()
    assert np.min(np.abs(crit - phase[k])) == pytest.approx(np.degrees(np.arctan(0.01 * h.data.omega[k])),
                                                             abs=1e-9)   # rounding only
    # a loop already near -180 deg keeps its single marker there
    assert nichols_plot(_pd_loop()).lines[1].get_xdata().tolist() == [-180.0]
