"""Issue 4: pushes, impacts and walls."""
from __future__ import annotations

SCENARIOS: tuple = ()
