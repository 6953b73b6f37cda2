"""A one-line progress line for a run on stderr: simulated time done, wall time, left.

Drawn only on a terminal and at most every ``REDRAW_S`` of wall time (a run
is ~10,000 ticks); ``-q`` turns it off. The rig calls it once per tick.
"""
from __future__ import annotations

import sys
import time

REDRAW_S = 0.2  # s of wall time between redraws


class RunProgress:
    """``progress(t_s)`` each tick of a run of ``duration_s``; silent off a terminal or when disabled."""

    def __init__(self, label: str, duration_s: float, enabled: bool = True, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = enabled and self.stream.isatty()
        self.label, self.duration_s = label, duration_s
        self.start = time.monotonic()
        self.next_draw = self.start

    def __call__(self, t_s: float) -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        if now < self.next_draw:
            return
        self.next_draw = now + REDRAW_S
        wall = now - self.start
        left = f", ~{wall / t_s * (self.duration_s - t_s):.0f} s left" if t_s > 0 else ""
        self.stream.write(f"\r{self.label}: {t_s:.2f}/{self.duration_s:g} s simulated, {wall:.0f} s{left}   ")
        self.stream.flush()

    def close(self) -> None:
        """End the line (a terminal's next output starts on a fresh one)."""
        if self.enabled:
            self.stream.write("\r" + " " * 72 + "\r")
            self.stream.flush()
