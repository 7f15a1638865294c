"""Requirements against the analysis: every crossing and loop gets a value, a bound and a verdict.

Each margin is measured where it is defined (gain margins at phase crossovers, phase and delay
margins at gain crossovers, disk margins and sensitivity peaks per loop and for all loops at
once); the limiting item of a quantity is the one with the least slack against its bound (the
smallest value when nothing is required). An unstable closed loop has no margins and no
sensitivity peaks (the peak of an unstable transfer function on the imaginary axis bounds
nothing): every item fails and its value is shown as none.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from linflex.scene import REQUIREMENTS, Requirements
from linflex.system import ModelError

from .._margins import StabilityMargins
from ._analysis import SceneAnalysis

__all__ = ["Check", "Verdicts", "margin_checks", "verdicts"]

#: How the report names each quantity.
LABELS = {
    "gain_margin_db": "gain margin",
    "phase_margin_deg": "phase margin",
    "delay_margin_s": "delay margin",
    "disk_margin": "disk margin",
    "sensitivity_peak_db": "sensitivity peak Ms",
    "complementary_sensitivity_peak_db": "compl. sensitivity peak Mt",
}
ALL_LOOPS = "all loops"


@dataclass(frozen=True)
class Check:
    """One quantity at one place: its value, the bound required there, and whether it holds.

    Attributes
    ----------
    quantity : str
        A key of ``REQUIREMENTS`` (linflex/scene/_requirements.py) (``"phase_margin_deg"``...).
    channel : str
        The loop (actuator where it is broken), or ``"all loops"`` for multi-loop quantities.
    where : str
        ``"gain crossover"``, ``"phase crossover"``, ``"loop"``, ``"no phase crossover"``.
    frequency : float
        Where the value is taken [rad/s] (nan when nowhere in particular).
    value : float
        In the quantity's unit (dB, deg, s, -); nan for a margin of an unstable closed loop.
    required : float or None
        The bound (a lower bound for margins, an upper one for peaks); None when not required.
    """

    quantity: str
    channel: str
    where: str
    frequency: float
    value: float
    required: float | None

    @property
    def unit(self) -> str:
        """The quantity's unit."""
        return REQUIREMENTS[self.quantity][0]

    @property
    def slack(self) -> float:
        """How far the value is inside its bound (negative: violated) [unit]; the value itself
        (or minus it, for peaks) when nothing is required; -inf for an unstable closed loop."""
        if np.isnan(self.value):
            return -np.inf
        lower = REQUIREMENTS[self.quantity][1] == ">="
        bound = 0.0 if self.required is None else self.required
        return self.value - bound if lower else bound - self.value

    @property
    def passed(self) -> bool | None:
        """Whether the requirement holds (None when nothing is required here)."""
        return None if self.required is None else bool(self.slack >= 0)


@dataclass(frozen=True)
class Verdicts:
    """Every check of a scene's loops against its requirements.

    Attributes
    ----------
    checks : tuple of Check
        Every crossing and loop, for every quantity, in table order.
    requirements : Requirements
        The requirements applied.
    closed_loop_stable : bool
        Whether the closed loop is stable (an unstable one fails every requirement).
    """

    checks: tuple[Check, ...]
    requirements: Requirements
    closed_loop_stable: bool

    @property
    def passed(self) -> bool:
        """True when the closed loop is stable and no required check fails."""
        return self.closed_loop_stable and all(c.passed is not False for c in self.checks)

    @property
    def failed(self) -> tuple[Check, ...]:
        """The checks that fail."""
        return tuple(c for c in self.checks if c.passed is False)

    def limiting(self, quantity: str) -> Check | None:
        """The check of ``quantity`` with the least slack (required checks first).

        Parameters
        ----------
        quantity : str
            A key of ``REQUIREMENTS`` (linflex/scene/_requirements.py).

        Returns
        -------
        Check or None
            The limiting check (value in the quantity's unit), None when nothing is measured.
        """
        of = [c for c in self.checks if c.quantity == quantity]
        required = [c for c in of if c.required is not None]
        pool = required or of
        return min(pool, key=lambda c: (c.slack, c.channel)) if pool else None


def _db(ratio: float) -> float:
    return float(20.0 * np.log10(ratio)) if ratio > 0 else -np.inf


def verdicts(analysis: SceneAnalysis, requirements: Requirements | None = None) -> Verdicts:
    """Check an analysis against requirements (the scene's when not given).

    Parameters
    ----------
    analysis : SceneAnalysis
        From :func:`analyse_scene` (with ``figures=True`` for the per-loop sensitivity peaks).
    requirements : Requirements or mapping, optional
        Default ``analysis.scene.requirements``; checked as a scene's ``[requirements]`` table
        (a mapping is read as one).

    Returns
    -------
    Verdicts
        One check per gain crossover (phase and delay margins), per phase crossover (gain
        margin; a loop without one gets an infinite gain margin), per loop (disk margin,
        sensitivity peaks), and for all loops at once (balanced multi-loop disk margin, peaks of
        the largest singular values of ``S_i`` and ``T_i``).

    Raises
    ------
    ModelError
        If ``requirements`` is not a valid ``[requirements]`` table of the scene (an unknown
        name or loop, a margin that is not a positive finite number), every problem listed.

    Examples
    --------
    >>> from linflex.scene import Requirements
    >>> from linflex.stability.report import analyse_scene, verdicts
    >>> v = verdicts(analyse_scene("examples/attitude_control.toml"), Requirements(phase_margin_deg=60.0))
    >>> v.passed, round(v.limiting("phase_margin_deg").value, 2)   # the three axes tie, by design
    (True, 65.16)
    """
    if requirements is None:
        requirements = getattr(analysis.scene, "requirements", None) or Requirements()
    else:
        requirements = _valid(analysis.scene, requirements)
    return rechecked(measured(analysis), requirements)


