"""Validation of signal names and of array shapes at the API boundary."""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable
from difflib import get_close_matches

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._errors import ModelError, ShapeError


def signal_names(names: Iterable[str] | str | None, n: int, prefix: str, what: str) -> tuple[str, ...]:
    """Return ``n`` validated signal names, or default ones ``prefix0, prefix1, ...``.

    Raises
    ------
    ModelError
        If the count is wrong, a name is empty or not a string, or names repeat.
    """
    if names is None:
        return tuple(f"{prefix}{i}" for i in range(n))
    if isinstance(names, str):
        names = [names]
    names = tuple(names)
    if len(names) != n:
        raise ModelError(f"{what}: {len(names)} names given for {n} signals")
    for i, name in enumerate(names):
        if not isinstance(name, str) or not name.strip():
            raise ModelError(f"{what}[{i}]: signal names must be non-empty strings, got {name!r}")
    seen: dict[str, int] = {}
    for i, name in enumerate(names):
        if name in seen:
            raise ModelError(f"{what}: duplicate name {name!r} at positions {seen[name]} and {i}")
        seen[name] = i
    return names


def signal_index(names: tuple[str, ...], key: str | int, what: str) -> int:
    """Position of a signal given by name or index, with a did-you-mean hint on a miss."""
    if isinstance(key, (int, np.integer)):
        if not -len(names) <= key < len(names):
            raise ModelError(f"{what}: index {key} out of range for {len(names)} signals")
        return int(key) % len(names)
    try:
        return names.index(key)
    except ValueError:
        hint = get_close_matches(str(key), names, n=1)
        suffix = f" (did you mean {hint[0]!r}?)" if hint else f"; known: {', '.join(names[:12])}"
        raise ModelError(f"{what}: unknown signal {key!r}{suffix}") from None


def real_array(value: ArrayLike, name: str, what: str) -> NDArray[np.float64]:
    """``value`` as float64, refusing complex values (numpy would drop their imaginary parts)."""
    try:
        raw = np.asarray(value)
        if np.iscomplexobj(raw):
            if np.any(np.imag(raw) != 0):
                raise ShapeError(f"{name} must be a real {what}, got complex values (for example "
                                 f"{complex(raw.flat[int(np.flatnonzero(np.imag(raw) != 0)[0])])}); linflex's systems are real")
            raw = np.real(raw)
        return np.array(raw, dtype=np.float64)
    except (TypeError, ValueError) as err:
        if isinstance(err, ShapeError):
            raise
        raise ShapeError(f"{name} must be a real {what}: {err}") from err


def real_matrix(value: ArrayLike, name: str, shape: tuple[int | None, int | None]) -> NDArray[np.float64]:
    """A read-only float64 copy of ``value`` checked against ``shape`` (None = any)."""
    arr = real_array(value, name, "matrix")
    if arr.ndim == 0:
        arr = arr.reshape(1, 1)
    if arr.ndim != 2:
        raise ShapeError(f"{name} must be 2-D, got an array of shape {arr.shape}")
    for axis, expected in enumerate(shape):
        if expected is not None and arr.shape[axis] != expected:
            raise ShapeError(f"{name} has shape {arr.shape} but {expected} {'rows' if axis == 0 else 'columns'} were expected")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ShapeError(f"{name}[{bad[0]}, {bad[1]}] is not finite ({arr[tuple(bad)]})")
    arr.setflags(write=False)
    return arr


def real_vector(value: ArrayLike, name: str, n: int) -> NDArray[np.float64]:
    """A read-only float64 vector of length ``n``; a scalar is accepted when ``n == 1``."""
    arr = real_array(value, name, "vector")
    if arr.ndim == 0 and n == 1:
        arr = arr.reshape(1)
    if arr.ndim == 2 and 1 in arr.shape:
        arr = arr.reshape(-1)
    if arr.shape != (n,):
        raise ShapeError(f"{name} has shape {arr.shape} but shape ({n},) was expected")
    if not np.all(np.isfinite(arr)):
        i = int(np.argwhere(~np.isfinite(arr))[0][0])
        raise ShapeError(f"{name}[{i}] is not finite ({arr[i]})")
    arr.setflags(write=False)
    return arr


def frozen_array(values: ArrayLike, dtype=np.float64) -> NDArray:
    """A read-only copy of ``values`` (``dtype=None`` keeps the values' type)."""
    arr = np.array(values, dtype=dtype)
    arr.setflags(write=False)
    return arr


def check_positive(value, name: str, *, allow_zero: bool = False) -> float:
    """``value`` as a float, checked: a finite positive real number (non-negative with
    ``allow_zero``), else a :class:`ModelError` naming ``name``. A bool, text, a complex number or
    an array of more than one entry is refused, not read (``True`` is not 1, ``"1e-6"`` not a
    tolerance)."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        value = value.item()
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ModelError(f"{name} must be a real number, got {value!r}")
    v = float(value)
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        expected = "non-negative" if allow_zero else "positive"
        raise ModelError(f"{name} must be a finite {expected} number, got {value!r}")
    return v
