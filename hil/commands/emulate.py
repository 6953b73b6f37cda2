"""``wheelleg emulate cybergear|c620|imu``: emulated devices alone on a CAN bus.

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
import numpy as np

from wheelleg.controller import bus_args
from wheelleg.emulators.c620 import C620
from wheelleg.emulators.cybergear import CyberGear
from wheelleg.emulators.device import EmulatedDevice
from wheelleg.emulators.imu import Imu, ImuNoise
from wheelleg.emulators.node import DeviceNode

NAME = "emulate"
HELP = "emulate CyberGears, C620s or an IMU alone on a CAN bus until interrupted"
DEFAULT_IDS = {"cybergear": 0x7F, "c620": 1, "imu": 0}

log = logging.getLogger(__name__)


def _int(text: str) -> int:
    return int(text, 0)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("device", choices=sorted(DEFAULT_IDS), help="which device to emulate")
    parser.add_argument("--id", type=_int, action="append", default=None, metavar="N",
                        help="CyberGear motor id 0..127 (default 0x7F) or C620 ESC id 1..8 (default 1); "
                             "decimal or 0x hex; repeat for several devices in one process")
    parser.add_argument("--host", type=_int, default=0x00, metavar="N",
                        help="CyberGear CAN_MASTER: the host id in 0..127 the motors answer (default 0x00); "
                             "hosts 0x80..0xFF (0xFD, the debugger's) are always answered")
    parser.add_argument("--position-range", choices=("12.5", "4pi"), default="12.5",
                        help="CyberGear position field range in rad (default: %(default)s)")
    parser.add_argument("--uid", type=_int, default=None, metavar="UID",
                        help="CyberGear 64-bit MCU unique id sent in type-0 replies")
    parser.add_argument("--command-timeout", type=float, default=None, metavar="S",
                        help="C620: zero the current when no command came for S seconds "
                             "(default: hold the last command forever)")
    parser.add_argument("--imu-period", type=float, default=0.002, metavar="S",
                        help="IMU frame period (default: %(default)s s)")
    parser.add_argument("--seed", type=int, default=0, help="IMU noise seed (default: %(default)s)")
    parser.add_argument("--tick", type=float, default=0.001, metavar="S",
                        help="shaft integration and periodic-frame tick (default: %(default)s s)")
    can.cli.add_bus_arguments(parser)


def make_devices(args: argparse.Namespace) -> list[EmulatedDevice]:
    """The devices the arguments ask for; ValueError on a bad id or option."""
    ids = [DEFAULT_IDS[args.device]] if args.id is None else args.id
    if len(set(ids)) != len(ids):
        raise ValueError(f"--id given twice for the same device: {ids}")
    if args.device == "imu":
        if args.id is not None:
            raise ValueError("the IMU has no --id")
        return [Imu(period_s=args.imu_period, noise=ImuNoise(), rng=np.random.default_rng(args.seed))]
    if args.device == "cybergear":
        if args.uid is not None and len(ids) > 1:
            raise ValueError("--uid names one motor; give it with a single --id")
        return [CyberGear(motor_id=i, position_range=args.position_range, uid=args.uid, host_id=args.host)
                for i in ids]
    return [C620(esc_id=i, command_timeout_s=args.command_timeout) for i in ids]


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
    if isinstance(device, CyberGear):
        return f"motor id 0x{device.motor_id:02X}"
    if isinstance(device, C620):
        return f"ESC id {device.esc_id}"
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
