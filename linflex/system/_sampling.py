"""Sampling and delays of linear systems: ``discretize``, ``pade`` and the exact maps the layers share.

- :func:`discretize` samples a continuous system (zero- or first-order hold, Tustin with optional
  prewarping, matched poles and zeros), the zero-order hold exactly even for an input delay that
  is not a whole number of periods (Franklin, Powell and Workman, "Digital Control of Dynamic
  Systems", 3rd ed., 1998, section 4.3.3: one extra state per delayed input holds the previous
  sample).
- :func:`pade` replaces every delay by a rational system: a diagonal Pade approximation of
  ``exp(-s tau)`` in continuous time, with an a-posteriori error bound; the exact shift register
  ``z^-k`` in discrete time (no approximation).
- :func:`w_plane` is the bilinear map ``z = (1 + s T/2) / (1 - s T/2)`` of a discrete system to a
  continuous one whose imaginary axis is the unit circle: the frequency-domain layers analyse a
  sampled system through it with the continuous engine, exactly (no approximation: the value at
  ``j nu`` is the value at ``z = exp(j omega T)`` with ``omega = (2/T) arctan(nu T/2)``).
- :func:`delay_factors` is the exact ``exp(-j omega (tau_out + tau_in))`` of every channel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ._errors import ModelError
from ._linear import LinearSystem, as_linear_system
from ._signals import check_positive

__all__ = [
    "DISCRETIZE_METHODS", "PadeApproximation", "delay_factors", "discretize", "from_w_frequency", "pade",
    "to_w_frequency", "w_plane",
]

#: Methods of :func:`discretize`.
DISCRETIZE_METHODS = ("zoh", "foh", "tustin", "matched")


def _whole_periods(delays: NDArray, dt: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``delays`` [s] split into whole periods ``N dt`` and the fractional rest in ``[0, dt)``."""
    periods = delays / dt
    whole = np.floor(periods + 1e-9 * np.maximum(1.0, periods))
    rest = delays - whole * dt
    rest = np.where(rest > 1e-9 * dt, rest, 0.0)  # a whole number of periods up to the round-off of tau / dt
    return whole, rest


