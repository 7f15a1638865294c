"""How results show themselves: a short one-line ``repr`` and a compact HTML table for Jupyter.

Every result class (responses, margins, modes, linearizations, simulations, sweeps, analyses)
writes ``__repr__`` and ``_repr_html_`` as a few lines that list its key fields and call these
helpers; the formatting, truncation and HTML escaping live here only.
"""

from __future__ import annotations

import html
from collections.abc import Iterable, Sequence

import numpy as np

__all__ = ["display_value", "html_summary", "short_repr"]

#: Longest ``repr`` a result gives [characters]: a notebook cell's echo stays a few lines.
REPR_LIMIT = 600
#: Longest text of one table cell in the HTML [characters].
HTML_WIDTH = 240
#: Most names a list shows before ``...``.
NAMES_SHOWN = 4


def display_value(value, digits: int = 4, width: int = 80) -> str:
    """A field's value as short text: numbers to ``digits`` significant digits, name lists cut
    after a few entries, arrays as their shape, ``-`` for None and nan.

    Parameters
    ----------
    value : object
        A number (real or complex), bool, str, sequence of names, array or anything else
        (its ``str``, cut to 80 characters).
    digits : int
        Significant digits of numbers.
    width : int
        Longest text shown [characters]; longer text is cut with ``...``.

    Returns
    -------
    str
        The text (not yet HTML-escaped).

    Examples
    --------
    >>> display_value(0.123456), display_value(float("nan")), display_value(["a", "b", "c", "d", "e", "f"])
    ('0.1235', '-', "['a', 'b', 'c', 'd', ... (6)]")
    """
    if value is None:
        return "-"
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return "-" if np.isnan(v) else ("inf" if v == np.inf else "-inf" if v == -np.inf else f"{v:.{digits}g}")
    if isinstance(value, (complex, np.complexfloating)):
        z = complex(value)
        return f"{z.real:.{digits}g}{'+' if z.imag >= 0 else '-'}{abs(z.imag):.{digits}g}j"
    if isinstance(value, str):
        return value if len(value) <= width else value[:width - 3] + "..."
    if isinstance(value, np.ndarray):
        return f"array{value.shape}" if value.size > NAMES_SHOWN else "[" + ", ".join(
            display_value(v, digits) for v in value.ravel()) + "]"
    if isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
        shown = ", ".join(repr(v) for v in value[:NAMES_SHOWN])
        return f"[{shown}, ... ({len(value)})]" if len(value) > NAMES_SHOWN else f"[{shown}]"
    if isinstance(value, (list, tuple)) and len(value) <= NAMES_SHOWN:
        return "[" + ", ".join(display_value(v, digits) for v in value) + "]"
    if isinstance(value, (list, tuple)):
        return f"<{len(value)} items>"
    text = str(value)
    return text if len(text) <= width else text[:width - 3] + "..."


def short_repr(name: str, fields: Iterable[tuple[str, object]], limit: int = REPR_LIMIT) -> str:
    """``Name(field=value, ...)`` with :func:`display_value` values, at most ``limit`` characters.

    Parameters
    ----------
    name : str
        The class name.
    fields : iterable of (str, object)
        The fields to show, in order; a name may end in its unit in brackets (``"delay_margin
        [s]"``), written after the value. The text is cut (``...``) where it would exceed
        ``limit``.
    limit : int
        Longest result [characters].

    Returns
    -------
    str

    Examples
    --------
    >>> short_repr("Margins", [("min_phase_margin [deg]", 65.156393), ("channels", ("tx", "ty"))])
    "Margins(min_phase_margin=65.16 deg, channels=['tx', 'ty'])"
    """
    parts = []
    for key, value in fields:
        field, _, unit = key.partition(" [")  # "delay_margin [s]" reads delay_margin=0.19 s
        unit = unit.rstrip("]")
        parts.append(f"{field}={display_value(value)}" + (f" {unit}" if unit and unit != "-" else ""))
    text = f"{name}(" + ", ".join(parts) + ")"
    if len(text) <= limit:
        return text
    out = f"{name}("
    for part in parts:
        if len(out) + len(part) + 7 > limit:
            return out + "...)"
        out += part + ", "
    return out[:-2] + ")"  # pragma: no cover -- the whole text fitted


def html_summary(title: str, fields: Iterable[tuple[str, object]] = (), header: Sequence[str] = (),
                 rows: Iterable[Sequence[object]] = (), *, max_rows: int = 12, note: str = "") -> str:
    """A compact HTML block: a title, a two-column table of fields, then a table of rows.

    Parameters
    ----------
    title : str
        The heading (the class and what it is of).
    fields : iterable of (str, object)
        Name and value of each key field (values through :func:`display_value`).
    header : sequence of str
        Column names of the row table (units in brackets, as the report writes them).
    rows : iterable of sequence
        The row table's cells (values through :func:`display_value`, text up to ``HTML_WIDTH``
        characters); only the first
        ``max_rows`` are shown, then a line that says how many more there are.
    max_rows : int
        Most rows shown.
    note : str
        A line below the tables.

    Returns
    -------
    str
        HTML (every text escaped) that Jupyter shows for a result's ``_repr_html_``.

    Examples
    --------
    >>> html_summary("Modes <3>", [("n", 3)], ("#", "wn [rad/s]"), [(0, 1.5)])[:60]
    '<div class="linflex-result"><strong>Modes &lt;3&gt;</strong>'
    """
    def cell(value, tag="td"):
        return f"<{tag} style='text-align:left;padding:1px 6px'>{html.escape(display_value(value, width=HTML_WIDTH))}</{tag}>"

    out = [f'<div class="linflex-result"><strong>{html.escape(title)}</strong>']
    fields = list(fields)
    if fields:
        out.append("<table style='border-collapse:collapse;margin:2px 0'>"
                   + "".join(f"<tr>{cell(k, 'th')}{cell(v)}</tr>" for k, v in fields) + "</table>")
    rows = list(rows)
    if header and rows:
        body = "".join("<tr>" + "".join(cell(v) for v in row) + "</tr>" for row in rows[:max_rows])
        more = (f"<tr><td colspan='{len(header)}' style='text-align:left;padding:1px 6px'>... "
                f"{len(rows) - max_rows} more rows</td></tr>") if len(rows) > max_rows else ""
        out.append("<table style='border-collapse:collapse;margin:2px 0'><thead><tr>"
                   + "".join(cell(h, "th") for h in header) + f"</tr></thead><tbody>{body}{more}</tbody></table>")
    if note:
        out.append(f"<div style='font-size:0.85em;color:#555'>{html.escape(note)}</div>")
    out.append("</div>")
    return "".join(out)
