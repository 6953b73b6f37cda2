"""The bus flags of every command that opens the robot's two buses (python-can's convention).

``-i/--interface``, ``-c/--channel`` and ``--bus-kwargs KEY=VALUE ...`` as in
``python -m can.logger``; the two buses are two channels, CAN1 (wheels, IMU,
remote) first and CAN2 (CyberGear joints) second: ``-c can0 -c can1``.
``--wheels``/``--joints`` name one of them alone (the robot program's older
flags, kept as aliases). An interface not given on the command line comes
from python-can's configuration (``CAN_INTERFACE``, ``CAN_CONFIG``,
``~/.canrc``; ``can.util.load_config``), then from the command's default.
Only the interface and the bus keyword arguments are taken from there: a
configuration names one channel, the robot has two.

Used by ``wheelleg run`` and ``wheelleg controller`` (= ``python -m
wheelleg.controller``), and ``open_bus`` by every command that opens a bus
(``wheelleg emulate`` too); it lives with the controller because the robot's
program must not import the rig.
"""
from __future__ import annotations

import argparse
from dataclasses import dataclass, field

import can
import can.util

UDP_MULTICAST_PORT = 43113  # python-can's udp_multicast default port


@dataclass(frozen=True)
class BusChoice:
    """Where the two buses are: python-can interface, CAN1 and CAN2 channels, extra bus kwargs."""

    interface: str
    channels: tuple  # (CAN1 channel, CAN2 channel)
    kwargs: dict = field(default_factory=dict)

    def kwargs_of(self, index: int) -> dict:
        """Bus ``index``'s (0: CAN1, 1: CAN2) keyword arguments; see ``per_bus_kwargs``."""
        return per_bus_kwargs(self.interface, self.kwargs, index)


def per_bus_kwargs(interface: str, kwargs: dict, index: int) -> dict:
    """The keyword arguments of bus ``index`` (0: CAN1, 1: CAN2).

    python-can's ``udp_multicast`` joins a group on one UDP port, and a socket
    bound to that port receives every group's datagrams on it: two groups on one
    port are one bus. So CAN2 takes the next port (``port`` + 1, from 43113 by
    default); every process on the rig's buses (``wheelleg run``, ``wheelleg
    controller``) reckons the same way.
    """
    if interface != "udp_multicast":
        return dict(kwargs)
    return {**kwargs, "port": int(kwargs.get("port", UDP_MULTICAST_PORT)) + index}


def _kwarg(text: str) -> tuple[str, object]:
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"--bus-kwargs takes KEY=VALUE, got {text!r}")
    return key, can.util.cast_from_string(value)


def add_bus_arguments(parser: argparse.ArgumentParser, default_interface: str,
                      default_channels: tuple[str, str]) -> None:
    """``-i``, ``-c`` (twice), ``--wheels``/``--joints`` and ``--bus-kwargs`` on ``parser``."""
    group = parser.add_argument_group("bus arguments (python-can's)")
    group.add_argument("-i", "--interface", default=None,
                       help=f"python-can interface; default: CAN_INTERFACE or ~/.canrc, else {default_interface}")
    group.add_argument("-c", "--channel", action="append", default=None, metavar="CHANNEL",
                       help=f"give it twice: CAN1 (wheels) then CAN2 (joints) "
                            f"(default: -c {default_channels[0]} -c {default_channels[1]})")
    group.add_argument("--wheels", default=None, metavar="CHANNEL", help="alias: the CAN1 channel alone")
    group.add_argument("--joints", default=None, metavar="CHANNEL", help="alias: the CAN2 channel alone")
    group.add_argument("--bus-kwargs", nargs="+", type=_kwarg, default=[], metavar="KEY=VALUE",
                       help="keyword arguments for both buses, e.g. --bus-kwargs bitrate=1000000")


def configured() -> dict:
    """python-can's configuration as ``can.util.load_config`` ranks it (``can.rc``, then the
    environment, then ``/etc/can.conf``, ``~/.can``, ``~/.canrc``), without its demand for an interface."""
    config: dict = {}
    for source in (can.util.load_file_config(), can.util.load_environment_config(), can.rc):
        config.update(source)  # a later source outranks an earlier one
    if "bustype" in config:  # python-can's legacy name
        config.setdefault("interface", config.pop("bustype"))
    return {k: can.util.cast_from_string(v) if isinstance(v, str) else v for k, v in config.items()}


def bus_choice(args: argparse.Namespace, default_interface: str,
               default_channels: tuple[str, str]) -> BusChoice:
    """The buses the flags (then python-can's configuration, then the defaults) name;
    ValueError with one line for a wrong count of channels."""
    channels = list(getattr(args, "channel", None) or default_channels)
    if len(channels) != 2:
        raise ValueError(f"-c/--channel names the two buses, CAN1 (wheels) then CAN2 (joints); got {channels}")
    for index, alias in enumerate((getattr(args, "wheels", None), getattr(args, "joints", None))):
        if alias is not None:
            channels[index] = alias
    if channels[0] == channels[1]:
        raise ValueError(f"CAN1 and CAN2 are one channel ({channels[0]!r}): the rig's two buses need two")
    config = configured()
    interface = getattr(args, "interface", None) or config.get("interface") or default_interface
    kwargs = {k: v for k, v in config.items() if k not in ("interface", "channel")} \
        if interface == config.get("interface") else {}
    kwargs.update(dict(getattr(args, "bus_kwargs", None) or ()))
    return BusChoice(interface, tuple(channels), kwargs)


def open_bus(**config) -> can.BusABC:
    """``can.Bus(**config)``, python-can's configuration filling what ``config`` leaves out
    (None values count as left out), except that ``udp_multicast`` opens
    ``EchoFreeUdpMulticastBus``: python-can's multicast bus hears every frame it sends
    and a node must not take its own frames for the bus's. Raises what ``can.Bus`` raises
    (and ImportError without msgpack)."""
    config = can.util.load_config(config={k: v for k, v in config.items() if v is not None})
    if config["interface"] != "udp_multicast":
        return can.Bus(ignore_config=True, **config)
    from wheelleg.controller.udp_bus import EchoFreeUdpMulticastBus  # noqa: PLC0415 (needs msgpack)

    del config["interface"]
    return EchoFreeUdpMulticastBus(**config)
