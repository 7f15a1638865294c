"""The documentation site: the scene vocabulary reference names exactly the keys the code accepts,
the API reference every public name, the generated sections exist, the link check finds broken
links, and CI builds the site after the tests.

The generators live in ``docs/_ext`` (``scene_vocabulary.py``, ``linflex_docs.py``) and the build
command in ``docs/build.py``; none of them needs Sphinx to be imported. The full build
(``python docs/build.py``, about a minute and a half) is run by ``.ci/run`` after the tests, not
here (the test extra does not install Sphinx).
"""

import importlib
import sys
from pathlib import Path

import pytest

import linflex

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "_ext"))
sys.path.insert(0, str(ROOT / "docs"))

import build  # noqa: E402  (docs/build.py)
import linflex_docs  # noqa: E402
import scene_vocabulary  # noqa: E402


@pytest.fixture(scope="module")
def page():
    return scene_vocabulary.render_markdown()


# -- the scene vocabulary cannot drift -------------------------------------------------------------

def test_reference_names_exactly_the_keys_the_code_accepts(page):
    # code_keys reads the entry classes' fields, BEAM_KEYS and PROFILES; reference_keys reads the
    # rendered rows. A key in code but not on the page, or on the page but not in code, fails.
    in_code, on_page = scene_vocabulary.code_keys(), scene_vocabulary.reference_keys(page)
    assert in_code - on_page == set(), "keys the code accepts but the reference does not name"
    assert on_page - in_code == set(), "keys the reference names but the code does not accept"
    assert len(in_code) > 150   # 15 entry tables with their keys, beam keys, profile keys


def test_a_row_missing_from_the_page_is_found(page):
    # The comparison above is sensitive: drop the row of bodies.beam.EI and it is reported.
    lines = page.splitlines()
    start = lines.index("(bodies-beam)=")
    row = next(i for i in range(start, len(lines)) if lines[i].startswith("| `EI` |"))
    damaged = "\n".join(lines[:row] + lines[row + 1:])
    assert scene_vocabulary.code_keys() - scene_vocabulary.reference_keys(damaged) == {"bodies.beam.EI"}


def _toml_keys(data, prefix=""):
    """Key paths of a parsed scene file, as the reference names them (independent of the code)."""
    out = set()
    for key, value in data.items():
        path = f"{prefix}{key}"
        if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for item in value:
                out |= _toml_keys(item, f"{path}.")
        elif isinstance(value, dict) and key == "prescribed":
            out |= {f"{path}.{value['profile']}.{k}" for k in value}
        elif isinstance(value, dict) and key in ("beam", "frame", "orbit", "environment", "limits", "requirements"):
            out |= _toml_keys(value, f"{path}.")
        else:
            out.add(path)
    return out


@pytest.mark.parametrize("scene", sorted(p.name for p in (ROOT / "examples").glob("*.toml") if "sweep" not in p.name))
def test_every_key_of_the_example_scenes_is_in_the_reference(scene, page):
    data = tomllib.loads((ROOT / "examples" / scene).read_text())
    used = _toml_keys(data)
    assert used, scene
    assert used - scene_vocabulary.reference_keys(page) == set()


def test_units_and_meanings_come_from_the_docstrings():
    tables = {t.path: {k.name: k for k in t.keys} for t in scene_vocabulary.scene_tables()}
    # Parameters sections: Body "mass : float / Mass [kg] ...", Joint "stiffness, damping : float /
    # Joint spring [N m/rad or N/m] and damper [N m s/rad or N s/m]" (one unit per name).
    assert tables["bodies"]["mass"].unit == "kg" and tables["bodies"]["mass"].default == "required"
    assert tables["joints"]["stiffness"].unit == "N m/rad or N/m"
    assert tables["joints"]["damping"].unit == "N m s/rad or N s/m"
    assert tables["joints"]["parent"].default == "'ground'"
    # Prose: Wheel "``spin_inertia`` and ``transverse_inertia`` [kg m^2]", "``speed`` [rad/s]".
    assert tables["wheels"]["spin_inertia"].unit == tables["wheels"]["transverse_inertia"].unit == "kg m^2"
    assert tables["wheels"]["speed"].unit == "rad/s" and tables["wheels"]["speed"].default == "0.0"
    # Beam keys: units from Body's beam parameter, meanings from linflex.Beam and beam_modal_data.
    assert tables["bodies.beam"]["EA"].unit == "N" and tables["bodies.beam"]["EA"].meaning == "Axial stiffness [N]."
    assert tables["bodies.beam"]["elements"].default == "10"
    assert tables["bodies.beam"]["direction"].default == "[1, 0, 0]"
    assert tables["bodies.beam"]["damping"].unit == "-"
    # Allowed values of a type from the lists the validation checks.
    assert '"wheel_speed"' in tables["sensors"]["type"].type


def test_every_built_in_effect_is_on_the_page_with_its_docstring(page):
    # The built-in effects (other tests register effects of their own in the same registry).
    built_in = {name: effect for name, effect in linflex.registered_effects().items()
                if type(effect).__module__.startswith("linflex.effects")}
    assert len(built_in) >= 12
    for name, effect in built_in.items():
        first = " ".join((type(effect).__doc__ or "").split("\n\n")[0].split())
        assert first, f"effect {name!r} has no docstring"
        meaning = first.split(": ", 1)[1] if first.startswith("``") else first
        assert f"| `{name}` |" in page and scene_vocabulary._cell(meaning) in page


def test_docstring_gaps_are_shown_on_the_page(page):
    gaps = scene_vocabulary.docstring_gaps()
    for gap in gaps:
        assert f"- `{gap.split(':')[0]}`" in page
    undocumented = sum(row.count("*not documented*") for row in page.splitlines() if row.startswith("| `"))
    assert undocumented >= len(gaps)


