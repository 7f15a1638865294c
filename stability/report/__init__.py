"""linflex.stability.report: from a scene to a stability-margin report (HTML, Markdown, PDF)."""

from ._analysis import SceneAnalysis, analyse_scene, margin_summary
from ._document import StabilityReport, stability_report

__all__ = ["SceneAnalysis", "StabilityReport", "analyse_scene", "margin_summary", "stability_report"]
