"""The scene vocabulary reference, generated from the code so that it cannot drift.

Every table and key a scene file may hold is read from the code:

* the tables are the fields of :class:`linflex.Scene` (their annotations name the entry classes:
  ``tuple[Body, ...]`` is an array of tables ``[[bodies]]``, ``Frame`` a table ``[frame]``);
* the keys of a table are the fields of its entry class (names, defaults, which are required);
* the keys of a ``beam`` table are ``BEAM_KEYS`` and the keys of each ``prescribed`` time profile
  are ``PROFILES`` (both in ``linflex.scene._entries``, the lists the scene validation uses);
* the effect names are :func:`linflex.registered_effects`, each with its class's docstring.

The type, unit and meaning of a key come from the docstrings: the ``Parameters`` section of the
entry class (``name : type`` and its description, whose first bracketed unit is the key's unit),
else the sentence of the class description that names the key in double back quotes (its unit is
the bracket right after the key). The beam keys are described by :class:`linflex.Beam` (the
keys it shares) and :func:`linflex.beam_modal_data` (``damping``), with the units the ``beam``
parameter of :class:`linflex.Body` gives. Nothing is typed here: a key whose docstrings give no
meaning, or a numeric key without a unit, is listed in :func:`docstring_gaps` and shown on the page
as a gap to fill in the code.

``python docs/_ext/scene_vocabulary.py`` prints the page (Markdown); ``--gaps`` prints the gaps.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re
import sys
import typing
from dataclasses import dataclass

__all__ = ["Key", "Table", "scene_tables", "effect_table", "docstring_gaps", "render_markdown", "code_keys"]

# A numpydoc section heading: a title on its own line, underlined with dashes.
_HEADING = re.compile(r"^(?P<title>[A-Z][A-Za-z ]+)\n-{3,}[ \t]*$", re.MULTILINE)
# An entry line of a Parameters section: "name", "name : type", "a, b : type".
_ENTRY = re.compile(r"^(?P<names>\*{0,2}\w+(?:\s*,\s*\*{0,2}\w+)*)\s*(?::\s*(?P<type>.*))?$")
# A unit in brackets that opens a word: "[rad/s]", "[-]", "[N m/rad]"; not an index such as x[0].
_UNIT = re.compile(r"(?:^|(?<=[\s(,;:{]))\[(?P<unit>[^\[\]`]+)\]")
_SENTENCE_END = re.compile(r"(?<=[.;])\s+(?=[A-Z`(])")


@dataclass(frozen=True)
class Key:
    """One key of a scene table."""

    name: str
    type: str
    unit: str | None
    default: str
    meaning: str | None
    needs_unit: bool


@dataclass(frozen=True)
class Table:
    """A scene table: its TOML header, where its keys are documented, and its keys."""

    path: str          # "bodies", "bodies.beam", "joints.prescribed", "frame", "(top level)"
    header: str        # "[[bodies]]", "[bodies.beam]", ...
    source: str        # the documented object, "linflex.Body"
    summary: str
    keys: tuple[Key, ...]


# -- docstrings ------------------------------------------------------------------------------------

def _sections(doc: str | None) -> tuple[str, dict[str, str]]:
    """The description before the first section, and ``{title: body}`` of the numpydoc sections."""
    doc = inspect.cleandoc(doc or "")
    headings = list(_HEADING.finditer(doc))
    ends = [h.start() for h in headings[1:]] + [len(doc)]
    intro = doc[:headings[0].start()] if headings else doc
    return intro.strip(), {h.group("title").strip(): doc[h.end():end].strip("\n") for h, end in zip(headings, ends)}


def _parameters(doc: str | None) -> dict[str, tuple[str, str, tuple[str, ...]]]:
    """``{name: (type, description, names of the entry)}`` of the Parameters section of a docstring."""
    out: dict[str, tuple[str, str, tuple[str, ...]]] = {}
    names: list[str] = []
    kind = ""
    lines: list[str] = []

    def flush():
        for name in names:
            out[name] = (kind, " ".join(lines).strip(), tuple(names))

    for line in _sections(doc)[1].get("Parameters", "").splitlines():
        if line and not line[0].isspace():
            flush()
            match = _ENTRY.match(line.strip())
            names = [n.strip().lstrip("*") for n in match.group("names").split(",")] if match else []
            kind = (match.group("type") or "").strip() if match else ""
            lines = []
        else:
            lines.append(line.strip())
    flush()
    return out


def _first_sentence(text: str) -> str:
    text = " ".join(text.split())
    return _SENTENCE_END.split(text, maxsplit=1)[0].strip()


def _unit_of(text: str) -> str | None:
    match = _UNIT.search(text)
    return match.group("unit").strip() if match else None


def _units_of(description: str, name: str, names: tuple[str, ...]) -> str | None:
    """The unit of ``name`` in an entry's description.

    One unit per name of a shared entry when there are as many (``stiffness, damping``: the
    first and the second); otherwise every distinct unit the description gives, in order.
    """
    units = list(dict.fromkeys(m.group("unit").strip() for m in _UNIT.finditer(description)))
    if not units:
        return None
    if len(names) > 1 and len(units) == len(names):
        return units[names.index(name)]
    return ", ".join(units)


def _prose_mentions(intro: str, key: str) -> tuple[str | None, str | None]:
    """The first sentence of ``intro`` naming ````key```` and the unit bracketed right after it.

    The unit may follow a group of keys: "``spin_inertia`` and ``transverse_inertia`` [kg m^2]".
    """
    text = " ".join(intro.split())
    marker = f"``{key}``"
    if marker not in text:
        return None, None
    sentences = _SENTENCE_END.split(text)
    sentence = next(s for s in sentences if marker in s)
    group = re.search(re.escape(marker) + r"(?:\s*(?:and|or)\s*``\w+``)*\s*\[(?P<unit>[^\[\]`]+)\]", text)
    return sentence.strip(), (group.group("unit").strip() if group else None)


# -- types and defaults ----------------------------------------------------------------------------

def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _numeric_default(value) -> bool:
    if _is_number(value):
        return True
    return isinstance(value, tuple) and bool(value) and all(_numeric_default(v) for v in value)


def _type_of(annotation, default, documented: str) -> str:
    if documented:
        return documented
    text = annotation if isinstance(annotation, str) else getattr(annotation, "__name__", str(annotation))
    if text == "Any" and isinstance(default, tuple) and default and all(_is_number(v) for v in default):
        return f"sequence of {len(default)} floats"
    return text


def _needs_unit(kind: str, default) -> bool:
    words = kind.lower()
    if re.fullmatch(r"int(, optional)?", words.strip()):       # a count
        return False
    if re.search(r"\b(str|bool|mapping|callable|modaldata)\b", words) and not re.search(r"float|int", words):
        return False
    return bool(re.search(r"float|int|number|array|matrix", words)) or _numeric_default(default)


def _default_text(field: dataclasses.Field) -> str:
    if field.default is not dataclasses.MISSING:
        value = field.default
    elif field.default_factory is not dataclasses.MISSING:
        value = field.default_factory()
    else:
        return "required"
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, tuple):
        return "[" + ", ".join(map(repr, value)) + "]"
    return repr(value)


def _keys_of(cls, *, skip=()) -> tuple[Key, ...]:
    documented = _parameters(cls.__doc__)
    intro = _sections(cls.__doc__)[0]
    hints = {f.name: f.type for f in dataclasses.fields(cls)}
    keys = []
    for field in dataclasses.fields(cls):
        if field.name in skip:
            continue
        kind, description, names = documented.get(field.name, ("", "", (field.name,)))
        unit = _unit_of(kind) or _units_of(description, field.name, names)
        meaning = _first_sentence(description) if description else None
        if meaning is None:
            meaning, prose_unit = _prose_mentions(intro, field.name)
            unit = unit or prose_unit
        default = field.default if field.default is not dataclasses.MISSING else None
        kind = _type_of(hints[field.name], default, kind)
        choices = _CHOICES.get((cls.__name__, field.name))
        if choices and "{" not in kind:
            kind = f"{kind}: " + ", ".join(f'"{c}"' for c in getattr(_entries_module(), choices))
        needs_unit = _needs_unit(kind, default)
        keys.append(Key(field.name, kind, unit if needs_unit else None, _default_text(field), meaning, needs_unit))
    return tuple(keys)


# -- the tables ------------------------------------------------------------------------------------

def _scene_fields():
    """``(name, entry class or None, is_array)`` of every field of :class:`linflex.Scene`."""
    import linflex

    module = sys.modules[linflex.Scene.__module__]
    hints = typing.get_type_hints(linflex.Scene, vars(module))
    out = []
    for field in dataclasses.fields(linflex.Scene):
        hint = hints[field.name]
        args = [a for a in typing.get_args(hint) if a is not type(None) and a is not Ellipsis]
        origin = typing.get_origin(hint)
        if origin is tuple and args and dataclasses.is_dataclass(args[0]):
            out.append((field.name, args[0], True))
        elif dataclasses.is_dataclass(hint):
            out.append((field.name, hint, False))
        elif args and dataclasses.is_dataclass(args[0]):      # Orbit | None
            out.append((field.name, args[0], False))
        else:
            out.append((field.name, None, False))
    return out


# The lists of allowed values the scene validation checks ``type`` and ``kind`` against.
_CHOICES = {("Joint", "type"): "JOINT_TYPES", ("LoopJoint", "type"): "LOOP_JOINT_TYPES",
            ("Constraint", "kind"): "CONSTRAINT_KINDS",
            ("Sensor", "type"): "SENSOR_TYPES", ("Actuator", "type"): "ACTUATOR_TYPES",
            ("Controller", "type"): "CONTROLLER_TYPES", ("Frame", "kind"): "FRAME_KINDS"}


def _entries_module():
    return importlib.import_module("linflex.scene._entries")


def _beam_table(body_cls) -> Table:
    import linflex

    beam_keys = _entries_module().BEAM_KEYS
    body_doc = _parameters(body_cls.__doc__).get("beam", ("", "", ()))[1]
    spec = re.search(r"\{(?P<spec>.*)\}", " ".join(body_doc.split()))
    # Units as the Body docstring lists them: "EI or EIy and EIz [N m^2], EA [N], ..."; a default
    # as "direction (default [1, 0, 0])"; alternatives as "EI or EIy and EIz".
    units: dict[str, str] = {}
    defaults: dict[str, str] = {}
    meanings: dict[str, str] = {}
    for item in re.split(r",\s*(?![^\[\(]*[\]\)])", spec.group("spec") if spec else ""):
        names = [n for n in re.findall(r"\w+", item.split("[")[0].split("(")[0]) if n in beam_keys]
        unit = _unit_of(re.sub(r"\(default [^)]*\)", "", item))  # not the default's brackets
        default = re.search(r"\(default (?P<value>[^)]*)\)", item)
        # "length [m] the beam's length": what follows the unit (and the default) is the meaning
        after = re.sub(r"\(default [^)]*\)", "", item.split("]", 1)[1]).strip() if "]" in item else ""
        for name in names:
            if after:
                meanings[name] = after
            if unit:
                units[name] = unit
            if default:
                defaults[name] = default.group("value")
            elif len(names) > 1 and " or " in item:
                defaults[name] = "required: " + item.split("[")[0].strip()
    beam_doc = _parameters(linflex.Beam.__doc__)
    beam_fields = {f.name: f for f in dataclasses.fields(linflex.Beam)}
    # damping is not a Beam field: beam_modal_data takes it (see _beam_body_modes).
    damping_doc = _parameters(linflex.beam_modal_data.__doc__).get("damping", ("", "", ()))
    damping_default = inspect.signature(linflex.beam_modal_data).parameters["damping"].default
    keys = []
    for name in beam_keys:
        kind, description, _ = damping_doc if name == "damping" else beam_doc.get(name, ("", "", ()))
        if name in defaults:
            default = defaults[name]
        elif name == "damping":
            default = repr(damping_default)
        elif name in beam_fields:
            default = _default_text(beam_fields[name])
        else:
            default = "required"
        meaning = _first_sentence(description) if description else meanings.get(name)
        if meaning and meaning.startswith("["):     # "mass_per_length : float" with "[kg/m]." only
            meaning = None
        if not kind:
            kind = f"sequence of {default.count(',') + 1} floats" if default.startswith("[") else "float"
        needs_unit = _needs_unit(kind, None)
        unit = units.get(name) or _unit_of(kind) or _unit_of(description)
        keys.append(Key(name, kind, unit if needs_unit else None, default, meaning, needs_unit))
    return Table("bodies.beam", "[bodies.beam]", "linflex.Body",
                 "The `beam` of a flexible body (instead of `modal_data`): a beam clamped at the body origin; "
                 "the keys it shares with {class}`linflex.Beam` are described there, `damping` by "
                 "{func}`linflex.beam_modal_data`.", tuple(keys))


def _profile_tables(joint_cls) -> list[Table]:
    profiles = _entries_module().PROFILES
    description = " ".join(_parameters(joint_cls.__doc__).get("prescribed", ("", "", ()))[1].split())
    tables = []
    for profile, keys in profiles.items():
        # The profile's clause in Joint's ``prescribed``: from its quoted name to the next one.
        start = description.find(f'"{profile}"')
        following = [description.find(f'"{p}"', start + 1) for p in profiles if p != profile]
        end = min([i for i in following if i > start] or [len(description)])
        clause = description[start:end] if start >= 0 else ""
        rows = [Key("profile", "str", None, "required", f'`"{profile}"`', False)]
        for key in keys:
            # "``key`` [unit] meaning;" in the profile's clause
            item = re.search(r"``" + re.escape(key) + r"``\s*\[(?P<unit>[^\[\]`]+)\]\s*(?P<meaning>[^;]*)", clause)
            meaning = item.group("meaning").strip().rstrip(".") if item else ""
            rows.append(Key(key, "sequence of floats" if key in ("times", "values") else "float",
                            item.group("unit").strip() if item else None, "required",
                            _first_sentence(meaning) or None, True))
        tables.append(Table(f"joints.prescribed.{profile}", f'[joints.prescribed] profile = "{profile}"',
                            "linflex.Joint", f"The keys of the `{profile}` time profile of a joint's `prescribed`.",
                            tuple(rows)))
    return tables


def _filter_table() -> Table:
    """The keys of a controller's ``filters`` tables: ``FILTER_KINDS`` (``linflex.scene._chains``)."""
    kinds = importlib.import_module("linflex.scene._chains").FILTER_KINDS
    units = {"frequency": "rad/s", "depth": "dB", "width": "rad/s", "damping": "-", "zero": "rad/s",
             "pole": "rad/s", "gain": "-"}
    rows = [Key("kind", "str: " + ", ".join(f'"{k}"' for k in kinds), None, "required",
                "The filter: " + ", ".join(f"`{k}`" for k in kinds) + ".", False)]
    for key in dict.fromkeys(k for keys in kinds.values() for k in keys):
        users = [kind for kind, keys in kinds.items() if key in keys]
        meaning = {"domain": '`"s"` (default) or `"z"` (needs the controller\'s `sample_time`)',
                   "num": "numerator coefficients, highest power first", "den": "denominator coefficients",
                   "A": "state matrix", "B": "input matrix", "C": "output matrix", "D": "feedthrough (default 0)"
                   }.get(key, f"see {{func}}`linflex.{users[0]}`")
        kind = "str" if key == "domain" else "float" if key in units else "array_like"
        rows.append(Key(key, kind, units.get(key, "channel units") if key != "domain" else None,
                        "see kind", f"For {', '.join(f'`{u}`' for u in users)}: {meaning}.", key != "domain"))
    return Table("controllers.filters", "[[controllers.filters]]", "linflex.Controller",
                 "The structural filters of a controller, in series with its law on every output channel, in "
                 "order (see `filters` above).", tuple(rows))


