"""Opening the rig's buses the python-can way (``interface`` + ``channel``).

For python-can's in-process ``virtual`` interface the rig uses a subclass
whose ``send`` copies a frame by constructing a new ``can.Message`` instead
of ``copy.deepcopy`` (which costs most of the rig's bus time at ~10,000
frames per simulated second), and whose receive queue is a ``FrameQueue``:
a deque whose put and non-blocking get are one operation each, where
``queue.Queue`` takes a lock and signals a condition every time (the
lockstep drain polls each bus about 15 times a tick, mostly empty). Same
channels, same semantics: it talks to plain ``virtual`` buses in the same
process. Between the rig's two ends of a channel the plant's frames cross
without a copy (``send_owned``, ``take_as_sent``; the plant makes each frame
for one send and only reads the controller's): one ``can.Message`` a frame
instead of two.
"""
from __future__ import annotations

import logging
import queue
import threading
import time
from collections import deque

import can
from can.interfaces import virtual
from can.interfaces.virtual import VirtualBus

from wheelleg.controller.bus_args import open_bus as python_can_bus

_CAN_LOG = logging.getLogger("can.bus")  # where BusABC.recv logs each frame received


class FrameQueue:
    """An unbounded FIFO with the ``queue.Queue`` calls python-can's virtual buses make.

    ``put`` and ``pop`` (a non-blocking get: None when empty) are one deque
    operation, atomic under the GIL; only a blocking ``get`` (real-time mode,
    tools) takes the condition, and ``put`` signals it only while a reader waits.
    One reader: the bus that owns the queue.

    ``as_sent``: the reader takes a sender's frame itself, not a copy (the
    plant's end, ``LockstepVirtualBus.take_as_sent``): its reader only reads the
    frames and the sender made each one for its send.
    """

    as_sent = False

    def __init__(self):
        self.frames: deque = deque()
        self._ready = threading.Condition(threading.Lock())
        self._waiting = 0  # readers in a blocking get

    def put(self, item, block: bool = True, timeout: float | None = None) -> None:
        self.frames.append(item)
        if self._waiting:  # read after the append: a reader that starts waiting later sees the item
            with self._ready:
                self._ready.notify()

    put_nowait = put

    def pop(self):
        """The oldest frame, or None at once."""
        frames = self.frames
        return frames.popleft() if frames else None

    def get(self, block: bool = True, timeout: float | None = None):
        """As ``queue.Queue.get``: the oldest frame, waiting up to ``timeout`` s (None: forever); ``queue.Empty``."""
        frames = self.frames
        if frames or not block:
            if frames:
                return frames.popleft()
            raise queue.Empty
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._ready:
            self._waiting += 1
            try:
                while not frames:
                    left = None if deadline is None else deadline - time.monotonic()
                    if left is not None and left <= 0:
                        raise queue.Empty
                    self._ready.wait(left)
                return frames.popleft()
            finally:
                self._waiting -= 1

    def get_nowait(self):
        return self.get(block=False)

    def qsize(self) -> int:
        return len(self.frames)

    def empty(self) -> bool:
        return not self.frames


