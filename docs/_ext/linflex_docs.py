"""Sphinx extension of the linflex docs: the pages generated from the code at each build.

At ``config-inited`` (before Sphinx looks for the sources, and before autosummary writes its stubs)
it writes ``docs/_generated/``:

``api/<package>.rst``
    One page per public package, an autosummary of its ``__all__`` (the core's names grouped by
    room, each layer's by its private module), so that a new public name appears without an edit.
``include/scene_vocabulary.md``
    The scene vocabulary reference (``docs/_ext/scene_vocabulary.py``).
``gallery/``
    The example notebooks, copied as committed (executed, with their figures: myst-nb renders
    the stored outputs, ``nb_execution_mode = "off"``), and one page per example scene and script.
``include/readme_*.md``, ``include/results_linearization.md``
    Sections of ``README.md`` and ``benchmarks/RESULTS.md`` included by the guide, cut at their
    headings (their images copied to ``_generated/benchmarks/``), so that no number is retyped.

Files are rewritten only when their text changes, so that a second build is incremental.
"""

from __future__ import annotations

import ast
import importlib
import re
import shutil
from collections import defaultdict
from pathlib import Path

import scene_vocabulary

DOCS = Path(__file__).resolve().parents[1]
ROOT = DOCS.parent
GENERATED = DOCS / "_generated"

PACKAGES = ["linflex", "linflex.linearize", "linflex.frequency", "linflex.stability", "linflex.stability.report",
            "linflex.design"]
LAYER_TITLES = {
    "linflex": "linflex: the core (scenes, models, simulation, systems, structures, sweeps)",
    "linflex.linearize": "linflex.linearize: operating points, linearization, reduction",
    "linflex.frequency": "linflex.frequency: frequency responses, Nyquist, zeros, root locus, plots",
    "linflex.stability": "linflex.stability: modes and stability margins",
    "linflex.stability.report": "linflex.stability.report: stability reports",
    "linflex.design": "linflex.design: control design (gains, filters, LQR/LQG, tuning to requirements)",
}
# The notebooks of examples/, in reading order (a notebook not listed is appended after them).
NOTEBOOKS = ["stability_report", "attitude_design", "reduction_design", "margin_sweep", "spinning_beam"]


