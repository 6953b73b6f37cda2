"""Issue 5: offline devices, device faults, frame loss, bus off, overload."""
from __future__ import annotations

SCENARIOS: tuple = ()
