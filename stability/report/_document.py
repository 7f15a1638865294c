"""The stability-margin report as a document: Markdown, one self-contained HTML file, PDF.

A :class:`StabilityReport` holds the analysis (numbers only); figures are drawn when the
report is rendered, from the same data, so every number in a figure is one in a table.
"""

from __future__ import annotations

import base64
import datetime
import html
import io
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import linflex
from linflex.system import atomic_write, check_output_folder, replaced_folder

from ._analysis import SceneAnalysis

__all__ = ["StabilityReport", "stability_report"]


def _fmt(value: float, digits: int = 4) -> str:
    if value is None:
        return "-"
    value = float(value)
    if np.isnan(value):
        return "-"
    if np.isinf(value):
        return "inf" if value > 0 else "-inf"
    return f"{value:.{digits}g}"


def _db(ratio: float) -> str:
    if ratio <= 0 or np.isinf(ratio):
        return "inf" if np.isinf(ratio) else "-inf"
    return f"{20 * np.log10(ratio):.2f}"


def _markdown_cell(text: str) -> str:
    """A table cell's text with the characters that would break a Markdown table row escaped."""
    return str(text).replace("\\", "\\\\").replace("|", "\\|").replace("\n", " ")


@dataclass(frozen=True)
class Table:
    """A titled table of strings."""

    title: str
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    note: str = ""

    def to_markdown(self) -> str:
        lines = [f"### {self.title}", ""]
        if self.note:
            lines += [self.note, ""]
        lines.append("| " + " | ".join(map(_markdown_cell, self.header)) + " |")
        lines.append("|" + "---|" * len(self.header))
        lines += ["| " + " | ".join(map(_markdown_cell, row)) + " |" for row in self.rows]
        return "\n".join(lines) + "\n"

    def to_html(self) -> str:
        head = "".join(f"<th>{html.escape(h)}</th>" for h in self.header)
        body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>" for row in self.rows)
        note = f"<p class='note'>{html.escape(self.note)}</p>" if self.note else ""
        slug = self.title.lower().replace(" ", "-")
        return (f"<section class='table' id='{html.escape(slug)}'><h3>{html.escape(self.title)}</h3>{note}"
                f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></section>")


@dataclass(frozen=True)
class StabilityReport:
    """A stability-margin report of one scene's loops.

    Attributes
    ----------
    analysis : SceneAnalysis
        The numbers the report shows.
    title : str
    created : str
        ISO time stamp of the report.
    figures : tuple of (str, callable)
        Figure titles and functions that draw each one on a new matplotlib figure (called at
        rendering time; :func:`stability_report` supplies Bode, Nichols, Nyquist and root locus).
    """

    analysis: SceneAnalysis
    title: str
    created: str
    figures: tuple[tuple[str, Callable], ...] = ()

    # -- content --------------------------------------------------------------------------------

    def summary(self) -> list[tuple[str, str]]:
        """Key facts as (label, value) pairs.

        Returns
        -------
        list of (str, str)
            Formatted values; each label names its unit (``"worst phase margin [deg]"``,
            ``"worst gain margin [dB]"``, delay margins [s], frequencies [rad/s]).
        """
        a = self.analysis
        m = a.margins
        worst_pm = min((lm.min_phase_margin for lm in m.loops), key=abs, default=float("inf"))
        worst_gm = min((lm.min_gain_margin for lm in m.loops), key=lambda g: abs(np.log(g)) if g > 0 else np.inf,
                       default=float("inf"))
        return [
            ("scene", a.scene.name),
            ("effects simulated and linearized", ", ".join(a.scene.effects) or "none"),
            ("closed loop", "stable" if a.closed_loop_stable else "UNSTABLE"),
            ("channels (loop broken at the plant inputs)", ", ".join(m.channels)),
            ("worst phase margin [deg]", _fmt(worst_pm)),
            ("worst gain margin [dB]", _db(worst_gm)),
            ("multi-loop disk margin (balanced)", f"alpha = {_fmt(m.disk_margin.alpha)}, "
                                                  f"+-{_fmt(m.disk_margin.phase_margin)} deg, "
                                                  f"[{_db(m.disk_margin.gain_margin[0])}, "
                                                  f"{_db(m.disk_margin.gain_margin[1])}] dB"),
            ("linearization", f"{a.plant.method}, max relative error estimate "
                              f"{a.plant.max_relative_error_estimate:.1e}, {a.plant.n_evaluations} evaluations"),
            ("operating point", "trimmed" if a.trimmed else "the scene's initial state (an equilibrium)"),
            ("plant states in the loop", str(a.loop.plant.n_states)),
        ]

    def tables(self) -> list[Table]:
        """The report's tables, in order.

        Returns
        -------
        list of Table
            Each with a title, a header whose columns name their units (frequencies [rad/s] and
            [Hz], margins [deg] and [dB], delay margins [s]) and rows of formatted values.
        """
        a = self.analysis
        m = a.margins
        crossings = []
        for lm in m.loops:
            for w, pm, dm in zip(lm.gain_crossovers, lm.phase_margins, lm.delay_margins):
                crossings.append((lm.channel, "gain crossover", _fmt(w), _fmt(w / (2 * np.pi)),
                                  f"phase margin {_fmt(pm)} deg", f"delay margin {_fmt(dm)} s"))
            for w, gm in zip(lm.phase_crossovers, lm.gain_margins):
                crossings.append((lm.channel, "phase crossover", _fmt(w), _fmt(w / (2 * np.pi)),
                                  f"gain margin {_db(gm)} dB", "increase" if gm > 1 else "reduction"))
        per_loop = [(lm.channel, _fmt(lm.min_phase_margin), _fmt(lm.min_phase_margin_frequency),
                     _db(lm.min_gain_margin), _fmt(lm.delay_margin), _fmt(lm.disk_margin.alpha),
                     _fmt(lm.disk_margin.phase_margin), str(lm.open_loop_unstable_poles)) for lm in m.loops]
        tables = [
            Table("Summary", ("item", "value"), tuple(self.summary())),
            Table("Margins per loop", ("channel", "min PM [deg]", "at [rad/s]", "min GM [dB]", "delay margin [s]",
                                       "disk alpha", "disk PM [deg]", "open-loop RHP poles"), tuple(per_loop),
                  note="Loop-at-a-time: each channel broken at the plant input with the other loops closed."),
            Table("Every crossing", ("channel", "kind", "frequency [rad/s]", "[Hz]", "margin", ""),
                  tuple(crossings)),
            Table("Multi-loop disk margins", ("disk", "alpha", "skew", "gain margin [dB]", "phase margin [deg]",
                                              "frequency [rad/s]"),
                  tuple((name, _fmt(d.alpha), _fmt(d.skew), f"[{_db(d.gain_margin[0])}, {_db(d.gain_margin[1])}]",
                         _fmt(d.phase_margin), _fmt(d.frequency))
                        for name, d in (("balanced", m.disk_margin), ("skewed", m.skewed_disk_margin)))),
            _modes_table("Closed-loop modes", a.closed_loop_modes),
            _modes_table("Plant modes", a.plant_modes),
            *([_stiffness_table(a.stiffness)] if a.stiffness is not None else []),
            Table("What each step cost", ("step", "seconds"),
                  tuple((step, f"{seconds:.4f}") for step, seconds in a.costs.items())),
        ]
        return tables

    # -- rendering ------------------------------------------------------------------------------

    def to_markdown(self) -> str:
        """The report's text and tables as Markdown (figures are in the HTML and PDF).

        Returns
        -------
        str
            The document, units as in :meth:`tables`.
        """
        parts = [f"# {self.title}", "", f"Created {self.created} by linflex {linflex.__version__}.", ""]
        parts += [t.to_markdown() for t in self.tables()]
        if self.figures:
            parts.append("Figures (in the HTML and PDF versions): " + ", ".join(t for t, _ in self.figures) + ".")
        return "\n".join(parts) + "\n"

    #: The files :meth:`write` puts in a report folder (an existing folder may hold only these).
    FILES = ("report.html", "report.md", "report.pdf")

    @classmethod
    def check_folder(cls, folder: str | Path) -> Path:
        """Refuse a report folder that :meth:`write` could not replace, before any analysis runs.

        Parameters
        ----------
        folder : str or path-like
            The report folder.

        Returns
        -------
        pathlib.Path
            ``folder``.

        Raises
        ------
        linflex.system.OutputError
            If ``folder`` is a file, holds files other than :attr:`FILES`, or cannot be written.
        """
        return check_output_folder(folder, cls.FILES)

    def write(self, folder: str | Path, *, pdf: bool = True) -> list[Path]:
        """Write ``report.html``, ``report.md`` and ``report.pdf`` into ``folder``, as a whole.

        The files are rendered into a temporary folder beside ``folder``, which then replaces
        ``folder`` in one step: a reader sees the previous report or the new one, never a mix of
        two runs, and a run that fails or is killed leaves the previous report as it was.
        Concurrent writers to one folder take turns (a lock beside it); the last one wins whole.
        Without ``pdf`` the folder holds no PDF afterwards (none of an earlier run).

        Parameters
        ----------
        folder : str or path-like
            The report folder (created if missing; it may hold only :attr:`FILES`).
        pdf : bool
            Also write the PDF.

        Returns
        -------
        list of pathlib.Path
            The files written, inside ``folder``.

        Raises
        ------
        linflex.system.OutputError
            As :meth:`check_folder`.
        """
        folder = Path(folder)
        names = [self.FILES[0], self.FILES[1], *([self.FILES[2]] if pdf else [])]
        with replaced_folder(folder, self.FILES) as build:
            self.to_html(build / self.FILES[0])
            with atomic_write(build / self.FILES[1]) as handle:
                handle.write(self.to_markdown())
            if pdf:
                self.to_pdf(build / self.FILES[2])
        return [folder / name for name in names]

    def _rendered_figures(self, fmt: str) -> Iterator[tuple[str, bytes]]:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        for title, draw in self.figures:
            fig = draw()
            buffer = io.BytesIO()
            fig.savefig(buffer, format=fmt, dpi=110, bbox_inches="tight")
            plt.close(fig)
            yield title, buffer.getvalue()

    def to_html(self, path: str | Path) -> Path:
        """Write one self-contained HTML file (inline CSS, figures as embedded PNG).

        Parameters
        ----------
        path : str or path-like
            The file to write; replaced in one step when complete (the old file stays if
            rendering fails).

        Returns
        -------
        pathlib.Path
            ``path``.
        """
        path = Path(path)
        figures = "".join(
            f"<figure><img alt='{html.escape(title)}' src='data:image/png;base64,{base64.b64encode(png).decode()}'>"
            f"<figcaption>{html.escape(title)}</figcaption></figure>"
            for title, png in self._rendered_figures("png"))
        tables = "".join(t.to_html() for t in self.tables())
        page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(self.title)}</title>
