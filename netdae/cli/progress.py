"""A one-line progress bar on stderr for long transients (terminal only).

Silent unless stderr is a terminal and the run has lasted
:data:`SHOW_AFTER` seconds (and off with ``-q``); cleared when the run ends.
"""

from __future__ import annotations

import sys
import time

__all__ = ["ProgressBar", "SHOW_AFTER"]

#: Seconds of running before the bar appears.
SHOW_AFTER = 1.5
#: Width of the bar in characters.
WIDTH = 30


class ProgressBar:
    """Callable ``(t, tstop, steps)`` that draws ``[#####.....] 42% t=1.2e-3 s, 3,400 steps/s``."""

    def __init__(self, stream=None, *, enabled: bool = True):
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled and bool(getattr(self.stream, "isatty", lambda: False)())
        self.start = time.perf_counter()
        self.shown = False

    def __call__(self, t: float, tstop: float, steps: int) -> None:
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.start
        if elapsed < SHOW_AFTER:
            return
        frac = min(max(t / tstop, 0.0), 1.0) if tstop > 0 else 1.0
        filled = int(round(frac * WIDTH))
        rate = steps / elapsed if elapsed > 0 else 0.0
        self.stream.write(f"\r[{'#' * filled}{'.' * (WIDTH - filled)}] {100 * frac:3.0f}% "
                          f"t={t:.4g} s, {rate:,.0f} steps/s ")
        self.stream.flush()
        self.shown = True

    def close(self) -> None:
        """Erase the bar."""
        if self.shown:
            self.stream.write("\r" + " " * (WIDTH + 48) + "\r")
            self.stream.flush()
            self.shown = False
