"""``wheelleg emulate NAME``: emulated devices of one family alone on a CAN bus.

NAME is any installed device family (``wheelleg.emulators.family``: the rig's
own cybergear, c620, c610, gm6020, damiao, robstride, imu, and those of
installed plug-ins); each family adds its own options after its name.
``--id`` may be given several times: ``wheelleg emulate cybergear --id 1 --id
2 --id 3 --id 4`` serves a robot's whole set of motors from one process.

For anyone who writes or tests a driver: the device answers frame for frame
as the real one (emulators/), its shaft a simple inertia with friction. The
bus flags are python-can's own (``-i/--interface``, ``-c/--channel``,
``-b/--bitrate``, ``--bus-kwargs``; ``can.cli``), so what works with
``python -m can.logger`` works here; on ``udp_multicast`` the devices do not
hear their own frames (``wheelleg.controller.bus_args.open_bus``). Runs until
SIGINT or SIGTERM, then shuts the bus down.
"""
from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
from collections.abc import Callable

import can
import can.cli

from wheelleg.controller import bus_args
from wheelleg.emulators.device import EmulatedDevice
from wheelleg.emulators.family import families, int_id
from wheelleg.emulators.node import DeviceNode

NAME = "emulate"
HELP = "emulate devices of one family (CyberGear, C620, Damiao, ...) alone on a CAN bus until interrupted"

log = logging.getLogger(__name__)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="device", required=True, metavar="NAME",
                                help="device family: " + ", ".join(families()))
    for name, family in families().items():
        p = sub.add_parser(name, help=family.summary, description=family.summary)
        if family.default_ids:
            p.add_argument("--id", type=int_id, action="append", default=None, metavar="N", help=family.id_help)
        family.add_arguments(p)
        p.add_argument("--tick", type=float, default=0.001, metavar="S",
                       help="shaft integration and periodic-frame tick (default: %(default)s s)")
        can.cli.add_bus_arguments(p)
        p.set_defaults(family=family)


def make_devices(args: argparse.Namespace) -> list[EmulatedDevice]:
    """The devices the arguments ask for; ValueError on a bad id or option."""
    family = args.family
    ids = list(family.default_ids) if getattr(args, "id", None) is None else args.id
    if len(set(ids)) != len(ids):
        raise ValueError(f"--id given twice for the same device: {ids}")
    return family.make(args, ids)


# the destinations of can.cli.add_bus_arguments, which can.cli.create_bus_from_namespace reads
_BUS_KEYS = ("channel", "interface", "bitrate", "fd", "data_bitrate", "can_filters", "timing")


def open_bus(args: argparse.Namespace) -> can.BusABC:
    """The bus python-can's flags name, opened by ``bus_args.open_bus`` as every node on the
    rig's buses opens one (on ``udp_multicast`` the devices do not hear their own frames)."""
    config = {key: getattr(args, key) for key in _BUS_KEYS if key in args}
    config.update(getattr(args, "bus_kwargs", None) or {})
    return bus_args.open_bus(single_handle=True, **config)


def serve(devices: list[EmulatedDevice], bus: can.BusABC, stop: threading.Event,
          tick_s: float = 0.001) -> DeviceNode:
    """Serve ``devices`` on ``bus`` in real time until ``stop`` is set; the caller owns the bus."""
    node = DeviceNode(bus, devices)
    node.run_realtime(stop, dt_s=tick_s)
    return node


def run(args: argparse.Namespace, stop: threading.Event | None = None) -> int:
    """Emulate until SIGINT/SIGTERM (or ``stop``, for callers in a thread); 0 on a clean stop."""
    try:
        devices = make_devices(args)
        if not args.tick > 0.0:
            raise ValueError(f"--tick must be > 0 s, got {args.tick}")
    except ValueError as exc:
        print(f"wheelleg emulate: {exc}", file=sys.stderr)
        return 2
    try:
        bus = open_bus(args)
    except (can.CanError, OSError, ValueError, ImportError) as exc:
        print(f"wheelleg emulate: cannot open the bus: {exc}", file=sys.stderr)
        return 1
    stop = stop if stop is not None else threading.Event()
    restore = _stop_on_signals(stop.set)
    try:
        described = ", ".join(_describe(d) for d in devices)
        print(f"wheelleg emulate: {args.device} {described} on {bus.channel_info}; Ctrl-C stops",
              file=sys.stderr, flush=True)
        node = serve(devices, bus, stop, args.tick)
    finally:
        restore()
        bus.shutdown()
    print(f"wheelleg emulate: stopped; {node.frames_in} frames in, {node.frames_out} out, "
          f"{node.send_errors} dropped", file=sys.stderr)
    return 0


def _describe(device: EmulatedDevice) -> str:
    for attribute in ("motor_id", "esc_id"):
        if hasattr(device, attribute):
            return f"id 0x{getattr(device, attribute):02X}"
    return f"every {device.period_s} s"


def _stop_on_signals(set_stop: Callable[[], None]) -> Callable[[], None]:
    """Make SIGINT/SIGTERM set the stop event (main thread only); returns the undo."""
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    for sig in previous:
        signal.signal(sig, lambda signum, frame: set_stop())

    def restore() -> None:
        for sig, handler in previous.items():
            signal.signal(sig, handler)

    return restore
