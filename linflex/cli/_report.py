"""``linflex report SCENE.toml -o DIR``: the stability-margin report of a scene (the main job)."""

from __future__ import annotations

import argparse
import contextlib
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
    parser.add_argument("--method", default="kane", choices=list(METHODS),
                        help="linearization method (default: kane, exact, which also splits the stiffness by "
                             "origin); see the list below")
    parser.add_argument("--require", nargs="+", action="extend", default=[], metavar="NAME=VALUE",
                        help="requirements, over the scene's [requirements]: gain_margin_db, phase_margin_deg, "
                             "delay_margin_s, disk_margin, sensitivity_peak_db, complementary_sensitivity_peak_db "
                             "(units as named); LOOP.NAME=VALUE for one loop (LOOP: its actuator), e.g. "
                             "--require phase_margin_deg=30 motor_x.delay_margin_s=0.1. Exit 1 when one fails")
    parser.add_argument("--sweep", type=Path, default=None, metavar="SPEC",
                        help="also analyse the scene over the cases of a sweep spec (the file linflex sweep takes, "
                             "analysis = \"margins\") and add a sweep section: histograms of the margins, Bode and "
                             "Nichols envelopes of the loops, the worst case of each requirement and the pass count; the "
                             "table of the cases goes to sweep.csv in the report folder. Exit 1 when a case fails a "
                             "requirement")
    parser.add_argument("--processes", type=int, default=None,
                        help="with --sweep: local worker processes for the cases (default: all cores for large "
                             "sweeps; 1 = serial)")
    parser.add_argument("--no-pdf", action="store_true", help="skip the PDF")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Handler of ``linflex report``: 0 stable and every requirement met (by every sweep case too), 1
    unstable or a requirement failed; bad input raises (exit code 2)."""
    from linflex import load_scene
    from linflex.linearize import METHODS
    from linflex.stability.report import PdfPrinter, StabilityReport, analyse_scene, analyse_sweep, stability_report
    from linflex.sweeps import load_sweep_spec, vary_scene

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
    cases = None
    if args.processes is not None and args.sweep is None:
        raise InputError("--processes runs the cases of a sweep: give --sweep SPEC too")
    if args.processes is not None and args.processes < 1:
        raise InputError(f"--processes must be at least 1, got {args.processes}")
    if args.sweep is not None:
        check_input_file(args.sweep, "sweep spec")
        with reading(args.sweep, loading=True):
            cases, analysis_name, _ = load_sweep_spec(args.sweep)
            vary_scene(scene, cases[0])  # a parameter path that does not apply fails now, not after the analysis
        if analysis_name != "margins":
            raise InputError(f"--sweep {args.sweep}: a report sweeps the margins; the spec asks for analysis = "
                             f"{analysis_name!r}")
    requirements = scene.requirements.updated(_requirements(args.require, scene))
    # Chromium starts now and prints the PDF at the end: its start-up overlaps the analysis
    with PdfPrinter() if not args.no_pdf else contextlib.nullcontext() as printer:
        with reading(args.scene):
            analysis = analyse_scene(scene, method=args.method)
        sweep = None
        if cases is not None:
            with reading(args.sweep):
                sweep = analyse_sweep(scene, args.sweep, method=args.method, processes=args.processes)
        report = stability_report(analysis, requirements=requirements, sweep=sweep)
        # the folder is built beside -o and swapped in whole: never a mix of two runs, never half a file
        written = report.write(args.output, pdf=not args.no_pdf, printer=printer)
    for label, value in report.summary():
        print(f"{label:>44}: {value}")
    print(f"\nwrote {', '.join(str(p) for p in written)} in {time.perf_counter() - start:.2f} s")
    return 0 if report.passed else 1


def _requirements(items: list[str], scene):
    """``--require`` items as :class:`linflex.scene.Requirements`, checked like a scene's table."""
    from linflex.scene import REQUIREMENTS, Requirements

    from ._boundary import InputError

    values: dict = {}
    loops: dict = {}
    for item in items:
        name, sep, text = item.partition("=")
        channel, dot, key = name.strip().rpartition(".")
        if not sep or not key:
            raise InputError(f"--require {item!r}: expected NAME=VALUE or LOOP.NAME=VALUE with NAME one of "
                             f"{', '.join(REQUIREMENTS)}")
        try:
            value = float(text)
        except ValueError:
            raise InputError(f"--require {item!r}: {text!r} is not a number [{REQUIREMENTS.get(key, ('',))[0]}]") from None
        (loops.setdefault(channel, {}) if dot else values)[key] = value
    unknown = sorted(k for k in [*values, *(k for own in loops.values() for k in own)] if k not in REQUIREMENTS)
    if unknown:
        raise InputError(f"--require: unknown requirement(s) {', '.join(unknown)}; known: {', '.join(REQUIREMENTS)}")
    requirements = Requirements(**values, loops=loops or None)
    problems = scene.replace(requirements=requirements).problems()
    problems = [p.replace("requirements", "--require", 1) for p in problems if p.startswith("requirements")]
    if problems:
        raise InputError("; ".join(problems))
    return requirements
