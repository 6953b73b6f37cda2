"""``wheelleg list``: every installed robot with the package it came from, its scenarios and what each checks."""
from __future__ import annotations

import argparse
import sys

from wheelleg.hil import robots, scenarios

NAME = "list"
HELP = "list the installed robots (with their packages) and their scenarios"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-v", "--verbose", action="store_true", help="also print each scenario's checks")
    robots.add_argument(parser, "only this robot's scenarios (default: every robot's)")


def run(args: argparse.Namespace) -> int:
    if getattr(args, "robot", None):
        try:
            tables = {args.robot: scenarios.all_scenarios(args.robot)}
        except KeyError as exc:  # a broken plug-in: its one line
            print(f"wheelleg list: {str(exc).strip(chr(39))}", file=sys.stderr)
            return 2
    else:
        tables = scenarios.by_robot()  # a broken plug-in is a warning and left out
    width = max((len(n) for table in tables.values() for n in table), default=0)
    for robot_name, table in tables.items():
        robot = robots.get(robot_name)
        default = " (the default)" if robot_name == robots.DEFAULT else f" (run as {robot_name}/NAME or --robot {robot_name})"
        print(f"{robot_name}{default} from {robots.origin(robot_name)}: {robot.summary}; {len(table)} scenarios")
        for name, scenario in table.items():
            print(f"  {name:<{width}}  {scenario.duration_s:5.1f} s  {scenario.summary}")
            if args.verbose:
                for check in scenario.checks:
                    print(f"  {'':<{width}}    - {check.name}")
    return 0
