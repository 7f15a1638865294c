"""A scene's stability analysis over the cases of a sweep: the data of the report's sweep section.

Every case is a varied scene (:func:`linflex.sweeps.vary_scene`) analysed as the nominal one
(:func:`analyse_scene`, loop-at-a-time responses included, stiffness by origin left out). What the
sweep section shows is computed here once and stored: the table of headline margins (the
:class:`~linflex.sweeps.SweepResult` that ``linflex sweep`` writes for ``analysis = "margins"``),
each case's measured margins and peaks at every loop and crossing (checked against the report's
requirements when it is rendered), each case's loop-at-a-time return ratios, and per loop the
min/max envelopes of their magnitude and phase over the cases. The cases' full analyses are not
kept (their multi-loop sensitivities and root loci would take megabytes per case).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

import linflex
from linflex import ModelError
from linflex.frequency import FrequencyResponse
from linflex.sweeps import SweepResult, load_sweep_spec, sweep
from linflex.system import frozen_array

from ._analysis import analyse_scene, phase_deg, summary_metrics
from ._verdicts import Verdicts, measured

__all__ = ["LoopEnvelope", "SweepAnalysis", "analyse_sweep"]

#: Most points an envelope keeps: beyond this the union of the cases' grids is merged into bins
#: of equal width in log frequency, each bin's band the min and max of every point in it.
ENVELOPE_POINTS = 1500


@dataclass(frozen=True)
class LoopEnvelope:
    """The band that one loop's return ratio sweeps over the cases.

    Attributes
    ----------
    channel : str
        The loop (the actuator where it is broken, the other loops closed).
    omega : ndarray, shape (n,)
        Frequencies [rad/s] (the union of the cases' adaptive grids, merged into at most
        ``ENVELOPE_POINTS`` log-spaced bins; each value is its bin's geometric centre).
    magnitude_db : ndarray, shape (n, 2)
        Smallest and largest ``|L_k(j omega)|`` [dB] over the cases at (or in the bin of) each
        frequency.
    phase_deg : ndarray, shape (n, 2)
        Smallest and largest unwrapped phase [deg] (each case starting in (-360, 0] deg).
    resolution_db : float
        The largest peak resolution [dB] of the cases' adaptive grids: between a case's own grid
        points its curve is interpolated linearly in log frequency, and its peaks are resolved to
        this.
    n_cases : int
        Cases the band is taken over (those that ran).
    """

    channel: str
    omega: NDArray[np.float64]
    magnitude_db: NDArray[np.float64]
    phase_deg: NDArray[np.float64]
    resolution_db: float
    n_cases: int


@dataclass(frozen=True)
class SweepAnalysis:
    """A scene analysed at every case of a sweep.

    Attributes
    ----------
    table : SweepResult
        One row per case: the parameter values and the headline metrics of
        :func:`margin_summary` (``gain_margin_db`` [dB], ``phase_margin_deg`` [deg],
        ``delay_margin_s`` [s], ``disk_margin`` [-], ...), the error of a case that failed.
    checks : tuple of (Verdicts or None)
        Each case's margins and peaks at every loop and crossing, nothing required yet (None
        where the case failed); :func:`linflex.stability.report.verdicts` measures them so.
    responses : tuple of (tuple of FrequencyResponse, or None)
        Each case's loop-at-a-time return ratios ``L_k(j omega)`` [-], in the order of
        ``envelopes``, on their adaptive grids (None where the case failed).
    envelopes : tuple of LoopEnvelope
        Per loop, the band of the return ratio over the cases that ran.
    source : str
        Where the cases came from (the spec file, or ``"cases"``).
    """

    table: SweepResult
    checks: tuple[Verdicts | None, ...]
    responses: tuple[tuple[FrequencyResponse, ...] | None, ...]
    envelopes: tuple[LoopEnvelope, ...]
    source: str

    def _display_fields(self):
        return [("n_cases", self.n_cases), ("n_failed", self.table.n_failed), ("parameters", self.table.parameters),
                ("loops", tuple(e.channel for e in self.envelopes)), ("source", self.source),
                ("seconds", self.table.seconds)]

    def __repr__(self) -> str:
        from linflex.system import short_repr

        return short_repr("SweepAnalysis", self._display_fields())

    def _repr_html_(self) -> str:
        return self.table._repr_html_().replace("SweepResult", "SweepAnalysis", 1)

    @property
    def n_cases(self) -> int:
        """Number of cases."""
        return self.table.n_cases

    def case_values(self, case: int) -> dict[str, float]:
        """The parameter values of one case.

        Parameters
        ----------
        case : int
            The case id (its index in the sweep).

        Returns
        -------
        dict
            Parameter path -> value, in the units of the scene entry it replaces.
        """
        return dict(zip(self.table.parameters, self.table.values[case].tolist()))


def _cases_of(cases) -> tuple[list[dict[str, float]], int | None, str]:
    if isinstance(cases, (str, Path)):
        cases_, analysis, seed = load_sweep_spec(cases)
        if analysis != "margins":
            raise ModelError(f"{cases}: a report sweeps the margins; this spec asks for analysis = {analysis!r}")
        return [dict(c) for c in cases_], seed, str(cases)
    if isinstance(cases, Mapping) or not isinstance(cases, Sequence) or not cases:
        raise ModelError("analyse_sweep: cases must be a sweep spec file or a non-empty sequence of "
                         f"{{parameter path: value}} mappings, got {cases!r}")
    cases = [dict(c) for c in cases]
    names = list(cases[0])
    for i, c in enumerate(cases):
        if list(c) != names:
            raise ModelError(f"analyse_sweep: case {i} has the parameters {list(c)}, case 0 has {names}")
    return cases, None, "cases"


def _envelope(channel: str, responses: list) -> LoopEnvelope:
    omega = np.unique(np.concatenate([r.omega for r in responses]))
    log_w = np.log(omega)
    lo = np.full((omega.size, 2), np.inf)
    hi = np.full((omega.size, 2), -np.inf)
    for r in responses:
        values = r.response[:, 0, 0]
        x = np.log(r.omega)
        for j, y in enumerate((20 * np.log10(np.abs(values)), phase_deg(values))):
            at = np.interp(log_w, x, y, left=np.nan, right=np.nan)  # no band outside a case's own grid
            lo[:, j] = np.fmin(lo[:, j], at)
            hi[:, j] = np.fmax(hi[:, j], at)
    if omega.size > ENVELOPE_POINTS:
        edges = np.linspace(log_w[0], log_w[-1], ENVELOPE_POINTS + 1)
        starts = np.unique(np.searchsorted(log_w, edges[:-1]))
        starts = starts[starts < omega.size]
        lo, hi = np.minimum.reduceat(lo, starts, axis=0), np.maximum.reduceat(hi, starts, axis=0)
        ends = np.append(starts[1:], omega.size) - 1
        omega = np.sqrt(omega[starts] * omega[ends])
    resolution = max((float(r.peak_resolution_db) for r in responses if np.isfinite(r.peak_resolution_db)),
                     default=float("nan"))
    return LoopEnvelope(channel, frozen_array(omega), frozen_array(np.stack([lo[:, 0], hi[:, 0]], axis=1)),
                        frozen_array(np.stack([lo[:, 1], hi[:, 1]], axis=1)), resolution, len(responses))


def sweep_case(scene, method: str = "kane"):
    """One case of :func:`analyse_sweep` (in a worker process): the headline metrics, and what the
    report keeps of the analysis: ``(measured checks, loop names, loop responses)``."""
    a = analyse_scene(scene, method=method, stiffness_by_origin=False)
    return summary_metrics(a), (measured(a), tuple(c.channel for c in a.channels), tuple(c.response for c in a.channels))


def analyse_sweep(scene, cases, *, method: str = "kane", processes: int | None = None,
                  progress: bool | None = None) -> SweepAnalysis:
    """Analyse a scene at every case of a sweep, as :func:`analyse_scene` analyses it once.

    Parameters
    ----------
    scene : Scene or path
        The nominal scene (or its TOML file), with at least one controller.
    cases : path or sequence of mapping
        A sweep spec file as ``linflex sweep`` reads it (``analysis = "margins"``, a ``[grid]``
        or a ``[sample]``; see ``linflex.sweeps.load_sweep_spec``), or the cases themselves
        (scene path -> value, in the units of the scene file), e.g. from
        :func:`linflex.sweeps.parameter_grid`.
    method : str
        Linearization method of every case (see :func:`analyse_scene`).
    processes : int, optional
        Local worker processes, as :func:`linflex.sweeps.sweep` takes them (default: every core
        when there are at least twice as many cases as cores, else serially in this process).
    progress : bool, optional
        Progress bar on stderr; default when stderr is a terminal and there are over 4 cases.

    Returns
    -------
    SweepAnalysis
        The cases run by :func:`linflex.sweeps.sweep`; a case that fails (an invalid varied
        scene, a trim that does not converge) is recorded with its error and the sweep goes on.

    Raises
    ------
    ModelError
        For cases that are empty or name different parameters, a spec whose analysis is not
        ``"margins"``, or a parameter path that does not apply to the scene (checked on the
        first case before anything runs).

    Examples
    --------
    Two proportional gains of the rigid spacecraft's x axis:

    >>> from linflex.stability.report import analyse_sweep
    >>> s = analyse_sweep("examples/attitude_control.toml",
    ...                   [{"controllers.attitude_pd.kp[0]": k} for k in (20.0, 40.0)])
    >>> s.n_cases, s.table.n_failed, [e.channel for e in s.envelopes]
    (2, 0, ['tx', 'ty', 'tz'])
    >>> [round(float(pm), 2) for pm in s.table.column("phase_margin_deg")]   # [deg]
    [65.16, 55.93]
    """
    if isinstance(scene, (str, Path)):
        scene = linflex.load_scene(scene)
    cases, seed, source = _cases_of(cases)
    result = sweep(scene, cases, functools.partial(sweep_case, method=method), processes=processes, seed=seed,
                   progress=progress, keep=True)
    kept = result.kept
    ran = [k for k in kept if k is not None]
    channels = ran[0][1] if ran else ()
    checks = tuple(k[0] if k is not None else None for k in kept)
    responses = tuple(k[2] if k is not None else None for k in kept)
    envelopes = tuple(_envelope(ch, [k[2][j] for k in ran]) for j, ch in enumerate(channels))
    table = dataclasses.replace(result, kept=None)
    return SweepAnalysis(table, tuple(checks), tuple(responses), envelopes, source)
