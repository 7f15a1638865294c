"""Stability margins of a feedback loop: every crossing, gain/phase/delay margins, disk margins.

Conventions: ``L`` is the open loop of a negative-feedback loop (closed loop ``(I + L)^-1 L``),
square, with the loop broken at its inputs. Frequencies are in rad/s, phase margins in degrees,
gain margins as ratios (``gain_margins_db`` in dB), delays in seconds.
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from linflex import AccuracyWarning, LinearSystem, ModelError, ShapeError
from linflex.frequency._checks import checked_system
from linflex.frequency._evaluate import WARN_RTOL, TransferEvaluator
from linflex.frequency._nyquist import count_encirclements, loop_poles
from linflex.frequency._response import pole_zero_grid
from linflex.frequency._spectrum import avoid_axis_poles, classify
from linflex.frequency._zeros import _invariant_zeros
from linflex.system import check_positive, html_summary, short_repr

from ._closed_loop import _RTOL_L, _RTOL_S, _close_others, _closed_loop, _estimate_at, _rechecked_to
from ._crossings import MAG_WINDOW, crossing_summary, crossings, extend, polish, refine
from ._disk import DiskMargin, disk_margin, not_computed
from ._sampled import delayed_band, delayed_sensitivity, sampled_margins

__all__ = ["DiskMargin", "LoopMargins", "StabilityMargins", "stability_margins"]

#: Re-check tolerance of the scan of a single loop's grid (see ``_siso_margins``): the modal
#: values there only bracket crossings; at order 2000 the re-checks to _RTOL_L were a third of
#: the margins' time.
_RTOL_GRID = 1e-8


@dataclass(frozen=True, eq=False)
class LoopMargins:
    """Classical and disk margins of one single loop (one channel, the others closed).

    Attributes
    ----------
    channel : str
        Name of the loop's channel (input of ``L`` where the loop is broken).
    gain_crossovers : ndarray
        Every frequency [rad/s] where ``|L(jw)| = 1``, ascending.
    phase_margins : ndarray
        Phase margin [deg] at each gain crossover, ``angle(-L(jw))`` in (-180, 180].
    delay_margins : ndarray
        Delay [s] that brings each gain crossover onto -1: ``(PM mod 360) / w`` in radians.
    phase_crossovers : ndarray
        Every frequency [rad/s] where ``L(jw)`` crosses the negative real axis, ascending;
        ``0`` is included when ``L(0)`` is finite and negative. A double integrator's phase of
        exactly -180 deg as ``w -> 0`` is not a crossing, and crossings where ``|L|`` is below
        1e-10 or above 1e10 (gain margins beyond 200 dB, phase dominated by rounding) are not
        reported.
    gain_margins : ndarray
        Gain factor ``-1 / L(jw)`` at each phase crossover [ratio]: above 1 a gain increase, below
        1 a gain reduction that puts ``-1`` on the curve.
    delay_margin : float
        Smallest of ``delay_margins`` [s] (``inf`` without gain crossovers).
    min_phase_margin : float
        Phase margin of smallest magnitude [deg] (``inf`` without gain crossovers).
    min_phase_margin_frequency : float
        Its gain crossover [rad/s] (``nan`` if none).
    min_gain_margin : float
        Gain margin closest to 1 in dB [ratio] (``inf`` without phase crossovers).
    min_gain_margin_frequency : float
        Its phase crossover [rad/s] (``nan`` if none).
    gain_increase_margin : float
        Smallest gain margin above 1 [ratio] (``inf`` if none).
    gain_reduction_margin : float
        Largest gain margin below 1 [ratio] (``0`` if none).
    disk_margin : DiskMargin
        Balanced (skew 0) disk margin of this loop.
    skewed_disk_margin : DiskMargin
        Disk margin with the requested skew.
    open_loop_unstable_poles : int
        Poles of this loop's ``L`` in the open right half-plane.
    """

    channel: str
    gain_crossovers: NDArray[np.float64]
    phase_margins: NDArray[np.float64]
    delay_margins: NDArray[np.float64]
    phase_crossovers: NDArray[np.float64]
    gain_margins: NDArray[np.float64]
    delay_margin: float
    min_phase_margin: float
    min_phase_margin_frequency: float
    min_gain_margin: float
    min_gain_margin_frequency: float
    gain_increase_margin: float
    gain_reduction_margin: float
    disk_margin: DiskMargin
    skewed_disk_margin: DiskMargin
    open_loop_unstable_poles: int

    @property
    def gain_margins_db(self) -> NDArray[np.float64]:
        """``gain_margins`` [dB]."""
        return 20 * np.log10(self.gain_margins)

    @property
    def min_gain_margin_db(self) -> float:
        """``min_gain_margin`` [dB]."""
        return float(20 * np.log10(self.min_gain_margin))


@dataclass(frozen=True, eq=False)
class StabilityMargins:
    """Result of :func:`stability_margins`.

    Attributes
    ----------
    loops : tuple of LoopMargins
        Margins of each single loop, broken at one channel with the other loops closed
        (loop-at-a-time); one entry for a SISO loop.
    disk_margin : DiskMargin
        Balanced multi-loop disk margin for independent perturbations of every channel
        (``structure="diagonal"``, a mu upper bound), for a SISO loop equal to
        ``loops[0].disk_margin``.
    skewed_disk_margin : DiskMargin
        Multi-loop disk margin with the requested skew.
    unstructured_disk_margin, unstructured_skewed_disk_margin : DiskMargin
        The same from the largest singular value of ``S + (skew-1)/2 I`` (full complex
        perturbation matrix): a lower bound of the structured margins, and of every
        loop-at-a-time disk margin. Equal to ``disk_margin`` for a SISO loop.
    channels : tuple of str
        Channel names (inputs of ``L``).
    open_loop_unstable_poles : int
        Poles of ``L`` in the open right half-plane (beyond ``rigid_tol``).
    open_loop_imaginary_poles : int
        Poles of ``L`` on the imaginary axis (rigid-body poles and undamped modes).
    closed_loop_unstable_poles : int
        Closed-loop poles (eigenvalues of ``A - B (I + D)^-1 C``) with non-negative real part.
    closed_loop_stable : bool
        True if every closed-loop pole is in the open left half-plane.
    hidden_poles : ndarray of complex
        Closed-loop poles on the imaginary axis [1/s] that are modes the loop does not drive or
        does not see (the antisymmetric bending of two identical undamped arrays under a hub's
        control): eigenvalues of every closed loop whatever its gains, in no transfer function
        of the loop, so neither counted in ``closed_loop_unstable_poles`` nor acted on by any
        margin; they stay undamped (:func:`~linflex.frequency._nyquist.loop_poles`).
    nyquist_encirclements : int or None
        ``N``: net **clockwise** encirclements of the origin by ``det(I + L(s))`` (of -1 by
        ``L`` for a single loop) along the Nyquist contour, indented to the right around
        imaginary-axis poles, counted from the curve itself
        (:func:`linflex.frequency._nyquist.count_encirclements`, the count of
        :func:`~linflex.frequency.nyquist_response` too); ``None`` when a closed-loop pole lies
        on the axis or the curve could not be resolved. The Nyquist criterion makes it
        ``closed_loop_unstable_poles - open_loop_unstable_poles`` (an :class:`~linflex.AccuracyWarning` is
        issued if the two counts disagree); the closed loop is stable iff it equals
        ``-open_loop_unstable_poles``.
    method : str
        How the crossings were found.
    rigid_tol : float
        Radius [1/s] of the rigid-body group of the spectrum policy (the user's ``rigid_tol``
        when given).
    grid_size : int
        Frequencies on the final grid of the first loop (largest over loops).
    n_evaluations : int
        Evaluations of a frequency response, all loops together.
    evaluation_error : float
        Largest a-posteriori estimate [-] of the relative error of ``L(jw)`` (and of ``S(jw)``)
        at the worst crossings, a spread of the others, and the disk margin peak: the backward
        error of the evaluation mapped through the conditioning of ``L`` there
        (``frequency/_evaluate.py``), a bound of the true error to first order.
    crossing_tol : float
        Relative tolerance [-] on the refined crossing frequencies.
    seconds : float
        Wall time [s].

    Notes
    -----
    The SISO accessors (``gain_crossovers``, ``phase_margins``, ...) return the fields of
    ``loops[0]`` and raise :class:`~linflex.ShapeError` for a MIMO loop. ``min_phase_margin``,
    ``min_gain_margin`` and ``delay_margin`` are defined for any loop: the worst over the
    loop-at-a-time loops.
    """

    loops: tuple[LoopMargins, ...]
    disk_margin: DiskMargin
    skewed_disk_margin: DiskMargin
    unstructured_disk_margin: DiskMargin
    unstructured_skewed_disk_margin: DiskMargin
    channels: tuple[str, ...]
    open_loop_unstable_poles: int
    open_loop_imaginary_poles: int
    closed_loop_unstable_poles: int
    closed_loop_stable: bool
    hidden_poles: NDArray[np.complex128]
    nyquist_encirclements: int | None
    method: str
    rigid_tol: float
    grid_size: int
    n_evaluations: int
    evaluation_error: float
    crossing_tol: float
    seconds: float

    def _siso(self, name: str) -> LoopMargins:
        if len(self.loops) != 1:
            raise ShapeError(
                f"{name} is a SISO accessor but this loop has {len(self.loops)} channels; "
                f"use .loops[i].{name} (loop-at-a-time margins)"
            )
        return self.loops[0]

    @property
    def gain_crossovers(self) -> NDArray[np.float64]:
        """Every gain crossover [rad/s] of a SISO loop (``ShapeError`` for MIMO)."""
        return self._siso("gain_crossovers").gain_crossovers

    @property
    def phase_margins(self) -> NDArray[np.float64]:
        """Phase margin [deg] at each gain crossover of a SISO loop."""
        return self._siso("phase_margins").phase_margins

    @property
    def delay_margins(self) -> NDArray[np.float64]:
        """Delay margin [s] at each gain crossover of a SISO loop."""
        return self._siso("delay_margins").delay_margins

    @property
    def phase_crossovers(self) -> NDArray[np.float64]:
        """Every phase crossover [rad/s] of a SISO loop."""
        return self._siso("phase_crossovers").phase_crossovers

    @property
    def gain_margins(self) -> NDArray[np.float64]:
        """Gain margin [ratio] at each phase crossover of a SISO loop."""
        return self._siso("gain_margins").gain_margins

    @property
    def gain_margins_db(self) -> NDArray[np.float64]:
        """Gain margins of a SISO loop [dB]."""
        return self._siso("gain_margins_db").gain_margins_db

    @property
    def min_phase_margin_frequency(self) -> float:
        """Gain crossover [rad/s] of the smallest phase margin of a SISO loop."""
        return self._siso("min_phase_margin_frequency").min_phase_margin_frequency

    @property
    def min_gain_margin_frequency(self) -> float:
        """Phase crossover [rad/s] of the gain margin closest to 1 of a SISO loop."""
        return self._siso("min_gain_margin_frequency").min_gain_margin_frequency

    @property
    def gain_increase_margin(self) -> float:
        """Smallest gain margin above 1 [ratio] of a SISO loop."""
        return self._siso("gain_increase_margin").gain_increase_margin

    @property
    def gain_reduction_margin(self) -> float:
        """Largest gain margin below 1 [ratio] of a SISO loop."""
        return self._siso("gain_reduction_margin").gain_reduction_margin

    @property
    def is_siso(self) -> bool:
        """True for a single loop."""
        return len(self.loops) == 1

    @property
    def min_phase_margin(self) -> float:
        """Phase margin of smallest magnitude over all loops [deg]."""
        pms = [lp.min_phase_margin for lp in self.loops]
        return float(min(pms, key=abs))

    @property
    def min_gain_margin(self) -> float:
        """Gain margin closest to 1 (in dB) over all loops [ratio]."""
        gms = [lp.min_gain_margin for lp in self.loops]
        return float(min(gms, key=lambda g: abs(np.log(g)) if 0 < g < np.inf else np.inf))

    @property
    def min_gain_margin_db(self) -> float:
        """``min_gain_margin`` [dB]."""
        return float(20 * np.log10(self.min_gain_margin))

    @property
    def delay_margin(self) -> float:
        """Smallest delay margin over all loops [s]."""
        return float(min(lp.delay_margin for lp in self.loops))

    def to_markdown(self) -> str:
        """Tables (GitHub-flavoured markdown) of every crossing per loop and of the disk margins.

        Returns
        -------
        str
            Per loop: crossing frequencies [rad/s], phase margins [deg], gain margins (absolute
            and [dB]) and delay margins [s]; then the disk margins.
        """
        out = []
        for lp in self.loops:
            out.append(f"**Loop {lp.channel}** (open-loop RHP poles: {lp.open_loop_unstable_poles})\n")
            out.append("| crossing | frequency [rad/s] | margin | delay margin [s] |")
            out.append("|---|---|---|---|")
            for w, pm, tau in zip(lp.gain_crossovers, lp.phase_margins, lp.delay_margins):
                out.append(f"| gain | {w:.6g} | {pm:.4f} deg | {tau:.4g} |")
            for w, gm in zip(lp.phase_crossovers, lp.gain_margins):
                out.append(f"| phase | {w:.6g} | {gm:.5g} ({20 * np.log10(gm):+.3f} dB) | - |")
            if not (lp.gain_crossovers.size or lp.phase_crossovers.size):
                out.append("| none | - | - | - |")
            out.append("")
        out.append("| disk margin | alpha | skew | frequency [rad/s] | gain range | phase [deg] |")
        out.append("|---|---|---|---|---|---|")
        named = [(f"loop {lp.channel}", lp.disk_margin) for lp in self.loops]
        if len(self.loops) > 1:
            named += [("multi-loop", self.disk_margin), ("multi-loop, unstructured", self.unstructured_disk_margin)]
        if self.skewed_disk_margin.skew != 0:
            named.append(("multi-loop, skewed" if len(self.loops) > 1 else "skewed", self.skewed_disk_margin))
        for name, dm in named:
            out.append(f"| {name} ({dm.structure}) | {dm.alpha:.4g} | {dm.skew:g} | {dm.frequency:.4g} "
                       f"| [{dm.gain_margin[0]:.4g}, {dm.gain_margin[1]:.4g}] | {dm.phase_margin:.3f} |")
        return "\n".join(out)

    def _display_fields(self):
        some = bool(self.loops)
        return [("channels", self.channels), ("closed_loop_stable", self.closed_loop_stable),
                ("min_phase_margin [deg]", self.min_phase_margin if some else None), ("min_gain_margin [dB]",
                 self.min_gain_margin_db if some else None), ("delay_margin [s]", self.delay_margin if some else None),
                ("disk_margin [-]", self.disk_margin.alpha), ("open_loop_unstable_poles", self.open_loop_unstable_poles),
                ("nyquist_encirclements", self.nyquist_encirclements), ("seconds", self.seconds)]

    #: Columns of the per-loop table of ``_repr_html_`` (also the scene analysis' table).
    _LOOP_HEADER = ("loop", "min PM [deg]", "at [rad/s]", "min GM [dB]", "delay margin [s]", "disk alpha", "gain crossovers",
                    "phase crossovers")

    def _loop_rows(self):
        return [(lp.channel, lp.min_phase_margin, lp.min_phase_margin_frequency, lp.min_gain_margin_db,
                 lp.delay_margin, lp.disk_margin.alpha, lp.gain_crossovers.size, lp.phase_crossovers.size)
                for lp in self.loops]

    def __repr__(self) -> str:
        return short_repr("StabilityMargins", self._display_fields())

    def _repr_html_(self) -> str:
        return html_summary(f"StabilityMargins ({len(self.loops)} loop{'s' if len(self.loops) != 1 else ''})",
                            self._display_fields(), self._LOOP_HEADER, self._loop_rows(),
                            note="Loop-at-a-time margins; str() lists every crossing.")

    def __str__(self) -> str:
        lines = [
            f"Stability margins ({len(self.loops)} loop{'s' if len(self.loops) > 1 else ''}, "
            f"closed loop {'stable' if self.closed_loop_stable else 'UNSTABLE'}, "
            f"{self.open_loop_unstable_poles} open-loop RHP poles, {self.open_loop_imaginary_poles} on the axis"
            + (f", {self.hidden_poles.size} hidden undamped poles" if self.hidden_poles.size else "") + ")"
        ]
        for lp in self.loops:
            lines.append(f"  loop {lp.channel}:")
            for w, pm, tau in zip(lp.gain_crossovers, lp.phase_margins, lp.delay_margins):
                lines.append(f"    gain crossover {w:.6g} rad/s: phase margin {pm:.4f} deg, delay margin {tau:.4g} s")
            for w, gm in zip(lp.phase_crossovers, lp.gain_margins):
                lines.append(f"    phase crossover {w:.6g} rad/s: gain margin {gm:.5g} ({20 * np.log10(gm):+.3f} dB)")
            dm = lp.disk_margin
            lines.append(
                "    disk margin not searched (disk_margins='multi-loop')" if np.isnan(dm.alpha) else
                f"    disk margin {dm.alpha:.4g} at {dm.frequency:.4g} rad/s: gain [{dm.gain_margin[0]:.4g}, "
                f"{dm.gain_margin[1]:.4g}], phase {dm.phase_margin:.3f} deg"
            )
        dm = self.disk_margin
        lines.append(
            f"  multi-loop disk margin ({dm.structure}) {dm.alpha:.4g} at {dm.frequency:.4g} rad/s: "
            f"gain [{dm.gain_margin[0]:.4g}, {dm.gain_margin[1]:.4g}], phase {dm.phase_margin:.3f} deg"
        )
        return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# checks

def _check_points(wgc, pm, wpc, gm, n: int = 6) -> NDArray[np.float64]:
    """Up to ``n`` crossings whose evaluation error is reported: the worst first, then spread."""
    pts = []
    if wgc.size:
        pts.append(wgc[int(np.argmin(np.abs(pm)))])
        pts.extend(wgc[np.linspace(0, wgc.size - 1, min(wgc.size, n // 2)).astype(int)])
    if wpc.size:
        with np.errstate(divide="ignore"):
            pts.append(wpc[int(np.argmin(np.abs(np.log(gm))))])
        pts.extend(wpc[np.linspace(0, wpc.size - 1, min(wpc.size, n // 2)).astype(int)])
    pts = np.unique(np.array(pts, dtype=float))
    return pts[pts > 0]


# --------------------------------------------------------------------------------------------
# single loop


def _siso_margins(sys: LinearSystem, channel: str, *, skew: float, rigid_tol, xtol: float, max_points: int,
                  ev_s=None, disks: bool = True):
    """Margins of one SISO loop; returns (LoopMargins, grid, evaluations, error, where, evaluator).
    ``ev_s``: the evaluator of this loop's sensitivity when already built; ``disks``: whether to
    search its disk margins (else they are :func:`~._disk.not_computed`)."""
    if ev_s is None:
        ev_s = _closed_loop(sys, repr(channel))
    ev = ev_s.ev_L  # L's evaluator, delays exact, shared with S = 1 / (1 + L)
    spec = classify(sys.A, rigid_tol, poles=ev.poles, B=sys.B, C=sys.C, D=sys.D)
    # the on-axis poles exactly on the axis (the policy): a 1e-16 real part left by rounding must
    # not decide the sign of Im L beside an undamped mode (a phase crossover that is not one)
    ev.snap_axis(spec)
    cl_poles = ev_s.poles
    zs = getattr(ev_s, "zeros", None)  # from the closed loop's Hessenberg form when there is one
    if zs is None:
        try:
            zs = _invariant_zeros(sys.A, sys.B, sys.C, sys.D)
        except (np.linalg.LinAlgError, ValueError, ArithmeticError):
            zs = np.zeros(0, complex)
    grid = pole_zero_grid(spec, np.concatenate([zs, cl_poles]), points_per_decade=30, decades=3.0)

    def L(w):
        return ev.siso(w)

    def log_mag(w):  # log |L(jw)| at an array of w [rad/s]
        with np.errstate(divide="ignore"):
            return np.log(np.abs(L(w)))

    # the scan only brackets the crossings (their signs, with the points' estimates as noise):
    # it is re-checked to _RTOL_GRID; the crossings are found and evaluated to _RTOL_L (the
    # evaluator remembers the scan's points at the scan's accuracy; the roots are new points)
    with _rechecked_to(ev, _RTOL_GRID):
        grid = np.unique(np.concatenate([grid, extend(log_mag, grid[0], 0.1), extend(log_mag, grid[-1], 10.0)]))
        grid = avoid_axis_poles(grid, spec)
        values = L(grid)
        if sys.has_delay:  # the delayed curve crosses the axis forever: stop where gain margins pass 60 dB
            grid, values = delayed_band(grid, values, float(sys.input_delay[0] + sys.output_delay[0]), L,
                                        np.concatenate([zs, spec.poles]) if sys.D[0, 0] != 0 else None)
        grid, values = refine(grid, values, L, max_points)

    # gain crossovers: roots of log|L| in log(w)
    with np.errstate(divide="ignore"):
        g = np.log(np.abs(values))
    wgc = np.array(crossings(grid, g, lambda t: log_mag(np.exp(t)), xtol))
    Lgc = L(wgc) if wgc.size else np.zeros(0, complex)
    # PM convention: angle(-L(j w_gc)) in (-180, 180] deg, the phase of L above -180 deg wrapped
    # into one turn; the delay margin is that angle taken in [0, 360) over w_gc
    pm = np.degrees(np.angle(-Lgc))
    pm = np.where(pm <= -180.0, pm + 360.0, pm) + 0.0  # angle(-1 - 0j) is -180: the convention is (-180, 180]
    dm = np.radians(np.mod(pm, 360.0)) / wgc if wgc.size else np.zeros(0)

    # phase crossovers: roots of Im L / |L| where Re L < 0
    def sin_phase(t):
        v = L(np.exp(t))
        with np.errstate(invalid="ignore", divide="ignore"):
            return v.imag / np.abs(v)

    with np.errstate(invalid="ignore", divide="ignore"):
        h = values.imag / np.abs(values)
        h = np.where(values.real < 0, h, np.sign(h) * np.inf)
    # the sign of Im L is unknown where |Im L| / |L| is within the evaluation's a-posteriori error
    # (k / s^2 under a similarity is real to rounding at every frequency: no phase crossover; a
    # rigid body in a similarity realization is evaluated to 1e-6 .. 1 below 1e-4 rad/s, where
    # Im L / |L| is 1e-9: no crossing either). Errors above 1e-2 are warned about.
    noise = np.zeros(grid.size)
    near = np.isfinite(h) & (np.abs(h) <= 1e-2)
    if np.any(near):
        L(grid[near])
        noise[near] = 2.0 * ev.last_error
    wpc = []
    axis_w = np.array([wp for wp, _ in spec.axis_frequencies() if wp > 0])
    for w in crossings(grid, np.where(np.isfinite(values), h, np.nan), sin_phase, xtol, noise=noise):
        v = L(np.array([w]))[0]
        if not (np.isfinite(v) and abs(v.imag) <= 1e-6 * abs(v)):  # to a loose crossing_tol?
            w = polish(sin_phase, w, xtol)
            v = L(np.array([w]))[0] if np.isfinite(w) else np.nan
        # across a pole on the axis Im L changes sign through infinity: not a crossing
        if not (np.isfinite(v) and v.real < 0 and abs(v.imag) <= 1e-6 * abs(v)):
            continue
        # beside a pole on the axis Im L / |L| -> 0 because |L| -> infinity: a crossing there
        # must be a sign change of Im L itself, checked on the same side of the pole
        if axis_w.size:
            k = int(np.argmin(np.abs(axis_w - w)))
            gap = abs(w - axis_w[k])
            if gap <= 1e-6 * axis_w[k]:
                side = L(np.array([w - 0.5 * gap, w + 0.5 * gap]))
                if not side[0].imag * side[1].imag < 0:
                    continue
        wpc.append(w)
    # L(0) is finite unless a pole sits at the origin (an undamped mode elsewhere leaves it so)
    if not spec.rigid.any() and all(wp > 0 for wp, _ in spec.axis_frequencies()):
        L0 = sys.D - sys.C @ np.linalg.solve(sys.A, sys.B) if sys.n_states else sys.D
        L0 = complex(L0[0, 0])
        if np.isfinite(L0) and L0.real < 0 and abs(L0.imag) <= 1e-12 * abs(L0):
            wpc.append(0.0)
    # gain margins beyond +-200 dB are not reported: where |L| < 1e-10 or > 1e10 the computed
    # phase is rounding noise (a velocity output at w -> 0, a double integrator's exact -180 deg)
    if wpc:
        mags = np.abs(np.array([L0 if w == 0 else L(np.array([w]))[0] for w in wpc]))
        wpc = [w for w, a in zip(wpc, mags) if MAG_WINDOW[0] <= a <= MAG_WINDOW[1]]
    wpc = np.array(sorted(wpc))
    Lpc = np.array([L0 if w == 0 else L(np.array([w]))[0] for w in wpc]) if wpc.size else np.zeros(0, complex)
    gm = -1.0 / Lpc.real if wpc.size else np.zeros(0)

    # disk margins from S = 1 / (1 + L), evaluated through L's evaluator, whose points need only
    # S's accuracy (the disk margins are reported to 4 digits): L re-checked to _RTOL_S rather
    # than _RTOL_L, S's error is then _RTOL_S |L S| (a few times _RTOL_S at the peak). The points
    # stay in L's memo at that accuracy; the a-posteriori estimate at the peak below reports it.
    if not disks:
        disk0, disk1 = not_computed(0.0, "siso"), not_computed(skew, "siso")
    else:
        own, hidden = loop_poles(sys, cl_poles, spec)
        stable, avoid = spec.count_unstable(own) == 0, np.abs(hidden.imag)
        with _rechecked_to(ev, _RTOL_S):
            disk0 = disk_margin([ev_s], grid, 0.0, stable, "siso", max_points, avoid)
            disk1 = disk0 if skew == 0 else disk_margin([ev_s], grid, skew, stable, "siso", max_points, avoid)

    # a-posteriori accuracy where it matters: at the crossings and the disk peak
    err, where = _estimate_at(ev, _check_points(wgc, pm, wpc, gm))
    cause = ev
    if np.isfinite(disk0.frequency) and disk0.frequency > 0:
        e2, w2 = _estimate_at(ev_s, [disk0.frequency])
        if e2 > err:
            err, where, cause = e2, w2, ev_s

    loop = LoopMargins(
        channel=channel,
        **crossing_summary(wgc, pm, dm, wpc, gm),
        disk_margin=disk0,
        skewed_disk_margin=disk1,
        open_loop_unstable_poles=spec.n_rhp,
    )
    return loop, grid, ev.n_evaluations, (err, where, cause), ev  # S's points are evaluations of L


# --------------------------------------------------------------------------------------------
# entry point


def _open_loop(L) -> LinearSystem:
    """The open loop as a LinearSystem; a :class:`linflex.frequency.Loop` gives ``loop.open_loop()``.

    ``Loop.open_loop()`` is ``L = K P`` broken at the plant input, with the negative-feedback
    convention used here (closed-loop characteristic equation ``det(I + L) = 0``).
    """
    from linflex.frequency import Loop

    return checked_system(L.open_loop() if isinstance(L, Loop) else L, "L", square=True, discrete=True, delay=True)


def stability_margins(
    loop,
    *,
    skew: float = 0.0,
    rigid_tol: float | None = None,
    crossing_tol: float = 1e-12,
    max_points: int = 400_000,
    disk_margins: str = "all",
) -> StabilityMargins:
    """Gain, phase, delay and disk margins of a feedback loop, with every crossing.

    Parameters
    ----------
    loop : Loop, LinearSystem, SecondOrderSystem or control.StateSpace
        A :class:`linflex.frequency.Loop` (analysed through ``loop.open_loop()``, the loop broken
        at the plant input, channels named by the actuators) or a square open loop of a
        negative-feedback loop: the closed loop is ``(I + L)^-1 L``. For a MIMO loop, input ``i``
        and output ``i`` form channel ``i``. A sampled loop (``dt``) is analysed on the unit
        circle, frequencies up to ``pi / dt``, unstable meaning outside the circle; a delayed
        continuous single loop keeps ``exp(-s tau)`` exact (``stability/_sampled.py``: phase
        crossovers reported up to where gain margins pass 60 dB, closed-loop stability from the
        Nyquist count of the delayed curve); delays on a MIMO loop are refused.
    skew : float, optional
        Skew ``sigma`` [-] of the second disk margin (``skewed_disk_margin``): 0 balanced, 1 the
        sensitivity-based disk (``1 / ||S||_inf``), -1 complementary-sensitivity based; a
        positive skew allows more gain increase than decrease. Default 0.
    rigid_tol : float, optional
        Tolerance [1/s] of the spectrum policy (``frequency/_spectrum.py``): poles with
        ``|lambda| <= rigid_tol`` are rigid-body poles at the origin, with ``|Re lambda| <=
        rigid_tol`` undamped poles on the axis. Default: the rounding rules of that policy (a
        Jordan block at the origin perturbed by round-off, ``1e-16`` in a double integrator, is
        rigid whichever way the perturbation splits it). For a sampled loop it applies to the
        poles of its w-plane image.
    crossing_tol : float, optional
        Relative tolerance [-] of the refined crossing frequencies. Default 1e-12.
    max_points : int, optional
        Cap on the adaptive frequency grid per loop. Default 400000; an
        :class:`~linflex.AccuracyWarning` says when it is reached.
    disk_margins : {"all", "multi-loop"}, optional
        ``"all"`` (default) searches every disk margin; ``"multi-loop"`` only the multi-loop
        ones of independent perturbations (``disk_margin``, ``skewed_disk_margin``): of a MIMO
        loop, each loop's own and the unstructured ones are then not searched and hold ``nan``
        (a sweep that reports the multi-loop margin saves about a third of the margins' time on
        three loops). A single loop's own disk margin is its multi-loop one and is always
        searched.

    Returns
    -------
    StabilityMargins
        Loop-at-a-time margins in ``loops`` (one per channel), multi-loop disk margins, pole
        counts, provenance; SISO accessors ``gain_crossovers``, ``phase_margins``, ...

    Raises
    ------
    ModelError
        If ``loop`` is not a loop or linear system, ``skew`` is not in [-1, 1], ``I + D`` is
        singular, or an option is out of its range (``max_points`` not an integer of at least
        100, ``crossing_tol`` not positive, ...).
    ShapeError
        If ``L`` is not square or has no channels.

    Warns
    -----
    AccuracyWarning
        If the grid cap is reached, if the a-posteriori error estimate of ``L(jw)`` or ``S(jw)``
        exceeds 1e-4 at a crossing or the disk peak (the message names the frequency and the
        cause), or if the Nyquist count on the curve disagrees with the eigenvalue counts.

    Notes
    -----
    Everything is computed from the state-space model, never from polynomial coefficients:

    1. ``L(jw)`` by the one evaluator of ``linflex.frequency`` (``frequency/_evaluate.py``:
       modal form with backward-stable Schur fallback), whose a-posteriori error estimate at the
       crossings and the disk peak is ``evaluation_error``;
    2. the grid policy of :func:`~linflex.frequency.frequency_grid` with 30 points per decade
       and three decades beyond every pole and zero of ``L`` and of the closed loop, never on an
       undamped pole (spectrum policy, ``frequency/_spectrum.py``), extended further while
       ``|L|`` moves towards 0 dB, then refined until phase steps are below 8 deg and magnitude
       steps below 1 dB;
    3. gain crossovers: roots of ``log|L|`` in ``log w``, phase crossovers: roots of
       ``Im L / |L|`` with ``Re L < 0`` (a sign change through a pole on the axis is rejected),
       found not sampled (``stability/_crossings.py``): a root on a grid point, a sign change
       refined (all brackets together), and ``|L|`` touching 1 at a grid extremum are each reported
       once. Phase margin convention: ``angle(-L(j w_gc))`` in ``(-180, 180]`` deg; encirclement
       convention: clockwise, ``N = Z - P`` (as :func:`~linflex.frequency.nyquist_response`). ``w = 0`` is a phase
       crossover only when ``L(0)`` is finite and negative, so a double integrator (phase exactly
       -180 deg as ``w -> 0``) has no spurious zero-frequency gain margin;
    4. disk margin ``alpha = 1 / ||S + (sigma - 1)/2 I||_inf`` (Seiler, Packard and Gahinet,
       "An introduction to disk margins", IEEE CSM 2020), peak by the Hamiltonian iteration (up to
       100 states, continuous and undelayed), else grid search and local refinement; gain range
       ``[(2 - a(1-s))/(2 + a(1+s)), (2 + a(1-s))/(2 - a(1+s))]`` and phase
       ``arccos((1 + g_lo g_hi)/(g_lo + g_hi))``.

    MIMO: loop-at-a-time margins break one channel with the others closed. The multi-loop disk
    margin (independent simultaneous perturbations of every channel) is computed from the
    D-scaled upper bound of the structured singular value of ``M = S + (sigma - 1)/2 I``,
    ``mu <= min_D sigma_max(D M D^-1)`` (Osborne scaling on the grid, exact convex minimization
    over D at the peaks), so the reported ``disk_margin`` is a lower bound of the exact one (the
    bound is tight for two channels and usually within a few percent otherwise). The fully
    unstructured bound from ``sigma_max(M)`` is reported as ``unstructured_disk_margin``.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> L = LinearSystem([[0, 1], [0, 0]], [[0], [1]], [[1, 1]])   # (s + 1) / s^2
    >>> m = stability_margins(L)
    >>> round(float(m.gain_crossovers[0]), 4), round(m.min_phase_margin, 2), m.phase_crossovers.size
    (1.272, 51.83, 0)
    """
    t0 = time.perf_counter()
    sys = _open_loop(loop)
    m = sys.n_inputs
    try:
        skew = float(skew)
    except (TypeError, ValueError) as err:
        raise ModelError(f"skew must be a number in [-1, 1], got {skew!r}") from err
    if not -1.0 <= skew <= 1.0:
        raise ModelError(f"skew must be in [-1, 1], got {skew!r}")
    xtol = check_positive(crossing_tol, "crossing_tol")
    try:
        n_points = int(max_points)
    except (TypeError, ValueError, OverflowError) as err:  # OverflowError: int(inf)
        raise ModelError(f"max_points must be an integer, got {max_points!r}") from err
    if isinstance(max_points, str) or n_points != max_points:  # 150.7 is not truncated silently
        raise ModelError(f"max_points must be an integer, got {max_points!r}")
    max_points = n_points
    if max_points < 100:
        raise ModelError(f"max_points must be at least 100, got {max_points}")
    if rigid_tol is not None:
        rigid_tol = check_positive(rigid_tol, "rigid_tol", allow_zero=True)
    if disk_margins not in ("all", "multi-loop"):
        raise ModelError(f"disk_margins must be 'all' or 'multi-loop', got {disk_margins!r}")
    if sys.is_discrete:
        return sampled_margins(sys, stability_margins, skew=skew, rigid_tol=rigid_tol, crossing_tol=xtol,
                               max_points=max_points, disk_margins=disk_margins)
    if sys.has_delay:
        ev_s = delayed_sensitivity(sys, _RTOL_L)[1]
    else:
        ev_s = _closed_loop(sys, "L")
    cl_poles = ev_s.poles

    loops, n_eval, grid_size = [], 0, 0
    err, where, cause = 0.0, np.nan, None
    for i in range(m):
        Li = _close_others(sys, i) if m > 1 else sys
        loop, grid, ne, (e, w_e, ev_e), ev_i = _siso_margins(Li, sys.inputs[i], skew=skew, rigid_tol=rigid_tol,
                                                             xtol=xtol, max_points=max_points,
                                                             ev_s=ev_s if m == 1 else None,
                                                             disks=m == 1 or disk_margins == "all")
        loops.append(loop)
        n_eval += ne
        if e > err or cause is None:
            err, where, cause = e, w_e, ev_e
        grid_size = max(grid_size, grid.size)
        if i == 0:
            first_grid, ev_L = grid, ev_i
    spec = classify(sys.A, rigid_tol, poles=ev_L.poles if m == 1 else None, B=sys.B, C=sys.C, D=sys.D)
    # closed-loop poles on the axis to rounding (the spectrum policy) are not asymptotically stable;
    # hidden modes (not driven or not seen by the loop) on the axis are not the loop's poles
    cl_poles, hidden = loop_poles(sys, cl_poles, spec)
    cl_rhp = spec.count_unstable(cl_poles)
    stable = cl_rhp == 0
    nyq_grid = first_grid
    if m == 1:
        disk0, disk1 = loops[0].disk_margin, loops[0].skewed_disk_margin
        u0, u1 = disk0, disk1
    else:
        spec_all = classify(sys.A, rigid_tol, poles=np.concatenate([spec.poles, cl_poles]), B=sys.B, C=sys.C, D=sys.D)
        grid = np.unique(np.concatenate([pole_zero_grid(spec_all, np.zeros(0), points_per_decade=30, decades=3.0),
                                         first_grid]))
        grid = avoid_axis_poles(grid, spec)
        nyq_grid = grid
        ev_L = TransferEvaluator(sys, rtol=_RTOL_L)
        avoid = np.abs(hidden.imag)
        if disk_margins == "all":
            u0 = disk_margin([ev_s], grid, 0.0, stable, "unstructured", max_points, avoid)
            u1 = u0 if skew == 0 else disk_margin([ev_s], grid, skew, stable, "unstructured", max_points, avoid)
        else:
            u0, u1 = not_computed(0.0, "unstructured"), not_computed(skew, "unstructured")
        disk0 = disk_margin([ev_s], grid, 0.0, stable, "diagonal", max_points, avoid)
        disk1 = disk0 if skew == 0 else disk_margin([ev_s], grid, skew, stable, "diagonal", max_points, avoid)
        n_eval += ev_s.n_evaluations
        if np.isfinite(disk0.frequency) and disk0.frequency > 0:
            e2, w2 = _estimate_at(ev_s, [disk0.frequency])
            if e2 > err:
                err, where, cause = e2, w2, ev_s
    if err > WARN_RTOL:
        why = cause.cause(1j * where) if cause is not None and np.isfinite(where) else "unknown"
        warnings.warn(
            f"stability_margins: the evaluation of the loop at omega = {where:.6g} rad/s has an estimated "
            f"relative error of {err:.1e} (cause: {why}); margins are accurate to about that level",
            AccuracyWarning, stacklevel=2,
        )
    ol_rhp = spec.n_rhp
    nyq = count_encirclements(ev_L, spec, cl_poles, nyq_grid, max_points=max_points)
    n_eval += ev_L.n_evaluations if m > 1 else 0
    if sys.has_delay and nyq is not None and nyq + ol_rhp != cl_rhp:
        # the delayed curve's count is exact (the Pade poles only placed grid points)
        cl_rhp, stable = nyq + ol_rhp, nyq + ol_rhp == 0
        disk0 = disk_margin([ev_s], first_grid, 0.0, stable, "siso", max_points)
        disk1 = disk0 if skew == 0 else disk_margin([ev_s], first_grid, skew, stable, "siso", max_points)
        u0, u1 = disk0, disk1
        loops = [dataclasses.replace(loops[0], disk_margin=disk0, skewed_disk_margin=disk1)]
    elif nyq is not None and nyq != cl_rhp - ol_rhp:
        warnings.warn(
            f"the Nyquist curve encircles -1 {nyq} times (clockwise) but the eigenvalues give "
            f"Z - P = {cl_rhp} - {ol_rhp}: a pole or zero of det(I + L) is too close to the imaginary axis "
            "for one of the two counts",
            AccuracyWarning, stacklevel=2,
        )
    elif sys.has_delay and nyq is None:
        warnings.warn("stability_margins: the delayed curve's Nyquist count did not resolve; closed-loop stability "
                      "comes from a 6th-order Pade approximation of the delay", AccuracyWarning, stacklevel=2)
    return StabilityMargins(
        loops=tuple(loops),
        disk_margin=disk0,
        skewed_disk_margin=disk1,
        unstructured_disk_margin=u0,
        unstructured_skewed_disk_margin=u1,
        channels=sys.inputs,
        open_loop_unstable_poles=ol_rhp,
        open_loop_imaginary_poles=spec.n_axis,
        closed_loop_unstable_poles=cl_rhp,
        closed_loop_stable=stable,
        hidden_poles=hidden,
        nyquist_encirclements=nyq,
        method="state space: modal/Schur evaluation with a-posteriori estimates, pole-aware adaptive grid, "
               "roots found on grid points, by Brent refinement and at touching extrema",
        rigid_tol=float(spec.rigid_radius),
        grid_size=int(grid_size),
        n_evaluations=int(n_eval),
        evaluation_error=float(err),
        crossing_tol=xtol,
        seconds=time.perf_counter() - t0,
    )
