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
import shutil
import subprocess
import tempfile
import textwrap
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import linflex
from linflex.scene import REQUIREMENTS
from linflex.system import OutputError, atomic_write, check_output_folder, replaced_folder

from ._analysis import SceneAnalysis
from ._verdicts import LABELS, Check, Verdicts, verdicts

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
class Paragraph:
    """A titled paragraph of plain text (a verdict, a description, a convention)."""

    title: str
    text: str
    css: str = ""

    def to_markdown(self) -> str:
        return (f"### {self.title}\n\n" if self.title else "") + self.text + "\n"

    def to_html(self) -> str:
        head = f"<h3>{html.escape(self.title)}</h3>" if self.title else ""
        css = f" class='{self.css}'" if self.css else ""
        return f"<section{css}>{head}<p>{html.escape(self.text)}</p></section>"


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
    """

    analysis: SceneAnalysis
    title: str
    created: str
    figures: tuple[tuple[str, Callable], ...] = ()
    verdicts: Verdicts | None = None

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
        out = [("verdict", _verdict_text(v)), ("closed loop", _stability_text(a))]
        for quantity in REQUIREMENTS:
            check = v.limiting(quantity)
            if check is not None:
                out.append((f"limiting {LABELS[quantity]} [{check.unit}]", _check_text(check)))
        out += [
            ("scene", a.scene.name),
            ("linearization", f"{a.plant.method}, max relative error estimate "
                              f"{a.plant.max_relative_error_estimate:.1e}, {a.plant.n_evaluations} evaluations"),
            ("operating point", "trimmed" if a.trimmed else "the scene's initial state (an equilibrium)"),
        ]
        return out

    def _verdicts(self) -> Verdicts:
        return self.verdicts if self.verdicts is not None else verdicts(self.analysis)

    def front(self) -> list:
        """The first screen: verdict, limiting items, plant and controller, convention, flexible modes."""
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
                         ("<= " if REQUIREMENTS[quantity][1] == "<=" else ">= ") + _fmt(check.required)
                         if check.required is not None else "not required",
                         check.channel, _where(check), _value(check),
                         "-" if check.required is None else ("PASS" if n_fail == 0 else f"FAIL ({n_fail} of {len(of)})")))
        verdict_css = "verdict pass" if v.passed else "verdict fail"
        parts = [
            Paragraph("", _verdict_text(v), verdict_css),
            Table("Requirements and the limiting loop and crossing of each",
                  ("quantity", "required", "limiting loop", "where", "value", "verdict"), tuple(rows),
                  note="Each requirement is checked at every crossing and loop (table 'Every crossing'); the "
                       "limiting item is the one with the least slack against its bound."),
            Paragraph("Plant and controller", _description(a)),
            Paragraph("Conventions", PM_CONVENTION),
        ]
        flexible = flexible_resonances(a)
        if flexible:
            parts.append(_flexible_table(flexible))
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
                                  f"PM {_fmt(pm)} deg", f"{_fmt(dm) if stable else 'none'} s",
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
                             _fmt(lm.disk_margin.alpha), _fmt(lm.disk_margin.phase_margin),
                             _db(c.sensitivity_peak[0]) if c else "-",
                             _db(c.complementary_sensitivity_peak[0]) if c else "-", str(lm.open_loop_rhp_poles)))
        disks = [("balanced, each loop independently (diagonal)", m.disk_margin),
                 ("balanced, all loops together (full block)", m.unstructured_disk_margin)]
        if m.skewed_disk_margin.skew != 0:
            disks.append((f"skewed (skew {_fmt(m.skewed_disk_margin.skew)}), diagonal", m.skewed_disk_margin))
        sens = []
        for name, response in (("S_i = (I + K P)^-1, plant input", a.sensitivity),
                               ("T_i = I - S_i, plant input", a.complementary_sensitivity),
                               ("S_o = (I + P K)^-1, sensors", a.output_sensitivity)):
            if response is not None:
                sigma = np.linalg.svd(response.response, compute_uv=False)[:, 0]
                k = int(np.argmax(sigma))
                sens.append((name, _db(sigma[k]), _fmt(sigma[k]), _fmt(response.omega[k]),
                             _fmt(response.peak_resolution_db)))
        tables = [
            Table("Margins per loop", ("loop", "min PM [deg]", "at [rad/s]", "min GM [dB]", "delay margin [s]",
                                       "disk alpha", "disk PM [deg]", "Ms [dB]", "Mt [dB]", "open-loop RHP poles"),
                  tuple(per_loop),
                  note="Loop-at-a-time: each loop broken at its actuator (the plant input) with the other loops "
                       "closed. Ms and Mt: peaks of 1/(1 + L) and L/(1 + L) of that loop."
                       + ("" if stable else " The closed loop is UNSTABLE: it has no delay margin.")),
            Table("Every crossing", ("#", "loop", "kind", "frequency [rad/s]", "[Hz]", "margin", "delay margin",
                                     "verdict"), tuple((str(i + 1), *row) for i, row in enumerate(crossings)),
                  note="Numbered as in the Bode diagram."),
            Table("Multi-loop disk margins", ("disk", "alpha", "gain margin [dB]", "phase margin [deg]",
                                              "frequency [rad/s]"),
                  tuple((name, _fmt(d.alpha), f"[{_db(d.gain_margin[0])}, {_db(d.gain_margin[1])}]",
                         _fmt(d.phase_margin), _fmt(d.frequency)) for name, d in disks),
                  note="Simultaneous gain and phase variations in every loop at once (Seiler, Packard and Gahinet "
                       "2020): diagonal, independent in each loop; full block, any coupled variation."),
            *([Table("Sensitivity peaks (all loops)", ("function", "peak [dB]", "peak [-]", "at [rad/s]",
                                                      "grid resolution [dB]"), tuple(sens),
                     note="Largest singular value over frequency, on the engine's adaptive grid (peaks resolved "
                          "to the resolution shown).")] if sens else []),
            _modes_table("Closed-loop modes", a.closed_loop_modes, a.closed_loop_modes.states, None),
            _modes_table("Plant modes (controllers open)", a.plant_modes, a.plant_modes.states, a.loop.plant),
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

    @functools.cached_property
    def _pngs(self) -> tuple[tuple[str, bytes], ...]:
        """Every figure drawn once, as PNG (the HTML embeds them; the PDF prints the HTML)."""
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        out = []
        for title, draw in self.figures:
            fig = draw()
            try:
                buffer = io.BytesIO()
                fig.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
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
        figures = "".join(
            f"<figure><img alt='{html.escape(title)}' src='data:image/png;base64,{base64.b64encode(png).decode()}'>"
            f"<figcaption>{html.escape(title)}</figcaption></figure>"
            for title, png in self._pngs)
        front = "".join(p.to_html() for p in self.front())
        tables = "".join(t.to_html() for t in self.tables())
        return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(self.title)}</title>
<style>
@page {{ size: A4; margin: 14mm 12mm; }}
body {{ font-family: "DejaVu Sans", system-ui, sans-serif; margin: 1.5em auto; max-width: 62em; color: #222;
        font-size: 14px; line-height: 1.35; }}
h1 {{ font-size: 1.6em; margin: 0 0 0.2em; }}
h2 {{ font-size: 1.25em; border-bottom: 1px solid #ccc; margin-top: 1.4em; }}
h3 {{ font-size: 1.05em; margin: 1em 0 0.3em; }}
table {{ border-collapse: collapse; margin: 0.4em 0 1em; max-width: 100%; }}
th, td {{ border: 1px solid #bbb; padding: 0.2em 0.5em; text-align: left; font-size: 0.9em;
          overflow-wrap: anywhere; }}
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

    def to_pdf(self, path: str | Path) -> Path:
        """Write a PDF: the HTML page printed by headless Chromium (A4).

        Without Chromium (``chromium`` or ``chromium-browser`` on the PATH) the PDF is a plain
        fallback: the text of the tables, then one page per figure, under a note that says so.

        Parameters
        ----------
        path : str or path-like
            The file to write; replaced in one step when complete (the old file stays if
            rendering fails).

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
        browser = chromium()
        if browser is None:
            return self._fallback_pdf(path)
        with tempfile.TemporaryDirectory(prefix=".linflex-pdf-") as tmp:
            page = Path(tmp) / "report.html"
            page.write_text(self.html_page(), encoding="utf-8")
            printed = Path(tmp) / "report.pdf"
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
        for part in [*self.front(), *self.tables()]:
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


