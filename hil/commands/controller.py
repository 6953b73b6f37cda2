"""``wheelleg controller``: the robot's controller alone on its buses (``python -m wheelleg.controller``)."""
from __future__ import annotations

import argparse

from wheelleg.controller import __main__ as standalone

NAME = "controller"
HELP = "run the controller as on the robot (socketcan can0/can1 by default); SIGINT disables the motors"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    standalone.add_arguments(parser)


def run(args: argparse.Namespace) -> int:
    return standalone.main(args)
