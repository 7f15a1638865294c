"""Titled tables of formatted strings, and the number formats of the report."""

from __future__ import annotations

import html
from dataclasses import dataclass

import numpy as np


def fmt(value: float, digits: int = 4) -> str:
    """A number with ``digits`` significant digits; ``-`` for None or nan."""
    if value is None:
        return "-"
    value = float(value)
    if np.isnan(value):
        return "-"
    if np.isinf(value):
        return "inf" if value > 0 else "-inf"
    return f"{value:.{digits}g}"


def db(ratio: float) -> str:
    """A ratio in dB with two decimals."""
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
