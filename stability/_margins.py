"""Stability margins of a feedback loop: every crossing, gain/phase/delay margins, disk margins.

Conventions: ``L`` is the open loop of a negative-feedback loop (closed loop ``(I + L)^-1 L``),
square, with the loop broken at its inputs. Frequencies are in rad/s, phase margins in degrees,
gain margins as ratios (``gain_margins_db`` in dB), delays in seconds.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.optimize
from numpy.typing import NDArray

from linflex import AccuracyWarning, LinearSystem, ModelError, ShapeError, as_linear_system

from ._common import check_positive, rigid_mask, system_scale
from ._nyquist import nyquist_encirclements
from ._response import TransferEvaluator

__all__ = ["DiskMargin", "LoopMargins", "StabilityMargins", "stability_margins"]

#: Grid refinement: an interval is split while the phase of L changes by more than this [deg] ...
_MAX_DPHASE_DEG = 8.0
#: ... or log10 |L| changes by more than this (0.05 = 1 dB).
_MAX_DLOG10 = 0.05
#: Relative offsets (in units of zeta * w_n) of the extra grid points around a lightly damped pole
#: or zero (the half-power band of a lightly damped pair is about 2 zeta w_n wide).
_VERNIER = np.array([0.0, 0.1, 0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 8.0, 16.0, 32.0, 64.0])
_ZETA_VERNIER = 0.3
_MAG_WINDOW = (1e-10, 1e10)
_ZETA_FLOOR = 1e-9


def _ro(a) -> NDArray:
    arr = np.array(a, dtype=float)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class DiskMargin:
    """A disk margin and the gain and phase variations it guarantees.

    Attributes
    ----------
    alpha : float
        Size [-] of the largest disk of multiplicative perturbations the loop tolerates:
        ``alpha = 1 / max_w mu(S(jw) + (skew - 1)/2 I)``, ``mu`` being ``|.|`` for a single
        loop and as stated by ``structure`` for several (0 when the nominal closed loop is
        unstable).
    skew : float
        Skew ``sigma`` [-] of the disk: 0 balanced (``S - T``)/2, 1 sensitivity ``S``, -1
        complementary sensitivity ``T``.
    frequency : float
        Frequency [rad/s] of the peak that sets ``alpha`` (``nan`` when the closed loop is
        unstable).
    gain_margin : tuple of float
        ``(low, high)``: simultaneous gain changes in this range [ratio] keep the loop stable
        (``high`` is ``inf`` when the disk contains all of ``[1, inf)``).
    phase_margin : float
        Phase change [deg] tolerated (simultaneously in all loops for a multi-loop margin).
    structure : str
        ``"siso"`` (exact for the single loop); ``"diagonal"``: multi-loop margin for
        independent, simultaneous complex perturbations of every channel, ``alpha = 1 / max_w
        mu_ub`` with the D-scaled upper bound ``mu_ub = min_D sigma_max(D M D^-1)`` of the
        structured singular value, hence a (slightly conservative) lower bound of the exact
        multi-loop margin; ``"unstructured"``: ``alpha`` from the largest singular value of
        ``S + (skew-1)/2 I`` (a full perturbation matrix), a lower bound of both.
    """

    alpha: float
    skew: float
    frequency: float
    gain_margin: tuple[float, float]
    phase_margin: float
    structure: str

    @property
    def gain_margin_db(self) -> tuple[float, float]:
        """``gain_margin`` [dB]."""
        with np.errstate(divide="ignore"):
            return tuple(float(20 * np.log10(g)) for g in self.gain_margin)


def _disk(alpha: float, skew: float, frequency: float, structure: str) -> DiskMargin:
    """Gain and phase ranges of the disk ``{(1 + (1-s)/2 d) / (1 - (1+s)/2 d) : |d| <= alpha}``.

    Seiler, Packard and Gahinet (2020), "An introduction to disk margins", IEEE Control Systems
    Magazine 40(5), eqs. for gamma_min, gamma_max and the phase margin.
    """
    a, s = alpha, skew
    # real end points of the boundary circle; x2 < 0 when the "disk" is the outside of a circle
    # (a (1 + s) > 2), which then holds every gain above x1
    x1 = (2 - a * (1 - s)) / (2 + a * (1 + s))
    den = 2 - a * (1 + s)
    x2 = (2 + a * (1 - s)) / den if den != 0 else np.inf
    low = max(x1, 0.0)
    high = x2 if den > 0 else np.inf
    # the boundary circle meets the unit circle where cos(phi) = (1 + x1 x2) / (x1 + x2)
    # (-> x1 as x2 -> inf)
    c = x1 if np.isinf(x2) else (1 + x1 * x2) / (x1 + x2)
    phase = 0.0 if a == 0 else float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))
    return DiskMargin(alpha=float(a), skew=float(s), frequency=float(frequency),
                      gain_margin=(float(low), float(high)), phase_margin=phase, structure=structure)


@dataclass(frozen=True)
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
    open_loop_rhp_poles : int
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
    open_loop_rhp_poles: int

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
    open_loop_rhp_poles : int
        Poles of ``L`` in the open right half-plane (beyond ``rigid_tol``).
    open_loop_imaginary_poles : int
        Poles of ``L`` on the imaginary axis (rigid-body poles and undamped modes).
    closed_loop_rhp_poles : int
        Closed-loop poles (eigenvalues of ``A - B (I + D)^-1 C``) with non-negative real part.
    closed_loop_stable : bool
        True if every closed-loop pole is in the open left half-plane.
    nyquist_encirclements : int or None
        Net counterclockwise encirclements of the origin by ``det(I + L(s))`` (of -1 by ``L`` for
        a single loop) along the Nyquist contour, indented to the right around imaginary-axis
        poles, counted from the curve itself (see ``stability/_nyquist.py``); ``None`` when a
        closed-loop pole lies on the axis or the curve could not be resolved. The argument
        principle makes it ``open_loop_rhp_poles - closed_loop_rhp_poles`` (an
        :class:`~linflex.AccuracyWarning` is issued if the two counts disagree); the closed loop
        is stable iff it equals ``open_loop_rhp_poles``.
    method : str
        How the crossings were found.
    rigid_tol : float
        Tolerance [1/s] on ``|lambda|`` for the rigid-body cluster.
    grid_size : int
        Frequencies on the final grid of the first loop (largest over loops).
    n_evaluations : int
        Evaluations of a frequency response, all loops together.
    evaluation_error : float
        Largest relative difference [-] between the fast frequency response and dense complex solves
        ``C (jw I - A)^-1 B + D`` at the worst crossings, a spread of the others, and the disk
        margin peaks.
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
    open_loop_rhp_poles: int
    open_loop_imaginary_poles: int
    closed_loop_rhp_poles: int
    closed_loop_stable: bool
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
            out.append(f"**Loop {lp.channel}** (open-loop RHP poles: {lp.open_loop_rhp_poles})\n")
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

    def __str__(self) -> str:
        lines = [
            f"Stability margins ({len(self.loops)} loop{'s' if len(self.loops) > 1 else ''}, "
            f"closed loop {'stable' if self.closed_loop_stable else 'UNSTABLE'}, "
            f"{self.open_loop_rhp_poles} open-loop RHP poles, {self.open_loop_imaginary_poles} on the axis)"
        ]
        for lp in self.loops:
            lines.append(f"  loop {lp.channel}:")
            for w, pm, tau in zip(lp.gain_crossovers, lp.phase_margins, lp.delay_margins):
                lines.append(f"    gain crossover {w:.6g} rad/s: phase margin {pm:.4f} deg, delay margin {tau:.4g} s")
            for w, gm in zip(lp.phase_crossovers, lp.gain_margins):
                lines.append(f"    phase crossover {w:.6g} rad/s: gain margin {gm:.5g} ({20 * np.log10(gm):+.3f} dB)")
            dm = lp.disk_margin
            lines.append(
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
# frequency grid


def _features(points: NDArray[np.complex128], tol: float) -> list[tuple[float, float]]:
    """(w_n, zeta) of poles/zeros away from the origin, one per conjugate pair."""
    out = []
    for p in points:
        if not np.isfinite(p) or abs(p) <= tol or p.imag < 0:
            continue
        wn = abs(p)
        out.append((wn, abs(p.real) / wn))
    return out


def _base_grid(features: list[tuple[float, float]], per_decade: int = 30) -> NDArray[np.float64]:
    if features:
        wns = np.array([f[0] for f in features])
        lo, hi = wns.min() / 1e3, wns.max() * 1e3
    else:
        lo, hi = 1e-3, 1e3
    n = max(int(np.ceil(np.log10(hi / lo) * per_decade)), 2)
    pts = [np.geomspace(lo, hi, n)]
    for wn, zeta in features:
        if zeta >= _ZETA_VERNIER:
            continue
        wd = wn * np.sqrt(max(1.0 - 2 * zeta**2, 0.0)) if zeta < 0.7 else wn
        z = max(zeta, _ZETA_FLOOR)
        off = _VERNIER if zeta > _ZETA_FLOOR else _VERNIER[1:]
        pts.append(wd * (1 + z * off))
        pts.append(wd * (1 - z * off[z * off < 0.5]))
        pts.append(wn * (1 + z * off[:6]))
        pts.append(wn * (1 - z * off[1:6]))
    grid = np.unique(np.concatenate(pts))
    return grid[(grid > 0) & np.isfinite(grid)]


def _extend(f_log: callable, w: float, factor: float, limit: int = 24) -> list[float]:
    """Points beyond a grid end while ``log|L|`` still moves towards 0 dB (asymptotic region)."""
    out = []
    g0 = f_log(w)
    for _ in range(limit):
        w1 = w * factor
        g1 = f_log(w1)
        if not (np.isfinite(g1) and np.isfinite(g0)) or w1 <= 0 or not np.isfinite(w1):
            break
        if np.sign(g1) != np.sign(g0):
            out.append(w1)
            break
        if abs(g1) < abs(g0) - 1e-3:
            out.append(w1)
            w, g0 = w1, g1
            continue
        break
    return out


def _refine(grid: NDArray[np.float64], values: NDArray[np.complex128], ev, max_points: int, depth: int = 14):
    """Insert geometric midpoints where the phase or the magnitude of L changes too fast."""
    for _ in range(depth):
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = values[1:] / values[:-1]
            dphase = np.degrees(np.abs(np.angle(ratio)))
            dlog = np.abs(np.log10(np.abs(ratio)))
            mag = np.abs(values)
        bad = (dphase > _MAX_DPHASE_DEG) | (dlog > _MAX_DLOG10) | ~np.isfinite(ratio)
        bad &= grid[1:] / grid[:-1] > 1 + 1e-12
        # no refinement where |L| stays below 1e-10 or above 1e10: a crossing there would mean a
        # gain margin beyond 200 dB, and the response of the model is only rounding noise
        bad &= ~((mag[1:] < _MAG_WINDOW[0]) & (mag[:-1] < _MAG_WINDOW[0]))
        bad &= ~((mag[1:] > _MAG_WINDOW[1]) & (mag[:-1] > _MAG_WINDOW[1]))
        if not bad.any():
            break
        if grid.size + bad.sum() > max_points:
            warnings.warn(
                f"stability_margins: the frequency grid reached max_points={max_points} with "
                f"{int(bad.sum())} intervals still unresolved; crossings inside them may be missed",
                AccuracyWarning, stacklevel=4,
            )
            break
        i = np.flatnonzero(bad)
        mid = np.sqrt(grid[i] * grid[i + 1])
        vm = ev(mid)
        grid = np.insert(grid, i + 1, mid)
        values = np.insert(values, i + 1, vm)
    return grid, values


# --------------------------------------------------------------------------------------------
# single loop


def _siso_zeros(sys: LinearSystem) -> NDArray[np.complex128]:
    """Finite zeros of a SISO system from the generalized eigenvalues of its system pencil."""
    n = sys.n_states
    if n == 0:
        return np.zeros(0, complex)
    M = np.block([[sys.A, sys.B], [sys.C, sys.D]])
    N = np.zeros_like(M)
    N[:n, :n] = np.eye(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = scipy.linalg.eigvals(M, N, check_finite=False)
    z = z[np.isfinite(z)]
    return z[np.abs(z) < 1e12 * max(1.0, np.linalg.norm(sys.A, 1))]


def _pole_structure(A: NDArray[np.float64], rigid_tol: float | None):
    """Poles, rigid-body mask, cluster tolerance for the evaluator, RHP and imaginary-axis counts."""
    poles = np.linalg.eigvals(A) if A.shape[0] else np.zeros(0, complex)
    rigid, radius = rigid_mask(poles, A, rigid_tol)
    floor = 100 * np.finfo(float).eps * system_scale(A)
    cluster = max(2 * radius, floor) if rigid.any() else -1.0
    rhp = int(np.count_nonzero(~rigid & (poles.real > floor) & (poles.real > 1e-12 * np.abs(poles))))
    axis = int(np.count_nonzero(rigid | (np.abs(poles.real) <= np.maximum(floor, 1e-12 * np.abs(poles)))))
    return poles, rigid, cluster, rhp, axis


def _root(f, a: float, b: float, xtol: float) -> float | None:
    """Brent's method on [a, b] (in log w); None when f does not change sign there.

    The sign test on the grid used batched evaluations; rounding may differ in single-point
    evaluations when f is within rounding of zero at an end, hence the check here.
    """
    fa, fb = f(a), f(b)
    if fa == 0:
        return a
    if fb == 0:
        return b
    if not (np.isfinite(fa) and np.isfinite(fb)) or np.sign(fa) == np.sign(fb):
        return None
    return scipy.optimize.brentq(f, a, b, xtol=xtol * 1e-3, rtol=xtol)


def _check_points(wgc, pm, wpc, gm, n: int = 6) -> NDArray[np.float64]:
    """Up to ``n`` crossings to check by dense solves: the worst ones first, then spread out."""
    pts = []
    if wgc.size:
        pts.append(wgc[int(np.argmin(np.abs(pm)))])
        pts.extend(wgc[np.linspace(0, wgc.size - 1, min(wgc.size, n // 2)).astype(int)])
    if wpc.size:
        with np.errstate(divide="ignore"):
            pts.append(wpc[int(np.argmin(np.abs(np.log(gm))))])
        pts.extend(wpc[np.linspace(0, wpc.size - 1, min(wpc.size, n // 2)).astype(int)])
    return np.unique(np.array(pts, dtype=float))


def _siso_margins(sys: LinearSystem, channel: str, *, skew: float, rigid_tol, xtol: float, max_points: int):
    """Margins of one SISO loop; returns (LoopMargins, grid size, evaluations, check error)."""
    poles, rigid, cluster, rhp, _ = _pole_structure(np.asarray(sys.A), rigid_tol)
    ev = TransferEvaluator(sys.A, sys.B, sys.C, sys.D, rigid_tol)
    tol = max(cluster, 0.0)
    zeros = _siso_zeros(sys)
    M = 1.0 / (1.0 + sys.D[0, 0]) if sys.D[0, 0] != -1 else None
    if M is None:
        raise ModelError(f"loop {channel!r}: I + D is singular (D = -1), the feedback loop is not well posed")
    A_cl = sys.A - M * sys.B @ sys.C
    ev_s = TransferEvaluator(A_cl, M * sys.B, -M * sys.C, np.array([[M]]), split_rigid=False)
    cl_poles = ev_s.poles

    feats = _features(np.concatenate([poles, zeros, cl_poles]), tol)
    grid = _base_grid(feats)

    def L(w):
        return ev.siso(w)

    def log_mag(w: float) -> float:
        with np.errstate(divide="ignore"):
            return float(np.log(np.abs(L(np.array([w]))[0])))

    grid = np.unique(np.concatenate([grid, _extend(log_mag, grid[0], 0.1), _extend(log_mag, grid[-1], 10.0)]))
    values = L(grid)
    grid, values = _refine(grid, values, L, max_points)

    # gain crossovers: sign changes of log|L|, refined by brentq in log(w)
    with np.errstate(divide="ignore"):
        g = np.log(np.abs(values))
    finite = np.isfinite(g)
    wgc = []
    for i in np.flatnonzero(finite[:-1] & finite[1:] & (np.sign(g[:-1]) * np.sign(g[1:]) < 0)):
        x = _root(lambda t: log_mag(np.exp(t)), np.log(grid[i]), np.log(grid[i + 1]), xtol)
        if x is not None:
            wgc.append(np.exp(x))
    wgc = np.array(sorted(wgc))
    Lgc = L(wgc) if wgc.size else np.zeros(0, complex)
    pm = np.degrees(np.angle(-Lgc))
    dm = np.radians(np.mod(pm, 360.0)) / wgc

    # phase crossovers: sign changes of Im L / |L| where Re L < 0, refined by brentq in log(w)
    def sin_phase(t: float) -> float:
        v = L(np.array([np.exp(t)]))[0]
        return float(v.imag / abs(v))

    with np.errstate(invalid="ignore"):
        h = values.imag / np.abs(values)
    ok = np.isfinite(h)
    wpc = []
    cand = np.flatnonzero(ok[:-1] & ok[1:] & (np.sign(h[:-1]) * np.sign(h[1:]) < 0)
                          & ((values.real[:-1] < 0) | (values.real[1:] < 0)))
    for i in cand:
        x = _root(sin_phase, np.log(grid[i]), np.log(grid[i + 1]), xtol)
        if x is None:
            continue
        v = L(np.array([np.exp(x)]))[0]
        # across a pole on the axis Im L changes sign through infinity: not a crossing
        if np.isfinite(v) and v.real < 0 and abs(v.imag) <= 1e-6 * abs(v):
            wpc.append(np.exp(x))
    if not rigid.any():
        L0 = L(np.array([0.0]))[0]
        if np.isfinite(L0) and L0.real < 0 and abs(L0.imag) <= 1e-12 * abs(L0):
            wpc.append(0.0)
    # gain margins beyond +-200 dB are not reported: where |L| < 1e-10 or > 1e10 the computed
    # phase is rounding noise (a velocity output at w -> 0, a double integrator's exact -180 deg)
    if wpc:
        mags = np.abs(L(np.array(wpc)))
        wpc = [w for w, a in zip(wpc, mags) if _MAG_WINDOW[0] <= a <= _MAG_WINDOW[1]]
    wpc = np.array(sorted(wpc))
    Lpc = L(wpc) if wpc.size else np.zeros(0, complex)
    gm = -1.0 / Lpc.real if wpc.size else np.zeros(0)

    # disk margins from the sensitivity S = (1 + L)^-1 evaluated from its own realization;
    # stability from LAPACK geev (balanced) eigenvalues of the closed loop
    stable = bool(np.all(np.linalg.eigvals(A_cl).real < 0)) if A_cl.shape[0] else True
    disk0 = _disk_margin([ev_s], grid, 0.0, stable, "siso", max_points)
    disk1 = disk0 if skew == 0 else _disk_margin([ev_s], grid, skew, stable, "siso", max_points)

    # accuracy of the fast evaluation where it matters: at the crossings and the disk peak
    check_w = _check_points(wgc, pm, wpc, gm)
    err = ev.check(check_w) if check_w.size else 0.0
    if np.isfinite(disk0.frequency):
        err = max(err, ev_s.check([disk0.frequency], floor=1.0))

    if wgc.size:
        j = int(np.argmin(np.abs(pm)))
        min_pm, min_pm_w = float(pm[j]), float(wgc[j])
    else:
        min_pm, min_pm_w = np.inf, np.nan
    if wpc.size:
        with np.errstate(divide="ignore"):
            j = int(np.argmin(np.abs(np.log(gm))))
        min_gm, min_gm_w = float(gm[j]), float(wpc[j])
    else:
        min_gm, min_gm_w = np.inf, np.nan
    up, down = gm[gm > 1], gm[gm < 1]
    loop = LoopMargins(
        channel=channel,
        gain_crossovers=_ro(wgc),
        phase_margins=_ro(pm),
        delay_margins=_ro(dm),
        phase_crossovers=_ro(wpc),
        gain_margins=_ro(gm),
        delay_margin=float(dm.min()) if dm.size else np.inf,
        min_phase_margin=min_pm,
        min_phase_margin_frequency=min_pm_w,
        min_gain_margin=min_gm,
        min_gain_margin_frequency=min_gm_w,
        gain_increase_margin=float(up.min()) if up.size else np.inf,
        gain_reduction_margin=float(down.max()) if down.size else 0.0,
        disk_margin=disk0,
        skewed_disk_margin=disk1,
        open_loop_rhp_poles=rhp,
    )
    return loop, grid, ev.n_evaluations + ev_s.n_evaluations, err, ev


def _osborne_log_scaling(M: NDArray[np.complex128], sweeps: int = 25) -> NDArray[np.float64]:
    """log of diagonal scalings D that balance the off-diagonal part of each ``M[k]`` (Osborne).

    Minimizing the Frobenius norm of ``D M D^-1`` row by row (Gauss-Seidel sweeps, vectorized over
    the first axis): row i and column i of ``|D M D^-1|^2`` are equalized by scaling ``d_i`` with
    ``(c_i / r_i)^(1/4)``. Any positive diagonal D gives an upper bound of mu; this one is a good
    start for the exact minimization of the largest singular value.
    """
    n, m, _ = M.shape
    P = np.abs(M) ** 2
    P[:, np.arange(m), np.arange(m)] = 0.0
    logd = np.zeros((n, m))
    tiny = np.finfo(float).tiny
    for _ in range(sweeps):
        for i in range(m):
            e = np.exp(2 * (logd[:, :, None] - logd[:, None, :]))
            r = (P[:, i, :] * e[:, i, :]).sum(axis=1)
            c = (P[:, :, i] * e[:, :, i]).sum(axis=1)
            ok = (r > tiny) & (c > tiny)
            logd[ok, i] += 0.25 * (np.log(c[ok]) - np.log(r[ok]))
        logd = np.clip(logd - logd[:, :1], -300, 300)
    return logd


def _peak_values(M: NDArray[np.complex128], structure: str) -> NDArray[np.float64]:
    """|M| (siso), sigma_max(M) (unstructured) or sigma_max(D M D^-1) with Osborne D (diagonal)."""
    if M.shape[1] == 1:
        return np.abs(M[:, 0, 0])
    if structure == "diagonal":
        logd = _osborne_log_scaling(M)
        M = M * np.exp(logd[:, :, None] - logd[:, None, :])
    return np.linalg.svd(M, compute_uv=False)[:, 0]


def _polished_mu(M: NDArray[np.complex128]) -> float:
    """min over positive diagonal D of sigma_max(D M D^-1) (the mu upper bound for scalar complex
    blocks), by Nelder-Mead in log D from the Osborne scaling; the problem is convex in log D."""
    m = M.shape[0]
    x0 = _osborne_log_scaling(M[None])[0, 1:]

    def f(x):
        logd = np.concatenate([[0.0], x])
        return float(np.linalg.svd(M * np.exp(logd[:, None] - logd[None, :]), compute_uv=False)[0])

    start = f(x0)
    if m == 1:
        return start
    res = scipy.optimize.minimize(f, x0, method="Nelder-Mead",
                                  options={"xatol": 1e-10, "fatol": 1e-14 * start, "maxiter": 4000})
    return min(start, float(res.fun))


def _disk_margin(evs, grid, skew: float, stable: bool, structure: str, max_points: int) -> DiskMargin:
    """alpha = 1 / max_w mu(S(jw) + (skew - 1)/2 I): grid search plus local refinement.

    ``mu`` is ``|.|`` for a single loop, ``sigma_max`` for ``structure="unstructured"`` and the
    D-scaled upper bound ``min_D sigma_max(D M D^-1)`` for ``structure="diagonal"``
    (independent complex perturbations of each channel). ``evs`` holds one evaluator of ``S``
    (for MIMO, the full sensitivity matrix). The grid is the pole-aware grid of the loop (which
    has clusters at the lightly damped closed-loop poles), refined where the peak function
    changes by more than 0.1 dB, with ``w = 0`` and ``w = inf`` added; the largest local maxima
    are polished by a bounded scalar search in ``log w`` between their neighbours (and, for the
    diagonal structure, by an exact minimization over D at the best candidates).
    """
    if not stable:
        return _disk(0.0, skew, np.nan, structure)
    ev = evs[0]
    c = (skew - 1.0) / 2.0
    eye = np.eye(ev.D.shape[1])

    def peak(w):
        return _peak_values(ev(w) + c * eye[None], structure)

    w = grid
    vals = peak(w)
    for _ in range(8):
        with np.errstate(divide="ignore", invalid="ignore"):
            dl = np.abs(np.log10(vals[1:] / vals[:-1]))
        bad = (dl > 0.005) & (w[1:] / w[:-1] > 1 + 1e-12)
        if not bad.any() or w.size + bad.sum() > max_points:
            break
        i = np.flatnonzero(bad)
        mid = np.sqrt(w[i] * w[i + 1])
        w = np.insert(w, i + 1, mid)
        vals = np.insert(vals, i + 1, peak(mid))
    cands = [(float(peak(np.array([0.0]))[0]), 0.0),
             (float(_peak_values((ev.D + c * eye)[None].astype(complex), structure)[0]), np.inf)]
    interior = np.flatnonzero((vals[1:-1] >= vals[:-2]) & (vals[1:-1] >= vals[2:])) + 1
    top = interior[np.argsort(-vals[interior])[:8]]
    for i in top:
        res = scipy.optimize.minimize_scalar(
            lambda t: -float(peak(np.array([np.exp(t)]))[0]),
            bounds=(np.log(w[i - 1]), np.log(w[i + 1])), method="bounded",
            options={"xatol": 1e-10},
        )
        cands.append(max((-float(res.fun), float(np.exp(res.x))), (float(vals[i]), float(w[i]))))
    if vals.size:
        j = int(np.argmax(vals))
        cands.append((float(vals[j]), float(w[j])))
    if structure == "diagonal" and eye.shape[0] > 1:
        polished = []
        for _, wc in sorted(cands, key=lambda t: -t[0])[:4]:
            Mc = (ev.D + c * eye).astype(complex) if np.isinf(wc) else ev(np.array([wc]))[0] + c * eye
            polished.append((_polished_mu(Mc), wc))
        cands = polished
    # on a plateau (S -> 1 both at w -> 0 and w -> inf, say) report the first of the tied
    # candidates in the order w = 0, w = inf, interior peaks, rather than a rounding-noise winner
    top = max(v for v, _ in cands)
    best, best_w = next((v, wc) for v, wc in cands if v >= top * (1 - 1e-9))
    best = top
    alpha = 1.0 / best if best > 0 else np.inf
    return _disk(alpha, skew, best_w, structure)


def _close_others(sys: LinearSystem, i: int) -> LinearSystem:
    """Loop ``i`` of a square ``L`` broken with the other loops closed by ``u_o = -y_o``.

    ::

        x' = (A - B_o M C_o) x + (B_i - B_o M D_oi) u_i        M = (I + D_oo)^-1
        y_i = (C_i - D_io M C_o) x + (D_ii - D_io M D_oi) u_i
    """
    m = sys.n_inputs
    o = [j for j in range(m) if j != i]
    A, B, C, D = (np.asarray(x) for x in (sys.A, sys.B, sys.C, sys.D))
    if not o:
        return sys
    Doo = D[np.ix_(o, o)]
    try:
        M = np.linalg.inv(np.eye(len(o)) + Doo)
    except np.linalg.LinAlgError as err:
        raise ModelError(f"closing the loops other than {sys.inputs[i]!r}: I + D is singular") from err
    Bo, Co = B[:, o], C[o, :]
    Ai = A - Bo @ M @ Co
    Bi = B[:, [i]] - Bo @ M @ D[np.ix_(o, [i])]
    Ci = C[[i], :] - D[np.ix_([i], o)] @ M @ Co
    Di = D[np.ix_([i], [i])] - D[np.ix_([i], o)] @ M @ D[np.ix_(o, [i])]
    return LinearSystem(Ai, Bi, Ci, Di, states=sys.states, inputs=[sys.inputs[i]], outputs=[sys.outputs[i]])


# --------------------------------------------------------------------------------------------
# entry point


def _nyquist_count(ev, D, cl_poles, grid, max_points: int) -> int | None:
    """Encirclement count of det(I + L) with the axis poles of ``ev`` indented (None if unresolved)."""
    if np.any(np.abs(cl_poles.real) <= 1e-12 * np.maximum(np.abs(cl_poles), 1.0)):
        return None  # a closed-loop pole on the contour
    poles = ev.poles
    scale = system_scale(np.asarray(ev.A))
    floor = 100 * np.finfo(float).eps * scale
    rigid = np.zeros(poles.size, bool)
    rigid[:ev.k] = True  # the rigid cluster comes first in the evaluator's Schur form
    axis = []
    if ev.k:
        axis.append((0.0, float(np.abs(poles[:ev.k]).max())))
    near_axis = ~rigid & (np.abs(poles.real) <= np.maximum(floor, 1e-12 * np.abs(poles)))
    on_axis = near_axis & (poles.imag > 0)  # conjugates are implied
    for p in sorted(poles[on_axis], key=lambda z: z.imag):
        r = max(abs(p.real), 1e-12 * abs(p))
        if axis and abs(axis[-1][0] - p.imag) <= 1e-8 * p.imag + axis[-1][1]:
            axis[-1] = (axis[-1][0], max(axis[-1][1], r, abs(axis[-1][0] - p.imag)))
        else:
            axis.append((float(p.imag), r))
    others = np.concatenate([poles[~rigid & ~near_axis], cl_poles])
    return nyquist_encirclements(ev, np.asarray(D), axis, others, grid, max_points=max_points)


def _open_loop(L) -> LinearSystem:
    """The open loop as a LinearSystem; a :class:`linflex.frequency.Loop` gives ``loop.open_loop()``.

    ``Loop.open_loop()`` is ``L = K P`` broken at the plant input, with the negative-feedback
    convention used here (closed-loop characteristic equation ``det(I + L) = 0``).
    """
    from linflex.frequency import Loop

    if isinstance(L, Loop):
        return L.open_loop()
    return as_linear_system(L, "L")


def stability_margins(
    L,
    *,
    skew: float = 0.0,
    rigid_tol: float | None = None,
    crossing_tol: float = 1e-12,
    max_points: int = 400_000,
) -> StabilityMargins:
    """Gain, phase, delay and disk margins of a feedback loop, with every crossing.

    Parameters
    ----------
    L : Loop, LinearSystem, SecondOrderSystem or control.StateSpace
        A :class:`linflex.frequency.Loop` (analysed through ``loop.open_loop()``, the loop broken
        at the plant input, channels named by the actuators) or a square open loop of a
        negative-feedback loop: the closed loop is ``(I + L)^-1 L``. For a MIMO loop, input ``i``
        and output ``i`` form channel ``i``.
    skew : float, optional
        Skew ``sigma`` [-] of the second disk margin (``skewed_disk_margin``): 0 balanced, 1 the
        sensitivity-based disk (``1 / ||S||_inf``), -1 complementary-sensitivity based; a
        positive skew allows more gain increase than decrease. Default 0.
    rigid_tol : float, optional
        Absolute tolerance [1/s] on ``|lambda|`` for rigid-body poles (default ``1e-6`` times
        the balanced 1-norm of ``A``).
    crossing_tol : float, optional
        Relative tolerance [-] of the refined crossing frequencies. Default 1e-12.
    max_points : int, optional
        Cap on the adaptive frequency grid per loop. Default 400000; an
        :class:`~linflex.AccuracyWarning` says when it is reached.

    Returns
    -------
    StabilityMargins
        Loop-at-a-time margins in ``loops`` (one per channel), multi-loop disk margins, pole
        counts, provenance; SISO accessors ``gain_crossovers``, ``phase_margins``, ...

    Raises
    ------
    ModelError
        If ``L`` is not a loop or linear system, ``skew`` is not in [-1, 1], or ``I + D`` is
        singular.
    ShapeError
        If ``L`` is not square or has no channels.

    Warns
    -----
    AccuracyWarning
        If the grid cap is reached, if the fast evaluation of ``L(jw)`` differs from dense solves
        by more than 1e-6 at the crossings, or if the Nyquist count on the curve disagrees with
        the eigenvalue counts.

    Notes
    -----
    Everything is computed from the state-space model, never from polynomial coefficients:

    1. ``L(jw)`` by a Schur/Sylvester/eigen factorization of ``A`` done once (see
       ``stability/_response.py``), checked against dense complex solves
       (``evaluation_error``);
    2. a pole-aware grid: 30 points per decade from three decades below the smallest to three
       above the largest pole or zero (of ``L`` and of the closed loop), plus clusters at
       ``w (1 +- zeta x)`` around every lightly damped pole and zero, extended further while
       ``|L|`` moves towards 0 dB, then refined until phase steps are below 8 deg and magnitude
       steps below 1 dB;
    3. gain crossovers: sign changes of ``log|L|``, refined by Brent's method in ``log w``;
       phase crossovers: sign changes of ``Im L / |L|`` with ``Re L < 0``, refined likewise and
       checked (a sign change through a pole on the axis is rejected). ``w = 0`` is a phase
       crossover only when ``L(0)`` is finite and negative, so a double integrator (phase exactly
       -180 deg as ``w -> 0``) has no spurious zero-frequency gain margin;
    4. disk margin ``alpha = 1 / ||S + (sigma - 1)/2 I||_inf`` (Seiler, Packard and Gahinet,
       "An introduction to disk margins", IEEE CSM 2020), peak by grid search plus bounded
       local refinement; gain range ``[(2 - a(1-s))/(2 + a(1+s)), (2 + a(1-s))/(2 - a(1+s))]``
       and phase ``arccos((1 + g_lo g_hi)/(g_lo + g_hi))``.

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
    sys = _open_loop(L)
    p, m = sys.shape
    if p != m:
        raise ShapeError(f"L must be square (the loop is closed output i to input i): it has {p} outputs and {m} inputs")
    if m == 0:
        raise ShapeError("L has no inputs or outputs: there is no loop to analyse")
    try:
        skew = float(skew)
    except (TypeError, ValueError) as err:
        raise ModelError(f"skew must be a number in [-1, 1], got {skew!r}") from err
    if not -1.0 <= skew <= 1.0:
        raise ModelError(f"skew must be in [-1, 1], got {skew!r}")
    xtol = check_positive(crossing_tol, "crossing_tol")
    try:
        max_points = int(max_points)
    except (TypeError, ValueError) as err:
        raise ModelError(f"max_points must be an integer, got {max_points!r}") from err
    if max_points < 100:
        raise ModelError(f"max_points must be at least 100, got {max_points}")

    if rigid_tol is not None:
        rigid_tol = check_positive(rigid_tol, "rigid_tol", allow_zero=True)
    A, B, C, D = (np.asarray(x) for x in (sys.A, sys.B, sys.C, sys.D))
    poles, rigid, cluster, ol_rhp, ol_axis = _pole_structure(A, rigid_tol)
    tol = max(cluster, 0.0)
    try:
        Minv = np.linalg.inv(np.eye(m) + D)
    except np.linalg.LinAlgError as err:
        raise ModelError("I + D is singular: the feedback loop is not well posed") from err
    if not np.all(np.isfinite(Minv)) or np.linalg.cond(np.eye(m) + D) > 1e14:
        raise ModelError("I + D is singular: the feedback loop is not well posed")
    A_cl = A - B @ Minv @ C
    cl_poles = np.linalg.eigvals(A_cl) if sys.n_states else np.zeros(0, complex)
    cl_rhp = int(np.count_nonzero(cl_poles.real >= 0))
    stable = cl_rhp == 0

    loops, n_eval, err, grid_size = [], 0, 0.0, 0
    for i in range(m):
        Li = _close_others(sys, i) if m > 1 else sys
        loop, grid, ne, e, ev_i = _siso_margins(Li, sys.inputs[i], skew=skew, rigid_tol=rigid_tol, xtol=xtol,
                                                max_points=max_points)
        loops.append(loop)
        n_eval += ne
        err = max(err, e)
        grid_size = max(grid_size, grid.size)
        if i == 0:
            first_grid, ev_L = grid, ev_i
    nyq_grid = first_grid
    if m == 1:
        disk0, disk1 = loops[0].disk_margin, loops[0].skewed_disk_margin
        u0, u1 = disk0, disk1
    else:
        ev_s = TransferEvaluator(A_cl, B @ Minv, -Minv @ C, Minv, split_rigid=False)
        feats = _features(np.concatenate([poles, cl_poles]), tol)
        grid = np.unique(np.concatenate([_base_grid(feats), first_grid]))
        nyq_grid = grid
        ev_L = TransferEvaluator(A, B, C, D, rigid_tol)
        u0 = _disk_margin([ev_s], grid, 0.0, stable, "unstructured", max_points)
        u1 = u0 if skew == 0 else _disk_margin([ev_s], grid, skew, stable, "unstructured", max_points)
        disk0 = _disk_margin([ev_s], grid, 0.0, stable, "diagonal", max_points)
        disk1 = disk0 if skew == 0 else _disk_margin([ev_s], grid, skew, stable, "diagonal", max_points)
        n_eval += ev_s.n_evaluations
        if np.isfinite(disk0.frequency):
            err = max(err, ev_s.check([disk0.frequency], floor=1.0))
    if err > 1e-6:
        warnings.warn(
            f"stability_margins: L(jw) from the fast evaluation differs from dense complex solves by "
            f"{err:.1e} (relative) at the crossings; margins are accurate to about that level",
            AccuracyWarning, stacklevel=2,
        )
    nyq = _nyquist_count(ev_L, D, cl_poles, nyq_grid, max_points)
    n_eval += ev_L.n_evaluations if m > 1 else 0
    if nyq is not None and nyq != ol_rhp - cl_rhp:
        warnings.warn(
            f"the Nyquist curve encircles -1 {nyq} times (counterclockwise) but the eigenvalues give "
            f"P - Z = {ol_rhp} - {cl_rhp}: a pole or zero of det(I + L) is too close to the imaginary axis "
            "for one of the two counts",
            AccuracyWarning, stacklevel=2,
        )
    return StabilityMargins(
        loops=tuple(loops),
        disk_margin=disk0,
        skewed_disk_margin=disk1,
        unstructured_disk_margin=u0,
        unstructured_skewed_disk_margin=u1,
        channels=sys.inputs,
        open_loop_rhp_poles=ol_rhp,
        open_loop_imaginary_poles=ol_axis,
        closed_loop_rhp_poles=cl_rhp,
        closed_loop_stable=stable,
        nyquist_encirclements=nyq,
        method="state space: Schur/Sylvester/eigen evaluation, pole-aware adaptive grid, Brent refinement",
        rigid_tol=tol,
        grid_size=int(grid_size),
        n_evaluations=int(n_eval),
        evaluation_error=float(err),
        crossing_tol=xtol,
        seconds=time.perf_counter() - t0,
    )
