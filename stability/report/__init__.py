"""linflex.stability.report: from a scene to a stability-margin report (HTML, Markdown, PDF)."""

from ._analysis import ChannelAnalysis, SceneAnalysis, analyse_scene, margin_summary
from ._document import StabilityReport, stability_report
from ._pdf import PdfPrinter
from ._sweep import LoopEnvelope, SweepAnalysis, analyse_sweep
from ._verdicts import Check, Verdicts, margin_checks, verdicts

__all__ = ["ChannelAnalysis", "Check", "LoopEnvelope", "PdfPrinter", "SceneAnalysis", "StabilityReport",
           "SweepAnalysis", "Verdicts", "analyse_scene", "analyse_sweep", "margin_checks", "margin_summary",
           "stability_report", "verdicts"]
