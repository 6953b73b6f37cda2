"""``wheelleg export TRACE [-o OUT]``: a copy of a trace with the /decoded/ topics, for Foxglove."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

NAME = "export"
HELP = ("write a copy of a trace with every frame's DBC signals on /decoded/<channel>/<Message> (JSON), "
        "for Foxglove's plots; a run's trace keeps raw frames only; default OUT: TRACE with .decoded.mcap")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("trace", type=Path, help="the rig's MCAP trace (complete or cut off)")
    parser.add_argument("-o", "--out", type=Path, default=None, help="the copy (default: TRACE.decoded.mcap)")


def default_out(trace: Path) -> Path:
    return trace.with_suffix(".decoded.mcap")


def run(args: argparse.Namespace) -> int:
    from wheelleg.hil.analyze.export import export_decoded
    from wheelleg.hil.record.sources import checked_copy

    done, refused = checked_copy(args.trace, args.out or default_out(args.trace), export_decoded)
    if refused:
        print(f"export: {refused}", file=sys.stderr)
        return 2
    cut = " (cut off: a killed run's trace)" if done.truncated else ""
    print(f"export: {args.trace}{cut} -> {done.out}: {done.frames} frames, {done.decoded} /decoded/ messages, "
          f"{done.copied} other messages copied")
    return 0