def chromium() -> str | None:
    """The headless browser that prints the PDF (``chromium`` or ``chromium-browser``), or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


def print_pdf(browser: str, page: Path, out: Path, profile: Path) -> None:
    """Print ``page`` to ``out`` with headless Chromium (a fresh profile, no network, no header)."""
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
             "--disable-component-update", "--disable-sync", "--disable-extensions", f"--user-data-dir={profile}",
             "--no-pdf-header-footer", f"--print-to-pdf={out}", page.as_uri()]
    try:
        done = subprocess.run([browser, *flags], capture_output=True, text=True, timeout=180)
    except (OSError, subprocess.TimeoutExpired) as err:
        raise OutputError(f"{browser} could not print the report to PDF: {err}") from err
    if not out.exists() or not out.read_bytes().startswith(b"%PDF"):
        raise OutputError(f"{browser} did not print the report to PDF (exit {done.returncode}): "
                          + " ".join(done.stderr.split()[-40:]))


def _plain_text(part) -> list[str]:
    if isinstance(part, Paragraph):
        return ([part.title] if part.title else []) + textwrap.wrap(part.text, 128)
    widths = [max(len(str(x)) for x in col) for col in zip(part.header, *part.rows)]
    lines = [part.title] + (textwrap.wrap(part.note, 128) if part.note else [])
    lines.append("  ".join(str(h).ljust(w) for h, w in zip(part.header, widths)))
    lines += ["  ".join(str(c).ljust(w) for c, w in zip(row, widths)) for row in part.rows]
    return lines


PM_CONVENTION = (
    "Phase margin PM = 180 deg + arg L(j wc), wrapped to (-180, 180] deg, at each gain crossover |L(j wc)| = 1 "
    "of the loop-at-a-time return ratio L (negative feedback, loop broken at the actuator). A negative PM at a "
    "crossover of a stable closed loop is normal for a phase-stabilized flexible mode: its distance to -180 deg "
    "is |PM|, which is what a phase-margin requirement bounds. Closed-loop stability is decided by the Nyquist "
    "count Z = N + P (N clockwise encirclements of -1, P open-loop unstable poles), not by the sign of a margin. "
    "Gain margins are |20 log10 GM| at each phase crossover (arg L = -180 deg), an increase (GM > 1) or a "
    "reduction (GM < 1); the delay margin at a crossover is the added delay that turns its phase to -180 deg.")

#: Units of sensor signals and actuator commands by type.
SENSOR_UNITS = {"attitude": "rad", "rate": "rad/s", "position": "m", "velocity": "m/s", "acceleration": "m/s^2",
                "wheel_speed": "rad/s"}
ACTUATOR_UNITS = {"torque": "N m", "wheel_torque": "N m", "force": "N", "thruster": "N"}


def _verdict_text(v: Verdicts) -> str:
    required = [c for c in v.checks if c.required is not None]
    names = sorted({LABELS[c.quantity] for c in required}, key=list(LABELS.values()).index)
    if not v.closed_loop_stable:
        return ("FAIL: the closed loop is UNSTABLE, so no margin holds"
                + (f" ({len(required)} required checks fail)." if required else "."))
    if not required:
        return "No requirements given (add a [requirements] table or --require): the closed loop is stable."
    if v.passed:
        return (f"PASS: all {len(required)} checks of {len(names)} requirements ({', '.join(names)}) hold on every "
                "loop and crossing; the closed loop is stable.")
    failed = v.failed
    worst = sorted(failed, key=lambda c: c.slack)[:3]
    return (f"FAIL: {len(failed)} of {len(required)} checks fail: "
            + "; ".join(f"{LABELS[c.quantity]} of {c.channel} {_where(c)}: {_value(c)} {c.unit} "
                        f"({'>=' if REQUIREMENTS[c.quantity][1] == '>=' else '<='} {_fmt(c.required)})" for c in worst)
            + ("; ..." if len(failed) > 3 else "."))


def _stability_text(a: SceneAnalysis) -> str:
    m = a.margins
    count = (f" (Nyquist: Z = N + P = {m.nyquist_encirclements} + {m.open_loop_rhp_poles})"
             if m.nyquist_encirclements is not None else "")
    return ("stable" if a.closed_loop_stable else
            f"UNSTABLE, {sum(md.unstable for md in a.closed_loop_modes)} unstable mode(s)") + count


def _where(c: Check) -> str:
    if np.isnan(c.frequency):
        return c.where
    return f"{c.where} at {_fmt(c.frequency)} rad/s"


def _value(c: Check) -> str:
    return "none (unstable)" if np.isnan(c.value) else _fmt(c.value)


def _check_text(c: Check) -> str:
    bound = "" if c.required is None else (
        f" (required {'>=' if REQUIREMENTS[c.quantity][1] == '>=' else '<='} {_fmt(c.required)}: "
        f"{'pass' if c.passed else 'FAIL'})")
    return f"{_value(c)}, {c.channel}, {_where(c)}{bound}"


def _gains(value) -> str:
    values = np.atleast_1d(np.asarray(value, dtype=float))
    return _fmt(values[0]) if values.size == 1 else "[" + ", ".join(_fmt(x) for x in values) + "]"


def _description(a: SceneAnalysis) -> str:
    """The plant and the controller in one paragraph, with units."""
    scene = a.scene
    bodies = []
    for b in scene.bodies:
        if b.type == "flexible":
            beam = getattr(b, "beam", None)
            length = f"{_fmt(beam['length'])} m beam, " if isinstance(beam, dict) and "length" in beam else ""
            bodies.append(f"{b.name} (flexible, {length}{b.modes if b.modes is not None else 'all'} modes)")
        else:
            inertia = np.asarray(b.inertia, dtype=float)
            diag = np.diag(inertia) if inertia.ndim == 2 else inertia
            bodies.append(f"{b.name} (rigid, {_fmt(b.mass)} kg, inertia {_gains(diag)} kg m^2)")
    text = [f"Plant: {len(scene.bodies)} bodies: " + "; ".join(bodies) + "."]
    if scene.wheels:
        text.append(f"{len(scene.wheels)} momentum wheels ({', '.join(w.name for w in scene.wheels)}).")
    plant_effects = [e for e in scene.effects if e != "control"]
    text.append("Effects in the plant (compiled and linearized): " + (", ".join(plant_effects) or "none")
                + "; the controllers are closed as linear systems, not linearized.")
    flexible = [m for m in a.plant_modes if m.kind == "oscillatory"]
    if flexible:
        text.append(f"{len(flexible)} lightly damped plant modes from {_fmt(flexible[0].natural_frequency)} to "
                    f"{_fmt(flexible[-1].natural_frequency)} rad/s: "
                    + ", ".join(f"{_fmt(m.natural_frequency)} rad/s (zeta {_fmt(m.damping_ratio, 2)})"
                                for m in flexible) + ".")
    text.append(f"{a.loop.plant.n_states} plant states in the loop.")
    sensors = {s.name: s for s in scene.sensors}
    actuators = {x.name: x for x in scene.actuators}

    def signals(names, table, units):
        return ", ".join(f"{n} ({table[n].type}, {units.get(table[n].type, '?')})" if n in table else n for n in names)

    text.append("Sensors: " + signals(a.loop.sensors, sensors, SENSOR_UNITS) + ". Actuators: "
                + signals(a.loop.actuators, actuators, ACTUATOR_UNITS) + ".")
    for c in scene.controllers:
        inputs = list(np.atleast_1d(c.inputs))
        outputs = list(np.atleast_1d(c.outputs))
        out_unit = ACTUATOR_UNITS.get(actuators[outputs[0]].type, "?") if outputs[0] in actuators else "?"
        in_unit = SENSOR_UNITS.get(sensors[inputs[0]].type, "?") if inputs[0] in sensors else "?"
        if c.type == "pid":
            terms = [f"kp = {_gains(c.kp)} {out_unit}/{in_unit}"]
            if np.any(np.asarray(c.ki, dtype=float)):
                terms.append(f"ki = {_gains(c.ki)} {out_unit}/({in_unit} s)")
            if np.any(np.asarray(c.kd, dtype=float)):
                rate = f" on {', '.join(np.atleast_1d(c.rate_inputs))}" if c.rate_inputs is not None else ""
                terms.append(f"kd = {_gains(c.kd)} {out_unit} s/{in_unit}{rate}")
            law = "PID, " + ", ".join(terms)
        else:
            law = c.type.replace("_", "-")
        text.append(f"Controller {c.name}: {law}; from {', '.join(inputs)} to {', '.join(outputs)}; continuous "
                    "time (no sampling).")
    first = [f"{lm.channel} {_fmt(lm.gain_crossovers[0])}" for lm in a.margins.loops if lm.gain_crossovers.size]
    if first:
        text.append("Loop bandwidth (first gain crossover) [rad/s]: " + ", ".join(first) + ".")
    return " ".join(text)


@dataclass(frozen=True)
class Resonance:
    """A resonance peak of a loop-at-a-time return ratio, classified.

    Attributes
    ----------
    channel : str
    frequency : float
        Of the peak [rad/s].
    peak_db : float
        ``20 log10 |L(j omega)|`` at the peak [dB].
    kind : str
        ``"gain-stabilized"`` (peak below 0 dB) or ``"phase-stabilized"`` (above: it crosses 0 dB).
    clearance : float
        Gain-stabilized: dB below 0 dB; phase-stabilized: the least |PM| [deg] of the gain
        crossovers around the peak.
    mode_frequency, mode_damping : float
        The nearest lightly damped plant mode [rad/s] and its damping ratio [-].
    """

    channel: str
    frequency: float
    peak_db: float
    kind: str
    clearance: float
    mode_frequency: float
    mode_damping: float


def flexible_resonances(a: SceneAnalysis, prominence_db: float = 3.0) -> list[Resonance]:
    """The resonance peaks of every loop-at-a-time return ratio, gain- or phase-stabilized.

    Parameters
    ----------
    a : SceneAnalysis
        With ``channels`` (``analyse_scene(..., figures=True)``).
    prominence_db : float
        Least prominence of a peak of ``|L|`` [dB] on the adaptive grid.

    Returns
    -------
    list of Resonance
    """
    import scipy.signal

    flexible = [m for m in a.plant_modes if m.kind == "oscillatory"]
    if not flexible:
        return []
    wn = np.array([m.natural_frequency for m in flexible])
    margins = {lm.channel: lm for lm in a.margins.loops}
    out = []
    for c in a.channels:
        mag_db = 20 * np.log10(np.abs(c.response.response[:, 0, 0]))
        peaks, _ = scipy.signal.find_peaks(mag_db, prominence=prominence_db)
        lm = margins[c.channel]
        for k in peaks:
            w, peak = float(c.response.omega[k]), float(mag_db[k])
            near = int(np.argmin(np.abs(np.log(wn / w))))
            if peak < 0:
                kind, clearance = "gain-stabilized", -peak
            else:
                below = lm.gain_crossovers[lm.gain_crossovers <= w]
                above = lm.gain_crossovers[lm.gain_crossovers >= w]
                around = [i for i, x in enumerate(lm.gain_crossovers)
                          if (below.size and x == below[-1]) or (above.size and x == above[0])]
                kind = "phase-stabilized"
                clearance = float(min((abs(lm.phase_margins[i]) for i in around), default=np.nan))
            out.append(Resonance(c.channel, w, peak, kind, clearance, float(wn[near]),
                                 float(flexible[near].damping_ratio)))
    return out


def _flexible_table(resonances: list[Resonance]) -> Table:
    rows = tuple((r.channel, _fmt(r.frequency), f"{_fmt(r.mode_frequency)} / {_fmt(r.mode_damping, 2)}",
                  f"{r.peak_db:+.1f}", r.kind.upper() if r.kind == "phase-stabilized" else r.kind,
                  (f"{r.clearance:.1f} dB below 0 dB" if r.kind == "gain-stabilized"
                   else f"|PM| {_fmt(r.clearance)} deg at its crossings"))
                 for r in resonances)
    n_phase = sum(r.kind == "phase-stabilized" for r in resonances)
    note = ("Resonance peaks of each loop's return ratio |L|. A gain-stabilized mode stays below 0 dB whatever its "
            "phase; a phase-stabilized one rises above 0 dB and is stable only through its phase (its clearance "
            "is the phase distance to -180 deg at its crossings), so an error in its frequency or in the loop's "
            "phase can destabilize it.")
    if n_phase:
        note = (f"WARNING: {n_phase} resonance(s) are phase-stabilized (peak above 0 dB). " + note)
    return Table("Flexible modes: gain- or phase-stabilized",
                 ("loop", "peak at [rad/s]", "plant mode [rad/s] / damping", "peak [dB]", "stabilized by",
                  "clearance"), rows, note=note)


def _rigid_labels(table, plant) -> dict[int, str]:
    """Labels of rigid-body rows by their Jordan chains: positions, then the rates that drive them.

    A double integrator has one eigenvector (the position) for two eigenvalues at 0; the eigen
    solver returns it twice. The rate of a chain is the least-squares ``w`` of ``A w = v``.
    """
    rows = [i for i, m in enumerate(table) if m.kind == "rigid-body"]
    if plant is None or not rows:
        return {}
    V = np.asarray(table.eigenvectors)[:, rows]
    positions, duplicates = [], []  # eigenvectors in row order; rows that repeat an earlier one
    for k in range(len(rows)):
        v = V[:, k] / np.linalg.norm(V[:, k])
        if positions:
            P = np.column_stack(positions)
            if np.linalg.norm(v - P @ np.linalg.lstsq(P, v, rcond=None)[0]) < 1e-3:
                duplicates.append(k)
                continue
        positions.append(v)
    if not duplicates:
        return {}
    P = np.column_stack(positions).real
    rates = np.linalg.lstsq(np.asarray(plant.A, dtype=float), P, rcond=None)[0]
    rates -= P @ np.linalg.lstsq(P, rates, rcond=None)[0]  # the part along the positions is not the rate
    names = plant.states

    def label(vector):
        weight = np.abs(vector) / np.max(np.abs(vector))
        order = np.argsort(-weight)[:3]
        return ", ".join(f"{names[j]} {weight[j]:.2f}" for j in order if weight[j] > 0.05)

    out = {}
    for j, k in enumerate(duplicates):
        if j < rates.shape[1] and np.max(np.abs(rates[:, j])) > 0:
            out[rows[k]] = label(rates[:, j]) + " (rate)"
    return out


def _modes_table(title: str, table, states, plant) -> Table:
    rigid = _rigid_labels(table, plant)
    rows = tuple((str(i), _fmt(m.eigenvalue.real) + (f" ± {_fmt(abs(m.eigenvalue.imag))}j" if m.eigenvalue.imag else ""),
                  _fmt(m.natural_frequency), _fmt(m.frequency_hz), _fmt(m.damping_ratio), m.kind,
                  rigid.get(i) or ", ".join(f"{name} {weight:.2f}" for name, weight in m.participation[:3]))
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


def stability_report(analysis: SceneAnalysis, *, title: str | None = None,
                     requirements=None) -> StabilityReport:
    """The stability-margin report of an analysed scene (see :func:`analyse_scene`).

    Parameters
    ----------
    analysis : SceneAnalysis
        The result of :func:`analyse_scene`.
    title : str, optional
        Default ``"Stability margins: <scene name>"``.
    requirements : linflex.scene.Requirements, optional
        What to check; default the scene's ``[requirements]``.

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
    >>> len(report.figures), "| phase margin [deg] | not required | tx | gain crossover at 0.7624 rad/s | 65.16 | - |" in report.to_markdown()
    (7, True)
    """
    from ._figures import report_figures

    checked = verdicts(analysis, requirements)
    return StabilityReport(
        analysis=analysis,
        title=title or f"Stability margins: {analysis.scene.name}",
        created=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        figures=tuple(report_figures(analysis, checked)),
        verdicts=checked,
    )
