"""Issue 4: jumps, drops, falls, E-stop and pose set points."""
from __future__ import annotations

SCENARIOS: tuple = ()
