"""Why the arrays' axial mode holds the exponential integrator's step at tight tolerances.

Two measurements on a case of ``benchmarks/simulation.py`` (an ``ArraysCase`` and its DOP853
reference at the sample times), printed as tables by :func:`axial_forcing_table`:

1. The spectrum of the axial mode's forcing: the mode's left eigenvector of the Jacobian at the
   start, ``w``, times the remainder ``N = f(x) - J0 x`` along a DOP853 run (rtol 1e-11, atol
   1e-13) sampled every 0.5 ms over a window after the pulse; the largest amplitude of each
   frequency band (|FFT| with a Hann window, scaled so that a real sinusoid of unit amplitude
   reads 1; the projection is complex, so the two signs of a frequency are read apart and the
   larger kept); beside it, what the measurement resolves in each band: the reference's own
   error (the same spectrum of its difference to DOP853 at rtol 1e-12) and the window's leakage
   of the largest peak.
2. The axial rates' local error over one sample interval (0.1 s), started from reference
   states (every 7th interval), in fixed steps of the interval over 1, 2, 4, 8, 16, in units of
   rtol 1e-8, atol 1e-10 (``error / (1e-8 |x| + 1e-10)``), median and largest over the intervals:
   with one Jacobian frozen at the start (as the integrator keeps it) and with the exact Jacobian
   taken anew at each step's start (an exponential Rosenbrock scheme of the same stages). The
   reference is DOP853 at rtol 1e-11, atol 1e-13: measured with finer fixed steps (0.0031 s, the
   exact Jacobian) the difference falls to 1.4e-3 of these units, so its own error is below that.

If the error came from the frozen Jacobian's age, the second column would fall to the tolerance;
if from the polynomial quadrature of the forcing's high frequencies, both stay flat until the
step resolves them.
"""

from __future__ import annotations

import numpy as np

BANDS = ((0.0, 50.0), (50.0, 150.0), (150.0, 250.0), (250.0, 270.0), (270.0, 290.0), (290.0, 600.0))


def _axial_rates(case, mode: int) -> list[int]:
    return [case.model.states.index(f"{name}.eta{mode}_rate") for name in ("array_left", "array_right")]


def fixed_stepper(form, pv, **options):
    """The exponential integrator's stepper in the momentum form ``form`` with tolerances too
    loose to reject a step and the fast eigenvalues' correction wherever ``|lambda| h > 10``;
    ``options`` as :func:`~linflex.simulation._steppers.momentum_stepper`'s (``jacobian0``)."""
    from linflex.simulation._steppers import IntegratorCounts, momentum_stepper

    return momentum_stepper(form, pv, 1e3, 1e3, IntegratorCounts(), fast_negligible=0.0, **options)


def fixed_steps(form, pv, times, z0, U, fresh: bool, frozen=None) -> np.ndarray:
    """The exponential integrator's states at ``times[1:]`` from ``z0`` in a model's momentum form
    ``form`` (parameter values ``pv``), in fixed steps (tolerances too loose to reject one; the
    fast eigenvalues' correction wherever ``|lambda| h > 10``), ``U[k]`` held over step ``k``:
    with one Jacobian frozen at the first step's start (the stepper ``frozen`` where given: its
    Jacobian carries over from earlier calls), or (``fresh``) a Jacobian and its matrix functions
    taken anew at the start of every step (an exponential Rosenbrock scheme of the same stages)."""
    if not fresh:
        return (frozen or fixed_stepper(form, pv))(times, z0, U)
    Z, z = [], z0
    for k in range(U.shape[0]):
        z = fixed_stepper(form, pv)(times[k:k + 2], z, U[k:k + 1])[0]
        Z.append(z)
    return np.asarray(Z)


def _local_errors(case, reference, sub: int, fresh: bool, rows: list[int], every: int = 7) -> np.ndarray:
    """The largest error of the states ``rows`` after one sample interval in ``sub`` fixed steps
    (:func:`fixed_steps`), each interval started from the reference, in units of rtol 1e-8,
    atol 1e-10."""
    from linflex.simulation._momentum import momentum_form

    model, pv = case.model, case.model.param_values
    form = momentum_form(model)
    J0 = form.jacobian(form.to_z(model.x0, pv, 0.0), case.pulse, pv, 0.0).full()
    frozen = fixed_stepper(form, pv, jacobian0=J0)
    errors = []
    for k in range(1, case.timepts.size - 1, every):
        t = case.timepts[k]
        times = np.linspace(t, case.timepts[k + 1], sub + 1)
        z = fixed_steps(form, pv, times, form.to_z(reference[k], pv, t), case.held(times[:-1]), fresh, frozen)[-1]
        x = form.to_x(z[None], pv, times[-1:])[0]
        floor = 1e-8 * np.abs(reference[k + 1]) + 1e-10
        errors.append(float(np.max(np.abs(x - reference[k + 1])[rows] / floor[rows])))
    return np.array(errors)


