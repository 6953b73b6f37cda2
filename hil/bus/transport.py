"""Opening the rig's buses the python-can way (``interface`` + ``channel``).

For python-can's in-process ``virtual`` interface the rig uses a subclass
whose ``send`` copies a frame by constructing a new ``can.Message`` instead
of ``copy.deepcopy`` (which costs most of the rig's bus time at ~10,000
frames per simulated second), and whose non-blocking receive (the lockstep
drain) asks the queue whether it holds a frame instead of raising and
catching ``queue.Empty``. Same channels, same semantics: it talks to
plain ``virtual`` buses in the same process.
"""
from __future__ import annotations

import queue
import time

import can
from can.interfaces.virtual import VirtualBus

from wheelleg.controller.bus_args import open_bus as python_can_bus


class LockstepVirtualBus(VirtualBus):
    """python-can's virtual bus with cheap per-receiver copies and a cheap non-blocking poll.

    It fills python-can's two back-end hooks, ``_recv_internal`` and
    ``send``; ``BusABC.recv`` keeps the policy (filters, timeouts).
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._closed = False

    def _check_open(self) -> None:
        if self._closed:
            raise can.CanOperationError("Cannot operate on a closed bus")

    def shutdown(self) -> None:
        self._closed = True
        super().shutdown()

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        if timeout != 0:  # a blocking wait (real-time mode, tools): python-can's own
            return super()._recv_internal(timeout)
        # The rig drains every bus with timeout 0 about 15 times a tick, mostly
        # finding it empty; queue.get would raise (and catch) queue.Empty each time.
        self._check_open()
        rx = self.queue
        if not rx.queue:  # this bus is its queue's only reader: a frame seen is a frame to get
            return None, False
        return rx.get_nowait(), False

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self._check_open()
        timestamp = msg.timestamp if self.preserve_timestamps else time.time()
        data = bytes(msg.data)
        full = False
        for bus_queue in self.channel:
            if bus_queue is self.queue and not self.receive_own_messages:
                continue
            copy = can.Message(timestamp=timestamp, arbitration_id=msg.arbitration_id,
                               is_extended_id=msg.is_extended_id, is_remote_frame=msg.is_remote_frame,
                               is_error_frame=msg.is_error_frame, channel=self.channel_id, dlc=msg.dlc,
                               data=data, is_fd=msg.is_fd, bitrate_switch=msg.bitrate_switch,
                               error_state_indicator=msg.error_state_indicator,
                               is_rx=bus_queue is not self.queue, check=False)
            try:
                bus_queue.put(copy, block=True, timeout=timeout)
            except queue.Full:
                full = True
        if full:
            raise can.CanOperationError("Could not send message to one or more recipients")


class BusOpenError(RuntimeError):
    """A bus that cannot be opened (no such vcan, no driver); the message says which and why."""


def open_bus(interface: str, channel: str, **kwargs) -> can.BusABC:
    """A bus on ``interface``/``channel``; ``BusOpenError`` when it cannot be had."""
    kwargs.setdefault("receive_own_messages", False)
    try:
        if interface == "virtual":
            return LockstepVirtualBus(channel=channel, preserve_timestamps=True, **kwargs)
        return python_can_bus(interface=interface, channel=channel, **kwargs)  # udp_multicast: without its echo
    except (can.CanError, OSError, ValueError, ImportError) as exc:
        hint = ""
        if isinstance(exc, ImportError) and exc.name == "msgpack":
            hint = " (pip install 'wheelleg-hil[udp]')"
        if interface == "socketcan":
            hint = " (no such interface? `wheelleg vcan up`, or run inside `bash ci/uml-vcan.sh ...`)"
        raise BusOpenError(f"cannot open {interface} channel {channel!r}: {exc}{hint}") from exc
