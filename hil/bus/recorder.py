"""The rig's recorder: every frame the plant side sees, on the wire's clock.

The plant's bus ends are wrapped in ``RecordingBus``: each frame the devices
send and each frame they receive from the controller passes the recorder
once, in bus order. A frame's time is bus time: the simulated time at which
the plant put it on or took it off the bus, serialised by the bus-load model
(``BusClock``) so no two frames on one bus overlap. Nothing depends on the wall
clock, so a scenario and seed give the same bytes on every run and transport.
"""
from __future__ import annotations

import can

from wheelleg.hil.bus.busload import BusClock, LoadMeter
from wheelleg.hil.record.frame import Frame


class Recorder:
    """Fans each observed frame out to the trace and the candump log."""

    def __init__(self, trace=None, log=None, bitrate: int = 1_000_000):
        self.trace = trace  # wheelleg.hil.record.trace.TraceWriter or None
        self.log = log  # wheelleg.hil.record.candump.CandumpWriter or None
        self.clocks: dict[str, BusClock] = {}
        self.bitrate = bitrate
        self.now_ns = 0  # simulated time, set by the rig before each batch of frames
        self.frames = 0
        self.load = LoadMeter(self.clocks, trace)  # /bus/load every 100 ms of bus time

    def clock(self, channel: str) -> BusClock:
        if channel not in self.clocks:
            self.clocks[channel] = BusClock(self.bitrate)
        return self.clocks[channel]

    def observe(self, channel: str, msg: can.Message) -> int:
        """Record one frame on ``channel``; returns its bus time (ns)."""
        data = bytes(msg.data[:msg.dlc])
        self.load.sample(self.now_ns)
        t_ns = self.clock(channel).transmit(self.now_ns, msg.arbitration_id, msg.is_extended_id, data)
        self.frames += 1
        frame = Frame(t_ns, channel, msg.arbitration_id, msg.is_extended_id, data, msg.dlc, "",
                      msg.is_error_frame, msg.is_remote_frame, msg.is_fd)
        if self.trace is not None:
            self.trace.frame(frame)
        if self.log is not None:
            self.log.write(frame)
        return t_ns


class RecordingBus:
    """A plant-side bus end that shows every frame to the recorder.

    Only what the device nodes use is forwarded (``send``, ``recv``,
    ``shutdown``); ``hook`` sees each received frame first (the rig watches for
    heartbeats there) and may return ``False`` to swallow it (fault injection).
    """

    def __init__(self, bus: can.BusABC, channel: str, recorder: Recorder, hook=None):
        self.bus, self.channel, self.recorder, self.hook = bus, channel, recorder, hook
        self.outbox_filter = None  # fn(msg) -> list[can.Message]: faults on frames the plant sends

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        out = [msg] if self.outbox_filter is None else self.outbox_filter(msg)
        for frame in out:
            self.recorder.observe(self.channel, frame)
            self.bus.send(frame, timeout)

    def recv(self, timeout: float | None = None) -> can.Message | None:
        while True:
            msg = self.bus.recv(timeout)
            if msg is None:
                return None
            self.recorder.observe(self.channel, msg)
            if self.hook is None or self.hook(self.channel, msg) is not False:
                return msg

    def shutdown(self) -> None:
        self.bus.shutdown()
