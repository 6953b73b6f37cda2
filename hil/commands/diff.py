"""``wheelleg diff PROGRAM_A PROGRAM_B RECORDING``: the differential check of two programs.

Both are fed the recording's inputs tick by tick (hil/analyze/differential.py); the first
tick and signal where their commands differ beyond the frames' quantisation is printed,
with each signal's largest difference as % of its full scale. Programs as ``run
--program`` takes them, in-process kinds only: ``python``, ``firmware``, PATH.so.

Exit status: 0 equal, 1 different, 2 bad input (a program, a recording that cannot be replayed).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from wheelleg.hil import robots

NAME = "diff"
HELP = "feed two programs the same recorded inputs; the first tick and signal where their commands differ"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("program_a", metavar="PROGRAM_A", help="'python', 'firmware' or PATH.so (as run --program)")
    parser.add_argument("program_b", metavar="PROGRAM_B", help="the other program, the same kinds")
    parser.add_argument("recording", type=Path, metavar="TRACE_OR_LOG",
                        help="the rig's MCAP trace or a candump -L log: the inputs fed to both")
    parser.add_argument("--channels", default=None, metavar="CAN1,CAN2",
                        help="interface names of CAN1 and CAN2 in the file (default: from the trace, or inferred)")
    parser.add_argument("--period", type=float, default=None, help="control period in s (default: the recording's)")
    robots.add_argument(parser, "whose recording (default: the trace's record, else the wheel-legged robot)")


def run(args: argparse.Namespace) -> int:
    from wheelleg.hil import program as programs
    from wheelleg.hil.analyze.differential import differential, report
    from wheelleg.hil.record.sources import TraceError, parse_channels

    robot = robots.get(getattr(args, "robot", None))
    try:
        pair = [programs.parse(text, robot.name) for text in (args.program_a, args.program_b)]
        for p in pair:
            if not p.in_process:
                raise ValueError(f"program {p.text!r}: a command cannot be fed recorded inputs tick by tick; "
                                 "give python, firmware or a library (PATH.so)")
        result = differential(args.recording, *(p.node_factory(robot) for p in pair),
                              channels=parse_channels(args.channels), robot=getattr(args, "robot", None),
                              period_s=args.period)
    except (TraceError, ValueError) as exc:
        print(f"diff: {exc}", file=sys.stderr)
        return 2
    print(f"diff: {args.recording}: " + report(result, (pair[0].text, pair[1].text)))
    return 0 if result.equal else 1