def write_if_changed(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def _underline(title: str, char: str = "=") -> str:
    return f"{title}\n{char * len(title)}\n"


# -- API reference ---------------------------------------------------------------------------------

def _group(package: str, documented: dict[int, str]) -> tuple[dict[str, list[str]], list[tuple[str, str]]]:
    """``{group: names}`` of a package's ``__all__`` (rooms for the core, modules for the layers),
    and ``(name, where documented)`` of the names an earlier package already exports."""
    module = importlib.import_module(package)
    groups: dict[str, list[str]] = defaultdict(list)
    again = []
    for name in module.__all__:
        if name.startswith("__"):
            continue
        obj = getattr(module, name)
        if id(obj) in documented:
            again.append((name, documented[id(obj)]))
            continue
        documented[id(obj)] = f"{package}.{name}"
        home = getattr(obj, "__module__", None) or package
        if package == "linflex":
            parts = home.split(".")
            group = f"linflex.{parts[1]}" if len(parts) > 1 and not parts[1].startswith("_") else "linflex"
        else:
            group = home if home.startswith(package) else package
        groups[group].append(name)
    return groups, again


def _summary(module_name: str) -> str:
    doc = importlib.import_module(module_name).__doc__ or ""
    return " ".join(doc.strip().split("\n\n")[0].split())


def _rooms() -> list[str]:
    import pkgutil

    import linflex

    return [f"linflex.{m.name}" for m in pkgutil.iter_modules(linflex.__path__) if m.ispkg and not m.name.startswith("_")]


def api_page(package: str, documented: dict[int, str]) -> str:
    lines = [_underline(LAYER_TITLES[package]), f".. automodule:: {package}", "   :no-members:", ""]
    groups, again = _group(package, documented)
    if again:
        lines += ["Also exported here: " + ", ".join(f"``{name}`` (:obj:`{where}`)" for name, where in again) + ".", ""]
    for group, names in groups.items():
        if package == "linflex" and group != "linflex":
            # A room: its name, its docstring, its public names (re-exported as linflex.X).
            lines += [_underline(f"Room ``{group.split('.')[-1]}``", "-"), f".. automodule:: {group}",
                      "   :no-members:", ""]
        elif group in (package, "linflex"):
            lines += [_underline("Constants", "-")]
        elif len(groups) > 1:
            doc = _summary(group)
            title = doc.split(". ")[0].rstrip(".") if doc else group.rsplit(".", 1)[-1].lstrip("_")
            lines += [_underline(title, "-")]
        lines += [f".. currentmodule:: {package}", "", ".. autosummary::", "   :toctree: stubs", "   :nosignatures:", ""]
        lines += [f"   {name}" for name in names]
        lines.append("")
    if package == "linflex":
        # Rooms without public names (dynamics, cli) still say what they hold.
        for room in _rooms():
            if room not in groups and room not in PACKAGES:
                lines += [_underline(f"Room ``{room.split('.')[-1]}``", "-"), f".. automodule:: {room}",
                          "   :no-members:", ""]
    return "\n".join(lines)


def write_api() -> None:
    documented: dict[int, str] = {}
    for package in PACKAGES:
        write_if_changed(GENERATED / "api" / f"{package}.rst", api_page(package, documented))


# -- included sections ---------------------------------------------------------------------------

def markdown_section(path: Path, heading: str) -> str | None:
    """The body of the Markdown section whose heading starts with ``heading`` (``"## Exit codes"``)
    up to the next heading of the same or a higher level; None when the file has no such heading."""
    text = path.read_text(encoding="utf-8")
    level = len(heading) - len(heading.lstrip("#"))
    match = re.search(rf"^{re.escape(heading)}[^\n]*$", text, flags=re.M)
    if not match:
        return None
    end = re.search(rf"^#{{1,{level}}} ", text[match.end():], flags=re.M)
    return text[match.end():match.end() + end.start() if end else len(text)].strip("\n") + "\n"


def write_includes() -> None:
    exit_codes = markdown_section(ROOT / "README.md", "## Exit codes")
    if exit_codes is None:
        exit_codes = ("```{note}\nThe README has no *Exit codes* section yet; this page shows it as soon as it has "
                      "(`docs/_ext/linflex_docs.py` includes it from `README.md`). Until then: `linflex --help`.\n```\n")
    write_if_changed(GENERATED / "include" / "readme_exit_codes.md", exit_codes)
    methods = markdown_section(ROOT / "README.md", "### Linearization methods")
    if methods is None:
        raise RuntimeError("README.md has no '### Linearization methods' section (docs/guide/linearization.md includes it)")
    write_if_changed(GENERATED / "include" / "readme_linearization_methods.md", methods)
    results = markdown_section(ROOT / "benchmarks" / "RESULTS.md", "## linearization")
    if results is None:
        raise RuntimeError("benchmarks/RESULTS.md has no '## linearization' section")
    # Images of the section, copied beside the generated pages and named from the source root
    # ("/_generated/...": Sphinx reads a leading slash as the docs folder).
    for image in re.findall(r"\]\((results/[^)]+)\)", results):
        source, target = ROOT / "benchmarks" / image, GENERATED / "benchmarks" / image
        if not target.exists() or target.read_bytes() != source.read_bytes():
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)
    results = re.sub(r"\]\((results/[^)]+)\)", r"](/_generated/benchmarks/\1)", results)
    header = markdown_section(ROOT / "benchmarks" / "RESULTS.md", "# Benchmark results") or ""
    machine = "\n".join(line for line in header.splitlines() if line.startswith("- "))
    write_if_changed(GENERATED / "include" / "results_linearization.md", results + "\nMeasured on:\n\n" + machine + "\n")


