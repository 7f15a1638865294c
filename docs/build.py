"""Build the documentation site and check it: ``python docs/build.py`` (after ``pip install -e ".[docs]"``).

Runs ``sphinx-build -b html -E -W --keep-going -n docs docs/_build/html``: a full build (``-E``, so
that every warning is shown again), warnings as errors, every cross reference checked
(``-n``, nitpicky). No network is used: no intersphinx, notebooks rendered from their committed
outputs. Then every internal link and image of the built HTML is checked: the file it names
exists and, for ``page.html#anchor``, the page has that ``id``. Exit status 0 when both pass.

Open ``docs/_build/html/index.html`` in a browser afterwards.
"""

from __future__ import annotations

import argparse
import html.parser
import subprocess
import sys
import time
from pathlib import Path
from urllib.parse import unquote, urlsplit

DOCS = Path(__file__).resolve().parent


class _Links(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.links: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if "id" in attrs:
            self.ids.add(attrs["id"])
        for key in ("href", "src"):
            if attrs.get(key) and not (tag == "link" and attrs.get("rel") == "preconnect"):
                self.links.append(attrs[key])


def _parse(path: Path) -> _Links:
    parser = _Links()
    parser.feed(path.read_text(encoding="utf-8", errors="replace"))
    return parser


def broken_links(site: Path) -> list[str]:
    """``"page.html: target"`` for every internal link or image of ``site`` that leads nowhere."""
    pages = {path: _parse(path) for path in site.rglob("*.html")}
    problems = []
    for path, parsed in pages.items():
        for link in parsed.links:
            parts = urlsplit(link)
            if parts.scheme or link.startswith(("//", "mailto:", "javascript:", "data:")):
                continue                      # external (not fetched: the build is offline)
            target = (path.parent / unquote(parts.path)).resolve() if parts.path else path
            if target.is_dir():
                target = target / "index.html"
            if not target.exists():
                problems.append(f"{path.relative_to(site)}: {link} (no such file)")
            elif parts.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else _parse(target).ids
                if unquote(parts.fragment) not in ids:
                    problems.append(f"{path.relative_to(site)}: {link} (no such anchor)")
    return sorted(set(problems))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("-o", "--output", default=str(DOCS / "_build" / "html"), help="HTML folder")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    command = [sys.executable, "-m", "sphinx", "-b", "html", "-E", "-W", "--keep-going", "-n", "-q",
               str(DOCS), args.output]
    status = subprocess.call(command)
    if status != 0:
        print(f"docs: sphinx-build failed (exit {status})", file=sys.stderr)
        return 1
    problems = broken_links(Path(args.output))
    for problem in problems:
        print(f"docs: broken internal link: {problem}", file=sys.stderr)
    seconds = time.perf_counter() - start
    if problems:
        print(f"docs: {len(problems)} broken internal link(s)", file=sys.stderr)
        return 1
    print(f"docs: built {args.output}/index.html in {seconds:.0f} s; internal links checked")
    return 0


if __name__ == "__main__":
    sys.exit(main())