<style>
body {{ font-family: system-ui, sans-serif; margin: 2em auto; max-width: 70em; color: #222; }}
table {{ border-collapse: collapse; margin: 0.5em 0 1.5em; }}
th, td {{ border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: left; font-size: 0.92em; }}
th {{ background: #eef; }}
figure {{ display: inline-block; margin: 0.5em; vertical-align: top; }}
figure img {{ max-width: 34em; }}
.note {{ color: #555; font-size: 0.9em; }}
</style></head><body>
<h1>{html.escape(self.title)}</h1>
<p class="note">Created {html.escape(self.created)} by linflex {html.escape(linflex.__version__)}.</p>
{tables}
<section id="figures"><h2>Figures</h2>{figures}</section>
</body></html>
"""
        with atomic_write(path) as handle:  # a temporary name renamed into place: never half a page
            handle.write(page)
        return path

    def to_pdf(self, path: str | Path) -> Path:
        """Write a PDF: the tables as text pages, then one page per figure.

        Parameters
        ----------
        path : str or path-like
            The file to write; replaced in one step when complete (the old file stays if
            rendering fails).

        Returns
        -------
        pathlib.Path
            ``path``.
        """
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
        from matplotlib.backends.backend_pdf import PdfPages

        path = Path(path)
        with atomic_write(path, "wb") as handle, PdfPages(handle) as pdf:
            lines = self.to_markdown().splitlines()
            for start in range(0, len(lines), 70):
                fig = plt.figure(figsize=(8.27, 11.69))
                fig.text(0.04, 0.97, "\n".join(lines[start:start + 70]), family="monospace", fontsize=6.5,
                         va="top")
                pdf.savefig(fig)
                plt.close(fig)
            for _, draw in self.figures:
                fig = draw()
                pdf.savefig(fig)
                plt.close(fig)
        return path


def _modes_table(title: str, table) -> Table:
    rows = tuple((str(i), _fmt(m.eigenvalue.real) + (f" ± {_fmt(abs(m.eigenvalue.imag))}j" if m.eigenvalue.imag else ""),
                  _fmt(m.natural_frequency), _fmt(m.frequency_hz), _fmt(m.damping_ratio), m.kind,
                  ", ".join(f"{name} {weight:.2f}" for name, weight in m.participation[:3]))
                 for i, m in enumerate(table))
    return Table(title, ("#", "eigenvalue [1/s]", "wn [rad/s]", "f [Hz]", "damping", "kind", "participating states"),
                 rows)


def _stiffness_table(shares, max_modes: int = 20) -> Table:
    squared = shares.squared
    scale = np.max(np.abs(squared), initial=0.0)
    keep = [i for i in range(squared.size) if abs(squared[i]) > 1e-9 * scale][:max_modes]
    origins = [o for o, v in shares.shares.items() if np.any(np.abs(v[keep]) > 1e-6 * np.abs(squared[keep]))]
    rows = []
    for i in keep:
        peak = np.argmax(np.abs(shares.shapes[:, i]))
        rows.append((str(i), _fmt(shares.frequencies[i]) if squared[i] > 0 else f"divergent ({_fmt(squared[i])})",
                     shares.dofs[peak], *(f"{100 * shares.shares[o][i] / squared[i]:.1f}" for o in origins)))
    return Table("What makes the plant stiff", ("#", "wn undamped [rad/s]", "largest dof",
                                                *(f"{o} [% of wn^2]" for o in origins)), tuple(rows),
                 note="Each origin's share of each undamped plant mode's squared frequency (Rayleigh quotients of "
                      "the stiffness by origin from Kane's direct linearization, controllers open; damping and "
                      "gyroscopic terms left out; rigid-body modes omitted). A negative share softens the mode.")


def stability_report(analysis: SceneAnalysis, *, title: str | None = None) -> StabilityReport:
    """The stability-margin report of an analysed scene (see :func:`analyse_scene`).

    Parameters
    ----------
    analysis : SceneAnalysis
        The result of :func:`analyse_scene`.
    title : str, optional
        Default ``"Stability margins: <scene name>"``.

    Returns
    -------
    StabilityReport
        Render it with ``to_markdown``, ``to_html`` or ``to_pdf``.

    Examples
    --------
    >>> from linflex.stability.report import analyse_scene, stability_report
    >>> report = stability_report(analyse_scene("examples/attitude_control.toml"))
    >>> report.title
    'Stability margins: attitude_control'
    >>> len(report.figures), "| worst phase margin [deg] | 65.16 |" in report.to_markdown()
    (4, True)
    """
    from ._figures import report_figures

    return StabilityReport(
        analysis=analysis,
        title=title or f"Stability margins: {analysis.scene.name}",
        created=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        figures=tuple(report_figures(analysis)),
    )