def _public_name(obj) -> str:
    """Where the API reference documents ``obj`` (``"linflex.Body"``), or its module path when no
    public package exports it (then the page names it without a link)."""
    for package in ("linflex", "linflex.linearize", "linflex.frequency", "linflex.stability"):
        module = importlib.import_module(package)
        for name in module.__all__:
            if getattr(module, name, None) is obj:
                return f"{package}.{name}"
    return f"{obj.__module__}.{obj.__qualname__}"


def scene_tables() -> list[Table]:
    """Every table a scene file may hold, with its keys, in the order of :class:`linflex.Scene`."""
    import linflex

    scene_doc = _parameters(linflex.Scene.__doc__)
    top_keys = []
    tables = []
    for name, cls, is_array in _scene_fields():
        if cls is None:
            kind, description, _ = scene_doc.get(name, ("", "", ()))
            field = next(f for f in dataclasses.fields(linflex.Scene) if f.name == name)
            default = _default_text(field)
            meaning = _first_sentence(description) if description else None
            if name == "effects":
                meaning = meaning or None
            top_keys.append(Key(name, kind or str(field.type), _unit_of(description), default, meaning, False))
            continue
        intro = _sections(cls.__doc__)[0]
        summary = _first_sentence(intro)
        header = f"[[{name}]]" if is_array else f"[{name}]"
        tables.append(Table(name, header, _public_name(cls), summary, _keys_of(cls)))
        if cls is linflex.Body:
            tables.append(_beam_table(cls))
        if cls is linflex.Joint:
            tables.extend(_profile_tables(cls))
        if cls is linflex.Controller:
            tables.append(_filter_table())
    return [Table("", "(top level)", "linflex.Scene", "The scene's name and the effects it includes.",
                  tuple(top_keys))] + tables


