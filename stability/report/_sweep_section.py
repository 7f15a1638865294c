"""The report's sweep section in words and tables: pass counts, spread and worst case of each margin.

Every number comes from a :class:`SweepAnalysis` computed once; the checks of each case are
:func:`verdicts` of its analysis against the report's requirements (the same rules as the
nominal report: every crossing and loop, an unstable closed loop fails every requirement).
"""

from __future__ import annotations

import numpy as np

from linflex.scene import REQUIREMENTS

from ._summary import bound_text, value_text, where
from ._sweep import SweepAnalysis
from ._table import Paragraph, Table
from ._table import fmt as _fmt
from ._verdicts import LABELS, Verdicts, rechecked

#: The margins the sweep's histograms show: the metrics of ``margin_summary`` that are requirements.
SWEEP_MARGINS = ("gain_margin_db", "phase_margin_deg", "delay_margin_s", "disk_margin")


def sweep_checks(sweep: SweepAnalysis, requirements) -> tuple[Verdicts | None, ...]:
    """Each case's measurements checked against ``requirements`` (None where the case failed to run)."""
    return tuple(rechecked(v, requirements) if v is not None else None for v in sweep.checks)


def _bound(quantity: str, value) -> str:
    return ("<= " if REQUIREMENTS[quantity][1] == "<=" else ">= ") + _fmt(value)


def _named(sweep: SweepAnalysis, case: int) -> str:
    return "; ".join(f"{k} = {_fmt(v, 6)}" for k, v in sweep.case_values(case).items())


def passed_count(checks) -> int:
    """Cases that ran, have a stable closed loop and meet every requirement."""
    return sum(v is not None and v.passed for v in checks)


def sweep_verdict_text(sweep: SweepAnalysis, checks) -> str:
    """One sentence: how many cases pass (or, without requirements, are stable)."""
    n, ran = sweep.n_cases, [v for v in checks if v is not None]
    failed_to_run = n - len(ran)
    tail = f"; {failed_to_run} case(s) failed to run (counted as failing)" if failed_to_run else ""
    required = any(c.required is not None for v in ran for c in v.checks)
    if not required:
        stable = sum(v.closed_loop_stable for v in ran)
        return f"No requirements: {stable} of {n} cases have a stable closed loop{tail}."
    k = passed_count(checks)
    return f"{'PASS' if k == n else 'FAIL'}: {k} of {n} cases meet every requirement{tail}."


def sweep_parts(sweep: SweepAnalysis, checks, nominal) -> list:
    """The sweep section's paragraphs and tables, in reading order.

    ``nominal`` is the nominal report's :class:`Verdicts` (its values in the spread table).
    """
    table = sweep.table
    n = sweep.n_cases
    seed = f", seed {table.seed}" if table.seed is not None else ""
    ranges = "; ".join(f"{name} from {_fmt(np.min(table.values[:, j]), 6)} to {_fmt(np.max(table.values[:, j]), 6)}"
                       for j, name in enumerate(table.parameters))
    verdict = sweep_verdict_text(sweep, checks)
    parts: list = [
        Paragraph("", verdict, "verdict pass" if verdict.startswith(("PASS", "No")) else "verdict fail"),
        Paragraph("Cases", f"{n} cases ({sweep.source}{seed}), each the scene with these parameters varied: {ranges}. "
                           "Every case is analysed as the nominal scene (trimmed, linearized, loops closed) and "
                           "checked against the same requirements at every crossing and loop."),
    ]
    ok = np.array([e is None for e in table.errors], dtype=bool)
    spread = []
    for quantity in SWEEP_MARGINS:
        if quantity not in table.metrics:
            continue
        column = table.column(quantity)[ok]
        finite = column[~np.isnan(column)]  # inf: a loop without a crossing of that kind
        limiting = nominal.limiting(quantity) if nominal is not None else None
        bound = nominal.requirements.global_values().get(quantity) if nominal is not None else None
        spread.append((f"{LABELS[quantity]} [{REQUIREMENTS[quantity][0]}]",
                       _bound(quantity, bound) if bound is not None else "not required",
                       value_text(limiting) if limiting is not None else "-",
                       *((_fmt(np.min(finite)), _fmt(np.median(finite)), _fmt(np.max(finite))) if finite.size
                         else ("-", "-", "-")),
                       f"{int(np.sum(np.isnan(column))) + int(np.sum(~ok))}"))
    parts.append(Table("Sweep: margins across the cases",
                       ("quantity", "required", "nominal", "min", "median", "max", "cases without a value"),
                       tuple(spread),
                       note="Per case the smallest value over its loops and crossings (the columns of "
                            "linflex sweep with analysis = \"margins\"); the disk margin is the multi-loop balanced "
                            "one; inf: no crossing of that kind. No value: an unstable closed loop (no margins) or a case that failed to run."))
    rows = []
    for quantity in REQUIREMENTS:
        worst, n_pass = None, 0
        for i, v in enumerate(checks):
            if v is None:
                continue
            check = v.limiting(quantity)
            if check is None:
                continue
            if all(c.passed is not False for c in v.checks if c.quantity == quantity) and v.closed_loop_stable:
                n_pass += 1
            if worst is None or check.slack < worst[1].slack:
                worst = (i, check)
        if worst is None:
            continue
        i, check = worst
        nowhere = np.isinf(check.value) and check.where.startswith("no ")  # no case has such a crossing
        is_required = any(c.required is not None for v in checks if v is not None for c in v.checks
                          if c.quantity == quantity)
        rows.append((f"{LABELS[quantity]} [{check.unit}]",
                     bound_text(check) if check.required is not None
                     else ("per loop" if is_required else "not required"),
                     f"{n_pass} of {n}" if is_required else "-",
                     "-" if nowhere else str(i), value_text(check),
                     f"every case: {check.where}" if nowhere else f"{check.channel}, {where(check)}",
                     "-" if nowhere else _named(sweep, i)))
    parts.append(Table("Sweep: worst case of each requirement",
                       ("quantity", "required", "cases passing", "worst case", "value", "loop, where",
                        "parameter values of the worst case"), tuple(rows),
                       note="The worst case is the one with the least slack against its bound (the smallest margin, "
                            "the largest peak, when nothing is required); case numbers are the case ids of the sweep "
                            "(the rows of sweep.csv beside the report, the table linflex sweep writes). A case passes a requirement when every loop and crossing "
                            "does and its closed loop is stable."))
    failed = [(str(i), e, _named(sweep, i)) for i, e in enumerate(table.errors) if e is not None]
    if failed:
        parts.append(Table("Sweep: cases that failed to run", ("case", "error", "parameter values"), tuple(failed)))
    return parts
