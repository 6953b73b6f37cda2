"""The plant's end of one rig bus, built once from stages; the run's simulated clock.

A ``PlantBus`` is what the emulated devices send on and receive from. Every
frame passes the recorder once, in bus order, and a list of ``BusStage``s
fixed when the rig is built: the frame faults and arbitration model of that
bus (``wheelleg.hil.bus.frame_faults.BusFaults``) and the lockstep watch
(``wheelleg.hil.run.schedule.HeartbeatWatch``). Time is a ``SimClock`` that
only the run's schedule moves; the recorder and the stages read it.
"""
from __future__ import annotations

from typing import Protocol, Sequence

import can

from wheelleg.hil.bus.recorder import Recorder


class SimClock:
    """Simulated time of one run (ns): set by its schedule, read by recorder and bus stages."""

    __slots__ = ("now_ns",)

    def __init__(self, now_ns: int = 0):
        self.now_ns = now_ns

    def set_s(self, t_s: float) -> None:
        """Move to ``t_s`` (s), rounded to the nanosecond."""
        self.now_ns = round(t_s * 1e9)


class BusStage(Protocol):
    """One step a plant-side frame passes through, besides the recorder."""

    def outbound(self, frames: list[can.Message]) -> list[can.Message]:
        """The frames that go on the wire towards the controller when the plant sends ``frames``."""

    def inbound(self, msg: can.Message) -> bool:
        """Sees a frame the controller sent; False: no device gets it."""


class PlantBus:
    """A plant-side bus end: ``send``/``recv``/``shutdown`` as the devices use them.

    Outgoing frames pass every stage's ``outbound`` in order, then the
    recorder, then the wire. Incoming frames pass the recorder (a frame that
    left the controller is in the trace even when no device gets it), then
    every stage's ``inbound`` until one swallows it.

    A device node answers a frame between the ``recv`` that returned it and
    its next ``recv`` (``wheelleg.emulators.node.DeviceNode``); what it sends
    then is recorded as the answer to that frame, what it sends after a
    ``recv`` that found nothing (periodic frames) as its own.

    On the in-process bus (``transport.LockstepVirtualBus``) frames cross
    without copies: the plant's frames are made for one send each, so the
    frame a device sent is the one the controller receives (``send_owned``:
    a device must not change a frame after sending it), and the plant receives
    the controller's frames themselves (``take_as_sent``: with the sender's
    ``channel`` and ``is_rx``, which nothing on the plant side reads).
    """

    def __init__(self, bus, channel: str, recorder: Recorder, stages: Sequence[BusStage] = ()):
        self.bus, self.channel, self.recorder = bus, channel, recorder
        self.stages = tuple(stages)
        self._outbound = tuple(stage.outbound for stage in self.stages)  # bound once: the per-frame path
        self._inbound = tuple(stage.inbound for stage in self.stages)
        self._answering = None  # the recorder's handle of the frame the devices are answering
        self._poll = getattr(bus, "poll", None)  # an in-process end: a frame without python-can's recv loop
        self._send = getattr(bus, "send_owned", None) or bus.send
        if hasattr(bus, "take_as_sent"):
            bus.take_as_sent()

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        frames = [msg]
        for outbound in self._outbound:
            frames = outbound(frames)
        sent, channel, answering, send = self.recorder.sent, self.channel, self._answering, self._send
        for frame in frames:
            sent(channel, frame, answering)
            send(frame, timeout)

    def recv(self, timeout: float | None = None) -> can.Message | None:
        while True:
            msg = self._poll() if timeout == 0 and self._poll is not None else self.bus.recv(timeout)
            if msg is None:
                self._answering = None
                return None
            received = self.recorder.received(self.channel, msg)
            for inbound in self._inbound:
                if not inbound(msg):
                    break
            else:
                self._answering = received
                return msg

    def shutdown(self) -> None:
        self.bus.shutdown()
