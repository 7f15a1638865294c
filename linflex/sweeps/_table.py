"""The sweep's CSV table, written as the cases finish and read back to resume.

Columns: ``case`` (the case's index in the sweep's case list), the parameters, the metrics,
``error`` (empty, or the error that stopped the case) and ``seconds`` (wall time of the case in
its worker [s], the one column that differs between two runs). While a sweep runs, each
finished case is appended as one line and flushed, in the order the cases finish; when the
sweep ends the file is rewritten, in one step, sorted by case id. A sweep that was stopped and
resumed therefore ends with the same file as one that ran through (``seconds`` aside).
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..system._errors import ModelError
from ..system._files import OutputError, atomic_write, check_output_file, file_lock

__all__ = ["SweepTable", "csv_row", "table_header"]

#: The outcome of one case: ``(metrics or None, error or None, seconds)``.
Outcome = tuple[dict[str, float] | None, str | None, float]


def table_header(parameters: Sequence[str], metrics: Sequence[str]) -> list[str]:
    """The CSV columns of a sweep table."""
    return ["case", *parameters, *metrics, "error", "seconds"]


def csv_row(case: int, values: Sequence[float], metrics: Sequence[str], outcome: Outcome) -> list[Any]:
    """One CSV row: ``nan`` for a metric the case did not give (every metric of a failed case)."""
    given, error, seconds = outcome
    given = given or {}
    return [case, *(float(v) for v in values), *(float(given.get(m, math.nan)) for m in metrics),
            "" if error is None else error, float(seconds)]


class SweepTable:
    """A sweep's CSV file, open for appending the cases as they finish (see the module docstring).

    Parameters
    ----------
    path : str or path-like
        The CSV file.
    parameters : sequence of str
        The varied parameters' names.
    values : ndarray, shape (n_cases, n_parameters)
        The parameter values of every case of the sweep.
    resume : bool
        Continue an existing file: its rows are checked against ``values`` (case id and every
        parameter value) and become :attr:`completed`. Without it, an existing file is refused
        (nothing is overwritten by accident).

    Raises
    ------
    OutputError
        If the path is a folder, the file exists and ``resume`` is false, or another sweep is
        writing it.
    ModelError
        With ``resume``, if the file was written for other parameters or other values (the
        specification changed) or is not a sweep table.
    """

    def __init__(self, path, parameters: Sequence[str], values: np.ndarray, *, resume: bool):
        self.path = check_output_file(path)
        self.parameters = tuple(parameters)
        self.values = values
        self.metrics: list[str] = []
        self.completed: dict[int, Outcome] = {}
        self._lock = contextlib.ExitStack()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._lock.enter_context(file_lock(self.path.with_name(f".{self.path.name}.lock"), wait=False,
                                           what=str(self.path)))
        try:
            if self.path.exists() and not resume:
                raise OutputError(f"{self.path} exists; resume it (--resume, resume=True: its finished cases are "
                                  "kept) or remove it (--overwrite) to start again")
            if resume and self.path.exists() and self.path.stat().st_size > 0:
                self._read()
            else:
                self._rewrite()
        except BaseException:
            self._lock.close()
            raise

    def _read(self) -> None:
        data = self.path.read_bytes()
        end = data.rfind(b"\n") + 1
        if end < len(data):
            # the last line was cut by a kill in the middle of a write: that case runs again
            with open(self.path, "r+b") as handle:
                handle.truncate(end)
            data = data[:end]
        try:
            rows = list(csv.reader(io.StringIO(data.decode("utf-8"), newline="")))
        except (UnicodeDecodeError, csv.Error) as err:
            raise ModelError(f"{self.path}: cannot resume: not a sweep table ({err})") from err
        if not rows:
            self._rewrite()
            return
        header, n_par = rows[0], len(self.parameters)
        if header[:1] != ["case"] or header[-2:] != ["error", "seconds"] or len(header) < n_par + 3:
            raise ModelError(f"{self.path}: cannot resume: not a sweep table (columns {header[:4]}...)")
        if tuple(header[1:1 + n_par]) != self.parameters:
            raise ModelError(f"{self.path}: cannot resume: it has the columns {header[1:-2]} and the specification varies "
                             f"{list(self.parameters)}; the specification changed (write to another file, or "
                             "start again with --overwrite)")
        self.metrics = header[1 + n_par:-2]
        for line, row in enumerate(rows[1:], start=2):
            self._read_row(line, row, n_par)

    def _read_row(self, line: int, row: list[str], n_par: int) -> None:
        where = f"{self.path}, line {line}"
        n_cases = self.values.shape[0]
        try:
            case = int(row[0])
            values = [float(v) for v in row[1:1 + n_par]]
            results = [float(v) for v in row[1 + n_par:-2]]
            seconds = float(row[-1])
        except (ValueError, IndexError) as err:
            raise ModelError(f"{where}: cannot resume: not a row of a sweep table ({err})") from err
        if len(row) != n_par + len(self.metrics) + 3:
            raise ModelError(f"{where}: cannot resume: {len(row)} columns, the header has {n_par + len(self.metrics) + 3}")
        if not 0 <= case < n_cases:
            raise ModelError(f"{where}: cannot resume: case {case}, but the specification has {n_cases} cases "
                             f"(0 to {n_cases - 1}); the specification changed")
        for name, got, want in zip(self.parameters, values, self.values[case]):
            if got != want:
                raise ModelError(f"{where}: cannot resume: case {case} has {name} = {got!r} in the file but "
                                 f"{float(want)!r} in the specification; the specification changed (write to "
                                 "another file, or start again with --overwrite)")
        if case in self.completed:
            return  # written twice (cannot happen in one run); the first one counts
        error = row[-2] or None
        metrics = None if error is not None else dict(zip(self.metrics, results))
        self.completed[case] = (metrics, error, seconds)

    def _rewrite(self, outcomes: Mapping[int, Outcome] | None = None) -> None:
        """Write the header and the given rows (by case id) to a temporary file renamed into place."""
        outcomes = self.completed if outcomes is None else outcomes
        with atomic_write(self.path, newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(table_header(self.parameters, self.metrics))
            for case in sorted(outcomes):
                writer.writerow(csv_row(case, self.values[case], self.metrics, outcomes[case]))

    def append(self, case: int, outcome: Outcome) -> None:
        """Append one finished case and flush it to disk (a new metric rewrites the file with that column).

        Parameters
        ----------
        case : int
            The case's index.
        outcome : tuple
            ``(metrics or None, error or None, seconds)`` as a worker returns it.
        """
        self.completed[case] = outcome
        new = [m for m in (outcome[0] or {}) if m not in self.metrics]
        if new:
            self.metrics += new
            self._rewrite()
            return
        line = io.StringIO(newline="")
        csv.writer(line).writerow(csv_row(case, self.values[case], self.metrics, outcome))
        with open(self.path, "a", encoding="utf-8", newline="") as handle:
            # one write of one whole line, flushed: it survives this process being killed (an
            # fsync per case, for power cuts too, measured 4 ms here; the final table is synced)
            handle.write(line.getvalue())

    def close(self) -> None:
        """Release the file's lock (the rows written stay)."""
        self._lock.close()

    @staticmethod
    def finished_cases(path) -> int:
        """The number of case rows in a sweep table (0 if it does not exist).

        Parameters
        ----------
        path : str or path-like
            The CSV file.

        Returns
        -------
        int
            Rows after the header, whole lines only.
        """
        path = Path(path)
        if not path.is_file():
            return 0
        return max(path.read_bytes().count(b"\n") - 1, 0)