# -- scene vocabulary ------------------------------------------------------------------------------

def write_scene_vocabulary() -> None:
    write_if_changed(GENERATED / "include" / "scene_vocabulary.md", scene_vocabulary.render_markdown())


# -- gallery ---------------------------------------------------------------------------------------

def _docstring(path: Path) -> str:
    return ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""


def _rst_text(docstring: str) -> str:
    """A script's story (reST-ish docstring) as a page body; its first line is the title."""
    return docstring.split("\n", 1)[1].strip() if "\n" in docstring else ""


def _scene_page(name: str, toml: Path | None, script: Path | None) -> str:
    title = _docstring(script).split("\n")[0].rstrip(".") if script else toml.name
    lines = [_underline(title)]
    if script:
        lines += [_rst_text(_docstring(script)), ""]
    if toml is not None:
        lines += [f"The scene, ``examples/{toml.name}`` (every key is in the :doc:`scene vocabulary "
                  f"</scene-vocabulary>`):", "", f".. literalinclude:: ../../../examples/{toml.name}",
                  "   :language: toml", ""]
    if script:
        lines += [f"The script, ``examples/{script.name}`` (``python examples/{script.name}``; run from "
                  "a checkout, it writes its figure to the current folder):", "",
                  f".. literalinclude:: ../../../examples/{script.name}", "   :language: python", ""]
    return "\n".join(lines)


def write_gallery(gallery: Path = GENERATED / "gallery") -> list[str]:
    """Write the gallery into ``gallery``; return its pages of scenes and scripts."""
    examples = ROOT / "examples"
    notebooks = NOTEBOOKS + sorted(p.stem for p in examples.glob("*.ipynb") if p.stem not in NOTEBOOKS)
    for stem in notebooks:
        source, target = examples / f"{stem}.ipynb", gallery / f"{stem}.ipynb"
        if not target.exists() or target.read_bytes() != source.read_bytes():
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)
    pages = []
    for script in sorted(examples.glob("scene_*.py")):
        toml = examples / f"{script.stem.removeprefix('scene_')}.toml"   # a script may build its scene itself
        write_if_changed(gallery / f"{script.stem}.rst", _scene_page(script.stem, toml if toml.exists() else None, script))
        pages.append(script.stem)
    scripted = {f"{p.removeprefix('scene_')}.toml" for p in pages}
    for toml in sorted(examples.glob("*.toml")):
        if toml.name not in scripted:
            stem = f"toml_{toml.stem}"
            write_if_changed(gallery / f"{stem}.rst", _scene_page(stem, toml, None))
            pages.append(stem)
    for script in sorted(examples.glob("*.py")):
        if not script.name.startswith("scene_") and script.name != "execute_notebooks.py":
            page = [_underline(_docstring(script).split("\n")[0].rstrip(".")), _rst_text(_docstring(script)), "",
                    f"``python examples/{script.name}``:", "",
                    f".. literalinclude:: ../../../examples/{script.name}", "   :language: python", ""]
            write_if_changed(gallery / f"script_{script.stem}.rst", "\n".join(page))
            pages.append(f"script_{script.stem}")
    index = [_underline("Gallery"),
             "The notebooks of ``examples/`` as committed, executed, with their figures (the site does not "
             "run them: ``python examples/execute_notebooks.py NAME`` refreshes a notebook's outputs), "
             "then every example scene and script with its story. Each is checked by a test "
             "(``tests/test_examples.py``, ``tests/linflex/test_scene_examples.py``).", "",
             "Notebooks", "---------", "", ".. toctree::", "   :maxdepth: 1", ""]
    index += [f"   {stem}" for stem in notebooks]
    index += ["", "Scenes and scripts", "------------------", "", ".. toctree::", "   :maxdepth: 1", ""]
    index += [f"   {page}" for page in pages]
    write_if_changed(gallery / "index.rst", "\n".join(index) + "\n")
    return pages


