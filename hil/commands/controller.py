"""``wheelleg controller``: a robot's controller alone on its buses (= ``python -m`` its program).

The wheel-legged robot's is ``python -m wheelleg.controller``; ``--robot NAME``
runs another registered robot's program (``wheelleg.hil.robots``: every
robot's program takes the same bus flags, ``controller/bus_args.py``). Without
``--period`` each runs at its robot's control period.
"""
from __future__ import annotations

import argparse
import importlib

from wheelleg.controller import __main__ as standalone
from wheelleg.hil import robots

NAME = "controller"
HELP = "run a robot's controller as on the robot (socketcan can0/can1 by default); SIGINT disables the motors"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    standalone.add_arguments(parser)
    parser.set_defaults(period=None)  # the robot's own, filled in by run()
    robots.add_argument(parser, "whose controller program to run (default: the wheel-legged robot's)")


def run(args: argparse.Namespace) -> int:
    robot = robots.get(args.robot)
    if args.period is None:
        args.period = robot.control_period_s
    return importlib.import_module(robot.controller_program).main(args)
