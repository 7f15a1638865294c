"""``linflex report SCENE.toml -o DIR``: the stability-margin report of a scene (the main job)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def register(subparsers) -> None:
    # The methods come from linflex.linearize's registry (a method registered there is a choice here).
    from linflex.linearize import METHODS

    parser = subparsers.add_parser(
        "report",
        help="stability-margin report of a scene (HTML, Markdown, PDF)",
        description="Compile the scene's plant, find its operating point, linearize it, close the loops of "
                    "its controllers and write a stability-margin report.",
        epilog="linearization methods (--method):\n"
               + "\n".join("  " + line for method in METHODS.values() for line in method.summary().splitlines()),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("scene", type=Path, help="scene file (TOML)")
    parser.add_argument("-o", "--output", type=Path, default=Path("report"), help="output folder (default: report)")
    parser.add_argument("--method", default="autodiff", choices=list(METHODS),
                        help="linearization method (default: autodiff, exact); see the list below")
    parser.add_argument("--no-pdf", action="store_true", help="skip the PDF")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from linflex import LinflexError
    from linflex.linearize import METHODS
    from linflex.stability.report import analyse_scene, stability_report

    start = time.perf_counter()
    method = METHODS[args.method]
    if not method.applies_to_compiled_scenes:
        # Said before compiling and trimming: a scene always compiles to a CasADi model.
        usable = [m.name for m in METHODS.values() if m.applies_to_compiled_scenes]
        print(f"linflex report: --method {method.name} needs {method.applies_to}, but a scene compiles to a "
              f"CasADi model; use one of {', '.join(usable)}", file=sys.stderr)
        return 2
    try:
        analysis = analyse_scene(args.scene, method=args.method)
    except LinflexError as err:
        print(f"linflex report: {args.scene}: {err}", file=sys.stderr)
        return 2
    report = stability_report(analysis)
    args.output.mkdir(parents=True, exist_ok=True)
    written = [report.to_html(args.output / "report.html")]
    markdown = args.output / "report.md"
    markdown.write_text(report.to_markdown(), encoding="utf-8")
    written.append(markdown)
    if not args.no_pdf:
        written.append(report.to_pdf(args.output / "report.pdf"))
    for label, value in report.summary():
        print(f"{label:>44}: {value}")
    print(f"\nwrote {', '.join(str(p) for p in written)} in {time.perf_counter() - start:.2f} s")
    return 0 if analysis.closed_loop_stable else 1