def effect_table() -> list[tuple[str, str, bool, str]]:
    """``(name, meaning, needs_orbit, class)`` of every registered effect, by name."""
    import linflex

    rows = []
    for name, effect in sorted(linflex.registered_effects().items()):
        intro = _sections(type(effect).__doc__)[0]
        paragraph = " ".join(intro.split("\n\n")[0].split())
        paragraph = re.sub(r"^``\w+``:\s*", "", paragraph)
        rows.append((name, paragraph, bool(getattr(effect, "needs_orbit", False)),
                     f"{type(effect).__module__}.{type(effect).__qualname__}"))
    return rows


def code_keys() -> set[str]:
    """Every key path the code accepts, ``"bodies.mass"``, ``"bodies.beam.EI"``, ``"name"``.

    Read independently of :func:`scene_tables` (from the entry classes' fields, ``BEAM_KEYS`` and
    ``PROFILES``), for the test that the reference names exactly these.
    """
    out = set()
    for name, cls, _ in _scene_fields():
        if cls is None:
            out.add(name)
            continue
        out.update(f"{name}.{f.name}" for f in dataclasses.fields(cls))
    entries = _entries_module()
    out.update(f"bodies.beam.{k}" for k in entries.BEAM_KEYS)
    for profile, keys in entries.PROFILES.items():
        out.add(f"joints.prescribed.{profile}.profile")
        out.update(f"joints.prescribed.{profile}.{k}" for k in keys)
    kinds = importlib.import_module("linflex.scene._chains").FILTER_KINDS
    out.add("controllers.filters.kind")
    out.update(f"controllers.filters.{k}" for keys in kinds.values() for k in keys)
    return out


