"""The rig's recorder: every frame the plant side sees, on the wire's clock.

Each frame the devices send and each frame they receive from the controller
passes the recorder once, in bus order (``wheelleg.hil.bus.plant_bus.PlantBus``). A frame's time is bus time: the simulated time at which
the plant put it on or took it off the bus, serialised by the bus-load model
(``BusClock``) so no two frames on one bus overlap. Nothing depends on the wall
clock, so a scenario and seed give the same bytes on every run and transport.
"""
from __future__ import annotations

from typing import Protocol, Sequence

import can

from wheelleg.hil.bus.busload import BusClock, LoadMeter
from wheelleg.hil.record.frame import Frame


class FrameSink(Protocol):
    """Where recorded frames go, in the manner of python-can's ``Listener``.

    ``on_frame`` gets every frame in bus order, at its bus time; ``stop`` ends
    the recording (flush and close). ``TraceWriter`` (MCAP) and
    ``CandumpWriter`` (candump log) are the rig's two sinks.
    """

    def on_frame(self, frame: Frame) -> None: ...

    def stop(self) -> None: ...


class Recorder:
    """Puts each observed frame on its bus's wire clock and hands it to every sink.

    ``clock``: the run's simulated time (``wheelleg.hil.bus.plant_bus.SimClock``);
    ``load_to``: where the ``/bus/load`` windows go (the MCAP trace), or None.
    """

    def __init__(self, sinks: Sequence[FrameSink], clock, *, load_to=None, bitrate: int = 1_000_000):
        self.sinks = list(sinks)
        self._to_sinks = tuple(sink.on_frame for sink in self.sinks)  # bound once: the per-frame path
        self.sim_clock = clock
        self.clocks: dict[str, BusClock] = {}  # channel -> its wire
        self.bitrate = bitrate
        self.frames = 0
        self.load = LoadMeter(self.clocks, load_to)  # /bus/load every 100 ms of bus time

    def clock(self, channel: str) -> BusClock:
        if channel not in self.clocks:
            self.clocks[channel] = BusClock(self.bitrate)
        return self.clocks[channel]

    def observe(self, channel: str, msg: can.Message) -> int:
        """Record one frame on ``channel``; returns its bus time (ns)."""
        data = bytes(msg.data[:msg.dlc])
        now_ns = self.sim_clock.now_ns
        self.load.sample(now_ns)
        t_ns = self.clock(channel).transmit(now_ns, msg.arbitration_id, msg.is_extended_id, data)
        self.frames += 1
        frame = Frame(t_ns, channel, msg.arbitration_id, msg.is_extended_id, data, msg.dlc, "",
                      msg.is_error_frame, msg.is_remote_frame, msg.is_fd)
        for on_frame in self._to_sinks:
            on_frame(frame)
        return t_ns

    def stop(self) -> None:
        """The last (partial) load window, then every sink stopped."""
        self.load.sample(self.sim_clock.now_ns, final=True)
        for sink in self.sinks:
            sink.stop()
