"""``wheelleg vcan up|down|status``: the virtual SocketCAN channels vcan0 (CAN1) and vcan1 (CAN2);
``wheelleg vcan uml -- CMD``: CMD inside user-mode-linux with them, where the kernel has no CAN."""
from __future__ import annotations

import argparse
import subprocess
import sys

from wheelleg.hil.bus import vcan

NAME = "vcan"
HELP = ("create (up) or remove (down) the vcan0/vcan1 SocketCAN links, txqueuelen 1000; "
        "status: exit 0 if both open; uml -- CMD: run CMD inside user-mode-linux with them")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=("up", "down", "status", "uml"))
    parser.add_argument("command", nargs="*", metavar="CMD",
                        help="uml: after --, the command to run inside user-mode-linux (its exit status is "
                             "vcan uml's; 124 when UML_VCAN_TIMEOUT ends it, 125 when UML fails)")
    parser.add_argument("-c", "--channel", action="append", default=None, metavar="IF",
                        help="an interface, repeatable as python-can's -c "
                             f"(default: -c {' -c '.join(vcan.CHANNELS)})")
    parser.add_argument("--txqueuelen", type=int, default=vcan.TXQUEUELEN, metavar="FRAMES",
                        help="transmit queue length for 'up' (default: %(default)s)")


def run(args: argparse.Namespace) -> int:
    if args.action == "uml":
        return _run_in_uml(args.command)  # argparse has taken the "--" out
    if args.command:
        print(f"wheelleg vcan {args.action}: unexpected arguments {' '.join(args.command)}", file=sys.stderr)
        return 2
    channels = tuple(args.channel or vcan.CHANNELS)
    if args.action == "status":
        reason = vcan.unavailable_reason(channels)
        print(reason or f"{', '.join(channels)}: up, python-can opens them")
        return 0 if reason is None else 1
    if args.txqueuelen < 1:
        print(f"wheelleg vcan: --txqueuelen must be >= 1 frame, got {args.txqueuelen}",
              file=sys.stderr)
        return 2
    try:
        lines = vcan.up(channels, args.txqueuelen) if args.action == "up" else vcan.down(channels)
    except vcan.VcanError as exc:
        print(f"wheelleg vcan {args.action}: {exc}", file=sys.stderr)
        return 1
    print("\n".join(lines))
    return 0


def _run_in_uml(command: list[str]) -> int:
    """CMD inside user-mode-linux (the packaged runner); its exit status."""
    if not command:
        print("wheelleg vcan uml: no command: wheelleg vcan uml -- CMD [ARG...]", file=sys.stderr)
        return 2
    return subprocess.call(["bash", str(vcan.UML_RUNNER), *command])
