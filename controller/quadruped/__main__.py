"""The quadruped's controller as the robot runs it: ``python -m wheelleg.controller.quadruped``.

    python -m wheelleg.controller.quadruped -i socketcan -c can0 -c can1

The same flags as ``python -m wheelleg.controller`` (controller/program.py):
the first channel is bus 0 (front legs, IMU, remote), the second bus 1 (rear
legs). Free-runs on its own 4 ms timer (``--sync`` ticks on the rig's SYNC
frames instead). SIGINT and SIGTERM stop every motor before it exits.
``--log FILE`` writes a candump-format log of every frame it saw and sent.
"""
from __future__ import annotations

import argparse
import sys

from wheelleg.controller.program import add_program_arguments, run_program
from wheelleg.controller.quadruped import params as P
from wheelleg.controller.quadruped.node import QuadrupedNode

DEFAULT_INTERFACE, DEFAULT_CHANNELS = "socketcan", ("can0", "can1")  # the robot's


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m wheelleg.controller.quadruped",
                                     description=__doc__.splitlines()[0])
    add_arguments(parser)
    return parser


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_program_arguments(parser, DEFAULT_INTERFACE, DEFAULT_CHANNELS, P.CONTROL_PERIOD)


def main(args: argparse.Namespace) -> int:
    return run_program(args, "quadruped controller", DEFAULT_INTERFACE, DEFAULT_CHANNELS, QuadrupedNode)


if __name__ == "__main__":
    sys.exit(main(build_parser().parse_args()))
