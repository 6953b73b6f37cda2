"""``wheelleg list``: the scenarios and what each checks."""
from __future__ import annotations

import argparse

from wheelleg.hil import scenarios

NAME = "list"
HELP = "list the scenarios"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-v", "--verbose", action="store_true", help="also print each scenario's checks")


def run(args: argparse.Namespace) -> int:
    table = scenarios.all_scenarios()
    width = max(len(n) for n in table)
    for name, scenario in table.items():
        print(f"{name:<{width}}  {scenario.duration_s:5.1f} s  {scenario.summary}")
        if args.verbose:
            for check in scenario.checks:
                print(f"{'':<{width}}    - {check.name}")
    return 0