def docstring_gaps(tables: list[Table] | None = None) -> list[str]:
    """Keys whose docstrings give no meaning, or no unit for a number: ``"bodies.beam.EI: meaning"``."""
    gaps = []
    for table in tables if tables is not None else scene_tables():
        for key in table.keys:
            path = f"{table.path}.{key.name}" if table.path else key.name
            missing = [what for what, absent in (("meaning", key.meaning is None),
                                                 ("unit", key.needs_unit and key.unit is None)) if absent]
            if missing:
                gaps.append(f"{path}: {' and '.join(missing)} (documented in {table.source})")
    return gaps


# -- the page --------------------------------------------------------------------------------------

def _myst(text: str) -> str:
    """reST inline markup of a docstring as MyST: roles and double back quotes."""
    text = re.sub(r":(?:py:)?(func|class|meth|mod|data|attr|exc):`~?([^`]+)`", r"{\1}`\2`", text)
    return re.sub(r"``([^`]+)``", r"`\1`", text)


def _cell(text: str | None) -> str:
    if text is None:
        return "*not documented*"
    return _myst(text).replace("|", "\\|").replace("\n", " ")


def _code(text: str) -> str:
    return f"`{text}`" if text else ""


def _source(name: str) -> str:
    if any(part.startswith("_") for part in name.split(".")):
        return f"`{name}` (not exported by a public package)"
    return f"{{class}}`{name}`"


