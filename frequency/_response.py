"""Frequency response: fast structured evaluation and a pole- and zero-aware frequency grid.

Evaluation (``G(jw) = D + C (jwI - A)^-1 B``) never forms ``jwI - A`` per frequency in the fast
path. The default is a block-diagonal modal form: eigenvalues that are ill-conditioned (defective
rigid-body double integrators, near-repeated clusters) are split off from an ordered complex Schur
form by a Sylvester equation and evaluated as one small dense block; the rest is diagonal. Every
point whose estimated rounding error exceeds the tolerance is evaluated again from the
Hessenberg form (one banded LU per frequency, LAPACK ``gbsv``), which is backward stable.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from linflex import AccuracyWarning, LinearSystem, ModelError, SecondOrderSystem
from linflex.system import check_positive, from_w_frequency, to_w_frequency

from ._checks import checked_omega, checked_system, sampled_omega
from ._evaluate import WARN_RTOL
from ._modal_forms import ZERO_SCALE
from ._sampled import axis_evaluator, engine_system
from ._spectrum import avoid_axis_poles, classify

__all__ = ["FrequencyResponse", "frequency_response", "frequency_grid"]



@dataclass(frozen=True)
class FrequencyResponse:
    """Frequency response of a linear system.

    Attributes
    ----------
    omega : numpy.ndarray, shape (n_omega,)
        Frequencies [rad/s], increasing.
    response : numpy.ndarray of complex, shape (n_omega, n_outputs, n_inputs)
        ``G(j omega)`` in the units of the outputs over the inputs.
    outputs, inputs : tuple of str
        Signal names.
    method : str
        Evaluation actually used: ``"modal"``, ``"second_order_modal"`` (a classically damped
        :class:`~linflex.SecondOrderSystem`), ``"schur"`` (triangular solves in the complex Schur
        form, when there is no usable modal form), ``"hessenberg"``, ``"direct"``, or a
        combination such as ``"modal+schur"`` (some points re-evaluated from the Schur form).
    error_estimate : float
        A-posteriori estimate [-] of the largest normwise relative error ``max|G - G_exact| /
        max|G_exact|`` over the points, on every path (see ``frequency/_evaluate.py``): for
        the Hessenberg and direct solves the backward error ``c eps ||A||`` mapped through the
        adjoint solution, ``c eps ||A|| ||(sI - A)^-H C^H|| ||(sI - A)^-1 B|| / max|G|``; for the
        modal form the rounding of the modal sum plus the first-order effect of the eigenvalue
        errors. ``inf`` where ``j omega I - A`` is singular (a pole on a grid point). An
        :class:`~linflex.AccuracyWarning` names the frequency and the cause when it exceeds
        1e-4.
    grid : str
        ``"user"`` when ``omega`` was given, else ``"auto"``.
    peak_resolution_db : float
        For an automatic grid: the largest predicted gap [dB] between a grid extremum (resonance
        peak or notch) and the true extremum, from a local parabola fit after refinement; ``nan``
        for a user grid.
    n_evaluations : int
        Number of frequencies evaluated (including refinement rounds).
    seconds : float
        Wall time of the computation [s].
    dt : float or None
        Sampling period [s] of a discrete-time system (``response`` is ``G(exp(j omega dt))``,
        ``omega`` up to the Nyquist frequency ``pi / dt``); None for a continuous one.
    """

    omega: NDArray[np.float64]
    response: NDArray[np.complex128]
    outputs: tuple[str, ...]
    inputs: tuple[str, ...]
    method: str
    error_estimate: float
    grid: str
    peak_resolution_db: float
    n_evaluations: int
    seconds: float
    dt: float | None = None

    def _display_fields(self):
        return [("n_omega", self.omega.size),
                ("omega [rad/s]", f"{self.omega[0]:.4g} to {self.omega[-1]:.4g}" if self.omega.size else "-"),
                ("outputs", self.outputs), ("inputs", self.inputs), ("method", self.method), ("grid", self.grid),
                ("error_estimate", self.error_estimate), ("peak_resolution_db", self.peak_resolution_db),
                ("n_evaluations", self.n_evaluations), ("seconds", self.seconds)]

    def __repr__(self) -> str:
        from linflex.system import short_repr

        return short_repr("FrequencyResponse", self._display_fields())

    def _repr_html_(self) -> str:
        from linflex.system import html_summary

        # a NaN value is a pole on a grid point (see error_estimate): the response is infinite there
        magnitude = np.abs(self.response)
        magnitude[np.isnan(magnitude)] = np.inf
        rows = []
        for i, out in enumerate(self.outputs):
            for j, inp in enumerate(self.inputs):
                if self.omega.size:
                    k = int(np.argmax(magnitude[:, i, j]))
                    peak = magnitude[k, i, j]
                    rows.append((out, inp, 20 * np.log10(peak) if peak > 0 else -np.inf, self.omega[k]))
        return html_summary(f"FrequencyResponse ({len(self.outputs)} x {len(self.inputs)})", self._display_fields(),
                            ("output", "input", "peak [dB]", "at [rad/s]"), rows)

    def _siso(self) -> NDArray[np.complex128]:
        if self.response.shape[1:] != (1, 1):
            raise ModelError(
                f"this response has {self.response.shape[1]} outputs and {self.response.shape[2]} inputs; "
                "use .channel(output, input) to pick one"
            )
        return self.response[:, 0, 0]

    @property
    def magnitude(self) -> NDArray[np.float64]:
        """``|G(j omega)|`` of a SISO response [output units / input units]."""
        return np.abs(self._siso())

    @property
    def phase(self) -> NDArray[np.float64]:
        """Unwrapped phase of a SISO response [rad]; NaN where the response is not finite (a pole
        on a frequency of ``omega``), the other values unwrapped among themselves."""
        # drawing depends on results, never the reverse (_draw imports no computing module)
        from ._draw import unwrapped_phase

        return unwrapped_phase(self._siso())

    def channel(self, output, input) -> NDArray[np.complex128]:
        """The complex response of one channel (names or indices), shape (n_omega,).

        Parameters
        ----------
        output, input : str or int
            Names or indices of the output and the input.

        Returns
        -------
        ndarray of complex, shape (n_omega,)
            ``G(j omega)`` of that channel at ``omega`` [rad/s], in [output units per input
            unit].

        Raises
        ------
        ModelError
            For an unknown name or an index out of range.
        """
        from linflex.system import signal_index

        return self.response[:, signal_index(self.outputs, output, "output"), signal_index(self.inputs, input, "input")]

    def singular_values(self) -> NDArray[np.float64]:
        """Singular values of ``G(j omega)``, shape (n_omega, min(n_outputs, n_inputs)), descending.

        Returns
        -------
        ndarray, shape (n_omega, min(n_outputs, n_inputs))
            Absolute values, in the units of ``response`` (convert to [dB] with
            ``20 log10``), one row per frequency of ``omega`` [rad/s]; NaN where the response
            is not finite (a pole on a frequency of ``omega``).
        """
        G = self.response
        finite = np.all(np.isfinite(G.reshape(G.shape[0], -1)), axis=1)
        sv = np.full((G.shape[0], min(G.shape[1:])), np.nan)
        sv[finite] = np.linalg.svd(G[finite], compute_uv=False)   # LAPACK does not converge on NaN
        return sv

    def plot(self, **kwargs):
        """Bode plot of this response: see :func:`linflex.frequency.bode_plot`.

        Parameters
        ----------
        **kwargs
            Keyword arguments of :func:`~linflex.frequency.bode_plot` (``hz``, ``ax``, ...).

        Returns
        -------
        PlotHandle
            As :func:`~linflex.frequency.bode_plot`: magnitude [dB] and phase [deg] against
            frequency [rad/s] (or [Hz]).
        """
        # drawing depends on results, never the reverse (_draw imports no computing module)
        from ._draw import draw_bode

        return draw_bode(self, **kwargs)


# ----------------------------------------------------------------------------------------------
# The grid


def _features(sys: LinearSystem, poles: NDArray | None, channel_zeros: bool, modal=None) -> tuple[NDArray, NDArray]:
    """Poles and channel zeros [1/s] for the grid. With a modal form of at most
    ``BLOCK_DENSE_MAX`` dense states (``modal``, the evaluator's), the zeros of each channel are
    the converged roots of the Aberth iteration on the modal sum (:mod:`._modal_roots`, O(n^2)
    in all) instead of a dense pencil (O(n^3)); a root that does not converge is left out, its
    notch then found by the extremum refinement of :func:`frequency_response`."""
    from ._modal_forms import BLOCK_DENSE_MAX, _Modal
    from ._modal_roots import modal_roots
    from ._zeros import _invariant_zeros

    if poles is None:
        poles = scipy.linalg.eigvals(sys.A, check_finite=False) if sys.n_states else np.zeros(0)
    structured = isinstance(modal, _Modal) and modal.k <= BLOCK_DENSE_MAX and modal.shape == sys.shape
    zs = []
    if channel_zeros and sys.n_states:
        for o in range(sys.n_outputs):
            for i in range(sys.n_inputs):
                try:
                    zs.append(modal_roots(modal, sys, 0.0, (o, i)) if structured else
                              _invariant_zeros(sys.A, sys.B[:, [i]], sys.C[[o]], sys.D[[o]][:, [i]]))
                except (np.linalg.LinAlgError, ValueError, ArithmeticError):
                    continue
    z = np.concatenate(zs) if zs else np.zeros(0, dtype=complex)
    return np.asarray(poles, dtype=complex), np.asarray(z, dtype=complex)


# Offsets in units of the half-power half-bandwidth |Re(root)| around Im(root): a point at the
# damped frequency and at +-0.3 keeps every isolated peak within 0.1 dB (|G| falls by 0.1 dB at
# 0.15 half-bandwidths); +-1 and +-3 follow the skirt into the base grid. Extremum refinement in
# frequency_response covers peaks displaced by neighbouring modes.
_VERNIER = np.array([0.0, -0.3, 0.3, -1.0, 1.0, -3.0, 3.0])


def frequency_grid(sys, *, points_per_decade: int = 20, zeta_max: float = 0.3,
                   channel_zeros: bool | None = None, _poles=None, _modal=None) -> NDArray[np.float64]:
    """A pole- and zero-aware frequency grid [rad/s] (the modern form of vernier stepping).

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
    points_per_decade : int, optional
        Density of the logarithmic base grid.
    zeta_max : float, optional
        Poles and zeros with damping ratio [-] below this get a vernier cluster.
    channel_zeros : bool, optional
        Whether to compute the zeros of every SISO channel and give the lightly damped ones a
        cluster (notches). Default: for SISO systems only; a MIMO structure has a set of notches
        per channel, which would multiply the point count.

    Returns
    -------
    numpy.ndarray
        Increasing, unique frequencies [rad/s]; for a discrete system below the Nyquist
        frequency ``pi / dt`` (the grid of its w-plane image, mapped back: see
        :func:`frequency_response`). Delays do not change the grid.

    Raises
    ------
    ModelError
        For a system linflex cannot read, ``points_per_decade`` not a positive integer or
        ``zeta_max`` not a non-negative finite number.

    Notes
    -----
    Range: one decade below the smallest and above the largest non-zero root modulus (rounded
    out to whole decades), as in python-control. For every root ``r`` with
    ``0 < zeta < zeta_max`` in range, points ``Im(r) + |Re(r)| x`` for ``x`` in
    ``{0, +-0.3, +-1, +-3}`` are candidates (reference notes 8.3, with the half-bandwidth as
    unit), then the base grid; taken in that order, a candidate is dropped when a kept point lies
    within a quarter of its own spacing, so that overlapping clusters of a dense spectrum share
    points. :func:`frequency_response` then refines every grid extremum (see there).

    Examples
    --------
    A 1 rad/s mode with zeta = 0.1: the grid spans 0.1 to 10 rad/s and clusters points at the
    resonance.

    >>> import numpy as np
    >>> from linflex import LinearSystem
    >>> from linflex.frequency import frequency_grid
    >>> w = frequency_grid(LinearSystem([[0, 1], [-1, -0.2]], [[0], [1]], [[1, 0]]))
    >>> float(w[0]), float(w[-1]), bool(np.all(np.diff(w) > 0))
    (0.1, 10.0, True)
    >>> int(np.sum(np.abs(w - 1.0) < 0.1))   # points within the half-bandwidth 0.1 rad/s
    4
    """
    lin = checked_system(sys, "sys", need_io=False, discrete=True, delay=True)
    sys = engine_system(lin)
    _check_positive_int(points_per_decade, "points_per_decade")
    zeta_max = check_positive(zeta_max, "zeta_max", allow_zero=True)
    if channel_zeros is None:
        channel_zeros = sys.shape == (1, 1)
    poles, zs = _features(sys, _poles, channel_zeros, _modal)
    grid = pole_zero_grid(classify(sys.A, poles=poles, B=sys.B, C=sys.C), zs, points_per_decade=points_per_decade,
                          zeta_max=zeta_max)
    return grid if lin.dt is None else from_w_frequency(grid, lin.dt)


def pole_zero_grid(spec, zs: NDArray[np.complex128], *, points_per_decade: int = 20, decades: float = 1.0,
                   zeta_max: float = 0.3) -> NDArray[np.float64]:
    """The grid policy of :func:`frequency_grid` for classified poles ``spec`` and zeros ``zs``.

    ``decades`` beyond the smallest and largest root modulus (rounded out to whole decades);
    rigid-body poles (:mod:`._spectrum`) do not set the range, and no point is left on an
    undamped pole (:func:`~._spectrum.avoid_axis_poles`).
    """
    poles = spec.poles[~spec.rigid]
    roots = np.concatenate([poles, np.asarray(zs, dtype=complex)])
    finite = np.isfinite(roots)
    mags = np.abs(roots)
    big = np.max(mags[finite]) if np.any(finite) else 0.0
    nonzero = finite & (mags > 1e-6 * big)
    nonzero[:poles.size] = finite[:poles.size] & (mags[:poles.size] > 0)
    roots, mags = roots[nonzero], mags[nonzero]
    if not roots.size:
        lo, hi = 0.1, 10.0
    else:
        lo, hi = np.min(mags) / 10**decades, np.max(mags) * 10**decades
    # round out to whole decades, but a root at 10.000000000001 (round-off of an exact 10) does not
    # open another decade
    lo_d, hi_d = np.floor(np.log10(lo) + 1e-9), np.ceil(np.log10(hi) - 1e-9)
    base = np.logspace(lo_d, hi_d, int(round((hi_d - lo_d) * points_per_decade)) + 1)
    r = roots[roots.imag > 0]
    zeta = -r.real / np.abs(r)
    r = r[np.abs(zeta) < zeta_max]
    lo_w, hi_w = base[0], base[-1]
    if not r.size:
        return avoid_axis_poles(_unique(base), spec)
    half = np.maximum(np.abs(r.real), 1e-7 * np.abs(r))
    # Candidates with a resolution each (the spacing they need around them), in priority order:
    # damped frequencies first, then the +-0.3, +-1, +-3 rings, then the base grid. A candidate
    # is dropped when a kept point already lies within a quarter of its resolution: clusters of
    # overlapping modes (dense spectra such as ISS 12A) then share points instead of stacking.
    cands, res = [], []
    for x in _VERNIER[np.argsort(np.abs(_VERNIER), kind="stable")]:
        cands.append(r.imag + half * x)
        res.append(half * max(abs(x), 0.3))
    step = base[1:] / base[:-1] - 1.0 if len(base) > 1 else np.ones(1)
    cands.append(base)
    res.append(base * step[0])
    w_all, r_all = np.concatenate(cands), np.concatenate(res)
    inside = (w_all >= lo_w) & (w_all <= hi_w)
    return avoid_axis_poles(_thin(w_all[inside], r_all[inside]), spec)


def _thin(w: NDArray, res: NDArray) -> NDArray[np.float64]:
    """Keep candidates in the given priority order unless a kept point lies within res/4."""
    import bisect

    kept: list[float] = []
    for wi, ri in zip(w.tolist(), res.tolist()):
        j = bisect.bisect_left(kept, wi)
        near = (j < len(kept) and kept[j] - wi <= 0.25 * ri) or (j > 0 and wi - kept[j - 1] <= 0.25 * ri)
        if not near:
            kept.insert(j, wi)
    return _unique(np.array(kept))


def _unique(w: NDArray) -> NDArray[np.float64]:
    w = np.sort(w)
    if w.size == 0:
        return w
    keep = np.r_[True, np.diff(w) > 1e-12 * w[1:]]
    return w[keep]


def _extremum_refinements(omega, G, tol_db: float, minima: bool, poles: NDArray | None = None):
    """Frequencies to add so that every local extremum of every channel magnitude is resolved.

    Near an isolated resonance ``|G|^2 ~ |r|^2 / ((w - w_d)^2 + h^2)``, so ``1/|G|^2`` is a
    parabola in ``w``; near a notch ``|G|^2`` is. Around each interior local maximum (minimum)
    of the grid magnitude, the parabola of ``1/|G|^2`` (``|G|^2``) through the three points
    predicts the true extremum; where the predicted value differs from the grid value by more
    than ``tol_db``, or where the bracket is wider than 0.6 fitted half-bandwidths, its frequency
    is returned, with the largest predicted gap [dB]."""
    mag2 = np.abs(G.reshape(len(omega), -1)) ** 2
    new, worst = [], 0.0
    if len(omega) < 3:
        return np.zeros(0), 0.0
    w0, w1, w2 = omega[:-2], omega[1:-1], omega[2:]
    # half-bandwidth of the lightly damped pole nearest to each interior grid point
    h_near = np.full(len(w1), np.inf)
    if poles is not None and len(poles):
        pk = poles[(poles.imag > 0) & (-poles.real < 0.3 * np.abs(poles))]
        if pk.size:
            order = np.argsort(pk.imag)
            pw, ph = pk.imag[order], np.maximum(np.abs(pk.real[order]), 1e-7 * np.abs(pk[order]))
            j = np.clip(np.searchsorted(pw, w1), 1, max(len(pw) - 1, 1))
            if len(pw) == 1:
                h_near = np.full(len(w1), ph[0])
            else:
                left = np.abs(w1 - pw[j - 1]) <= np.abs(pw[j] - w1)
                h_near = np.where(left, ph[j - 1], ph[j])
    for c in range(mag2.shape[1]):
        m0, m1, m2 = mag2[:-2, c], mag2[1:-1, c], mag2[2:, c]
        ok = np.isfinite(m0) & np.isfinite(m1) & np.isfinite(m2) & (m1 > 0)
        kinds = [(ok & (m1 > m0) & (m1 >= m2), True)]
        if minima:
            kinds.append((ok & (m1 < m0) & (m1 <= m2), False))
        for sel, is_max in kinds:
            if not np.any(sel):
                continue
            a0, a1, a2 = w0[sel], w1[sel], w2[sel]
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                b0, b1, b2 = (1 / m0[sel], 1 / m1[sel], 1 / m2[sel]) if is_max else (m0[sel], m1[sel], m2[sel])
                # Newton form b0 + s01 (w - a0) + curv (w - a0)(w - a1): vertex, value there
                s01, s12 = (b1 - b0) / (a1 - a0), (b2 - b1) / (a2 - a1)
                curv = (s12 - s01) / (a2 - a0)
                wv = 0.5 * (a0 + a1) - s01 / (2 * curv)
                bv = b0 + s01 * (wv - a0) + curv * (wv - a0) * (wv - a1)
                gap = np.abs(10 * np.log10(b1 / bv))
                # half-bandwidth of the fitted resonance: b = curv ((w - wv)^2 + h^2)
                h = np.sqrt(bv / curv)
            good = np.isfinite(wv) & (wv > a0) & (wv < a2) & (curv > 0) & (bv > 0) & np.isfinite(gap)
            gap = np.where(good, gap, 0.0)
            worst = max(worst, float(np.max(gap)))
            # The parabola is only trusted when the bracket is narrow against the fitted
            # half-bandwidth (neighbouring modes bend a wide bracket): otherwise refine anyway.
            wide = np.maximum(a1 - a0, a2 - a1) > 0.6 * np.minimum(h, h_near[sel])
            new.append(wv[good & ((gap > tol_db) | wide)])
    return (np.concatenate(new) if new else np.zeros(0)), worst


# ----------------------------------------------------------------------------------------------


def _check_positive_int(value, name, *, allow_zero: bool = False):
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < (0 if allow_zero else 1):
        raise ModelError(f"{name} must be a {'non-negative' if allow_zero else 'positive'} integer, got {value!r}")


#: Relative accuracy is asked of a response's values down to this fraction [-] of its peak (120 dB
#: below it); a value below, near a zero on the axis (an undamped plant mode is one of its loop's
#: sensitivity), has its estimated error measured against this floor of the peak instead: its
#: own relative error is unbounded however accurate the evaluation.
ZERO_FLOOR = 1e-6


def _warn_if_inaccurate(evaluator, w: NDArray[np.float64], G: NDArray[np.complex128], omega) -> None:
    """The evaluator's :class:`~linflex.AccuracyWarning` for the returned grid ``w`` [rad/s, on
    the engine's axis; ``omega`` the same in the system's own frequencies] and response ``G``,
    each point's estimate relative to ``max(|G|, ZERO_FLOOR * peak)``."""
    if not evaluator.error > WARN_RTOL or w.size == 0:
        return
    evaluator(w)   # the grid's own estimates (from the evaluator's memo)
    rel = np.asarray(evaluator.last_error, dtype=float)
    rel = np.where(np.isnan(rel), np.inf, rel)
    scale = np.abs(G).reshape(w.size, -1).max(axis=1)
    finite = np.isfinite(scale)
    floor = ZERO_FLOOR * float(np.max(scale[finite], initial=0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        # below the floor: the estimate against the floor (an exact zero's estimate is relative
        # to ZERO_SCALE, as _modal_forms._relative makes it)
        effective = rel * np.where(~finite | (scale >= floor), 1.0, np.maximum(scale, ZERO_SCALE) / floor)
    effective = np.where(np.isnan(effective), np.inf, effective)
    j = int(np.argmax(effective))
    if effective[j] > WARN_RTOL:
        warnings.warn(f"frequency_response: the evaluation at omega = {omega[j]:.6g} rad/s has an estimated relative "
                      f"error of {effective[j]:.2g} (cause: {evaluator.cause(1j * w[j])})", AccuracyWarning,
                      stacklevel=3)


def frequency_response(sys, omega: ArrayLike | None = None, *, method: str = "auto", rtol: float = 1e-11,
                       points_per_decade: int = 20, resolution_db: float = 0.05,
                       max_refinements: int = 6, notches: bool | None = None) -> FrequencyResponse:
    """Frequency response ``G(j omega) = D + C (j omega I - A)^-1 B`` of a linear system.

    A discrete-time system is evaluated on the unit circle, ``G(exp(j omega dt))`` for ``omega``
    up to the Nyquist frequency ``pi / dt``; delays multiply each channel by
    ``exp(-j omega (tau_out + tau_in))`` exactly (no approximation).

    Parameters
    ----------
    sys : LinearSystem, SecondOrderSystem or control.StateSpace
        Continuous or discrete, with or without input and output delays.
    omega : array_like, optional
        Frequencies [rad/s], positive and finite, at most ``pi / dt`` for a discrete system
        (sorted on output). Default: an automatic
        pole- and zero-aware grid (:func:`frequency_grid`) refined until every peak and notch of
        every channel is resolved to ``resolution_db``.
    method : {"auto", "modal", "hessenberg", "direct"}
        ``"auto"``: block-diagonal modal form, with every point whose estimated relative rounding
        error exceeds ``rtol`` re-checked by a backward-stable O(n^2) path (a residual of the
        modal solution, or a triangular solve in the complex Schur form; see
        ``frequency/_evaluate.py``), the value with the smaller estimate kept. For a
        :class:`~linflex.SecondOrderSystem` with symmetric ``M, D, K`` and damping diagonal in
        the undamped modes, the modal form comes from ``eigh(K, M)`` at half the order
        (``"second_order_modal"``). ``"modal"``: the modal form
        only. ``"hessenberg"``: one banded LU of ``j omega I - H`` per point (O(n^2) each).
        ``"direct"``: dense LU of ``j omega I - A`` per point (O(n^3) each), a reference.
    rtol : float, optional
        Relative tolerance [-] of the ``"auto"`` switch.
    points_per_decade : int, optional
        Base density of the automatic grid.
    resolution_db : float, optional
        Refinement target [dB] for extrema on the automatic grid.
    max_refinements : int, optional
        Rounds of extremum refinement.
    notches : bool, optional
        Whether the automatic grid also places clusters at the zeros of each channel and refines
        minima. Default: for SISO systems (see :func:`frequency_grid`); MIMO structures have one
        set of notches per channel.

    Returns
    -------
    FrequencyResponse

    Raises
    ------
    ShapeError
        If ``omega`` is not a 1-D array of positive finite frequencies, or the system has no
        input or no output.
    ModelError
        For an unknown method, ``method="modal"`` on a system without a usable modal form,
        complex system matrices, ``rtol`` or ``resolution_db`` not a positive finite number, or
        ``points_per_decade`` (``max_refinements``) not a positive (non-negative) integer.

    Warns
    -----
    AccuracyWarning
        When the estimated relative error exceeds 1e-4 at some frequency (message: the frequency
        and the cause, say a pole within rounding of ``j omega``).

    Notes
    -----
    The modal form splits off the eigenvalues whose condition number exceeds 1e5 (defective
    rigid-body modes, near-repeated clusters) by an ordered Schur form and a Sylvester equation
    (Bavely and Stewart's block diagonalization); its error estimate is
    ``eps cond(T) sum_i |c_i| |w_i| (1 / |s - lambda_i| + ||A|| / |s - lambda_i|^2)`` relative to
    ``max |G(s)|``. The
    Hessenberg path follows Laub (IEEE TAC 26, 1981): ``A = Q H Q^T`` once, then a banded solve
    per frequency.

    A discrete system is evaluated at ``z = exp(j omega dt)`` by the same evaluator (so the same
    error estimate); its automatic grid is the one of its w-plane image (``frequency/_sampled.py``:
    ``z = (1 + s dt/2)/(1 - s dt/2)`` maps the unit circle onto the imaginary axis) mapped back by
    ``omega = (2/dt) arctan(nu dt/2)``, so it clusters at lightly damped poles and zeros near the
    circle in the same way.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> sys = LinearSystem([[0, 1], [-1, -0.002]], [[0], [1]], [[1, 0]])   # zeta = 0.001
    >>> fr = frequency_response(sys)
    >>> round(float(20 * np.log10(fr.magnitude.max())), 2)              # 1/(2 zeta), in dB
    53.98
    """
    t0 = time.perf_counter()
    second_order = sys if isinstance(sys, SecondOrderSystem) else None
    lin = checked_system(sys, "sys", discrete=True, delay=True)
    sys = engine_system(lin)
    _check_positive_int(points_per_decade, "points_per_decade")
    _check_positive_int(max_refinements, "max_refinements", allow_zero=True)
    rtol = check_positive(rtol, "rtol")
    resolution_db = check_positive(resolution_db, "resolution_db")
    evaluator = axis_evaluator(lin, method, rtol, second_order)
    n_eval = 0
    if omega is not None:
        w = np.sort(sampled_omega(checked_omega(omega, "omega"), lin.dt))
        w_engine = w if lin.dt is None else to_w_frequency(w, lin.dt)
        G = evaluator(w_engine)
        n_eval = len(w)
        grid, resolution = "user", float("nan")
    else:
        poles = evaluator.poles
        if notches is None:
            notches = sys.shape == (1, 1)
        spec = classify(sys.A, poles=poles, B=sys.B, C=sys.C)
        w = frequency_grid(sys, points_per_decade=points_per_decade, channel_zeros=notches, _poles=poles,
                           _modal=getattr(evaluator, "modal", None) if lin.dt is None and not lin.has_delay else None)
        G = evaluator(w)
        n_eval = len(w)
        resolution = 0.0
        for _ in range(max_refinements):
            extra, resolution = _extremum_refinements(w, G, resolution_db, notches, poles)
            extra = avoid_axis_poles(_unique(extra), spec)  # never on an undamped pole
            if extra.size:
                k = np.clip(np.searchsorted(w, extra), 1, len(w) - 1)
                near = np.minimum(np.abs(w[k] - extra), np.abs(w[k - 1] - extra)) <= 1e-12 * extra
                extra = extra[~near]
            if extra.size == 0:
                break
            Gx = evaluator(extra)
            n_eval += len(extra)
            w_all = np.concatenate([w, extra])
            order = np.argsort(w_all, kind="stable")
            w, G = w_all[order], np.concatenate([G, Gx])[order]
        else:
            _, resolution = _extremum_refinements(w, G, resolution_db, notches, poles)
        grid = "auto"
        w_engine = w
        if lin.dt is not None:
            w = from_w_frequency(w, lin.dt)
    _warn_if_inaccurate(evaluator, w_engine, G, w)
    w.setflags(write=False)
    G.setflags(write=False)
    return FrequencyResponse(
        omega=w, response=G, outputs=sys.outputs, inputs=sys.inputs, method=evaluator.label,
        error_estimate=float(evaluator.error), grid=grid, peak_resolution_db=float(resolution),
        n_evaluations=n_eval, seconds=time.perf_counter() - t0, dt=lin.dt,
    )
