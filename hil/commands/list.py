"""``wheelleg list``: the scenarios of every robot, grouped by robot, and what each checks."""
from __future__ import annotations

import argparse

from wheelleg.hil import robots, scenarios

NAME = "list"
HELP = "list the scenarios, grouped by robot"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-v", "--verbose", action="store_true", help="also print each scenario's checks")
    robots.add_argument(parser, "only this robot's scenarios (default: every robot's)")


def run(args: argparse.Namespace) -> int:
    names = (args.robot,) if getattr(args, "robot", None) else robots.names()
    tables = {name: scenarios.all_scenarios(name) for name in names}
    width = max(len(n) for table in tables.values() for n in table)
    for robot_name, table in tables.items():
        robot = robots.get(robot_name)
        default = " (the default)" if robot_name == robots.DEFAULT else f" (run as {robot_name}/NAME or --robot {robot_name})"
        print(f"{robot_name}{default}: {robot.summary}; {len(table)} scenarios")
        for name, scenario in table.items():
            print(f"  {name:<{width}}  {scenario.duration_s:5.1f} s  {scenario.summary}")
            if args.verbose:
                for check in scenario.checks:
                    print(f"  {'':<{width}}    - {check.name}")
    return 0
