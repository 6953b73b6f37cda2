"""``wheelleg recover TRACE [-o OUT]``: an indexed copy of a killed run's trace."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

NAME = "recover"
HELP = ("write an indexed copy of a trace whose run was killed (no summary: mcap's indexed readers "
        "and Foxglove's seek fail on it); default OUT: TRACE with .recovered.mcap")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("trace", type=Path, help="the rig's MCAP trace, complete or cut off")
    parser.add_argument("-o", "--out", type=Path, default=None, help="the copy (default: TRACE.recovered.mcap)")


def default_out(trace: Path) -> Path:
    return trace.with_suffix(".recovered.mcap")


def run(args: argparse.Namespace) -> int:
    from wheelleg.hil.analyze.recover import recover
    from wheelleg.hil.record.sources import checked_copy

    done, refused = checked_copy(args.trace, args.out or default_out(args.trace), recover)
    if refused:
        print(f"recover: {refused}", file=sys.stderr)
        return 2
    state = "complete" if done.was_complete else f"cut off ({done.stopped_at or 'ends mid-record'})"
    print(f"recover: {args.trace} ({state}) -> {done.out}: {done.messages} messages on {done.channels} "
          f"channels, {done.metadata} metadata, {done.attachments} attachments, indexed")
    return 0
