"""``wheelleg inspect TRACE``: what a trace or candump log holds, faults and deadline misses."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from wheelleg.hil import robots

NAME = "inspect"
HELP = "summarize a trace (.mcap) or candump log: rates, bus load, signal ranges, faults, deadline misses"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("trace", type=Path, help="the rig's MCAP trace or a candump -L log")
    parser.add_argument("--plot", type=Path, metavar="FILE.png", help="also draw bus load, heartbeat and commands")
    parser.add_argument("--channels", default=None, metavar="CAN1,CAN2",
                        help="interface names of CAN1 (wheels) and CAN2 (joints) (default: inferred)")
    parser.add_argument("--bitrate", type=int, default=1_000_000, help="bit/s for the bus load (1000000)")
    parser.add_argument("--period", type=float, default=None,
                        help="control period (s) for late-tick detection in robot logs (default: the robot's)")
    robots.add_argument(parser, "whose log it is (default: the trace's record, else the wheel-legged robot)")
    parser.add_argument("--no-signals", action="store_true", help="leave out the signal ranges")


def run(args: argparse.Namespace) -> int:
    from wheelleg.hil.analyze.inspect_trace import format_summary, plot_summary, summarize
    from wheelleg.hil.record.sources import TraceError, parse_channels

    robot = getattr(args, "robot", None)
    try:
        summary = summarize(args.trace, bitrate=args.bitrate, channels=parse_channels(args.channels),
                            period_s=args.period or robots.get(robot).control_period_s, robot=robot)
    except TraceError as exc:
        print(f"inspect: cannot read {args.trace}: {exc}", file=sys.stderr)
        return 2
    print(format_summary(summary, signals=not args.no_signals))
    if args.plot is not None:
        print(f"plot: {plot_summary(summary, args.plot)}")
    return 0
