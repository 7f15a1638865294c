"""linflex.stability: modal tables and stability margins (see ARCHITECTURE.md).

- :func:`modes` -- eigenvalues, natural frequencies, damping, time constants and participating
  states, rigid-body modes labelled.
- :func:`stability_margins` -- every gain and phase crossover of a loop, gain margins in both
  directions, delay margin, disk margins (symmetric and skewed), loop-at-a-time and multi-loop for
  MIMO loops; crossings found from the state-space model by bracketing and refinement.

Only what is about margins lives here (``_margins.py``, ``_crossings.py``, ``_disk.py``,
``_modes.py``): the evaluator, the frequency grid, the Nyquist count, the zeros and the spectrum
policy (rigid-body and undamped poles) are those of ``linflex.frequency``.
"""

if __name__ != "linflex.stability":
    raise ImportError(
        "this folder is the linflex.stability package: install linflex (pip install -e .) and "
        "write 'import linflex.stability', not 'import stability'"
    )

from ._margins import DiskMargin, LoopMargins, StabilityMargins, stability_margins
from ._modes import Mode, ModeTable, modes

__all__: list[str] = [
    "DiskMargin",
    "LoopMargins",
    "Mode",
    "ModeTable",
    "StabilityMargins",
    "modes",
    "stability_margins",
]
