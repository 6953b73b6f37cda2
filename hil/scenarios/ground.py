"""Issue 4: slopes, bumps, steps and fast turns."""
from __future__ import annotations

SCENARIOS: tuple = ()
