"""A text progress bar on stderr, shared by long-running work (simulation, sweeps)."""

from __future__ import annotations

import sys


def stderr_is_terminal() -> bool:
    """Whether stderr is an interactive terminal (the default for showing a progress bar)."""
    return sys.stderr is not None and hasattr(sys.stderr, "isatty") and sys.stderr.isatty()


class Progress:
    """``label [#####-----]  40%`` redrawn in place on stderr; silent when not ``enabled``."""

    def __init__(self, enabled: bool, total: int, label: str = "simulate") -> None:
        self.enabled, self.total, self.label, self.last = enabled, max(int(total), 1), label, -1

    def update(self, done: int) -> None:
        """Show that ``done`` of ``total`` units are finished."""
        if not self.enabled:
            return
        pct = int(100 * done / self.total)
        if pct != self.last:
            self.last = pct
            bar = "#" * (pct // 4) + "-" * (25 - pct // 4)
            sys.stderr.write(f"\r{self.label} [{bar}] {pct:3d}%")
            sys.stderr.flush()

    def close(self) -> None:
        """End the bar's line."""
        if self.enabled:
            sys.stderr.write("\n")
            sys.stderr.flush()