def discretize(sys, dt: float, method: str = "zoh", *, prewarp: float | None = None) -> LinearSystem:
    """Sample a continuous-time linear system with period ``dt`` [s].

    Parameters
    ----------
    sys : LinearSystem or any system :func:`~linflex.as_linear_system` accepts
        A continuous-time system, with input and output delays [s] allowed (see Notes).
    dt : float
        Sampling period [s].
    method : {"zoh", "foh", "tustin", "matched"}
        ``"zoh"``: zero-order hold, exact at the samples for inputs held over each period
        (``scipy.signal.cont2discrete``); ``"foh"``: first-order (triangle) hold; ``"tustin"``:
        the bilinear substitution ``s = (2/dt) (z - 1)/(z + 1)``; ``"matched"``: poles and zeros
        mapped by ``z = exp(s dt)`` (python-control's ``sample_system`` convention, single-input
        single-output systems only), the gain matched at DC, or for poles or zeros at ``s = 0``
        on the lowest power of ``s`` there (``s`` as ``(z - 1) / dt``).
    prewarp : float, optional
        For ``"tustin"`` only: the frequency [rad/s] at which the discrete response equals the
        continuous one (``s = (w0 / tan(w0 dt/2)) (z - 1)/(z + 1)``); below the Nyquist
        frequency ``pi / dt``.

    Returns
    -------
    LinearSystem
        The discrete system with ``dt`` [s] and the same input, output and state names (the
        state units are kept: for ``"zoh"`` the state at sample ``k`` is the continuous state at
        ``t = k dt``; ``"matched"`` builds a new realization, with default state names). A fractional input delay adds one state per delayed input, named
        ``"<input>.held"`` (the previous input sample, in the input's unit); whole periods of
        delay stay in ``input_delay`` and ``output_delay`` [s].

    Raises
    ------
    ModelError
        For a discrete system, an unknown method, ``prewarp`` with another method or at or
        beyond the Nyquist frequency, ``"matched"`` on a multivariable system, a delay that is
        not a whole number of periods with a method other than ``"zoh"``, or an output delay
        that is not a whole number of periods (move it to the input of a loop, where delays add).

    Notes
    -----
    Zero-order hold of an input delayed by ``tau = N dt + f`` with ``0 < f < dt`` (Franklin,
    Powell and Workman 1998, section 4.3.3): over one period the input is ``u[k-1]`` for
    ``f`` seconds, then ``u[k]``, so ::

        x[k+1] = Phi x[k] + G1 u[k-1] + G0 u[k]       Phi = expm(A dt)
        G0 = int_0^(dt-f) expm(A s) ds B              G1 = expm(A (dt - f)) int_0^f expm(A s) ds B

    with ``u[k-1]`` held as a state, and the ``N`` whole periods kept as the discrete
    ``input_delay``: exact at the sample instants. The output at ``t = k dt`` sees the input
    ``u[k-1]`` through ``D`` when ``f > 0``.

    Examples
    --------
    A double integrator ``1 / s^2`` under a zero-order hold at 10 Hz: ``Phi = [[1, dt], [0, 1]]``,
    ``Gamma = [dt^2/2, dt]``:

    >>> from linflex import LinearSystem, discretize
    >>> d = discretize(LinearSystem([[0, 1], [0, 0]], [[0], [1]], [[1, 0]]), 0.1)
    >>> d.A.round(12).tolist(), d.B.round(12).ravel().tolist(), d.dt
    ([[1.0, 0.1], [0.0, 1.0]], [0.005, 0.1], 0.1)
    """
    lin = as_linear_system(sys, "sys", delay=True)
    T = check_positive(dt, "dt")   # the sampling period [s]
    if method not in DISCRETIZE_METHODS:
        raise ModelError(f"method must be one of {DISCRETIZE_METHODS}, got {method!r}")
    if prewarp is not None:
        if method != "tustin":
            raise ModelError(f"prewarp is a frequency of the 'tustin' method, not of {method!r}")
        w0 = check_positive(prewarp, "prewarp")
        if not w0 < math.pi / T:
            raise ModelError(
                f"prewarp must be a frequency in (0, pi/dt) = (0, {math.pi / T:.6g}) rad/s, got {prewarp!r}"
            )
    in_whole, in_rest = _whole_periods(lin.input_delay, T)
    out_whole, out_rest = _whole_periods(lin.output_delay, T)
    if out_rest.any():
        i = int(np.flatnonzero(out_rest)[0])
        raise ModelError(
            f"output_delay[{i}] = {lin.output_delay[i]} s is not a whole number of periods (dt = {T} s): "
            f"discretize holds fractional delays on the inputs only; in a loop, move the delay to the "
            f"plant input (delays around a loop add up)"
        )
    if in_rest.any() and method != "zoh":
        raise ModelError(
            f"input delays that are not whole periods (dt = {T} s) are discretized exactly by method='zoh' "
            f"only, got method={method!r}"
        )
    base = lin.with_(input_delay=None, output_delay=None)
    if method == "zoh":
        result = _zoh(base, T, in_rest)
    elif method == "matched":
        result = _matched(base, T)
    else:
        import scipy.signal

        if method == "foh":
            A, B, C, D, _ = scipy.signal.cont2discrete((base.A, base.B, base.C, base.D), T, method="foh")
        else:
            # prewarped Tustin is the plain bilinear map with the period 2 tan(w0 T/2) / w0
            Tw = T if prewarp is None else 2.0 * math.tan(0.5 * w0 * T) / w0
            try:
                A, B, C, D, _ = scipy.signal.cont2discrete((base.A, base.B, base.C, base.D), Tw, method="bilinear")
            except np.linalg.LinAlgError as err:   # I - A Tw/2 singular
                raise ModelError(
                    f"method='tustin': sys has a pole at s = 2/{'(2 tan(prewarp dt/2)/prewarp)' if prewarp else 'dt'} "
                    f"= {2.0 / Tw:.6g} rad/s, which the bilinear map sends to z = infinity; use another dt or method"
                ) from err
        result = LinearSystem(A, B, C, D, states=base.states, inputs=base.inputs, outputs=base.outputs, dt=T)
    return result.with_(input_delay=in_whole * T, output_delay=out_whole * T)