def _valid(scene, requirements) -> Requirements:
    """``requirements`` checked as the scene's ``[requirements]`` table, as the CLI's ``--require``
    is: a misspelled loop or name would otherwise require nothing and pass."""
    scene = scene.replace(requirements=requirements)
    problems = [p for p in scene.problems() if p.startswith("requirements")]
    if problems:
        raise ModelError("verdicts: invalid requirements: " + "; ".join(problems))
    return scene.requirements


def rechecked(measured: Verdicts, requirements: Requirements) -> Verdicts:
    """The same measurements against other requirements (each check's bound looked up again:
    the loop's own, else the global one)."""
    def bound(c: Check):
        own = requirements.for_loop(c.channel) if c.channel != ALL_LOOPS else requirements.global_values()
        return own.get(c.quantity)

    return Verdicts(tuple(dataclasses.replace(c, required=bound(c)) for c in measured.checks), requirements,
                    measured.closed_loop_stable)


def _measure(stable: bool):
    """A list of checks and the function that adds one (no margins when the closed loop is unstable)."""
    out: list[Check] = []

    def add(quantity, channel, where, frequency, value):
        if not stable:
            value = np.nan  # an unstable closed loop has no margins, and S and T have no peak (no H-infinity norm)
        out.append(Check(quantity, channel, where, float(frequency), float(value), None))

    return out, add


def _margin_measurements(margins: StabilityMargins, add) -> None:
    for lm in margins.loops:
        for w, pm, dm in zip(lm.gain_crossovers, lm.phase_margins, lm.delay_margins):
            add("phase_margin_deg", lm.channel, "gain crossover", w, abs(pm))
            add("delay_margin_s", lm.channel, "gain crossover", w, dm)
        for w, gm in zip(lm.phase_crossovers, lm.gain_margins):
            add("gain_margin_db", lm.channel, "phase crossover", w, abs(_db(gm)))
        if lm.phase_crossovers.size == 0:
            add("gain_margin_db", lm.channel, "no phase crossover", np.nan, np.inf)
        if lm.gain_crossovers.size == 0:
            add("phase_margin_deg", lm.channel, "no gain crossover", np.nan, np.inf)
            add("delay_margin_s", lm.channel, "no gain crossover", np.nan, np.inf)
        add("disk_margin", lm.channel, "loop", lm.disk_margin.frequency, lm.disk_margin.alpha)
    if len(margins.loops) > 1:
        disk = margins.disk_margin
        add("disk_margin", ALL_LOOPS, "multi-loop", disk.frequency, disk.alpha)


def margin_checks(margins: StabilityMargins, requirements: Requirements) -> list[Check]:
    """The margin checks of loops (gain, phase, delay and disk margins) against requirements.

    The same measurements and the same rule as :func:`verdicts`, from the margins alone (no
    sensitivity peaks), for design loops that have no scene analysis (:func:`linflex.design.tune`).

    Parameters
    ----------
    margins : StabilityMargins
        From :func:`linflex.stability.stability_margins`.
    requirements : Requirements
        The bounds (per loop where given).

    Returns
    -------
    list of Check
        Per loop: one phase- and delay-margin check per gain crossover, one gain-margin check per
        phase crossover (an infinite gain margin when there is none), the loop's disk margin;
        the multi-loop disk margin when there are several loops. Values are nan (failing) when
        the closed loop is unstable.

    Examples
    --------
    The PD loop ``(1.4 s + 1) / s^2`` against a 30 deg phase margin requirement:

    >>> from linflex import LinearSystem
    >>> from linflex.scene import Requirements
    >>> from linflex.stability import stability_margins
    >>> L = LinearSystem([[0, 1], [0, 0]], [[0], [1]], [[1, 1.4]])
    >>> [(c.quantity, round(c.value, 2), c.passed) for c in
    ...  margin_checks(stability_margins(L), Requirements(phase_margin_deg=30.0)) if c.required]
    [('phase_margin_deg', 65.16, True)]
    """
    stable = bool(margins.closed_loop_stable)
    out, add = _measure(stable)
    _margin_measurements(margins, add)
    return list(rechecked(Verdicts(tuple(out), Requirements(), stable), requirements).checks)


def measured(analysis: SceneAnalysis) -> Verdicts:
    """Every quantity at every place of an analysis, nothing required yet (see :func:`verdicts`)."""
    stable = bool(analysis.closed_loop_stable)
    out, add = _measure(stable)
    _margin_measurements(analysis.margins, add)
    channels = {c.channel: c for c in analysis.channels}
    for lm in analysis.margins.loops:
        if lm.channel in channels:
            c = channels[lm.channel]
            add("sensitivity_peak_db", lm.channel, "loop", c.sensitivity_peak[1], _db(c.sensitivity_peak[0]))
            add("complementary_sensitivity_peak_db", lm.channel, "loop", c.complementary_sensitivity_peak[1],
                _db(c.complementary_sensitivity_peak[0]))
    if len(analysis.margins.loops) > 1 and analysis.peaks is not None:
        for quantity, (peak, at) in zip(("sensitivity_peak_db", "complementary_sensitivity_peak_db"), analysis.peaks):
            add(quantity, ALL_LOOPS, "multi-loop", at, _db(peak))
    return Verdicts(tuple(out), Requirements(), stable)
