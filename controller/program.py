"""What every controller program does around its node: open the buses, log, stop on signals.

``python -m wheelleg.controller`` and ``python -m wheelleg.controller.quadruped``
both run ``run_program``: the buses from the flags of ``bus_args``, an optional
candump-format log (python-can's CanutilsLogWriter: the robot carries no part
of the rig), the node's loop until SIGINT or SIGTERM, the motors stopped on
the way out.
"""
from __future__ import annotations

import argparse
import signal
import sys
import threading
import time

import can

from wheelleg.controller import bus_args
from wheelleg.controller.bus_args import BusChoice, add_bus_arguments, bus_choice
from wheelleg.dbc import CAN1, CAN2


def open_bus(choice: BusChoice, index: int) -> can.BusABC:
    """Bus ``index`` (0: CAN1, 1: CAN2) of ``choice``; SystemExit with the reason when it cannot be had."""
    channel = choice.channels[index]
    try:
        return bus_args.open_bus(interface=choice.interface, channel=channel, receive_own_messages=False,
                                 **choice.kwargs_of(index))
    except (can.CanError, OSError, ValueError, ImportError) as exc:
        raise SystemExit(f"cannot open {choice.interface} channel {channel!r}: {exc}") from exc


def log_copy(msg: can.Message, channel: str, sent: bool) -> can.Message:
    """What the log keeps of one frame: a copy (the frame the node holds is not touched)
    named by its channel, ``is_rx`` False for frames we sent, and for those the wall-clock
    time of sending (their own timestamp is controller time; a received frame keeps the
    time the interface stamped on it)."""
    return can.Message(timestamp=time.time() if sent else msg.timestamp, arbitration_id=msg.arbitration_id,
                       is_extended_id=msg.is_extended_id, is_remote_frame=msg.is_remote_frame,
                       is_error_frame=msg.is_error_frame, channel=channel, dlc=msg.dlc, data=bytes(msg.data),
                       is_fd=msg.is_fd, bitrate_switch=msg.bitrate_switch,
                       error_state_indicator=msg.error_state_indicator, is_rx=not sent, check=False)


def log_listener(writer: can.Listener, names: dict):
    """A ``ControllerNode`` listener that hands ``writer`` a ``log_copy`` of each frame;
    ``names`` maps the node's bus names (can1, can2) to channel names."""
    def listener(bus: str, msg: can.Message, sent: bool) -> None:
        writer.on_message_received(log_copy(msg, names[bus], sent))
    return listener


def stop_on_signals(stop: threading.Event) -> None:
    """SIGINT and SIGTERM set ``stop``: the loop ends and disables the motors."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())


def add_program_arguments(parser: argparse.ArgumentParser, default_interface: str, default_channels: tuple,
                          period_s: float) -> None:
    """The flags of a controller program: the buses (``bus_args``), ``--sync``, ``--period``, ``--log``."""
    add_bus_arguments(parser, default_interface, default_channels)
    parser.add_argument("--sync", action="store_true", help="tick on the rig's SYNC frames (lockstep)")
    parser.add_argument("--period", type=float, default=period_s, help="control period (s)")
    parser.add_argument("--log", default=None, help="candump-format log of every frame seen and sent")


def run_program(args: argparse.Namespace, name: str, default_interface: str, default_channels: tuple,
                make_node) -> int:
    """Open the buses the flags name, run ``make_node(bus1, bus2, sync=, period_s=, listener=)`` until a
    signal, stop the motors; the exit status (2 for flags that name no two buses)."""
    try:
        choice = bus_choice(args, default_interface, default_channels)
    except ValueError as exc:
        print(f"{name}: {exc}", file=sys.stderr)
        return 2
    bus1, bus2 = open_bus(choice, 0), open_bus(choice, 1)
    writer = can.CanutilsLogWriter(args.log) if args.log else None
    names = {CAN1: choice.channels[0], CAN2: choice.channels[1]}
    listener = log_listener(writer, names) if writer is not None else None
    node = make_node(bus1, bus2, sync=args.sync, period_s=args.period, listener=listener)
    stop = threading.Event()
    stop_on_signals(stop)
    print(f"{name}: running on {choice.interface} {'/'.join(choice.channels)}, "
          f"{'ticking on the rig SYNC' if args.sync else f'every {args.period:g} s'}", file=sys.stderr, flush=True)
    try:
        node.run(stop)  # disables the motors on the way out
    finally:
        if writer is not None:
            writer.stop()
        bus1.shutdown()
        bus2.shutdown()
    print(f"{name} stopped after {node.ticks} ticks; motors disabled", file=sys.stderr)
    return 0
