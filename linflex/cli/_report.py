"""``linflex report SCENE.toml -o DIR``: the stability-margin report of a scene (the main job)."""

from __future__ import annotations

import argparse
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
    """Handler of ``linflex report``: 0 stable, 1 unstable; bad input raises (exit code 2)."""
    from linflex import load_scene
    from linflex.linearize import METHODS
    from linflex.stability.report import StabilityReport, analyse_scene, stability_report

    from ._boundary import InputError, check_input_file, reading

    start = time.perf_counter()
    method = METHODS[args.method]
    if not method.applies_to_compiled_scenes:
        # Said before compiling and trimming: a scene always compiles to a CasADi model.
        usable = [m.name for m in METHODS.values() if m.applies_to_compiled_scenes]
        raise InputError(f"--method {method.name} needs {method.applies_to}, but a scene compiles to a "
                         f"CasADi model; use one of {', '.join(usable)}")
    # every input and the output folder are checked before the analysis runs
    check_input_file(args.scene, "scene file")
    StabilityReport.check_folder(args.output)
    with reading(args.scene, loading=True):
        scene = load_scene(args.scene)
    with reading(args.scene):
        analysis = analyse_scene(scene, method=args.method)
    report = stability_report(analysis)
    # the folder is built beside -o and swapped in whole: never a mix of two runs, never half a file
    written = report.write(args.output, pdf=not args.no_pdf)
    for label, value in report.summary():
        print(f"{label:>44}: {value}")
    print(f"\nwrote {', '.join(str(p) for p in written)} in {time.perf_counter() - start:.2f} s")
    return 0 if analysis.closed_loop_stable else 1
