"""The balancer's controller as the robot runs it: ``python -m wheelleg_balancer -i socketcan -c can0 -c can1``.

The flags of the rig's controller programs (wheelleg.controller.program):
free-runs on its own 2 ms timer, or ticks on the rig's SYNC frames with
``--sync``; SIGINT and SIGTERM send zero current before it exits.
"""
from __future__ import annotations

import argparse
import sys

from wheelleg.controller.program import add_program_arguments, run_program
from wheelleg_balancer import params as P
from wheelleg_balancer.controller import BalancerNode

DEFAULT_INTERFACE, DEFAULT_CHANNELS = "socketcan", ("can0", "can1")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_program_arguments(parser, DEFAULT_INTERFACE, DEFAULT_CHANNELS, P.CONTROL_PERIOD)


def main(args: argparse.Namespace) -> int:
    return run_program(args, "balancer controller", DEFAULT_INTERFACE, DEFAULT_CHANNELS, BalancerNode)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m wheelleg_balancer", description=__doc__.splitlines()[0])
    add_arguments(parser)
    sys.exit(main(parser.parse_args()))
