"""Structural filters placed from the plant: a notch on a chosen mode, a roll-off for an attenuation.

The filters themselves are defined once in :mod:`linflex.system` (``notch``, ``low_pass``);
this module chooses their parameters from what the user asks (a mode of :func:`modes` by state
name or frequency; an attenuation above a frequency); :func:`linflex.series` chains them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linflex.stability import Mode, ModeTable, modes
from linflex.system import LinearSystem, ModelError, as_linear_system, check_positive, low_pass, notch, series

__all__ = ["NotchDesign", "notch_at", "roll_off"]


@dataclass(frozen=True)
class NotchDesign:
    """A notch placed on a plant mode (result of :func:`notch_at`).

    Attributes
    ----------
    filter : LinearSystem
        The notch (input ``"in"``, output ``"out"``).
    mode : Mode
        The plant mode it sits on.
    frequency : float
        Centre frequency [rad/s]: the mode's natural frequency.
    depth : float
        Attenuation at the centre [dB].
    width : float
        Width [rad/s] (see :func:`linflex.notch`).
    """

    filter: LinearSystem
    mode: Mode
    frequency: float
    depth: float
    width: float


def _pick_mode(table: ModeTable, mode) -> Mode:
    oscillatory = [m for m in table if m.kind == "oscillatory"]
    if not oscillatory:
        raise ModelError("notch_at: the plant has no oscillatory (flexible) mode to notch")
    if isinstance(mode, (bool, np.bool_)):
        raise ModelError(f"notch_at: mode must be an index, a state name or a frequency [rad/s], got {mode!r}")
    if isinstance(mode, (int, np.integer)):
        if not 0 <= mode < len(oscillatory):
            raise ModelError(f"notch_at: mode index {mode} out of range for {len(oscillatory)} oscillatory modes")
        return oscillatory[int(mode)]
    if isinstance(mode, str):
        involved = [(dict(m.participation).get(mode, 0.0), m) for m in oscillatory]
        best = max(involved, key=lambda pair: pair[0])
        if best[0] == 0.0:
            raise ModelError(f"notch_at: no oscillatory mode has state {mode!r} among its participating states; "
                             f"states of the plant: {', '.join(table.states[:12])}")
        return best[1]
    try:
        w = float(mode)
    except (TypeError, ValueError):
        raise ModelError(f"notch_at: mode must be an index, a state name or a frequency [rad/s], got {mode!r}") from None
    if not np.isfinite(w) or w <= 0:
        raise ModelError(f"notch_at: a mode frequency must be positive [rad/s], got {mode!r}")
    return min(oscillatory, key=lambda m: abs(np.log(m.natural_frequency / w)))


def notch_at(plant, mode, depth: float = 20.0, width: float | None = None) -> NotchDesign:
    """A notch on one flexible mode of ``plant``.

    Parameters
    ----------
    plant : LinearSystem or ModeTable
        The plant (its :func:`~linflex.stability.modes` are computed) or its mode table.
    mode : int, str or float
        Which oscillatory mode: an index among the oscillatory rows (lowest frequency first), a
        state name (the mode in which that state participates most), or a frequency [rad/s]
        (the mode nearest to it on a log scale).
    depth : float, optional
        Attenuation at the mode [dB], 20 by default.
    width : float, optional
        Width [rad/s]; default 40 % of the mode's frequency (a pole damping of 0.2), wide enough
        to hold the attenuation when the mode moves by a few percent.

    Returns
    -------
    NotchDesign
        The filter and the mode it sits on.

    Raises
    ------
    ModelError
        If the plant has no oscillatory mode, or ``mode`` names none.

    Examples
    --------
    >>> from linflex import LinearSystem
    >>> plant = LinearSystem([[0, 1], [-25.0, -0.05]], [[0], [1]], [[1, 0]])
    >>> round(notch_at(plant, 5.0).frequency, 6)
    5.0
    """
    table = plant if isinstance(plant, ModeTable) else modes(as_linear_system(plant, "plant"))
    chosen = _pick_mode(table, mode)
    w = float(chosen.natural_frequency)
    width = 0.4 * w if width is None else width
    design = notch(w, depth, width)   # validates depth and width, naming them
    return NotchDesign(design, chosen, w, float(depth), float(width))


def roll_off(frequency: float, attenuation: float, *, damping: float | None = None, sections: int = 1) -> LinearSystem:
    """A low-pass roll-off that attenuates by at least ``attenuation`` dB at and above ``frequency``.

    ``sections`` identical second-order low-pass filters (:func:`linflex.low_pass`, damping
    ``damping``) in series, their corner placed so that the gain at ``frequency`` is exactly
    ``-attenuation`` dB. With ``damping >= 1/sqrt(2)`` the gain of a section falls monotonically,
    so the attenuation holds at every higher frequency.

    Parameters
    ----------
    frequency : float
        Lowest frequency to attenuate [rad/s] (for example the first flexible mode).
    attenuation : float
        Attenuation required there [dB], positive.
    damping : float, optional
        Damping ratio of each section [-]; default ``1/sqrt(2)`` (Butterworth: the flattest
        pass band whose gain still falls monotonically).
    sections : int, optional
        Number of second-order sections (each -40 dB per decade), 1 by default.

    Returns
    -------
    LinearSystem
        Unit DC gain, ``-attenuation`` dB at ``frequency``.

    Raises
    ------
    ModelError
        For a non-positive frequency or attenuation, a damping below 1/sqrt(2) (the gain would
        rise above the corner), or fewer than one section.

    Examples
    --------
    >>> f = roll_off(10.0, 20.0)
    >>> s = 10j
    >>> import numpy as np
    >>> g = (f.C @ np.linalg.solve(s * np.eye(f.n_states) - f.A, f.B) + f.D)[0, 0]
    >>> round(float(20 * np.log10(abs(g))), 9)
    -20.0
    """
    if not (isinstance(sections, (int, np.integer)) and not isinstance(sections, bool) and sections >= 1):
        raise ModelError(f"sections must be a positive integer, got {sections!r}")
    for label, value in (("frequency", frequency), ("attenuation", attenuation)):
        check_positive(value, label)
    damping = 1 / np.sqrt(2) if damping is None else damping
    if not (isinstance(damping, (int, float, np.number)) and not isinstance(damping, bool) and np.isfinite(damping)
            and damping >= 1 / np.sqrt(2) - 1e-12):
        raise ModelError(f"damping must be a finite number of at least 1/sqrt(2) = 0.7071 so the attenuation holds "
                         f"above the frequency, got {damping!r}")
    damping = float(damping)
    f = float(frequency)
    # The corner wc of one section: with u = (f / wc)^2, |LP(j f)|^-2 = (1 - u)^2 + 4 z^2 u = 10^(att / (10 sections)),
    # so u^2 + b u + c = 0 with b = 4 z^2 - 2 >= 0 and c = 1 - 10^(...) < 0: one positive root, written
    # without cancellation as u = -2 c / (b + sqrt(b^2 - 4 c)).
    b = 4.0 * damping * damping - 2.0
    c = -np.expm1(np.log(10.0) * float(attenuation) / (10.0 * sections))
    if not np.isfinite(c):
        raise ModelError(f"attenuation = {attenuation!r} dB over {sections} section(s) is beyond floating point "
                         "(1e308 per section); ask for less, or for more sections")
    u = -2.0 * c / (b + np.sqrt(b * b - 4.0 * c))
    section = low_pass(f / np.sqrt(u), damping)
    out = section
    for _ in range(sections - 1):
        out = series(out, section)
    return out