def generate(app=None, config=None) -> None:
    write_api()
    write_includes()
    write_scene_vocabulary()
    write_gallery()


# -- two tolerances, each for a quirk of the tools, not of the docstrings ---------------------------

def public_name(path: str) -> str | None:
    """The documented name of the object at ``path`` (``"linflex.structures.join_components"``
    -> ``"linflex.join_components"``): the first public package whose ``__all__`` holds the same
    object; for a field of a documented dataclass (``"linflex.ModalData.geometric_stiffness"``)
    the class itself. None when there is none."""
    import dataclasses

    parts = path.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
            break
        except ImportError:
            continue
    else:
        return None
    owner = None
    rest = parts[i:]
    for k, part in enumerate(rest):
        owner, obj = obj, getattr(obj, part, dataclasses.MISSING)
        if obj is dataclasses.MISSING:
            # a dataclass field without a class attribute (no default): name its class instead
            if k == len(rest) - 1 and dataclasses.is_dataclass(owner) and part in {
                    f.name for f in dataclasses.fields(owner)}:
                obj = owner
                break
            return None
    for package in PACKAGES:
        module = importlib.import_module(package)
        for name in module.__all__:
            if getattr(module, name, None) is obj:
                return f"{package}.{name}"
    if owner is not None and obj is not owner and isinstance(owner, type):
        cls = public_name(f"{owner.__module__}.{owner.__qualname__}")
        return f"{cls}.{parts[-1]}" if cls else None
    return None


def resolve_unqualified(app, env, node, contnode):
    """Resolve a name as the docstrings give it (``:class:`Model```, ``:meth:`Scene.validate```,
    ``:func:`linflex.structures.join_components```).

    Sphinx looks an unqualified name up in the current module only, and finds a qualified one
    only where it is documented; linflex's docstrings, written in private modules, name the API as
    users see it (``Model`` for ``linflex.Model``) or by the room that defines it (rooms re-export
    into ``linflex``, which the reference documents). Try the current class, then each public
    package; for a path, the public name of the same object (:func:`public_name`).
    """
    if node.get("refdomain") != "py":
        return None
    domain = env.get_domain("py")
    target = node["reftarget"].lstrip("~.")
    candidates = []
    if target.startswith("linflex."):
        candidates.append(public_name(target))
    else:
        module, cls = node.get("py:module"), node.get("py:class")
        if module and cls:
            candidates.append(f"{module}.{cls}.{target}")
        candidates += [f"{p}.{target}" for p in PACKAGES]
    # A dataclass field listed in its class's Attributes section has no target of its own
    # (numpydoc renders the section as a list): link the class.
    if node["reftype"] in ("attr", "obj"):
        candidates += [c.rsplit(".", 1)[0] for c in candidates if c and "." in c]
    for full in candidates:
        if full and full in domain.objects:
            new = node.deepcopy()
            new["reftarget"] = full
            kind = node["reftype"] if domain.objects[full].objtype != "class" else "class"
            return domain.resolve_xref(env, node["refdoc"], app.builder, kind, full, new, contnode)
    return None


def literal_summary(app, what, name, obj, options, lines):
    """A summary line that ends with ``::`` introduces a literal block in reST, but numpydoc
    parses the summary as a paragraph of its own and docutils then finds no block: end the
    summary with ``:`` and open the block with a ``::`` paragraph of its own (same rendering)."""
    if lines and lines[0].rstrip().endswith("::") and len(lines) > 1 and not lines[1].strip():
        lines[0] = lines[0].rstrip()[:-1]
        lines.insert(2, "::")
        lines.insert(3, "")


def setup(app):
    app.connect("missing-reference", resolve_unqualified)
    app.connect("autodoc-process-docstring", literal_summary, priority=100)  # before numpydoc (500)
    # Before Sphinx looks for source files (and autosummary for the pages to write stubs for).
    app.connect("config-inited", generate, priority=100)
    return {"parallel_read_safe": True, "parallel_write_safe": True, "version": "1"}
