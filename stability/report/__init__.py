"""linflex.stability.report: from a scene to a stability-margin report (HTML, Markdown, PDF)."""

from ._analysis import SceneAnalysis, analyse_scene

__all__ = ["SceneAnalysis", "analyse_scene"]
