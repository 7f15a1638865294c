"""Plots (frequency/_plot.py), rendered with the Agg backend; the handles carry the data drawn."""

import matplotlib

matplotlib.use("Agg")

import control  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from linflex import LinearSystem, ModelError  # noqa: E402
from linflex.frequency import (  # noqa: E402
    bode_envelope_plot,
    bode_plot,
    frequency_response,
    nichols_plot,
    nyquist_plot,
    nyquist_response,
    root_locus,
    root_locus_plot,
    sigma_plot,
)

from .conftest import flexible_modal, two_mass  # noqa: E402


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def test_bode_plot_data_in_db_and_degrees():
    sys = two_mass().subsystem(outputs="x1")
    fr = frequency_response(sys, [0.5, 1.0, 3.0])
    fig, (ax1, ax2) = plt.subplots(2)
    h = bode_plot(fr, ax=(ax1, ax2))
    mag, ph = h.lines
    # reference notes 13: -19.432 dB and -174.699 deg at 1 rad/s
    assert mag.get_ydata()[1] == pytest.approx(-19.432, abs=1e-3)
    assert ph.get_ydata()[1] == pytest.approx(-174.699, abs=1e-3)
    assert h.axes == (ax1, ax2) and h.figure is fig
    hz = bode_plot(fr, hz=True)
    assert hz.lines[0].get_xdata() == pytest.approx(fr.omega / (2 * np.pi))


def test_bode_plot_mimo_channels():
    sys = flexible_modal(5, 1e-2, seed=1, n_in=2, n_out=2)
    h = bode_plot(sys)
    assert len(h.lines) == 8  # 4 channels x (magnitude, phase)
    assert np.asarray(h.lines[2].get_ydata()) == pytest.approx(20 * np.log10(np.abs(h.data.response[:, 0, 1])))


def test_nichols_plot():
    sys = two_mass().subsystem(outputs="x1")
    fr = frequency_response(sys, [0.5, 1.0])
    h = nichols_plot(fr)
    assert h.lines[0].get_xdata() == pytest.approx([-179.742, -174.699], abs=1e-3)
    assert h.lines[0].get_ydata() == pytest.approx(20 * np.log10([0.723550, 0.106758]), abs=1e-4)
    with pytest.raises(ModelError, match="outputs"):
        nichols_plot(frequency_response(two_mass(), [1.0]))


def test_nyquist_plot_reports_count():
    L = LinearSystem.from_control(control.ss(control.tf([10], np.polymul([1, 1, 0], [1, 2]))))
    h = nyquist_plot(L)
    assert isinstance(h.data.encirclements, int)
    assert "Z = N + P = 2" in h.axes[0].get_title()  # Routh: two RHP closed-loop roots at K = 10
    line = h.lines[0]
    small = np.abs(h.data.values) <= 20
    assert np.asarray(line.get_xdata())[small] == pytest.approx(h.data.values.real[small])
    # indentation around the integrator: compressed part drawn dashed
    assert h.lines[1].get_linestyle() == "--"
    assert np.any(np.isfinite(np.asarray(h.lines[1].get_xdata(), dtype=float)))
    again = nyquist_plot(nyquist_response(L), ax=plt.gca())
    assert again.axes[0] is plt.gca()


def test_sigma_plot():
    sys = flexible_modal(5, 1e-2, seed=2, n_in=2, n_out=2)
    fr = frequency_response(sys, np.logspace(-1, 2, 50))
    h = sigma_plot(fr)
    sv = np.linalg.svd(fr.response, compute_uv=False)
    assert len(h.lines) == 2
    assert h.lines[0].get_ydata() == pytest.approx(20 * np.log10(sv[:, 0]))


def test_root_locus_plot():
    L = LinearSystem.from_control(control.ss(control.tf([1], np.polymul([1, 1, 0], [1, 2]))))
    rl = root_locus(L)
    h = root_locus_plot(rl)
    assert len(h.lines) == 3 + 2
    assert h.lines[0].get_xdata() == pytest.approx(rl.roots[:, 0].real)
    assert sorted(h.lines[3].get_xdata()) == pytest.approx([-2, -1, 0], abs=1e-12)


def test_ax_count_validated():
    with pytest.raises(ModelError, match="2 matplotlib axes"):
        bode_plot(frequency_response(two_mass(), [1.0]), ax=plt.gca())


def test_result_plot_methods_delegate():
    sys = two_mass().subsystem(outputs="x1")
    fr = frequency_response(sys, [0.5, 1.0])
    assert fr.plot().data is fr
    L = LinearSystem.from_control(control.ss(control.tf([4], [1, 1, 0])))
    nr = nyquist_response(L)
    assert nr.plot().data is nr
    rl = root_locus(L)
    assert rl.plot().data is rl


def test_bode_envelope_is_the_band_of_the_cases():
    # three damping values of one mode 1/(s^2 + 2 zeta s + 1): at 1 rad/s |G| = 1/(2 zeta), the
    # band spans 20 log10(1/(2 zeta)) for the largest and smallest zeta; the nominal is case 1
    cases = [LinearSystem([[0, 1], [-1, -2 * z]], [[0], [1]], [[1, 0]]) for z in (0.01, 0.05, 0.2)]
    w = np.array([0.1, 1.0, 10.0])
    h = bode_envelope_plot(cases, w, nominal=1)
    band = h.axes[0].collections[0].get_paths()[0].vertices[:, 1]
    assert band.max() == pytest.approx(20 * np.log10(1 / 0.02), abs=1e-9)  # zeta 0.01 at 1 rad/s
    assert band.min() == pytest.approx(20 * np.log10(1 / np.hypot(99.0, 2 * 0.2 * 10.0)), abs=1e-9)  # zeta 0.2 at 10
    assert h.lines[0].get_ydata()[1] == pytest.approx(20 * np.log10(1 / 0.1), abs=1e-9)  # nominal zeta 0.05
    assert len(h.data) == 3 and np.array_equal(h.data[0].omega, w)
    with pytest.raises(ModelError, match="other frequencies"):
        bode_envelope_plot([frequency_response(cases[0], w), frequency_response(cases[1], w * 2)])
    with pytest.raises(ModelError, match="no cases"):
        bode_envelope_plot([])
    with pytest.raises(ModelError, match="channel"):
        bode_envelope_plot(cases, w, output=1)


def test_bode_and_sigma_plots_take_the_callers_label_and_color():
    sys = two_mass().subsystem(outputs="x1")
    h = bode_plot(frequency_response(sys, [0.5, 1.0, 3.0]), label="full model", color="k", linestyle="--")
    mag, ph = h.lines
    assert mag.get_label() == "full model" and mag.get_color() == "k" and ph.get_color() == "k"
    assert ph.get_linestyle() == "--" and not ph.get_label().startswith("full")
    s = sigma_plot(frequency_response(two_mass(), [0.5, 1.0]), color="r")
    assert all(line.get_color() == "r" for line in s.lines)
