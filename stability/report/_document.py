"""The stability-margin report as a document: Markdown, one self-contained HTML file, PDF.

A :class:`StabilityReport` holds the analysis (numbers only); figures are drawn when the
report is rendered, from the same data, so every number in a figure is one in a table.
"""

from __future__ import annotations

import base64
import datetime
import functools
import html
import io
import tempfile
import textwrap
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import linflex
from linflex.scene import REQUIREMENTS
from linflex.system import atomic_write, check_output_folder, replaced_folder

from ._analysis import SceneAnalysis
from ._pdf import chromium, print_pdf
from ._summary import (
    PM_CONVENTION,
    bound_text,
    check_text,
    description,
    flexible_resonances,
    flexible_table,
    hidden_modes_text,
    modes_table,
    stability_text,
    unstable_poles,
    value_text,
    verdict_text,
    where,
)
from ._sweep import SweepAnalysis, analyse_sweep
from ._sweep_section import passed_count, sweep_checks, sweep_parts, sweep_verdict_text
from ._table import Paragraph, Table
from ._table import db as _db
from ._table import fmt as _fmt
from ._verdicts import LABELS, Verdicts, verdicts

__all__ = ["StabilityReport", "stability_report"]


#: What a report says where its figures would be when the analysis drew none.
NO_FIGURES = ("No figures: the analysis was made without the data they draw (analyse_scene(..., figures=False)); "
              "analyse the scene with figures=True, the default, for the Bode, Nichols, Nyquist, sensitivity "
              "and root-locus figures.")


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
        Figure titles and functions without arguments that draw each one on a new matplotlib
        figure from the analysis' stored data (:func:`stability_report` supplies Bode, Nichols,
        Nyquist, root loci and sensitivities); each is drawn once per written report.
    verdicts : Verdicts or None
        The requirements checked against every crossing and loop.
    sweep : SweepAnalysis or None
        The scene analysed over the cases of a sweep (the report's sweep section), or None.
    sweep_checks : tuple of (Verdicts or None)
        Each sweep case checked against the same requirements (None where the case failed).
    sweep_figures : tuple of (str, callable)
        The sweep section's figures (histograms, Bode and Nichols envelopes), drawn as ``figures``.
    """

    analysis: SceneAnalysis
    title: str
    created: str
    figures: tuple[tuple[str, Callable], ...] = ()
    verdicts: Verdicts | None = None
    sweep: SweepAnalysis | None = None
    sweep_checks: tuple[Verdicts | None, ...] = ()
    sweep_figures: tuple[tuple[str, Callable], ...] = ()

    def __repr__(self) -> str:
        from linflex.system import short_repr

        return short_repr("StabilityReport", [("title", self.title), ("verdict", verdict_text(self._verdicts())),
                                              ("figures", len(self.figures) + len(self.sweep_figures)),
                                              ("sweep_cases", self.sweep.n_cases if self.sweep is not None else None),
                                              ("created", self.created)])

    def _repr_html_(self) -> str:
        from linflex.system import html_summary

        return html_summary(f"StabilityReport: {self.title}", self.summary(), note="write(folder) gives the HTML, Markdown and PDF report.")

    # -- content --------------------------------------------------------------------------------

    def summary(self) -> list[tuple[str, str]]:
        """Key facts as (label, value) pairs: the verdict and the limiting item of each quantity first.

        Returns
        -------
        list of (str, str)
            Formatted values; each label names its unit (``"phase margin [deg]"``, ``"gain
            margin [dB]"``, delay margins [s], frequencies [rad/s]).
        """
        a = self.analysis
        v = self._verdicts()
        out = [("verdict", verdict_text(v)), ("closed loop", stability_text(a))]
        for quantity in REQUIREMENTS:
            check = v.limiting(quantity)
            if check is not None:
                out.append((f"limiting {LABELS[quantity]} [{check.unit}]", check_text(check)))
        out += [
            ("scene", a.scene.name),
            ("linearization", f"{a.plant.method}, max relative error estimate "
                              f"{a.plant.max_relative_error_estimate:.1e}, {a.plant.n_evaluations} evaluations"),
            ("operating point", "trimmed" if a.trimmed else "the scene's initial state (an equilibrium)"),
        ]
        if self.sweep is not None:
            out.insert(2, ("sweep", sweep_verdict_text(self.sweep, self.sweep_checks)))
        return out

    @property
    def passed(self) -> bool:
        """Whether the nominal closed loop is stable and meets every requirement, and so does every
        sweep case (when there is a sweep)."""
        return self._verdicts().passed and (self.sweep is None or passed_count(self.sweep_checks) == self.sweep.n_cases)

    def sweep_section(self) -> list:
        """The sweep section's verdict, cases, spread and worst cases (empty without a sweep).

        Returns
        -------
        list of Paragraph and Table
            Values in the units their rows name (dB, deg, s, -).
        """
        return sweep_parts(self.sweep, self.sweep_checks, self._verdicts()) if self.sweep is not None else []

    def _verdicts(self) -> Verdicts:
        return self.verdicts if self.verdicts is not None else verdicts(self.analysis)

    def front(self) -> list:
        """The first screen: verdict, limiting items, plant and controller, convention, flexible modes.

        Returns
        -------
        list of Paragraph and Table
            In reading order; the requirements table's values are in the units of their rows
            (dB, deg, s), frequencies in rad/s.
        """
        a = self.analysis
        v = self._verdicts()
        rows = []
        for quantity in REQUIREMENTS:
            check = v.limiting(quantity)
            if check is None:
                continue
            of = [c for c in v.checks if c.quantity == quantity and c.required is not None]
            n_fail = sum(c.passed is False for c in of)
            rows.append((LABELS[quantity] + f" [{check.unit}]",
                         bound_text(check) or "not required",
                         check.channel, where(check), value_text(check),
                         "-" if check.required is None else ("PASS" if n_fail == 0 else f"FAIL ({n_fail} of {len(of)})")))
        verdict_css = "verdict pass" if v.passed else "verdict fail"
        closed = stability_text(a)
        parts = [
            Paragraph("", verdict_text(v), verdict_css),
            Paragraph("Closed loop", closed[0].upper() + closed[1:] + "."),
            Table("Requirements and the limiting loop and crossing of each",
                  ("quantity", "required", "limiting loop", "where", "value", "verdict"), tuple(rows),
                  note="Each requirement is checked at every crossing and loop (table 'Every crossing'); the "
                       "limiting item is the one with the least slack against its bound."),
            Paragraph("Plant and controller", description(a)),
            Paragraph("Conventions", PM_CONVENTION),
        ]
        untouched = hidden_modes_text(a)
        if untouched:
            parts.insert(3, Paragraph("Modes the loops do not act on", untouched[0].upper() + untouched[1:] + (
                ": poles of every closed loop whatever its gains and of none of its transfer functions, so in no "
                "margin and not in the verdict; structural damping, or a sensor and an actuator that reach them, "
                "would damp them.")))
        flexible = flexible_resonances(a)
        if flexible:
            parts.append(flexible_table(flexible))
        return parts

    def tables(self) -> list[Table]:
        """The report's detail tables, in order.

        Returns
        -------
        list of Table
            Each with a title, a header whose columns name their units (frequencies [rad/s] and
            [Hz], margins [deg] and [dB], delay margins [s]) and rows of formatted values.
        """
        a = self.analysis
        m = a.margins
        v = self._verdicts()
        stable = a.closed_loop_stable
        verdict_of = {(c.quantity, c.channel, c.frequency): c for c in v.checks}

        def mark(quantity, channel, w):
            c = verdict_of.get((quantity, channel, float(w)))
            return "" if c is None or c.passed is None else ("pass" if c.passed else "FAIL")

        crossings = []
        for lm in m.loops:
            for w, pm, dm in zip(lm.gain_crossovers, lm.phase_margins, lm.delay_margins):
                crossings.append((lm.channel, "gain crossover", _fmt(w), _fmt(w / (2 * np.pi)),
                                  f"PM {_fmt(pm)} deg", f"{_fmt(dm)} s" if stable else "none",
                                  " / ".join(x for x in (mark("phase_margin_deg", lm.channel, w),
                                                         mark("delay_margin_s", lm.channel, w)) if x)))
            for w, gm in zip(lm.phase_crossovers, lm.gain_margins):
                crossings.append((lm.channel, "phase crossover", _fmt(w), _fmt(w / (2 * np.pi)),
                                  f"GM {_db(gm)} dB ({'increase' if gm > 1 else 'reduction'})", "",
                                  mark("gain_margin_db", lm.channel, w)))
        channels = {c.channel: c for c in a.channels}
        per_loop = []
        for lm in m.loops:
            c = channels.get(lm.channel)
            per_loop.append((lm.channel, _fmt(lm.min_phase_margin), _fmt(lm.min_phase_margin_frequency),
                             _db(lm.min_gain_margin), _fmt(lm.delay_margin) if stable else "none",
                             *((_fmt(lm.disk_margin.alpha), _fmt(lm.disk_margin.phase_margin),
                                _db(c.sensitivity_peak[0]) if c else "-",
                                _db(c.complementary_sensitivity_peak[0]) if c else "-") if stable else ("none",) * 4),
                             str(unstable_poles(lm))))
        disks = [("balanced, each loop independently (diagonal)", m.disk_margin),
                 ("balanced, all loops together (full block)", m.unstructured_disk_margin)]
        if m.skewed_disk_margin.skew != 0:
            disks.append((f"skewed (skew {_fmt(m.skewed_disk_margin.skew)}), diagonal", m.skewed_disk_margin))
        sens = []
        peaks = a.peaks or (None, None)
        for name, response, norm in (("S_i = (I + K P)^-1, plant input", a.sensitivity, peaks[0]),
                                     ("T_i = I - S_i, plant input", a.complementary_sensitivity, peaks[1]),
                                     ("S_o = (I + P K)^-1, sensors", a.output_sensitivity, None)):
            if norm is not None:
                sens.append((name, _db(norm[0]), _fmt(norm[0]), _fmt(norm[1]),
                             "H-infinity norm" if stable else "largest gain on the imaginary axis"))
            elif response is not None:
                sigma = np.linalg.svd(response.response, compute_uv=False)[:, 0]
                k = int(np.argmax(sigma))
                sens.append((name, _db(sigma[k]), _fmt(sigma[k]), _fmt(response.omega[k]),
                             f"grid, to {_fmt(response.peak_resolution_db)} dB"))
        tables = [
            Table("Margins per loop", ("loop", "min PM [deg]", "at [rad/s]", "min GM [dB]", "delay margin [s]",
                                       "disk alpha", "disk PM [deg]", "Ms [dB]", "Mt [dB]",
                                       "open-loop unstable poles"),
                  tuple(per_loop),
                  note="Loop-at-a-time: each loop broken at its actuator (the plant input) with the other loops "
                       "closed. Ms and Mt: peaks of 1/(1 + L) and L/(1 + L) of that loop (their H-infinity norms)."
                       + ("" if stable else " The closed loop is UNSTABLE: it has no delay margin, no disk margin "
                                            "and no sensitivity peaks.")),
            Table("Every crossing", ("#", "loop", "kind", "frequency [rad/s]", "f [Hz]", "margin", "delay margin",
                                     "verdict"), tuple((str(i + 1), *row) for i, row in enumerate(crossings)),
                  note="Numbered as in the Bode diagram."),
            Table("Multi-loop disk margins", ("disk", "alpha", "gain margin [dB]", "phase margin [deg]",
                                              "frequency [rad/s]"),
                  tuple((name, _fmt(d.alpha), f"[{_db(d.gain_margin[0])}, {_db(d.gain_margin[1])}]",
                         _fmt(d.phase_margin), _fmt(d.frequency)) if stable else (name, "none", "none", "none", "-")
                        for name, d in disks),
                  note="Simultaneous gain and phase variations in every loop at once (Seiler, Packard and Gahinet "
                       "2020): diagonal, independent in each loop; full block, any coupled variation."),
            *([Table("Sensitivity peaks (all loops)", ("function", "peak [dB]", "peak [-]", "at [rad/s]",
                                                      "found by"), tuple(sens),
                     note="Largest singular value over frequency: the H-infinity norm (the peak over every "
                          "frequency, within 1e-6 of its certified bound), or the largest value on the frequency grid (the peak to the "
                          "resolution shown). Requirements on Ms and Mt apply at the plant input."
                          + (f" S_o acts on the {len(a.loop.sensors)} sensors of {len(a.loop.actuators)} loops: "
                             "sensors of one axis (an angle and its rate) share a loop, so its peak is not a "
                             "loop's margin." if len(a.loop.sensors) != len(a.loop.actuators) else "")
                          + ("" if stable else " The closed loop is UNSTABLE: S and T are unstable and have no "
                                               "H-infinity norm; the values shown bound nothing."))]
              if sens else []),
            modes_table("Closed-loop modes", a.closed_loop_modes, a.closed_loop_modes.states, None),
            modes_table("Plant modes (controllers open)", a.plant_modes, a.plant_modes.states,
                        a.loop.continuous_plant or a.loop.plant),
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
        parts += [p.to_markdown() for p in self.front()]
        if self.sweep is not None:
            parts += ["## Sweep", ""] + [p.to_markdown() for p in self.sweep_section()]
        parts += [t.to_markdown() for t in self.tables()]
        if self.figures or self.sweep_figures:
            parts.append("Figures (in the HTML and PDF versions): "
                         + ", ".join(t for t, _ in (*self.figures, *self.sweep_figures)) + ".")
        if not self.figures:
            parts += ["", NO_FIGURES]
        return "\n".join(parts) + "\n"

    #: The files :meth:`write` puts in a report folder (an existing folder may hold only these).
    FILES = ("report.html", "report.md", "report.pdf", "sweep.csv")

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

    def write(self, folder: str | Path, *, pdf: bool = True, printer=None) -> list[Path]:
        """Write ``report.html``, ``report.md`` and ``report.pdf`` (and, with a sweep, its table
        ``sweep.csv``, as ``linflex sweep`` writes it) into ``folder``, as a whole.

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
        printer : PdfPrinter, optional
            A browser started earlier (see :meth:`to_pdf`).

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
        names = [self.FILES[0], self.FILES[1], *([self.FILES[2]] if pdf else []),
                 *([self.FILES[3]] if self.sweep is not None else [])]
        with replaced_folder(folder, self.FILES) as build:
            self.to_html(build / self.FILES[0])
            with atomic_write(build / self.FILES[1]) as handle:
                handle.write(self.to_markdown())
            if pdf:
                self.to_pdf(build / self.FILES[2], printer=printer)
            if self.sweep is not None:
                self.sweep.table.to_csv(build / self.FILES[3])
        return [folder / name for name in names]

    @functools.cached_property
    def _pngs(self) -> tuple[tuple[str, bytes], ...]:
        """Every figure drawn once, as PNG (the HTML embeds them; the PDF prints the HTML)."""
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        out = []
        for title, draw in (*self.figures, *self.sweep_figures):
            fig = draw()
            try:
                buffer = io.BytesIO()
                fig.savefig(buffer, format="png", dpi=110)  # laid out when drawn: one rendering pass
            finally:
                plt.close(fig)
            out.append((title, buffer.getvalue()))
        return tuple(out)

    def html_page(self) -> str:
        """The report as one self-contained HTML page (inline CSS, figures as embedded PNG).

        Returns
        -------
        str
            The page: the verdict and the limiting crossings first, then figures and details.
        """
        pngs = [f"<figure><img alt='{html.escape(title)}' src='data:image/png;base64,{base64.b64encode(png).decode()}'>"
                f"<figcaption>{html.escape(title)}</figcaption></figure>" for title, png in self._pngs]
        figures = "".join(pngs[:len(self.figures)]) or f"<p>{html.escape(NO_FIGURES)}</p>"
        sweep = ""
        if self.sweep is not None:
            sweep = ("<section id='sweep' style='break-before: page; break-inside: auto'><h2>Sweep over "
                     f"{self.sweep.n_cases} cases</h2>{''.join(p.to_html() for p in self.sweep_section())}"
                     f"{''.join(pngs[len(self.figures):])}</section>")
        front = "".join(p.to_html() for p in self.front())
        tables = "".join(t.to_html() for t in self.tables())
        return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(self.title)}</title>
<style>
@page {{ size: A4; margin: 14mm 12mm; }}
body {{ font-family: "DejaVu Sans", system-ui, sans-serif; margin: 1.5em auto; max-width: 62em; color: #222;
        font-size: 14px; line-height: 1.35; }}
h1 {{ font-size: 1.6em; margin: 0 0 0.2em; }}
h2 {{ font-size: 1.25em; border-bottom: 1px solid #ccc; margin-top: 1.4em; break-after: avoid; }}
h3 {{ font-size: 1.05em; margin: 1em 0 0.3em; break-after: avoid; }}
.table .note {{ break-after: avoid; }}
table {{ border-collapse: collapse; margin: 0.4em 0 1em; max-width: 100%; }}
th, td {{ border: 1px solid #bbb; padding: 0.2em 0.5em; text-align: left; font-size: 0.9em;
          overflow-wrap: break-word; }}
th {{ background: #eef; }}
section {{ break-inside: avoid; }}
section.table {{ break-inside: auto; }}
tr {{ break-inside: avoid; }}
.verdict {{ font-size: 1.15em; font-weight: bold; padding: 0.5em 0.8em; border-radius: 4px; margin: 0.5em 0; }}
.verdict p {{ margin: 0; }}
.pass {{ background: #e3f4e3; border: 2px solid #2a2; }}
.fail {{ background: #fbe3e3; border: 2px solid #c22; }}
figure {{ display: block; margin: 0.6em 0; break-inside: avoid; }}
figure img {{ max-width: 100%; }}
figcaption {{ font-size: 0.9em; color: #444; }}
.note {{ color: #555; font-size: 0.88em; margin: 0.2em 0; }}
@media print {{ body {{ font-size: 10.5px; margin: 0; max-width: none; }} }}
</style></head><body>
<h1>{html.escape(self.title)}</h1>
<p class="note">Created {html.escape(self.created)} by linflex {html.escape(linflex.__version__)}.</p>
<section id="summary"><h2>Summary</h2>{front}</section>
<section id="figures" style="break-inside: auto"><h2>Figures</h2>{figures}</section>
{sweep}
<section id="details" style="break-inside: auto"><h2>Details</h2>{tables}</section>
</body></html>
"""

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
        page = self.html_page()
        with atomic_write(path) as handle:  # a temporary name renamed into place: never half a page
            handle.write(page)
        return path

    def to_pdf(self, path: str | Path, *, printer=None) -> Path:
        """Write a PDF: the HTML page printed by headless Chromium (A4).

        Without Chromium (``chromium`` or ``chromium-browser`` on the PATH) the PDF is a plain
        fallback: the text of the tables, then one page per figure, under a note that says so.

        Parameters
        ----------
        path : str or path-like
            The file to write; replaced in one step when complete (the old file stays if
            rendering fails).
        printer : PdfPrinter, optional
            A headless Chromium started before the analysis (its start-up overlaps it); default:
            ``chromium --print-to-pdf`` now.

        Returns
        -------
        pathlib.Path
            ``path``.

        Raises
        ------
        linflex.system.OutputError
            When Chromium is installed but fails to print the page.
        """
        path = Path(path)
        browser = printer.browser if printer is not None else chromium()
        if browser is None:
            return self._fallback_pdf(path)
        with tempfile.TemporaryDirectory(prefix=".linflex-pdf-") as tmp:
            page = Path(tmp) / "report.html"
            page.write_text(self.html_page(), encoding="utf-8")
            printed = Path(tmp) / "report.pdf"
            if printer is not None:
                printer.print(page, printed)
            else:
                print_pdf(browser, page, printed, Path(tmp) / "profile")
            with atomic_write(path, "wb") as handle:
                handle.write(printed.read_bytes())
        return path

    def _fallback_pdf(self, path: Path) -> Path:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
        from matplotlib.backends.backend_pdf import PdfPages

        note = ("NOTE: Chromium was not found, so this PDF is a plain fallback (text and figures); "
                "install chromium for the formatted report, or read report.html.")
        lines = [self.title, f"Created {self.created} by linflex {linflex.__version__}.", "", note, ""]
        for part in [*self.front(), *self.sweep_section(), *self.tables()]:
            lines += _plain_text(part) + [""]
        with atomic_write(path, "wb") as handle, PdfPages(handle) as pdf:
            for start in range(0, len(lines), 80):
                fig = plt.figure(figsize=(8.27, 11.69))
                fig.text(0.04, 0.97, "\n".join(textwrap.shorten(line, 130) if len(line) > 130 else line
                                               for line in lines[start:start + 80]),
                         family="monospace", fontsize=6.5, va="top")
                pdf.savefig(fig)
                plt.close(fig)
            for title, png in self._pngs:
                fig = plt.figure(figsize=(8.27, 11.69))
                image = plt.imread(io.BytesIO(png), format="png")
                ax = fig.add_axes((0.05, 0.05, 0.9, 0.85))
                ax.imshow(image)
                ax.set_axis_off()
                fig.suptitle(title)
                pdf.savefig(fig)
                plt.close(fig)
        return path


def _plain_text(part) -> list[str]:
    if isinstance(part, Paragraph):
        return ([part.title] if part.title else []) + textwrap.wrap(part.text, 128)
    widths = [max(len(str(x)) for x in col) for col in zip(part.header, *part.rows)]
    lines = [part.title] + (textwrap.wrap(part.note, 128) if part.note else [])
    lines.append("  ".join(str(h).ljust(w) for h, w in zip(part.header, widths)))
    lines += ["  ".join(str(c).ljust(w) for c, w in zip(row, widths)) for row in part.rows]
    return lines


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


def stability_report(analysis: SceneAnalysis, *, title: str | None = None,
                     requirements=None, sweep=None) -> StabilityReport:
    """The stability-margin report of an analysed scene (see :func:`analyse_scene`).

    Parameters
    ----------
    analysis : SceneAnalysis
        The result of :func:`analyse_scene`.
    title : str, optional
        Default ``"Stability margins: <scene name>"``.
    requirements : linflex.scene.Requirements, optional
        What to check; default the scene's ``[requirements]``.
    sweep : SweepAnalysis, path or sequence of mapping, optional
        Add a sweep section: the scene over these cases (a :class:`SweepAnalysis` from
        :func:`analyse_sweep`, or what it takes: a sweep spec file or the cases, analysed here),
        each case checked against the same requirements; histograms of the margins, Bode and
        Nichols envelopes of the loops, the worst case of each requirement and the pass count.

    Returns
    -------
    StabilityReport
        Render it with ``to_markdown``, ``to_html`` or ``to_pdf``.

    Raises
    ------
    TypeError
        If ``analysis`` is not a :class:`SceneAnalysis` (a scene or its path: analyse it first).
    ModelError
        If ``requirements`` is invalid (see :func:`verdicts`), or if the analysis did not search
        every disk margin (``analyse_scene(..., disk_margins="multi-loop")``): the report checks
        each loop's.

    Examples
    --------
    >>> from linflex.stability.report import analyse_scene, stability_report
    >>> report = stability_report(analyse_scene("examples/attitude_control.toml"))
    >>> report.title
    'Stability margins: attitude_control'
    >>> row = next(r for r in report.to_markdown().splitlines() if r.startswith("| phase margin [deg]"))
    >>> len(report.figures), row.split(" | ")[1], row.split(" | ")[4]   # figures; required; limiting PM [deg]
    (7, 'not required', '65.16')
    """
    from ._figures import report_figures

    if not isinstance(analysis, SceneAnalysis):
        raise TypeError(f"stability_report: analysis must be a SceneAnalysis (analyse_scene(scene)), got "
                        f"{type(analysis).__name__} {analysis!r:.60}")
    if any(np.isnan(lm.disk_margin.alpha) for lm in analysis.margins.loops):
        raise linflex.ModelError("stability_report: the analysis did not search each loop's disk margin "
                                 "(analyse_scene(..., disk_margins='multi-loop')); analyse the scene with "
                                 "disk_margins='all', the default, for a report")
    checked = verdicts(analysis, requirements)
    extra: dict = {}
    if sweep is not None:
        from ._sweep_figures import sweep_figures

        if not isinstance(sweep, SweepAnalysis):
            sweep = analyse_sweep(analysis.scene, sweep, method=analysis.plant.method)
        extra = dict(sweep=sweep, sweep_checks=sweep_checks(sweep, checked.requirements),
                     sweep_figures=tuple(sweep_figures(sweep, analysis, checked)))
    return StabilityReport(
        analysis=analysis,
        title=title or f"Stability margins: {analysis.scene.name}",
        created=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        figures=tuple(report_figures(analysis, checked)),
        verdicts=checked,
        **extra,
    )
