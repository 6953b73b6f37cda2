"""Every scenario the rig knows, by robot and name (``wheelleg list``).

Each registered robot (``wheelleg.hil.robots``) names the modules that hold
its scenarios (a ``SCENARIOS`` tuple each). A name is unique within a robot;
``ROBOT/NAME`` names a scenario of one robot, a bare name one of the
default robot's, else the one robot that has it.
"""
from __future__ import annotations

import importlib

from wheelleg.hil import robots
from wheelleg.hil.run.scenario import Scenario


def all_scenarios(robot: str | None = None) -> dict[str, Scenario]:
    """Name -> scenario of one robot (None: the default robot), in its modules' order."""
    spec = robots.get(robot)
    table: dict[str, Scenario] = {}
    for name in spec.scenario_modules:
        for scenario in importlib.import_module(name).SCENARIOS:
            if scenario.name in table:
                raise ValueError(f"scenario {scenario.name!r} defined twice")
            if scenario.robot != spec.name:
                raise ValueError(f"scenario {scenario.name!r} of {name} runs on {scenario.robot!r}, "
                                 f"not on {spec.name!r}")
            table[scenario.name] = scenario
    return table


def by_robot() -> dict[str, dict[str, Scenario]]:
    """Robot -> its scenarios (``all_scenarios``), the default robot first; a robot that does not load, or
    whose scenarios do not, is left out with one ``RobotPluginWarning`` (``robots.usable``)."""
    tables = {}
    for name in robots.usable():
        try:
            tables[name] = all_scenarios(name)
        except Exception as exc:  # noqa: BLE001 - a third party's module: its package is named, the rest goes on
            if name in robots.BUILTIN:
                raise
            robots.warn_broken(name, f"its scenarios: {type(exc).__name__}: {exc}")
    return tables


def get(name: str, robot: str | None = None) -> Scenario:
    """The scenario ``name`` ('NAME' or 'ROBOT/NAME'), of ``robot`` when given; KeyError (one line) if none."""
    qualified, bare = robots.split_name(name)
    if qualified is not None and robot is not None and qualified != robot:
        raise KeyError(f"scenario {name!r} names robot {qualified!r}, but --robot is {robot!r}")
    robot = qualified or robot
    if robot is not None:
        table = all_scenarios(robot)
        if bare not in table:
            raise KeyError(f"no scenario {bare!r} for the {robot} robot; known: {', '.join(sorted(table))}")
        return table[bare]
    tables = by_robot()
    found = [table[bare] for table in tables.values() if bare in table]
    if not found:
        known = ", ".join(sorted(tables[robots.DEFAULT]))
        others = ", ".join(f"{r}/..." for r in tables if r != robots.DEFAULT)
        raise KeyError(f"no scenario {bare!r}; known: {known}" + (f" (and {others}: `wheelleg list`)" if others else ""))
    return found[0]  # the default robot's first (by_robot puts it first)


def qualified_name(scenario: Scenario) -> str:
    """'NAME' for the default robot's scenario, 'ROBOT/NAME' for another robot's."""
    return scenario.name if scenario.robot == robots.DEFAULT else f"{scenario.robot}/{scenario.name}"
