"""The controller as the robot runs it: ``python -m controller``.

    python -m controller --interface socketcan --wheels can0 --joints can1

Free-runs on its own 2 ms timer (``--sync`` ticks on the rig's SYNC frames
instead). SIGINT and SIGTERM stop every motor before it exits. ``--log FILE``
writes a candump-format log of every frame it saw and sent (python-can's
CanutilsLogWriter: the robot carries no part of the rig).
"""
from __future__ import annotations

import argparse
import signal
import sys
import threading

import can

from controller import params as P
from controller.node import ControllerNode


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m controller", description=__doc__.splitlines()[0])
    add_arguments(parser)
    return parser


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-i", "--interface", default="socketcan", help="python-can interface (socketcan)")
    parser.add_argument("--wheels", default="can0", help="CAN1 channel: wheel ESCs, IMU, remote (can0)")
    parser.add_argument("--joints", default="can1", help="CAN2 channel: CyberGear joints (can1)")
    parser.add_argument("--sync", action="store_true", help="tick on the rig's SYNC frames (lockstep)")
    parser.add_argument("--period", type=float, default=P.CONTROL_PERIOD, help="control period (s)")
    parser.add_argument("--log", default=None, help="candump-format log of every frame seen and sent")


def open_bus(interface: str, channel: str) -> can.BusABC:
    try:
        return can.Bus(interface=interface, channel=channel, receive_own_messages=False)
    except (can.CanError, OSError, ValueError) as exc:
        raise SystemExit(f"cannot open {interface} channel {channel!r}: {exc}") from exc


def main(args: argparse.Namespace) -> int:
    wheels, joints = open_bus(args.interface, args.wheels), open_bus(args.interface, args.joints)
    writer = can.CanutilsLogWriter(args.log) if args.log else None
    names = {"can1": args.wheels, "can2": args.joints}

    def listener(bus: str, msg: can.Message, sent: bool) -> None:
        if writer is not None:
            msg.channel = names[bus]
            writer.on_message_received(msg)

    node = ControllerNode(wheels, joints, sync=args.sync, period_s=args.period, listener=listener)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    try:
        node.run(stop)  # disables the motors on the way out
    finally:
        if writer is not None:
            writer.stop()
        wheels.shutdown()
        joints.shutdown()
    print(f"controller stopped after {node.ticks} ticks; motors disabled", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(build_parser().parse_args()))
