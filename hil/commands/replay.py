"""``wheelleg replay TRACE``: replay a recording into today's controller, report the first difference.

Exit status: 0 identical, 1 a difference (the first is printed), 2 the file
cannot be replayed (the reason is printed).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from wheelleg.hil import robots
from wheelleg.hil.watch import options as watch_options

NAME = "replay"
HELP = "replay a trace (.mcap) or candump log into a fresh controller and compare what it sends"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("trace", type=Path, help="the rig's MCAP trace or a candump -L log")
    parser.add_argument("--tolerance", action="append", default=[], metavar="SIGNAL=VALUE",
                        help="allowed |difference| of a signal in its unit, or in LSB ('TorqueRef=2lsb'); "
                             "'Message.Signal=VALUE' for one message; repeatable. Default: 1 LSB for "
                             "scaled signals the controller sends, exact for the rest")
    parser.add_argument("--exact", action="store_true", help="no default tolerances: every bit must match")
    parser.add_argument("--update", type=Path, metavar="OUT",
                        help="write a new reference: the recording with the controller's frames "
                             "replaced by what the current controller sent")
    parser.add_argument("--channels", default=None, metavar="CAN1,CAN2",
                        help="interface names of CAN1 (wheels) and CAN2 (joints) in the file "
                             "(default: from the trace's metadata, or inferred from the frames)")
    parser.add_argument("--period", type=float, default=None,
                        help="controller period in s (default: the trace's, else the controller's)")
    parser.add_argument("--allow-drops", action="store_true",
                        help="replay a candump log even though it reports DROPCOUNT losses")
    parser.add_argument("--program", default="python", metavar="P",
                        help="the program replayed: python (default), firmware or PATH.so (in-process kinds of "
                             "`wheelleg run --program`)")
    robots.add_argument(parser, "whose recording, replayed into that robot's controller (default: the "
                                "trace's record, else the wheel-legged robot)")
    watch_options.add_view_arguments(parser)  # after the comparison: the trace's poses in MuJoCo's viewer


def run(args: argparse.Namespace) -> int:
    from wheelleg.hil.analyze.replay import parse_tolerance, replay
    from wheelleg.hil.analyze.update import write_reference
    from wheelleg.hil.record.sources import TraceError, parse_channels

    from wheelleg.hil import program as programs

    try:
        tolerances = dict(parse_tolerance(t) for t in args.tolerance)
        robot = robots.get(getattr(args, "robot", None))
        program = programs.parse(getattr(args, "program", "python"), robot.name)
        if not program.in_process:
            raise ValueError(f"program {program.text!r}: a command cannot be fed recorded inputs tick by tick")
        result = replay(args.trace, tolerances=tolerances, exact=args.exact,
                        channels=parse_channels(args.channels), period_s=args.period,
                        allow_drops=args.allow_drops, keep_sent=args.update is not None,
                        robot=getattr(args, "robot", None),
                        build_controller=program.node_factory(robot) if program.kind != programs.PYTHON else None)
    except (TraceError, ValueError) as exc:
        print(f"replay: cannot replay {args.trace}: {exc}", file=sys.stderr)
        return 2
    for line in result.warnings:
        print(f"warning: {line}", file=sys.stderr)
    for line in result.notes:
        print(line if line.startswith("warning:") else f"note: {line}", file=sys.stderr)
    src = result.source
    what = (f"{result.ticks} ticks, {result.frames} controller frames, {result.schedule.mode} mode, "
            f"{src.channels.get('can1')}/{src.channels.get('can2')}")
    if result.identical:
        print(f"replay: {args.trace}: identical ({what})")
    else:
        print(f"replay: {args.trace}: DIFFERENT ({what})")
        print(result.first.describe())
        print(f"  {result.differing_ticks} of {result.ticks} ticks differ "
              f"({result.differing_frames} frames)")
    if args.update is not None:
        out = write_reference(result, args.update)
        print(f"replay: new reference written to {out}")
    if args.view:
        shown = _view(args)
        if shown is not None:
            return shown
    return 0 if result.identical else 1


def _view(args: argparse.Namespace) -> int | None:
    """The trace's recorded poses in MuJoCo's viewer (paced unless --view-fast); 2 if they cannot be shown."""
    from wheelleg.hil.watch.scene import SceneError, recorded_motion
    from wheelleg.hil.watch.viewer import ViewerError, play_motion

    try:
        play_motion(recorded_motion(args.trace), fast=args.view_fast)
    except (SceneError, ViewerError) as exc:
        print(f"replay: --view: {exc}", file=sys.stderr)
        return 2
    return None
