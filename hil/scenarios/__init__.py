"""Every scenario the rig knows, by name (``wheelleg list``)."""
from __future__ import annotations

from wheelleg.hil.run.scenario import Scenario
from wheelleg.hil.scenarios import airborne
from wheelleg.hil.scenarios import basic
from wheelleg.hil.scenarios import collisions
from wheelleg.hil.scenarios import faults
from wheelleg.hil.scenarios import ground

_MODULES = (basic, airborne, collisions, ground, faults)


def all_scenarios() -> dict[str, Scenario]:
    table: dict[str, Scenario] = {}
    for module in _MODULES:
        for scenario in module.SCENARIOS:
            if scenario.name in table:
                raise ValueError(f"scenario {scenario.name!r} defined twice")
            table[scenario.name] = scenario
    return table


def get(name: str) -> Scenario:
    table = all_scenarios()
    if name not in table:
        raise KeyError(f"no scenario {name!r}; known: {', '.join(sorted(table))}")
    return table[name]
