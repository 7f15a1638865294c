"""Parameter sweeps and Monte Carlo studies: one analysis over many variants of a scene or model.

A sweep is a list of *cases*, each a mapping from parameter names to values, and an *analysis*,
a function of one varied scene (or model) that returns named numbers. Scene parameters are
addressed by paths in the scene's own vocabulary (the keys of its TOML file, entries named by
their ``name``)::

    "bodies.hub.mass"                 the mass of the body named hub
    "bodies.hub.inertia[0]"           the first principal inertia
    "bodies.array_left.beam.EI"       a beam property of a flexible body
    "controllers.pd_x.kp"             a controller gain
    "wheels.wheel_x.spin_inertia"

Model parameters are the names of ``NonlinearModel.params``. Cases come from
:func:`parameter_grid` (every combination) or :func:`parameter_sample` (Monte Carlo with a seed),
and run serially, in a local process pool, or on a Dask cluster when a
``dask.distributed.Client`` is passed. A case that fails is recorded with its error; the sweep
goes on.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import pickle
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..compiler._parametric import compile_once
from ..scene._scene import Scene
from ..system._errors import ModelError
from ..system._files import atomic_write
from ..system._model import NonlinearModel
from ..system._plotting import PlotHandle, plot_axes
from ..system._progress import Progress, stderr_is_terminal
from ._cases import _finite, _scene_from, _thaw
from ._table import SweepTable, csv_row, table_header

__all__ = ["SweepResult", "sweep", "sweep_scatter_plot"]

@dataclass(frozen=True)
class SweepResult:
    """The table of a sweep: one row per case.

    Attributes
    ----------
    parameters : tuple of str
        Names of the varied parameters (scene paths or model parameter names).
    metrics : tuple of str
        Names of the analysis results, in the order the analysis returned them.
    values : ndarray, shape (n_cases, n_parameters)
        The parameter values of each case, in the units of the scene entries they replace
        ([kg], [kg m^2], [N m^2], gains, ...).
    results : ndarray, shape (n_cases, n_metrics)
        The analysis results, in the units the analysis gives them (e.g.
        :func:`~linflex.stability.report.margin_summary`: [dB], [deg], [s], [rad/s]); ``nan`` where the case failed or did not return that metric.
    errors : tuple of (str or None)
        Per case: ``None``, or the error that stopped it (``"ModelError: ..."``).
    case_seconds : ndarray, shape (n_cases,)
        Wall time of each case in its worker [s].
    backend : str
        ``"serial"``, ``"processes"`` or ``"dask"``.
    workers : int
        Number of processes (or Dask workers) that ran the cases.
    seed : int or None
        Seed of the Monte Carlo sample, when the cases came from :func:`parameter_sample`
        (recorded by the caller through ``seed=``; ``None`` otherwise).
    seconds : float
        Wall time of the whole sweep [s].
    kept : tuple or None
        With ``sweep(..., keep=True)``: per case the object the analysis returned beside its
        metrics (None for a case that failed or was read back from a resumed CSV); None
        otherwise.
    """

    parameters: tuple[str, ...]
    metrics: tuple[str, ...]
    values: NDArray[np.float64]
    results: NDArray[np.float64]
    errors: tuple[str | None, ...]
    case_seconds: NDArray[np.float64]
    backend: str
    workers: int
    seed: int | None
    seconds: float
    kept: tuple | None = None

    def _display_fields(self):
        return [("n_cases", self.n_cases), ("n_failed", self.n_failed), ("parameters", self.parameters),
                ("metrics", self.metrics), ("backend", self.backend), ("workers", self.workers), ("seed", self.seed),
                ("seconds", self.seconds)]

    def __repr__(self) -> str:
        from ..system._display import short_repr

        return short_repr("SweepResult", self._display_fields())

    def _repr_html_(self) -> str:
        from ..system._display import html_summary

        ok = np.array([e is None for e in self.errors], dtype=bool)
        rows = []
        for kind, names in (("parameter", self.parameters), ("metric", self.metrics)):
            for name in names:
                column = self.column(name)[ok]
                column = column[~np.isnan(column)]
                rows.append((name, kind, *((column.min(), np.median(column), column.max()) if column.size
                                            else (None, None, None))))
        return html_summary(f"SweepResult ({self.n_cases} cases, {self.n_failed} failed)", self._display_fields(),
                            ("column", "kind", "min", "median", "max"), rows, max_rows=40,
                            note="Over the cases that ran; rows() or to_pandas() give every case.")

    @property
    def n_cases(self) -> int:
        """Number of cases."""
        return len(self.errors)

    @property
    def n_failed(self) -> int:
        """Number of cases that ended with an error."""
        return sum(e is not None for e in self.errors)

    def column(self, name: str) -> NDArray[np.float64]:
        """The values of one parameter or metric over all cases.

        Parameters
        ----------
        name : str
            A name in ``parameters`` or ``metrics``.

        Returns
        -------
        ndarray, shape (n_cases,)
            A column of ``values`` or ``results``, in that column's units.

        Raises
        ------
        KeyError
            If ``name`` is neither a parameter nor a metric.
        """
        if name in self.parameters:
            return self.values[:, self.parameters.index(name)]
        if name in self.metrics:
            return self.results[:, self.metrics.index(name)]
        raise KeyError(f"{name!r} is neither a parameter {list(self.parameters)} nor a metric {list(self.metrics)}")

    def rows(self) -> list[dict[str, Any]]:
        """One dict per case (``case``, parameters, metrics, ``error``, ``seconds``): ``pandas.DataFrame(rows)``.

        Returns
        -------
        list of dict
            Keys ``case`` (int), the parameter and metric names (float, in their units),
            ``error`` (str or None) and ``seconds`` (wall time of the case [s]).
        """
        out = []
        for i in range(self.n_cases):
            row: dict[str, Any] = {"case": i}
            row.update(zip(self.parameters, self.values[i].tolist()))
            row.update(zip(self.metrics, self.results[i].tolist()))
            row["error"] = self.errors[i]
            row["seconds"] = float(self.case_seconds[i])
            out.append(row)
        return out

    def to_pandas(self):
        """The table as a ``pandas.DataFrame`` (needs pandas).

        Returns
        -------
        pandas.DataFrame
            The :meth:`rows`, one per case.

        Raises
        ------
        ImportError
            Without pandas.
        """
        try:
            import pandas
        except ImportError as err:
            raise ImportError("SweepResult.to_pandas needs pandas (pip install pandas); rows() needs nothing") from err
        return pandas.DataFrame(self.rows())

    def to_csv(self, path) -> None:
        """Write the table as CSV (``case``, parameters, metrics, ``error``, ``seconds``), rows by case id.

        Parameters
        ----------
        path : str or path-like
            The file to write; values in their units, ``seconds`` [s]. Written under a temporary
            name and renamed into place: an existing file is replaced in one step, or kept if
            writing fails.
        """
        import csv

        with atomic_write(path, newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(table_header(self.parameters, self.metrics))
            for i in range(self.n_cases):
                given = dict(zip(self.metrics, self.results[i].tolist()))
                writer.writerow(csv_row(i, self.values[i].tolist(), self.metrics,
                                        (given, self.errors[i], self.case_seconds[i])))

    def plot(self, x: str, y: str, *, ax=None):
        """Scatter of one column against another; see :func:`sweep_scatter_plot`.

        Parameters
        ----------
        x, y : str
            Parameter or metric names.
        ax : matplotlib Axes, optional
            The axes to draw on; a new figure when omitted.

        Returns
        -------
        PlotHandle
            As :func:`sweep_scatter_plot`.
        """
        return sweep_scatter_plot(self, x, y, ax=ax)


# -- running ----------------------------------------------------------------------------------


def sweep(
    subject: Scene | NonlinearModel,
    cases: Sequence[Mapping[str, float]],
    analysis: Callable[[Any], Mapping[str, float]],
    *,
    client=None,
    processes: int | None = None,
    seed: int | None = None,
    progress: bool | None = None,
    csv=None,
    resume: bool = False,
    keep: bool = False,
    compile_once: bool = True,
) -> SweepResult:
    """Run ``analysis`` on every case of a sweep.

    Parameters
    ----------
    subject : Scene or NonlinearModel
        What is varied. For a scene each case maps scene paths to values (see
        :func:`vary_scene`); for a model it maps parameter names to values
        (:meth:`NonlinearModel.with_params`).
    cases : sequence of mapping
        The cases, e.g. from :func:`parameter_grid` or :func:`parameter_sample`; all with the
        same parameter names. A case's id is its index in this sequence.
    analysis : callable
        ``analysis(varied) -> mapping of metric name to number`` (booleans count as 0/1). To
        run in processes or on Dask it must be importable (a module-level function, not a
        lambda), e.g. :func:`linflex.stability.report.margin_summary`.
    client : dask.distributed.Client, optional
        Run the cases on this Dask cluster (``pip install "dask[distributed]"``).
    processes : int, optional
        Without ``client``: the number of local worker processes; ``1`` runs serially in this
        process. Default: every core when there are at least twice as many cases as cores,
        else serial. Workers run with one BLAS thread each.
    seed : int, optional
        Recorded in the result (the seed the cases were drawn with).
    progress : bool, optional
        Progress bar on stderr; default: when stderr is a terminal and there are over 4 cases.
    csv : str or path-like, optional
        Stream the table to this CSV file: each case is appended and flushed as it finishes (in
        the order the cases finish), and at the end the file is rewritten in one step with the
        rows sorted by case id, as :meth:`SweepResult.to_csv` writes them. An existing file is
        refused unless ``resume``; another sweep writing the same file is refused (a lock).
    resume : bool
        With ``csv``: keep the cases already in the file (matched by case id and every parameter
        value; a file written for other cases is refused) and run only the others. The final
        file is the one an uninterrupted sweep writes (the ``seconds`` column aside).
    keep : bool
        The analysis returns a pair ``(metrics, kept)``: the metrics go into the table as
        usual, ``kept`` (any picklable object, e.g. responses) into :attr:`SweepResult.kept`.
    compile_once : bool
        For a scene: :func:`linflex.compile_model` compiles each *structure* of the sweep once
        per process, the varied numbers (masses, inertias, joint stiffness and damping, modal
        stiffness and damping in the first case's mode basis) becoming graph parameters; results
        equal per-case compilation (``False``) to round-off. Cases that change the structure
        (modes, effects, joints, mode shapes) are grouped, one compilation per group.

    Returns
    -------
    SweepResult

    Raises
    ------
    ModelError
        If the cases are empty or do not all name the same parameters, if the first case's
        parameters do not apply to the subject (checked before anything runs), if the
        analysis or subject cannot be sent to worker processes, if ``resume`` is given without
        ``csv``, or if ``resume`` finds a file written for other cases or parameters.
    linflex.system.OutputError
        If ``csv`` exists without ``resume``, is a folder, or another sweep is writing it.
    KeyboardInterrupt
        On Ctrl-C (or a signal handler raising it): the worker processes are stopped (Dask
        futures cancelled) first, and every finished case is in ``csv``.

    Notes
    -----
    A case whose analysis raises is recorded with its error (``SweepResult.errors``) and
    ``nan`` results; the sweep continues. So is a case whose metrics are not numbers or are
    named like another column of the table (``case``, a parameter, ``error``, ``seconds``).

    Examples
    --------
    >>> from linflex import NonlinearModel, parameter_grid
    >>> import numpy as np
    >>> model = NonlinearModel(lambda x, u, p, t: np.array([-p[0] * x[0]]), states=["x"], params={"a": 1.0})
    >>> def rate(m): return {"pole": -m.param_values[0]}
    >>> res = sweep(model, parameter_grid({"a": [1.0, 2.0]}), rate, processes=1)
    >>> res.column("pole").tolist()
    [-1.0, -2.0]
    """
    t0 = time.perf_counter()
    if isinstance(cases, (Mapping, str, bytes)):
        raise ModelError(f"sweep: cases must be a sequence of mappings (one per case), got a {type(cases).__name__}; "
                         "parameter_grid(...) makes every combination of the values of a mapping")
    cases = list(cases)
    for i, c in enumerate(cases):
        if not isinstance(c, Mapping):
            raise ModelError(f"sweep: case {i} must be a mapping of parameter -> value, got {c!r}")
    cases = [dict(c) for c in cases]
    if not cases:
        raise ModelError("sweep: no cases")
    names = tuple(cases[0])
    for i, c in enumerate(cases):
        if tuple(c) != names:
            raise ModelError(f"sweep: case {i} has the parameters {list(c)}, case 0 has {list(names)}")
    values = np.array([[_finite(c[k], f"case {i}: {k}") for k in names] for i, c in enumerate(cases)], dtype=float)
    if isinstance(subject, Scene):
        payload: tuple[str, Any] = ("scene" if compile_once else "scene-each", _thaw(subject.to_dict()))
        # a wrong path or key fails here, once, not in every case; values are checked per case
        _scene_from(payload[1], cases[0], f"{subject.name} (varied)")
    elif isinstance(subject, NonlinearModel):
        payload = ("model", subject)
        unknown = [k for k in names if k not in subject.params]
        if unknown:
            raise ModelError(f"sweep: the model has no parameters {unknown} (it has {list(subject.params)})")
    else:
        raise ModelError(f"sweep: subject must be a Scene or a NonlinearModel, got {type(subject).__name__}")
    if not callable(analysis):
        raise ModelError(f"sweep: analysis must be callable, got {analysis!r}")
    if resume and csv is None:
        raise ModelError("sweep: resume=True continues the table in csv=..., but no csv was given")
    n_workers = 1
    if client is None:
        if processes is not None and (isinstance(processes, bool) or not isinstance(processes, (int, np.integer))):
            raise ModelError(f"sweep: processes must be an integer number of worker processes, got {processes!r}")
        n_workers = _default_processes(len(cases)) if processes is None else int(processes)
        if n_workers < 1:
            raise ModelError(f"sweep: processes must be at least 1, got {processes!r}")
        if n_workers > 1:
            _check_picklable(payload, analysis)

    table = SweepTable(csv, names, values, resume=resume) if csv is not None else None
    # a file written for more parameters than the specification now varies reads its extra
    # parameter columns as metrics: refuse it, as SweepTable refuses other parameters
    stray = [m for m in table.metrics if _is_parameter(payload, m)] if table is not None else []
    if stray:
        table.close()
        raise ModelError(f"{table.path}: cannot resume: its columns {stray} are parameters of the "
                         f"{payload[0].split('-')[0]} that the specification does not vary (it varies {list(names)}); "
                         "the specification changed (write to another file, or start again with --overwrite)")
    outcomes: dict[int, Any] = dict(table.completed) if table is not None else {}
    kept: dict[int, Any] = {}
    pending = [i for i in range(len(cases)) if i not in outcomes]
    show = (stderr_is_terminal() and len(cases) > 4) if progress is None else bool(progress)
    bar = Progress(show, len(cases), "sweep")

    def record(i, outcome):
        outcome, kept[i] = outcome[:3], outcome[3]
        outcomes[i] = outcome
        if table is not None:
            table.append(i, outcome)
        bar.update(len(outcomes))

    try:
        if client is not None:
            backend, workers = "dask", _run_dask(client, payload, cases, pending, analysis, record, keep)
        elif n_workers == 1 or not pending:
            backend, workers = "serial", 1
            for i in pending:
                record(i, run_case(payload, cases[i], analysis, keep))
        else:
            backend, workers = "processes", n_workers
            _run_processes(n_workers, payload, cases, pending, analysis, record, keep)
        result = _result(names, values, [outcomes[i] for i in range(len(cases))], backend, workers, seed,
                         time.perf_counter() - t0)
        if keep:
            result = dataclasses.replace(result, kept=tuple(kept.get(i) for i in range(len(cases))))
        if table is not None:
            result.to_csv(table.path)  # every row, sorted by case id, in one step
    finally:
        bar.close()
        if table is not None:
            table.close()
    return result


def _is_parameter(payload, name: str) -> bool:
    """Whether ``name`` names a parameter of the sweep's subject (a scene path or a model parameter)."""
    kind, subject = payload
    if kind == "model":
        return name in subject.params
    try:
        _scene_from(subject, {name: 1.0}, "column")
    except ModelError:
        return False
    return True


def _result(names, values, outcomes, backend, workers, seed, seconds) -> SweepResult:
    metrics: list[str] = []
    for metrics_i, _, _ in outcomes:
        for k in metrics_i or {}:
            if k not in metrics:
                metrics.append(k)
    results = np.full((len(outcomes), len(metrics)), np.nan)
    for i, (metrics_i, _, _) in enumerate(outcomes):
        for k, v in (metrics_i or {}).items():
            results[i, metrics.index(k)] = v
    for arr in (values, results):
        arr.setflags(write=False)
    case_seconds = np.array([s for _, _, s in outcomes], dtype=float)
    case_seconds.setflags(write=False)
    return SweepResult(
        parameters=names, metrics=tuple(metrics), values=values, results=results,
        errors=tuple(e for _, e, _ in outcomes), case_seconds=case_seconds, backend=backend, workers=workers,
        seed=seed, seconds=seconds,
    )


def run_case(payload, case: Mapping[str, float], analysis, keep: bool = False):
    """One case in a worker: ``(metrics, error, seconds, kept)``; never raises for the analysis' errors."""
    t0 = time.perf_counter()
    try:
        kind, subject = payload
        if kind == "model":
            raw = analysis(subject.with_params(**case))
        else:
            varied = _scene_from(subject, case, "sweep case").validate()
            with compile_once(tuple(case)) if kind == "scene" else contextlib.nullcontext():
                raw = analysis(varied)
        if keep and not (isinstance(raw, tuple) and len(raw) == 2):
            raise TypeError(f"with keep=True the analysis returns (metrics, kept), not {type(raw).__name__}")
        raw, kept = raw if keep else (raw, None)
        if not isinstance(raw, Mapping):
            raise TypeError(f"the analysis returned {type(raw).__name__}, not a mapping of metric -> number")
        metrics = {}
        for k, v in raw.items():
            if str(k) in case or str(k) in ("case", "error", "seconds"):
                # one table column per name: rows() and the CSV would lose one of the two
                raise ValueError(f"metric {str(k)!r} has the name of a column of the table (case, the parameters, "
                                 "error, seconds); rename it")
            try:
                metrics[str(k)] = float(v)
            except (TypeError, ValueError) as err:
                raise TypeError(f"metric {k!r} is {v!r}, not a number") from err
        return metrics, None, time.perf_counter() - t0, kept
    except Exception as err:  # noqa: BLE001 -- a failed case is a result of the sweep
        where = traceback.extract_tb(err.__traceback__)[-1]
        message = " ".join(str(err).split())
        return None, f"{type(err).__name__}: {message} ({os.path.basename(where.filename)}:{where.lineno})", \
            time.perf_counter() - t0, None


def _default_processes(n_cases: int) -> int:
    cores = os.cpu_count() or 1
    return cores if cores > 1 and n_cases >= 2 * cores else 1


def _check_picklable(payload, analysis) -> None:
    for what, obj in (("analysis", analysis), ("subject", payload[1])):
        try:
            pickle.dumps(obj)
        except Exception as err:  # noqa: BLE001 -- pickle raises many types
            raise ModelError(
                f"sweep: the {what} cannot be sent to worker processes ({type(err).__name__}: {err}); "
                "use a module-level function and a scene or picklable model, or processes=1"
            ) from err


_BLAS_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _run_processes(n_workers, payload, cases, pending, analysis, record, keep=False) -> None:
    import concurrent.futures
    import multiprocessing

    # one BLAS thread per worker (the workers read these when they start): n workers with n BLAS
    # threads each would oversubscribe the cores
    saved = {k: os.environ.get(k) for k in _BLAS_VARIABLES}
    os.environ.update({k: "1" for k in _BLAS_VARIABLES})
    before = set(multiprocessing.active_children())
    try:
        context = multiprocessing.get_context("spawn")  # fork after BLAS/CasADi threads can deadlock
        with concurrent.futures.ProcessPoolExecutor(max_workers=n_workers, mp_context=context,
                                                    initializer=_worker_start, initargs=(os.getpid(),)) as pool:
            try:
                futures = {pool.submit(run_case, payload, cases[i], analysis, keep): i for i in pending}
                for future in concurrent.futures.as_completed(futures):
                    record(futures[future], future.result())
            except BaseException:
                # Ctrl-C, SIGTERM (raised by the command line's handler) or an error: stop the
                # workers now rather than let them finish every queued case
                pool.shutdown(wait=False, cancel_futures=True)
                _stop(set(multiprocessing.active_children()) - before)
                raise
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _worker_start(parent: int) -> None:
    """In each worker process: Ctrl-C is the parent's to handle (it reaches the whole process
    group), and the worker ends when the parent dies, even by SIGKILL (Linux)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        import ctypes

        pr_set_pdeathsig = 1
        ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, int(signal.SIGTERM), 0, 0, 0)
    except (OSError, AttributeError):  # pragma: no cover -- not Linux
        pass
    if os.getppid() != parent:  # the parent died before the request above took effect
        os._exit(1)


def _stop(processes, timeout: float = 5.0) -> None:
    """Terminate worker processes and wait for them (SIGKILL those that do not end)."""
    for process in processes:
        process.terminate()
    deadline = time.monotonic() + timeout
    for process in processes:
        process.join(max(deadline - time.monotonic(), 0.0))
        if process.is_alive():  # pragma: no cover -- a worker stuck in C code ignoring SIGTERM
            process.kill()
            process.join(1.0)


def _run_dask(client, payload, cases, pending, analysis, record, keep=False) -> int:
    try:
        from distributed import as_completed
    except ImportError as err:
        raise ImportError('sweep(client=...) needs dask.distributed: pip install "dask[distributed]"') from err
    _check_picklable(payload, analysis)
    workers = len(client.scheduler_info().get("workers", {})) or 1
    if not pending:
        return workers
    shared = client.scatter(payload, broadcast=True)
    futures = client.map(run_case, [shared] * len(pending), [cases[i] for i in pending],
                         [analysis] * len(pending), [keep] * len(pending), pure=False)
    index = {f.key: i for f, i in zip(futures, pending)}
    try:
        for future in as_completed(futures):
            record(index[future.key], future.result())
    except BaseException:
        client.cancel(futures)  # the cluster stops the cases not yet finished
        raise
    return workers


# -- plots ------------------------------------------------------------------------------------


def sweep_scatter_plot(result: SweepResult, x: str, y: str, *, ax=None) -> PlotHandle:
    """Scatter of column ``y`` against column ``x`` of a sweep; failed cases marked on the x axis.

    Parameters
    ----------
    result : SweepResult
        The sweep to draw.
    x, y : str
        Parameter or metric names; each axis is in that column's units.
    ax : matplotlib Axes, optional
        The axes to draw on; a new figure when omitted.

    Returns
    -------
    PlotHandle
        ``lines``: the scatter of the cases, then that of the failed cases (None when none
        failed); ``data`` the sweep.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> import numpy as np
    >>> from linflex import NonlinearModel, parameter_grid, sweep, sweep_scatter_plot
    >>> model = NonlinearModel(lambda x, u, p, t: np.array([-p[0] * x[0]]), states=["x"], params={"a": 1.0})
    >>> def rate(m): return {"pole": -m.param_values[0]}
    >>> res = sweep(model, parameter_grid({"a": [1.0, 2.0, 3.0]}), rate, processes=1)
    >>> h = sweep_scatter_plot(res, "a", "pole")
    >>> len(h.lines[0].get_offsets())
    3
    >>> plt.close(h.figure)
    """
    xs, ys = result.column(x), result.column(y)
    fig, (ax,) = plot_axes(ax, 1, figsize=(6, 4))
    ok = np.array([e is None for e in result.errors], dtype=bool)
    points = ax.scatter(xs[ok], ys[ok], s=14, label=f"{int(ok.sum())} cases")
    failed = None
    if not ok.all():
        floor = np.nanmin(ys[ok]) if ok.any() and np.isfinite(ys[ok]).any() else 0.0
        failed = ax.scatter(xs[~ok], np.full(int((~ok).sum()), floor), marker="x", color="C3",
                            label=f"{int((~ok).sum())} failed")
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    return PlotHandle(fig, (ax,), (points, failed), result)