class LockstepVirtualBus(VirtualBus):
    """python-can's virtual bus with cheap per-receiver copies and a cheap non-blocking poll.

    It fills python-can's two back-end hooks, ``_recv_internal`` and
    ``send``; ``BusABC.recv`` keeps the policy (filters, timeouts).
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._closed = False
        if kwargs.get("rx_queue_size", 0) == 0:  # a bounded queue stays python-can's queue.Queue
            with virtual.channels_lock:
                slot = next(i for i, q in enumerate(self.channel) if q is self.queue)
                self.queue = self.channel[slot] = FrameQueue()

    def take_as_sent(self) -> None:
        """Receive the frames sent on the channel themselves, not copies (``FrameQueue.as_sent``).

        For an end whose reader never changes a frame and reads none of the
        fields a copy would set (``channel``, ``is_rx``): the plant's
        (``wheelleg.hil.bus.plant_bus.PlantBus``). A bounded queue keeps copies.
        """
        if type(self.queue) is FrameQueue:
            self.queue.as_sent = True

    def _check_open(self) -> None:
        if self._closed:
            raise can.CanOperationError("Cannot operate on a closed bus")

    def shutdown(self) -> None:
        self._closed = True
        super().shutdown()

    def poll(self) -> can.Message | None:
        """The oldest frame received, or None at once: ``recv(timeout=0)`` for an end without
        filters (the plant's), without ``BusABC.recv``'s wait loop and log call."""
        # ~30 polls a tick: BusABC's ``_filters`` (its ``filters`` property's value), the
        # open check and ``FrameQueue.pop`` are read here without a call each
        if self._filters is not None:
            return self.recv(timeout=0)
        if self._closed:
            raise can.CanOperationError("Cannot operate on a closed bus")
        rx = self.queue
        if type(rx) is FrameQueue:
            frames = rx.frames
            return frames.popleft() if frames else None
        return rx.get_nowait() if rx.queue else None

    def recv(self, timeout: float | None = None) -> can.Message | None:
        """``BusABC.recv``; ``timeout=0`` without filters (the lockstep drain of the controller's
        ends, ~15 polls a tick) takes the frame at once, without its wait loop and clock reads."""
        if timeout != 0 or self._filters is not None:
            return super().recv(timeout)
        msg = self.poll()
        if msg is not None and _CAN_LOG.isEnabledFor(self.RECV_LOGGING_LEVEL):  # as BusABC.recv logs it
            _CAN_LOG.log(self.RECV_LOGGING_LEVEL, "Received: %s", msg)
        return msg

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        if timeout != 0:  # a blocking wait (real-time mode, tools): python-can's own
            return super()._recv_internal(timeout)
        # The rig drains every bus with timeout 0 about 15 times a tick, mostly
        # finding it empty; queue.get would raise (and catch) queue.Empty each time.
        self._check_open()
        rx = self.queue
        if type(rx) is FrameQueue:
            return rx.pop(), False
        if not rx.queue:  # this bus is its queue's only reader: a frame seen is a frame to get
            return None, False
        return rx.get_nowait(), False

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        if self._closed:  # _check_open, inline: ~20 frames a tick
            raise can.CanOperationError("Cannot operate on a closed bus")
        timestamp = msg.timestamp if self.preserve_timestamps else time.time()
        data = msg.data
        full = False
        for bus_queue in self.channel:
            if bus_queue is self.queue and not self.receive_own_messages:
                continue
            if bus_queue.__class__ is FrameQueue and bus_queue.as_sent:
                bus_queue.put(msg)  # the plant's end: its reader neither changes nor keeps the frame
                continue
            # python-can's parameters by position (a third cheaper than by keyword): timestamp,
            # arbitration_id, is_extended_id, is_remote_frame, is_error_frame, channel, dlc, data,
            # is_fd, is_rx, bitrate_switch, error_state_indicator; a bytearray is taken as it is (one
            # copy of the payload per receiver, where bytes made python-can copy it again)
            copy = can.Message(timestamp, msg.arbitration_id, msg.is_extended_id, msg.is_remote_frame,
                               msg.is_error_frame, self.channel_id, msg.dlc, bytearray(data), msg.is_fd,
                               bus_queue is not self.queue, msg.bitrate_switch, msg.error_state_indicator)
            try:
                bus_queue.put(copy, block=True, timeout=timeout)
            except queue.Full:
                full = True
        if full:
            raise can.CanOperationError("Could not send message to one or more recipients")

    def send_owned(self, msg: can.Message, timeout: float | None = None) -> None:
        """``send`` of a frame the caller made for this one send and gives up.

        With one receiver (the lockstep's two ends of a channel), ``msg`` itself
        becomes that receiver's copy: stamped with what ``send`` sets on a copy
        (this end's ``channel_id``, ``is_rx`` True, the payload as a new
        ``bytearray``) instead of a second ``can.Message`` (~5,000 machine
        instructions, 13 frames a tick from the plant). Several receivers: ``send``.
        """
        if self._closed:
            raise can.CanOperationError("Cannot operate on a closed bus")
        channel, own = self.channel, self.queue
        if len(channel) == 2 and not self.receive_own_messages and self.preserve_timestamps:
            rx = channel[1] if channel[0] is own else channel[0]
            if rx.__class__ is FrameQueue and not rx.as_sent:
                msg.channel, msg.is_rx, msg.data = self.channel_id, True, bytearray(msg.data)
                rx.put(msg)
                return
        self.send(msg, timeout)


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
