"""The controller as the robot runs it: ``python -m wheelleg.controller``.

    python -m wheelleg.controller -i socketcan -c can0 -c can1

The bus flags are python-can's (``controller/bus_args.py``): without ``-i``
the interface comes from ``CAN_INTERFACE`` or ``~/.canrc``, else socketcan.

Free-runs on its own 2 ms timer (``--sync`` ticks on the rig's SYNC frames
instead). SIGINT and SIGTERM stop every motor before it exits. ``--log FILE``
writes a candump-format log of every frame it saw and sent (python-can's
CanutilsLogWriter: the robot carries no part of the rig).
"""
from __future__ import annotations

import argparse
import sys

from wheelleg.controller import params as P
from wheelleg.controller.node import ControllerNode
from wheelleg.controller.program import add_program_arguments, run_program


DEFAULT_INTERFACE, DEFAULT_CHANNELS = "socketcan", ("can0", "can1")  # the robot's


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m wheelleg.controller", description=__doc__.splitlines()[0])
    add_arguments(parser)
    return parser


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_program_arguments(parser, DEFAULT_INTERFACE, DEFAULT_CHANNELS, P.CONTROL_PERIOD)


def main(args: argparse.Namespace) -> int:
    return run_program(args, "controller", DEFAULT_INTERFACE, DEFAULT_CHANNELS, ControllerNode)


if __name__ == "__main__":
    sys.exit(main(build_parser().parse_args()))
