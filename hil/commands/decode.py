"""``wheelleg decode LOG|TRACE``: every frame decoded, CyberGear id fields included, as cantools decode prints."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

NAME = "decode"
HELP = ("print every frame of a trace (.mcap), candump log or other python-can log decoded by the rig's "
        "DBC files, the CyberGear 29-bit id fields included (cantools decode's style, or CSV)")
ID_HELP = ("only these frames (repeatable, any matches): an id in hex as candump writes it (201, 0200FD01), "
           "candump's ID:MASK (02000000:1F000000), or CyberGear frames by type and/or motor "
           "(type=2, motor=1, type=1,motor=3)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", type=Path, metavar="LOG|TRACE",
                        help="the rig's MCAP trace, a candump -L log (plain or .gz) or any log python-can reads")
    parser.add_argument("--id", action="append", default=[], metavar="ID", help=ID_HELP)
    parser.add_argument("--signal", action="append", default=[], metavar="NAME",
                        help="only these signals, SIGNAL or MESSAGE.SIGNAL (repeatable); frames without any "
                             "of them are left out")
    parser.add_argument("--csv", action="store_true",
                        help="CSV instead: time_s, bus, channel, id, message and the signals, one row per frame")
    parser.add_argument("-s", "--single-line", action="store_true", help="one line per frame (cantools' -s)")
    parser.add_argument("--channels", default=None, metavar="CAN1,CAN2",
                        help="interface names of CAN1 (wheels) and CAN2 (joints) (default: inferred)")


def run(args: argparse.Namespace) -> int:
    from wheelleg.hil.analyze.decode_log import decode, format_text, parse_id_filter, select_signals, write_csv
    from wheelleg.hil.record.sources import TraceError, open_recording, parse_channels

    try:
        filters = [parse_id_filter(text) for text in args.id]
        signals = select_signals(args.signal)
        channels = parse_channels(args.channels)
    except (ValueError, TraceError) as exc:
        print(f"decode: {exc}", file=sys.stderr)
        return 2
    try:
        recording = open_recording(args.recording, channels, strict=False)
    except TraceError as exc:
        print(f"decode: cannot read {args.recording}: {exc}", file=sys.stderr)
        return 2
    frames = decode(recording, filters, signals)
    if args.csv:
        count = write_csv(frames, sys.stdout, signals)
    else:
        count = 0
        for decoded in frames:
            print(format_text(decoded, args.single_line))
            count += 1
    if count == 0:
        print(f"decode: no frame of {args.recording} matched", file=sys.stderr)
        return 1
    return 0
