"""Validation of a controller's chain: sampling, delay, hold, structural filters and output stages.

A :class:`~linflex.Controller` may carry ``sample_time``, ``delay``, ``hold``, ``filters``,
``saturation``, ``rate_limit``, ``quantization``, ``noise`` and ``seed``; this module checks them
(every problem with its entry path) and defines the filter vocabulary. The filters themselves
are built in one place, :mod:`linflex.system._filters` (``notch``, ``low_pass``, ``lead_lag``),
which validation calls so that a filter it accepts is one that can be built.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..system._errors import ModelError
from ..system._filters import lead_lag, low_pass, notch
from ._problems import Problems, hint, is_numeric

__all__ = ["FILTER_KINDS", "HOLDS", "check_chain", "filter_matrices", "is_sampled"]

#: Filter kinds and the keys each takes (``kind`` aside); the first ones listed are required.
FILTER_KINDS = {
    "notch": ("frequency", "depth", "width"),
    "low_pass": ("frequency", "damping"),
    "lead_lag": ("zero", "pole", "gain"),
    "transfer_function": ("num", "den", "domain"),
    "state_space": ("A", "B", "C", "D", "domain"),
}
_REQUIRED = {"notch": 3, "low_pass": 1, "lead_lag": 2, "transfer_function": 2, "state_space": 3}
_BUILDERS = {"notch": notch, "low_pass": low_pass, "lead_lag": lead_lag}
#: The holds a sampled controller's command can have between samples.
HOLDS = ("zoh",)
#: The keys that need ``sample_time`` (they act at the sample instants or on the held command).
_SAMPLED_KEYS = ("delay", "saturation", "rate_limit", "quantization", "noise")


def is_sampled(controller: Any) -> bool:
    """Whether a (validated) controller runs at sample instants (it has a ``sample_time``)."""
    return getattr(controller, "sample_time", None) is not None


def _per_channel(out: Problems, value: Any, path: str, n: int, unit: str, *, positive: bool,
                 each: str = "output channel") -> None:
    """A scalar or one value per channel, finite and positive (or non-negative)."""
    vals = [value] if not isinstance(value, (list, tuple)) else list(value)
    if not is_numeric(vals) or any(isinstance(v, bool) for v in vals) or len(vals) not in (1, n):
        count = "" if n == 1 else f" or {n} numbers (one per {each})"
        out.add(path, f"expected a number{count} [{unit}], got {value!r}")
        return
    arr = np.asarray(vals, dtype=float)
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0 if positive else arr < 0):
        out.add(path, f"must be {'positive' if positive else 'non-negative'} and finite [{unit}], got {value!r}")


def check_chain(controller: Any, out: Problems, path: str, n_in: int, n_out: int) -> None:
    """Add the problems of ``controller``'s chain keys (at ``path``) to ``out``.

    Parameters
    ----------
    controller : Controller
        The entry.
    out : Problems
        Where the problems go.
    path : str
        The entry's path (``controllers[0]``).
    n_in, n_out : int
        Number of measured signals (``inputs`` then ``rate_inputs``) and of output channels.
    """
    c = controller
    sample_time = None
    if c.sample_time is not None and out.number(c.sample_time, f"{path}.sample_time", "s", positive=True):
        sample_time = float(c.sample_time)
    if c.sample_time is None:
        for key in _SAMPLED_KEYS:
            value = getattr(c, key)
            if value is not None and not (key == "delay" and isinstance(value, (int, float)) and value == 0):
                out.add(f"{path}.{key}", "needs sample_time: the delay, the output stages and the noise act at "
                                         "the sample instants of a sampled controller (give sample_time [s])")
    out.number(c.delay, f"{path}.delay", "s", nonnegative=True)
    if not isinstance(c.hold, str) or c.hold not in HOLDS:
        out.add(f"{path}.hold", f"unknown hold {c.hold!r}{hint(c.hold, HOLDS)} (one of {', '.join(HOLDS)})")
    for key, unit in (("saturation", "actuator units"), ("rate_limit", "actuator units/s"),
                      ("quantization", "actuator units")):
        if getattr(c, key) is not None:
            _per_channel(out, getattr(c, key), f"{path}.{key}", n_out, unit, positive=True)
    if c.noise is not None:
        _per_channel(out, c.noise, f"{path}.noise", n_in, "sensor units", positive=False,
                     each="signal read: the inputs, then the rate_inputs of a derivative gain")
    if isinstance(c.seed, bool) or not isinstance(c.seed, (int, np.integer)) or c.seed < 0:
        out.add(f"{path}.seed", f"expected a non-negative integer, got {c.seed!r}")
    filters = c.filters
    if not isinstance(filters, (list, tuple)):
        out.add(f"{path}.filters", f"expected a list of filter tables, got {filters!r}")
        return
    for k, spec in enumerate(filters):
        _check_filter(out, spec, f"{path}.filters[{k}]", sample_time, c.sample_time is not None, n_out)


def _check_filter(out: Problems, spec: Any, path: str, sample_time: float | None, sampled: bool, n_out: int) -> None:
    if not isinstance(spec, dict):
        out.add(path, f"expected a table with a kind ({', '.join(FILTER_KINDS)}), got {spec!r}")
        return
    kind = spec.get("kind")
    if kind not in FILTER_KINDS:
        out.add(f"{path}.kind", f"unknown filter kind {kind!r}{hint(kind, FILTER_KINDS)} "
                                f"(one of {', '.join(FILTER_KINDS)})")
        return
    keys = FILTER_KINDS[kind]
    for key in spec:
        if key != "kind" and key not in keys:
            out.add(f"{path}.{key}", f"unknown key for a {kind} filter{hint(key, keys)} (keys: {', '.join(keys)})")
    missing = [key for key in keys[:_REQUIRED[kind]] if key not in spec]
    if missing:
        out.add(path, f"a {kind} filter needs {', '.join(missing)}")
        return
    if kind in _BUILDERS:
        try:
            _BUILDERS[kind](**{key: spec[key] for key in keys if key in spec})
        except ModelError as err:
            out.add(path, str(err))
            return
        if sample_time is not None and "frequency" in spec and float(spec["frequency"]) >= np.pi / sample_time:
            out.add(f"{path}.frequency", f"{spec['frequency']} rad/s is not below the Nyquist frequency "
                                         f"pi/sample_time = {np.pi / sample_time:.6g} rad/s")
        return
    domain = spec.get("domain", "s")
    if domain not in ("s", "z"):
        out.add(f"{path}.domain", f"expected 's' or 'z', got {domain!r}")
    elif domain == "z" and not sampled:
        out.add(f"{path}.domain", "a filter in z needs the controller's sample_time (its sampling period [s])")
    try:
        system = filter_matrices(spec)
    except ModelError as err:
        out.add(path, str(err))
        return
    shapes = {system[1].shape[1], system[2].shape[0]}
    if shapes not in ({1}, {n_out}):
        out.add(path, f"has {system[1].shape[1]} inputs and {system[2].shape[0]} outputs; a filter takes one "
                      f"(the same on every channel) or {n_out} (one per channel) of each")


def filter_matrices(spec: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C, D)`` of a ``transfer_function`` or ``state_space`` filter table (in its domain).

    Parameters
    ----------
    spec : dict
        The filter's table (``num``, ``den`` or ``A``, ``B``, ``C``, ``D``).

    Returns
    -------
    tuple of ndarray
        The state-space matrices.

    Raises
    ------
    ModelError
        For non-numeric, non-finite, mis-shaped or improper coefficients.
    """
    if spec["kind"] == "transfer_function":
        from scipy import signal

        num, den = spec["num"], spec["den"]
        if not (is_numeric(num) and is_numeric(den)):
            raise ModelError(f"num and den must be lists of coefficients, got {num!r} and {den!r}")
        num_, den_ = np.atleast_1d(np.asarray(num, float)), np.atleast_1d(np.asarray(den, float))
        if num_.ndim != 1 or den_.ndim != 1 or not (np.all(np.isfinite(num_)) and np.all(np.isfinite(den_))):
            raise ModelError(f"num and den must be finite lists of coefficients, got {num!r} and {den!r}")
        if den_[0] == 0 or np.trim_zeros(num_, "f").size > den_.size:
            raise ModelError("den's leading coefficient must not be zero and num's degree not above den's")
        return tuple(np.atleast_2d(m) for m in signal.tf2ss(num_, den_))  # type: ignore[return-value]
    mats = []
    for key in ("A", "B", "C", "D"):
        value = spec.get(key)
        if value is None and key == "D":
            mats.append(None)
            continue
        arr = np.asarray(value, dtype=float) if is_numeric(value) else None
        if arr is None or arr.ndim != 2 or not np.all(np.isfinite(arr)):
            raise ModelError(f"{key} must be a finite matrix (a list of rows), got {value!r}")
        mats.append(arr)
    A, B, C, D = mats
    D = np.zeros((C.shape[0], B.shape[1])) if D is None else D
    n = A.shape[0]
    if A.shape != (n, n) or B.shape[0] != n or C.shape[1] != n or D.shape != (C.shape[0], B.shape[1]):
        raise ModelError(f"inconsistent shapes A {A.shape}, B {B.shape}, C {C.shape}, D {D.shape}")
    return A, B, C, D
