"""Sphinx configuration of the linflex documentation.

Build it (offline: no intersphinx, no notebook execution) with ``python docs/build.py``, which runs
``sphinx-build -W --keep-going -n`` and then checks the internal links of the built HTML.
The pages generated from the code (API reference, scene vocabulary, gallery, included README and
benchmark sections) are written to ``docs/_generated/`` at the start of every build by
``docs/_ext/linflex_docs.py``.

Two tolerances, each for a quirk of the tools (both in ``linflex_docs.py``, both tested or
documented there): a name a docstring gives unqualified (``:class:`Model```) or by its room
(``linflex.structures.X``) is looked up as users see it, in the public packages; and a numpydoc summary line ending in ``::`` keeps its
literal block. Every other docstring problem fails the build.
"""

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))

import linflex  # noqa: E402

project = "linflex"
author = "the linflex authors"
copyright = "the linflex authors, BSD-3-Clause"
version = release = linflex.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_nb",
    "linflex_docs",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "_generated/include", "_generated/benchmarks", "reference/README.md", "**/.ipynb_checkpoints"]
templates_path = ["_templates"]
root_doc = "index"

# --- API reference: autosummary from each package's __all__ (pages written by linflex_docs) ---
autosummary_generate = True
autosummary_imported_members = True
autodoc_typehints = "none"          # the numpydoc sections state every type (with its unit)
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_validation_checks = set()  # tests/test_docstring_units.py checks the docstrings
numpydoc_xref_param_type = False

# --- Markdown and notebooks: committed outputs are rendered, never executed ---
nb_execution_mode = "off"
nb_merge_streams = True
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
suppress_warnings = ["mystnb.unknown_mime_type"]

# --- Cross references: checked (-n) for linflex's own names; no network, so no intersphinx ---
# References to other projects (numpy, scipy, python-control, CasADi, matplotlib, dask, pyyeti) and to
# Python's builtins cannot resolve offline; they are listed here by package, and every other
# unresolved reference fails the build.
nitpicky = True
nitpick_ignore_regex = [
    # private modules and base classes (``_Entry``): by design not part of the documented API
    (r"py:.*", r"linflex(\.\w+)*\._\w+(\..*)?"),
    (r"py:.*", r"(numpy|np|scipy|control|ct|casadi|ca|matplotlib|plt|dask|distributed|slycot|pyyeti|pathlib|os|typing|collections|numbers|concurrent)(\..*)?"),
    (r"py:.*", r"(str|int|float|bool|complex|tuple|list|dict|set|frozenset|bytes|callable|object|None|Exception|"
               r"ValueError|TypeError|RuntimeError|KeyError|IndexError|OSError|FileNotFoundError|UserWarning|Warning|"
               r"ArithmeticError|LinAlgError|NotImplementedError|KeyboardInterrupt|Path|Mapping|Sequence|Callable|Iterable|Any|"
               r"ArrayLike|NDArray|ndarray|Figure|Axes|Client|Future)"),
]

# --- HTML ---
html_theme = "furo"
html_title = f"linflex {release}"
html_static_path = []
html_show_sourcelink = False
html_copy_source = False
