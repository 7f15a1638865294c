"""A small TOML writer for scenes (the subset the scene vocabulary needs)."""

from __future__ import annotations

import math
from typing import Any

from ..system._errors import ModelError

__all__ = ["dumps"]


def _key(key: str) -> str:
    if key and all(c.isalnum() or c in "_-" for c in key):
        return key
    return _string(key)


def _string(value: str) -> str:
    escaped = value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\t", "\\t")
    return f'"{escaped}"'


def _value(value: Any, path: str) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(float(value))  # a numpy float64 is a float whose repr is "np.float64(...)"
    if isinstance(value, str):
        return _string(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v, f"{path}[{i}]") for i, v in enumerate(value)) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(v, f'{path}.{k}')}" for k, v in value.items()) + "}"
    if hasattr(value, "item") and callable(value.item):  # numpy scalar
        return _value(value.item(), path)
    raise ModelError(f"{path}: a {type(value).__name__} cannot be written to TOML "
                     "(callables and objects exist only in Python scenes)")


def dumps(data: dict[str, Any]) -> str:
    """TOML text for a mapping of scalars, arrays, tables and arrays of tables."""
    lines: list[str] = []
    tables, arrays = {}, {}
    for key, value in data.items():
        if isinstance(value, dict):
            tables[key] = value
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            arrays[key] = value
        else:
            lines.append(f"{_key(key)} = {_value(value, key)}")
    for key, table in tables.items():
        lines.append("")
        lines.append(f"[{_key(key)}]")
        lines.extend(f"{_key(k)} = {_value(v, f'{key}.{k}')}" for k, v in table.items())
    for key, items in arrays.items():
        for i, item in enumerate(items):
            lines.append("")
            lines.append(f"[[{_key(key)}]]")
            lines.extend(f"{_key(k)} = {_value(v, f'{key}[{i}].{k}')}" for k, v in item.items())
    return "\n".join(lines) + "\n"