# -- API reference, included sections --------------------------------------------------------------

def test_api_pages_document_every_public_name_once():
    documented: dict[int, str] = {}
    pages = {package: linflex_docs.api_page(package, documented) for package in linflex_docs.PACKAGES}
    for package, text in pages.items():
        module = importlib.import_module(package)
        listed = [line.strip() for line in text.splitlines() if line.startswith("   ") and line.strip().isidentifier()]
        again = {name for name in module.__all__ if f"``{name}`` (:obj:" in text}
        missing = {n for n in module.__all__ if not n.startswith("__")} - set(listed) - again
        assert missing == set(), f"{package}: public names without a page"
        assert len(listed) == len(set(listed))
    # An object exported by two packages gets one page: linflex.PlotHandle, also in frequency.
    assert "``PlotHandle`` (:obj:`linflex.PlotHandle`)" in pages["linflex.frequency"]


def test_the_guide_includes_sections_that_exist():
    methods = linflex_docs.markdown_section(ROOT / "README.md", "### Linearization methods")
    assert methods is not None and "| `autodiff` |" in methods
    results = linflex_docs.markdown_section(ROOT / "benchmarks" / "RESULTS.md", "## linearization")
    assert results is not None and "linflex autodiff" in results and "## margins" not in results
    assert linflex_docs.markdown_section(ROOT / "README.md", "## No such section") is None


# -- build command and CI -------------------------------------------------------------------------

def test_link_check_finds_missing_pages_and_anchors(tmp_path):
    (tmp_path / "a.html").write_text('<p id="here"><a href="b.html#there">b</a> <a href="a.html#here">a</a>'
                                     '<a href="https://example.org/x">x</a><img src="_images/x.png"></p>')
    (tmp_path / "b.html").write_text('<h1 id="top">b</h1><a href="c.html">c</a>')
    problems = build.broken_links(tmp_path)
    assert problems == ["a.html: _images/x.png (no such file)", "a.html: b.html#there (no such anchor)",
                        "b.html: c.html (no such file)"]


def test_ci_builds_the_docs_after_the_tests_and_fails_with_them():
    ci = (ROOT / ".ci" / "run").read_text()
    tests_line = next(i for i, line in enumerate(ci.splitlines()) if line.startswith("python3 -m venv .venv"))
    docs_line = next(i for i, line in enumerate(ci.splitlines()) if "docs/build.py" in line)
    assert docs_line > tests_line
    assert '".[docs]"' in ci


def test_a_summary_that_opens_a_literal_block_keeps_it():
    # numpydoc parses the summary line as its own paragraph; a "::" there would open a literal
    # block with no block (docutils: "Literal block expected"). The summary ends with ":" and
    # the block is opened by a "::" paragraph of its own (BodeForm's docstring has this shape).
    lines = ["A SISO transfer function in Bode form::", "", "    T(s) = gain / s", "", "Attributes"]
    linflex_docs.literal_summary(None, "class", "x", None, {}, lines)
    assert lines == ["A SISO transfer function in Bode form:", "", "::", "", "    T(s) = gain / s", "", "Attributes"]
    plain = ["A summary.", "", "More."]
    linflex_docs.literal_summary(None, "class", "x", None, {}, plain)
    assert plain == ["A summary.", "", "More."]


def _guide_blocks():
    import re

    for path in sorted((ROOT / "docs").rglob("*.md")):
        if "_build" in path.parts or "_generated" in path.parts:
            continue
        for i, block in enumerate(re.findall(r"```python\n(.*?)\n```", path.read_text(), flags=re.S)):
            yield pytest.param(block, id=f"{path.relative_to(ROOT / 'docs')}[{i}]")


@pytest.mark.parametrize("block", list(_guide_blocks()))
def test_guide_code_uses_only_public_names_that_exist(block):
    # Each block parses, and every linflex name it imports or reads (linflex.X, from linflex.y
    # import Z) exists in the public API (the blocks were run by hand when written; running them
    # here would compile the example spacecraft several times).
    import ast

    tree = ast.parse(block)
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("linflex"):
            module = importlib.import_module(node.module)
            for alias in node.names:
                assert alias.name in module.__all__, f"{node.module}.{alias.name} is not public"
        elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "linflex":
            assert node.attr in linflex.__all__, f"linflex.{node.attr} is not public"


def test_the_gallery_has_every_notebook_scene_and_script(tmp_path):
    pages = linflex_docs.write_gallery(tmp_path)
    examples = ROOT / "examples"
    for notebook in examples.glob("*.ipynb"):
        # copied as committed: the site renders the stored outputs, it does not run them
        assert (tmp_path / notebook.name).read_bytes() == notebook.read_bytes()
    index = (tmp_path / "index.rst").read_text()
    scenes = {p.stem for p in examples.glob("scene_*.py")}
    assert scenes <= set(pages)
    for toml in examples.glob("*.toml"):
        assert any(toml.name in (tmp_path / f"{page}.rst").read_text() for page in pages), toml.name
    for page in pages:
        assert f"   {page}\n" in index


def test_room_paths_resolve_to_the_documented_public_name():
    # Rooms re-export into linflex (docs/architecture.md); the reference documents linflex.X.
    assert linflex_docs.public_name("linflex.structures.beam_modal_data") == "linflex.beam_modal_data"
    assert linflex_docs.public_name("linflex.scene.Scene.validate") == "linflex.Scene.validate"
    assert linflex_docs.public_name("linflex.system.LinearSystem") == "linflex.LinearSystem"
    assert linflex_docs.public_name("linflex.structures.no_such_name") is None