def _hold_integrals(A: NDArray, B: NDArray, h: float) -> tuple[NDArray, NDArray]:
    """``expm(A h)`` and ``int_0^h expm(A s) ds B`` from one exponential (Van Loan 1978)."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = scipy.linalg.expm(h * M)
    return E[:n, :n], E[:n, n:]


def _zoh(sys: LinearSystem, T: float, rest: NDArray) -> LinearSystem:
    n, m = sys.n_states, sys.n_inputs
    Phi, Gamma = _hold_integrals(sys.A, sys.B, T)
    late = np.flatnonzero(rest > 0)
    if not late.size:
        return LinearSystem(Phi, Gamma, sys.C, sys.D, states=sys.states, inputs=sys.inputs, outputs=sys.outputs, dt=T)
    k = late.size
    G0, G1 = Gamma.copy(), np.zeros((n, k))
    for col, j in enumerate(late):
        E, g0 = _hold_integrals(sys.A, sys.B[:, [j]], T - rest[j])
        _, g = _hold_integrals(sys.A, sys.B[:, [j]], rest[j])
        G0[:, [j]] = g0
        G1[:, [col]] = E @ g
    A = np.zeros((n + k, n + k))
    A[:n, :n], A[:n, n:] = Phi, G1
    B = np.zeros((n + k, m))
    B[:n] = G0
    B[n + np.arange(k), late] = 1.0
    C = np.hstack([sys.C, sys.D[:, late]])
    D = sys.D.copy()
    D[:, late] = 0.0
    states = list(sys.states) + [f"{sys.inputs[j]}.held" for j in late]
    return LinearSystem(A, B, C, D, states=states, inputs=sys.inputs, outputs=sys.outputs, dt=T)


def _matched(sys: LinearSystem, T: float) -> LinearSystem:
    """Poles and zeros mapped by ``z = exp(s T)`` (python-control's ``sample_system(method="matched")``
    convention: no zeros added at ``z = -1``), the gain matched at low frequency.

    python-control matches the DC gain, which is infinite (or zero) with a pole (or zero) at
    ``s = 0``: its result is then nan, realized as an empty zero system. Here the gain matches
    the lowest power of ``s`` at the origin (Franklin, Powell and Workman 1998, section 6.3.2:
    ``(z - 1) / T`` for ``s``): with ``g(p) = (exp(p T) - 1) / p`` (``T`` at ``p = 0``, by
    ``expm1`` without cancellation), ``K_d = K prod g(poles) / prod g(zeros)``, which is the DC
    match wherever that exists.
    """
    import control
    import scipy.signal

    from ._realization import siso_realization

    if sys.shape != (1, 1):
        raise ModelError(f"method='matched' maps the poles and zeros of a SISO system; sys has shape {sys.shape}")
    tf = control.ss2tf(control.ss(sys.A, sys.B, sys.C, sys.D))
    if not np.any(tf.num[0][0]):  # the zero system has no poles and zeros to map
        return LinearSystem(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.zeros((1, 1)),
                            inputs=sys.inputs, outputs=sys.outputs, dt=T)
    zeros, poles, gain = scipy.signal.tf2zpk(np.asarray(tf.num[0][0], float), np.asarray(tf.den[0][0], float))

    def g(r: NDArray) -> NDArray:
        r = np.asarray(r, dtype=complex)
        safe = np.where(r == 0, 1.0, r)
        return np.where(r == 0, T, np.expm1(r * T) / safe)

    kd = gain * np.prod(g(poles)) / np.prod(g(zeros))
    num = np.real(kd * np.atleast_1d(np.poly(np.exp(zeros * T))))
    den = np.real(np.atleast_1d(np.poly(np.exp(poles * T))))
    A, B, C, D = siso_realization(num, den, "sys")
    return LinearSystem(A, B, C, D, inputs=sys.inputs, outputs=sys.outputs, dt=T)


# ----------------------------------------------------------------------------------------------
# Pade


@dataclass(frozen=True, eq=False)
class PadeApproximation:
    """Result of :func:`pade`: a rational system in place of a delayed one, with its error.

    Attributes
    ----------
    sys : LinearSystem
        The system without delays: the original states, then the delay states (named
        ``"<input>.delay<k>"`` and ``"<output>.delay<k>"``, dimensionless scaled copies of the
        channel's signal).
    order : int
        Degree of each diagonal Pade approximation (numerator and denominator); for a discrete
        system the number of periods of each shift register instead (exact).
    bandwidth : float
        Upper end [rad/s] of the band ``[0, bandwidth]`` over which ``error_estimate`` holds.
    error_estimate : float
        Bound [-] of the relative error ``||G_exact(jw) - G_pade(jw)||_2 / ||G(jw)||_2`` at every
        ``w`` in the band, with ``G`` the undelayed transfer matrix. Each diagonal Pade
        approximant ``P`` is all-pass (``|P(jw)| = 1``) and the delays are diagonal, so
        ``||G_exact - G_pade|| <= (d_out + d_in) ||G||`` with ``d = max |exp(-jw tau) - P(jw)|
        = 2 |sin(e / 2)|`` for the phase error ``e`` of the largest input (output) delay. The
        phase error of a diagonal Pade approximant grows with frequency (its group delay stays
        below the delay; :func:`pade` checks the slope on 4096 points of the band), so its largest
        value over the band is the one at ``bandwidth``; otherwise the maximum over the points
        plus a Lipschitz term for the gaps is used. 0 for a discrete system (its shift registers
        are exact).
    phase_error : float
        Phase error [rad] of the largest delay's approximant at ``bandwidth``.
    frequency_limit : float
        Frequency [rad/s] up to which every approximant's phase error stays below ``phase_tol``
        (``inf`` when there is no delay or the system is discrete).
    phase_tol : float
        The phase tolerance [rad] of ``frequency_limit``.
    method : str
        ``"pade"`` (continuous) or ``"shift register"`` (discrete, exact).
    """

    sys: LinearSystem
    order: int
    bandwidth: float
    error_estimate: float
    phase_error: float
    frequency_limit: float
    phase_tol: float
    method: str


def _pade_unit(order: int) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """A state-space realization of the diagonal Pade approximation of ``exp(-s)`` (python-control's ``pade``)."""
    import control
    import scipy.signal

    num, den = control.pade(1.0, order)
    return scipy.signal.tf2ss(num, den)


def _pade_phase_error(order: int, x: NDArray) -> NDArray[np.float64]:
    """Phase error ``x + arg P(jx)`` [rad] of the unit-delay approximant, unwrapped from 0."""
    import control

    num, den = control.pade(1.0, order)
    P = np.polyval(num, 1j * x) / np.polyval(den, 1j * x)
    return np.unwrap(np.angle(P * np.exp(1j * x)))


def _pade_phase_slope(order: int, x: NDArray) -> NDArray[np.float64]:
    """``d e / dx = 1 + Re(num'/num - den'/den)(jx)`` of the unit approximant's phase error."""
    import control

    num, den = control.pade(1.0, order)
    jx = 1j * x
    return 1.0 + np.real(np.polyval(np.polyder(num), jx) / np.polyval(num, jx)
                         - np.polyval(np.polyder(den), jx) / np.polyval(den, jx))


def _pade_lipschitz(order: int) -> float:
    """Bound of ``|d e / dx|`` for the phase error of the unit approximant: ``1 + 2 sum 1/|Re p|``."""
    import control

    _, den = control.pade(1.0, order)
    p = np.roots(den)
    return 1.0 + 2.0 * float(np.sum(1.0 / np.abs(p.real)))


def _shift_register(k: int) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    A = np.eye(k, k, -1)
    B = np.zeros((k, 1))
    B[0, 0] = 1.0
    C = np.zeros((1, k))
    C[0, -1] = 1.0
    return A, B, C, np.zeros((1, 1))


def _channel_blocks(delays: NDArray, names, realize) -> tuple[NDArray, NDArray, NDArray, NDArray, list[str]]:
    """Block-diagonal realization of the delays of a set of channels (identity where undelayed)."""
    q = delays.size
    As, Bs, Cs, Ds, states = [], [], [], [], []
    for j in range(q):
        if delays[j] > 0:
            A, B, C, D = realize(delays[j])
            As.append(A)
            Bs.append(B)
            Cs.append(C)
            Ds.append(D)
            states += [f"{names[j]}.delay{i}" for i in range(A.shape[0])]
        else:
            As.append(np.zeros((0, 0)))
            Bs.append(np.zeros((0, 1)))
            Cs.append(np.zeros((1, 0)))
            Ds.append(np.ones((1, 1)))
    n = sum(a.shape[0] for a in As)
    if not q:
        return np.zeros((0, 0)), np.zeros((0, 0)), np.zeros((0, 0)), np.zeros((0, 0)), states
    A = scipy.linalg.block_diag(*As) if n else np.zeros((0, 0))
    B = scipy.linalg.block_diag(*Bs) if n else np.zeros((0, q))
    C = scipy.linalg.block_diag(*Cs) if n else np.zeros((q, 0))
    D = scipy.linalg.block_diag(*Ds)
    return A.reshape(n, n), B.reshape(n, q), C.reshape(q, n), D.reshape(q, q), states


def delay_free(sys: LinearSystem, realize) -> LinearSystem:
    """``sys`` with each channel delay replaced by the system ``realize(tau)`` in series."""
    Ai, Bi, Ci, Di, si = _channel_blocks(sys.input_delay, sys.inputs, realize)
    Ao, Bo, Co, Do, so = _channel_blocks(sys.output_delay, sys.outputs, realize)
    A, B, C, D = sys.A, sys.B, sys.C, sys.D
    n, ni, no = A.shape[0], Ai.shape[0], Ao.shape[0]
    # x' = A x + B (Ci xi + Di u), xi' = Ai xi + Bi u, y0 = C x + D (Ci xi + Di u),
    # xo' = Ao xo + Bo y0, y = Co xo + Do y0
    C0 = np.hstack([C, D @ Ci, np.zeros((C.shape[0], no))])
    D0 = D @ Di
    Af = np.zeros((n + ni + no, n + ni + no))
    Af[:n, :n], Af[:n, n:n + ni] = A, B @ Ci
    Af[n:n + ni, n:n + ni] = Ai
    Af[n + ni:, :] = Bo @ C0
    Af[n + ni:, n + ni:] += Ao
    Bf = np.vstack([B @ Di, Bi, Bo @ D0])
    Cf = Do @ C0
    Cf[:, n + ni:] += Co
    return LinearSystem(Af, Bf, Cf, Do @ D0, states=list(sys.states) + si + so, inputs=sys.inputs,
                        outputs=sys.outputs, dt=sys.dt)


def pade(sys, order: int, *, bandwidth: float | None = None, phase_tol: float = math.radians(1.0)) -> PadeApproximation:
    """Replace every input and output delay by a rational system, with the error reported.

    Parameters
    ----------
    sys : LinearSystem or any system :func:`~linflex.as_linear_system` accepts
        A system with delays [s] (one without delays is returned unchanged, error 0).
    order : int
        Degree (numerator = denominator) of the diagonal Pade approximation of each
        ``exp(-s tau)`` (python-control's ``pade``), 1 to 10. Ignored for a discrete system,
        whose delays of ``k`` periods become exact ``k``-state shift registers ``z^-k``.
    bandwidth : float, optional
        Upper end [rad/s] of the band over which the error is bounded. Default: the largest
        modulus of the system's eigenvalues (at least ``1 / max delay``).
    phase_tol : float, optional
        Phase error [rad] that defines ``frequency_limit``. Default 1 deg.

    Returns
    -------
    PadeApproximation
        ``sys`` (rational), ``error_estimate`` (relative bound [-] over ``[0, bandwidth]``),
        ``phase_error`` [rad] at ``bandwidth`` and ``frequency_limit`` [rad/s].

    Raises
    ------
    ModelError
        For an order outside 1 to 10 or a non-positive ``bandwidth`` or ``phase_tol``.

    Examples
    --------
    A 0.1 s delay on a first-order lag, second-order Pade: the phase stays within 1 deg up to
    about 17 rad/s.

    >>> from linflex import LinearSystem, pade
    >>> p = pade(LinearSystem([[-1.0]], [[1.0]], [[1.0]], input_delay=0.1), 2, bandwidth=10.0)
    >>> p.sys.n_states, round(p.frequency_limit, 1), bool(p.error_estimate < 0.01)
    (3, 17.2, True)
    """
    lin = as_linear_system(sys, "sys", discrete=True, delay=True)
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or not 1 <= order <= 10:
        raise ModelError(f"order must be an integer from 1 to 10, got {order!r}")
    order = int(order)
    tol = check_positive(phase_tol, "phase_tol")
    if not tol < math.pi:
        raise ModelError(f"phase_tol must be an angle in (0, pi) rad, got {phase_tol!r}")
    tau_in = float(lin.input_delay.max(initial=0.0))
    tau_out = float(lin.output_delay.max(initial=0.0))
    tau = max(tau_in, tau_out)
    if bandwidth is None:
        eig = np.abs(np.linalg.eigvals(lin.A)) if lin.n_states else np.zeros(0)
        band = max(float(eig.max(initial=0.0)), 1.0 / tau if tau > 0 else 1.0)
    else:
        band = check_positive(bandwidth, "bandwidth")
    if lin.is_discrete:
        T = lin.dt
        rational = delay_free(lin, lambda d: _shift_register(int(round(d / T))))
        return PadeApproximation(rational, order, band, 0.0, 0.0, math.inf, tol, "shift register")
    A1, B1, C1, D1 = _pade_unit(order)
    rational = delay_free(lin, lambda d: (A1 / d, B1 / d, C1, D1))
    if tau == 0:
        return PadeApproximation(rational, order, band, 0.0, 0.0, math.inf, tol, "pade")
    lipschitz = _pade_lipschitz(order)

    def worst(t: float) -> tuple[float, float]:
        if t == 0:
            return 0.0, 0.0
        x = np.linspace(0.0, band * t, 4096)
        e = np.abs(_pade_phase_error(order, x))
        if e[-1] < np.pi and np.all(_pade_phase_slope(order, x) >= -1e-12):
            # the phase error grows monotonically over the band: its largest value is at the end
            return 2.0 * math.sin(0.5 * float(e[-1])), float(e[-1])
        d = np.where(e >= np.pi, 2.0, 2.0 * np.abs(np.sin(0.5 * e)))
        return min(2.0, float(d.max()) + lipschitz * (x[1] - x[0])), float(e[-1])

    d_in, _ = worst(tau_in)
    d_out, _ = worst(tau_out)
    _, phase_at_band = worst(tau)
    return PadeApproximation(rational, order, band, float(d_in + d_out), phase_at_band,
                             _phase_limit(order, tol) / tau, tol, "pade")


def _phase_limit(order: int, tol: float) -> float:
    """Smallest ``x = w tau`` where the unit approximant's phase error reaches ``tol`` [rad]."""
    import scipy.optimize

    x = np.linspace(0.0, 4.0 * order + 8.0, 8192)
    e = np.abs(_pade_phase_error(order, x))
    k = int(np.argmax(e >= tol))
    return float(scipy.optimize.brentq(lambda v: abs(float(_pade_phase_error(order, np.array([0.0, v]))[-1])) - tol,
                                       x[k - 1], x[k], xtol=1e-14))


# ----------------------------------------------------------------------------------------------
# The exact maps the frequency-domain layers share


def delay_factors(sys: LinearSystem, omega: ArrayLike) -> NDArray[np.complex128] | None:
    """``exp(-j omega (tau_out_i + tau_in_j))`` per channel, shape ``(n_omega, p, m)``; None without delays.

    Parameters
    ----------
    sys : LinearSystem
        The system, continuous or discrete (whole-period delays: ``z^-k = exp(-j omega k dt)``
        on the unit circle).
    omega : array_like
        Frequencies [rad/s].

    Returns
    -------
    ndarray of complex or None
        The factors [-] that multiply ``G(j omega)`` (or ``G(exp(j omega dt))``).
    """
    if not sys.has_delay:
        return None
    w = np.asarray(omega, dtype=float)
    tau = sys.output_delay[:, None] + sys.input_delay[None, :]
    return np.exp(-1j * w[:, None, None] * tau[None, :, :])


def w_plane(sys: LinearSystem) -> tuple[LinearSystem, float]:
    """The continuous system ``G_w(s) = G(z)`` at ``z = (1 + s T/2) / (1 - s T/2)`` of a discrete ``G``.

    With ``a = 2/T`` and ``M = I + A`` (invertible unless ``z = -1`` is a pole) ::

        A_w = a M^-1 (A - I)      B_w = sqrt(2a) M^-1 B
        C_w = sqrt(2a) C M^-1     D_w = D - C M^-1 B = G(-1)

    The unit circle maps onto the imaginary axis (``z = exp(j omega T)`` to ``s = j nu``,
    ``nu = (2/T) tan(omega T/2)``) and the outside of the disk onto the right half-plane, so
    poles outside the unit circle become right half-plane poles and the magnitude, the phase and
    every encirclement are unchanged. Whole-period delays are first realized as exact shift
    registers. Returns the map and ``cond(M)`` (the rounding of the map is about ``eps cond(M)``).

    Raises
    ------
    ModelError
        If ``z = -1`` is a pole (an undamped oscillation at the Nyquist frequency: its image is a
        pole at infinity, which no state space holds).
    """
    if sys.has_delay:
        sys = delay_free(sys, lambda d: _shift_register(int(round(d / sys.dt))))
    T = sys.dt
    n = sys.n_states
    a = 2.0 / T
    M = np.eye(n) + sys.A
    cond = float(np.linalg.cond(M)) if n else 1.0
    if not math.isfinite(cond) or cond > 1.0 / (n * np.finfo(float).eps + np.finfo(float).tiny):
        raise ModelError(
            f"the discrete system has a pole at z = -1 (an undamped oscillation at the Nyquist frequency "
            f"pi/dt = {math.pi / T:.6g} rad/s): its frequency response is infinite there and the bilinear "
            f"map to the continuous engine has no state space"
        )
    if n == 0:
        return LinearSystem(sys.A, sys.B, sys.C, sys.D, inputs=sys.inputs, outputs=sys.outputs), 1.0
    lu = scipy.linalg.lu_factor(M)
    MB = scipy.linalg.lu_solve(lu, sys.B)
    CM = scipy.linalg.lu_solve(lu, sys.C.T, trans=1).T
    Aw = a * scipy.linalg.lu_solve(lu, sys.A - np.eye(n))
    r = math.sqrt(2.0 * a)
    return LinearSystem(Aw, r * MB, r * CM, sys.D - sys.C @ MB, states=sys.states, inputs=sys.inputs,
                        outputs=sys.outputs), cond


def to_w_frequency(omega: ArrayLike, dt: float) -> NDArray[np.float64]:
    """``nu = (2/dt) tan(omega dt / 2)`` [rad/s]: a real frequency of a sampled system on the w-plane axis."""
    return (2.0 / dt) * np.tan(0.5 * np.asarray(omega, dtype=float) * dt)


def from_w_frequency(nu: ArrayLike, dt: float) -> NDArray[np.float64]:
    """``omega = (2/dt) arctan(nu dt / 2)`` [rad/s], the inverse of :func:`to_w_frequency`."""
    return (2.0 / dt) * np.arctan(0.5 * np.asarray(nu, dtype=float) * dt)
