"""A small progress bar on stderr for runs of more than a few seconds.

Drawn only on a terminal (a log file or a pipe gets nothing), redrawn at most
ten times a second, so it costs nothing measurable in a loop.
"""
from __future__ import annotations

import sys
import time


class Progress:
    """Progress of a job of ``total`` units.

    Parameters
    ----------
    total : int
        Number of units of work.
    label : str
        Text in front of the bar.
    stream : file, optional
        Where to draw (default: stderr).
    enabled : bool, optional
        Force drawing on or off (default: only if ``stream`` is a terminal).
    """

    WIDTH = 30

    def __init__(self, total: int, label: str = "", stream=None, enabled: bool | None = None):
        self.total = max(int(total), 1)
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.done = 0
        self._start = time.monotonic()
        self._last_draw = 0.0

    def update(self, units: int = 1, label: str | None = None):
        """Count ``units`` more as done (and change the label if given)."""
        self.done = min(self.done + units, self.total)
        if label is not None:
            self.label = label
        now = time.monotonic()
        if self.enabled and (now - self._last_draw >= 0.1 or self.done == self.total):
            self._last_draw = now
            self._draw(now)

    def _draw(self, now):
        filled = int(self.WIDTH * self.done / self.total)
        bar = "#" * filled + "." * (self.WIDTH - filled)
        self.stream.write(f"\r{self.label:<28.28} [{bar}] {100 * self.done / self.total:3.0f}% "
                          f"{now - self._start:5.1f} s")
        self.stream.flush()

    def close(self):
        """Finish the line."""
        if self.enabled:
            self._draw(time.monotonic())
            self.stream.write("\n")
            self.stream.flush()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