def render_markdown() -> str:
    """The scene vocabulary page (MyST Markdown), every key a row with its path as anchor."""
    tables = scene_tables()
    lines = [
        "# Scene vocabulary",
        "",
        "```{py:currentmodule} linflex",
        "```",
        "",
        "Every table and key a scene file (TOML, read by {func}`linflex.load_scene`) may hold, "
        "generated from the code at each build: the tables are the fields of {class}`linflex.Scene`, "
        "the keys the fields of its entry classes, the beam keys and the time profiles the lists "
        "the scene validation checks, and the effects the registry ({func}`linflex.registered_effects`). "
        "Type, unit and meaning come from each entry class's docstring; a key the code does not know "
        "is refused with its path and a hint. Units are SI with angles in radians.",
        "",
        "A key written with the same name in Python builds the same entry: "
        "`Body(\"hub\", 500.0, inertia=[...])` is `[[bodies]] name = \"hub\" mass = 500.0 inertia = [...]`.",
        "",
    ]
    for table in tables:
        title = table.header if table.path else "Top-level keys"
        anchor = (table.path or "top-level").replace(".", "-")
        lines += [f"({anchor})=", f"## `{title}`" if table.path else f"## {title}", "",
                  f"{_cell(table.summary)} Documented by {_source(table.source)}.", "",
                  "| key | type | unit | default | meaning |", "|---|---|---|---|---|"]
        for key in table.keys:
            unit = key.unit if key.unit is not None else ("*not documented*" if key.needs_unit else "")
            lines.append(f"| `{key.name}` | {_cell(key.type)} | {_cell(unit) if unit else ''} | "
                         f"{_code(key.default)} | {_cell(key.meaning)} |")
        lines.append("")
    lines += ["(effects)=", "## Effects (`effects = [...]`)", "",
              "The names a scene lists in `effects`; a term whose effect is not named is absent from the "
              "compiled model. Register your own with {func}`linflex.register_effect`.", "",
              "| effect | needs `[orbit]` | what it adds |", "|---|---|---|"]
    for name, meaning, needs_orbit, _ in effect_table():
        lines.append(f"| `{name}` | {'yes' if needs_orbit else ''} | {_cell(meaning)} |")
    gaps = docstring_gaps(tables)
    lines += ["", "(docstring-gaps)=", "## Gaps in the docstrings", ""]
    if gaps:
        lines += ["The code accepts these keys but its docstrings do not yet say what follows; "
                  "the reference shows *not documented* there until the docstring says it:", ""]
        lines += [f"- `{gap.split(':')[0]}`: {gap.split(':', 1)[1].strip()}" for gap in gaps]
    else:
        lines.append("None: every key has a meaning, and every number a unit.")
    return "\n".join(lines) + "\n"


def reference_keys(markdown: str) -> set[str]:
    """The key paths a rendered page names (for the test that they are exactly the code's)."""
    out = set()
    path = None
    for line in markdown.splitlines():
        anchor = re.match(r"^\((?P<a>[\w-]+)\)=$", line)
        if anchor:
            path = anchor.group("a")
            continue
        row = re.match(r"^\| `(?P<key>\w+)` \|", line)
        if row and path not in (None, "effects"):
            prefix = "" if path == "top-level" else path.replace("-", ".") + "."
            out.add(prefix + row.group("key"))
    return out


if __name__ == "__main__":
    print("\n".join(docstring_gaps()) if "--gaps" in sys.argv else render_markdown())