def axial_forcing_table(case, reference, mode: int, frequency: float, window=(4.0, 14.0)) -> None:
    """Print the two tables of the module docstring for the axial mode ``mode`` of the arrays
    (frequency [rad/s], to find its eigenvalue of the Jacobian at the start)."""
    from scipy.integrate import solve_ivp

    model = case.model
    J0 = case.jac(model.x0, case.pulse).full()
    lam, V = np.linalg.eig(J0)
    j = int(np.argmin(np.abs(lam - 1j * frequency)))
    w = np.linalg.solve(V, np.eye(lam.size))[j]           # its left eigenvector (row of V^-1)
    zero = np.zeros_like(case.pulse)
    start = case.timepts.searchsorted(window[0])
    dt = 5e-4
    t = np.arange(window[0], window[1], dt)

    def forcing(rtol: float) -> np.ndarray:
        run = solve_ivp(lambda _, x: case.fnum(x, zero).full().ravel(), window, reference[start], method="DOP853",
                        t_eval=t, rtol=rtol, atol=rtol * 1e-2)
        return np.array([w @ (case.fnum(x, zero).full().ravel() - J0 @ x) for x in run.y.T])

    hann = np.hanning(t.size)
    omega = 2 * np.pi * np.abs(np.fft.fftfreq(t.size, dt))

    def spectrum(signal: np.ndarray) -> np.ndarray:
        return np.abs(np.fft.fft((signal - signal.mean()) * hann)) / hann.sum() * 2

    def band_maxima(amplitude: np.ndarray, at: bool, skip: float | None = None) -> list[str]:
        out = []
        for lo, hi in BANDS:
            band = (omega >= lo) & (omega < hi)
            if skip is not None and lo <= skip < hi:
                out.append("(the peak's band)")
                continue
            k = int(np.argmax(np.where(band, amplitude, -1.0)))
            out.append(f"{amplitude[k]:.1e}" + (f" at {omega[k]:.0f}" if at else ""))
        return out

    N, finer = forcing(1e-11), forcing(1e-12)
    amplitude = spectrum(N)
    # the largest peak as a pure sinusoid at its interpolated frequency (a parabola through the
    # log amplitudes of its bin and the neighbours), through the same window: its leakage
    k = int(np.argmax(amplitude[: t.size // 2]))
    a, b, c = np.log(amplitude[max(k - 1, 0)]), np.log(amplitude[k]), np.log(amplitude[k + 1])
    shift = 0.5 * (a - c) / (a - 2 * b + c) if a - 2 * b + c < 0 else 0.0
    f_peak = (k + shift) / (t.size * dt)
    leak = spectrum(amplitude[k] * np.cos(2 * np.pi * f_peak * (t - t[0])))
    print(f"\nThe axial mode's forcing (mode {mode}, {abs(lam[j]):.1f} rad/s): its left eigenvector of the "
          f"Jacobian at the start times N = f - J0 x along DOP853 (rtol 1e-11) every {dt * 1e3:g} ms over "
          f"t = {window[0]:g} to {window[1]:g} s; the largest amplitude in each band, and what the measurement "
          "resolves: the reference's own error (the spectrum of its difference to DOP853 at rtol 1e-12) and the "
          "Hann window's leakage of the largest peak (a sinusoid of its amplitude and frequency through the "
          "same window); a band's value above both is the forcing's")
    print("| band [rad/s] | " + " | ".join(f"{lo:g}-{hi:g}" for lo, hi in BANDS) + " |")
    print("|---|" + "---|" * len(BANDS))
    print("| largest amplitude at [rad/s] | " + " | ".join(band_maxima(amplitude, True)) + " |")
    print("| the reference's error | " + " | ".join(band_maxima(spectrum(N - finer), False)) + " |")
    print(f"| leakage of the peak at {2 * np.pi * f_peak:.2f} rad/s | " + " | ".join(band_maxima(leak, False, 2 * np.pi * f_peak)) + " |")
    rows = _axial_rates(case, mode)
    h0 = float(case.timepts[1] - case.timepts[0])
    print("\nThe axial rates' local error over one sample interval in fixed steps, from DOP853 states "
          "(every 7th interval), in units of rtol 1e-8, atol 1e-10: median / largest over the intervals")
    print("| step [s] | abs(lambda) h | one frozen Jacobian | the exact Jacobian at each step's start |")
    print("|---|---|---|---|")
    for sub in (1, 2, 4, 8, 16):
        frozen = _local_errors(case, reference, sub, False, rows)
        fresh = _local_errors(case, reference, sub, True, rows)
        print(f"| {h0 / sub:g} | {abs(lam[j]) * h0 / sub:.1f} | {np.median(frozen):.2g} / {frozen.max():.2g} "
              f"| {np.median(fresh):.2g} / {fresh.max():.2g} |", flush=True)
