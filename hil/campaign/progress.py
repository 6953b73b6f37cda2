"""A one-line progress bar on stderr, drawn only on a terminal."""
from __future__ import annotations

import sys
import time

WIDTH = 30  # characters of bar


class Progress:
    """``update(passed)`` after each run; silent when ``enabled`` is False or stderr is not a terminal."""

    def __init__(self, total: int, done: int = 0, enabled: bool = True, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = enabled and self.stream.isatty()
        self.total, self.done, self.failed, self.new = total, done, 0, 0
        self.start = time.monotonic()
        self.draw()

    def update(self, passed: bool) -> None:
        self.done += 1
        self.new += 1
        self.failed += not passed
        self.draw()

    def eta_s(self) -> float | None:
        """Seconds left at this campaign's pace so far (None before the first run ends)."""
        if not self.new:
            return None
        return (time.monotonic() - self.start) / self.new * (self.total - self.done)

    def draw(self) -> None:
        if not self.enabled:
            return
        filled = WIDTH * self.done // max(self.total, 1)
        eta = self.eta_s()
        left = f", {eta:.0f} s left" if eta is not None else ""
        self.stream.write(f"\r[{'#' * filled}{'.' * (WIDTH - filled)}] {self.done}/{self.total} runs, "
                          f"{self.failed} failed{left}   ")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()
