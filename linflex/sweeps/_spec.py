"""Sweep spec files: which analysis, over a grid or a Monte Carlo sample of scene paths.

The spec file names the analysis and either a grid or a Monte Carlo sample of scene paths::

    analysis = "margins"
    [sample]                       # Monte Carlo: n cases drawn with seed
    n = 200
    seed = 1
    [sample.parameters]
    "bodies.hub.inertia[0]" = {distribution = "normal", mean = 800.0, std = 80.0}

    [grid]                         # or: every combination
    "controllers.attitude_pd.kp[0]" = [20.0, 25.0, 30.0]
"""

from __future__ import annotations

import sys
from pathlib import Path

from ..system._errors import ModelError
from ._cases import parameter_grid, parameter_sample

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["load_sweep_spec"]


def load_sweep_spec(path: str | Path):
    """``(cases, analysis_name, seed)`` from a sweep spec file (see the module docstring).

    Parameters
    ----------
    path : str or Path
        The spec file (TOML).

    Returns
    -------
    tuple
        ``(cases, analysis, seed)``: the cases as mappings of scene path to value (SI units of
        each path), the analysis name, the sample's seed (None for a grid).

    Raises
    ------
    ModelError
        For a file that is not TOML (or not UTF-8), unknown keys, both or neither of ``[grid]``
        and ``[sample]``, a scene path written without quotes (TOML reads it as nested tables),
        a seed that is not a non-negative integer, or cases that :func:`parameter_grid` /
        :func:`parameter_sample` refuse (the message names the file and the section).
    OSError
        If the file cannot be read.
    """
    try:
        spec = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ModelError(f"{path}: not a valid TOML file: {err}") from err
    unknown = sorted(set(spec) - {"analysis", "grid", "sample"})
    if unknown:
        raise ModelError(f"{path}: unknown keys {unknown} (expected analysis and one of [grid], [sample])")
    analysis = spec.get("analysis", "margins")
    if not isinstance(analysis, str):
        raise ModelError(f"{path}: analysis must be a name (a string), got {analysis!r}")
    if ("grid" in spec) == ("sample" in spec):
        raise ModelError(f"{path}: give exactly one of [grid] (every combination) and [sample] (Monte Carlo)")
    if "grid" in spec:
        _check_quoted(path, "grid", spec["grid"])
        try:
            return parameter_grid(spec["grid"]), analysis, None
        except ModelError as err:
            raise ModelError(f"{path}: [grid]: {err}") from err
    sample = spec["sample"]
    if not isinstance(sample, dict):
        raise ModelError(f"{path}: [sample] must be a table (n, seed, [sample.parameters]), got {sample!r}")
    extra = sorted(set(sample) - {"n", "seed", "parameters"})
    if extra or "n" not in sample or "parameters" not in sample:
        raise ModelError(f"{path}: [sample] needs n and [sample.parameters] (and optionally seed); got {sorted(sample)}")
    seed = sample.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ModelError(f"{path}: [sample] seed must be a non-negative integer, got {seed!r}")
    _check_quoted(path, "sample.parameters", sample["parameters"])
    try:
        return parameter_sample(sample["parameters"], sample["n"], seed=seed), analysis, seed
    except ModelError as err:
        raise ModelError(f"{path}: [sample]: {err}") from err


def _check_quoted(path, section: str, table) -> None:
    """Refuse a scene path written without quotes: TOML reads ``bodies.hub.mass = [...]`` as
    nested tables, which would otherwise be reported as a parameter ``bodies`` with odd values."""
    if not isinstance(table, dict):
        return
    for key, value in table.items():
        dotted = [key]
        # descend through tables of tables (not a distribution, not {low = 1, high = 2})
        while isinstance(value, dict) and value and "distribution" not in value \
                and all(isinstance(v, (dict, list)) for v in value.values()):
            child, value = next(iter(value.items()))
            dotted.append(child)
        if len(dotted) > 1 and "." not in key:  # a quoted path has its dots in the key
            name = ".".join(dotted)
            raise ModelError(f'{path}: [{section}] {key}: a table, not a parameter; write the scene path in quotes: '
                             f'"{name}" = ...')
