"""The rig's recorder: every frame the plant side sees, in the order and at the times of the wire.

The plant hands each frame over once (``wheelleg.hil.bus.plant_bus.PlantBus``):
the frames its devices and the rig put on a bus (``sent``) and the frames it
took off the bus from the controller (``received``), in the order the rig ran
them. The recorder queues each on its bus's wire model
(``wheelleg.hil.bus.wire_order.BusWire``) at the time its sender queued it:

- the rig's SYNC at the rig's clock, after every frame queued before it on
  its bus (lockstep: SYNC comes after the period's feedback) and before any
  queued after it;
- the controller's frames when it has had SYNC on every bus (the end of the
  later SYNC; its computing takes no simulated time in lockstep), or at the
  rig's clock where there is no SYNC (real time);
- a device's reply when the frame it answers has been received (plus
  ``wire_order.RESPONSE_NS``); any other device frame at the rig's clock.

The sinks get every frame once its time is settled, in time order across
all buses (ties: in the order of ``channels``), stamped with the end of its
transmission. Only the record is ordered this way: what the controller and
the devices receive, and when, is the rig's business and does not change.
Nothing depends on the wall clock, so a scenario and seed give the same bytes
on every run and transport.
"""
from __future__ import annotations

from typing import Protocol, Sequence

import can

from wheelleg.dbc import CAN1, load_bus
from wheelleg.hil.bus.busload import LoadMeter
from wheelleg.hil.bus.wire_order import BusWire, Queued
from wheelleg.hil.record.frame import Frame

SYNC_ID = load_bus(CAN1).get_message_by_name("SYNC").frame_id


class FrameSink(Protocol):
    """Where recorded frames go, in the manner of python-can's ``Listener``.

    ``on_frame`` gets every frame in time order, at its bus time; ``stop``
    ends the recording (flush and close). ``TraceWriter`` (MCAP) and
    ``CandumpWriter`` (candump log) are the rig's two sinks.
    """

    def on_frame(self, frame: Frame) -> None: ...

    def stop(self) -> None: ...


def is_sync(msg: can.Message) -> bool:
    """The rig's lockstep SYNC (rig.dbc), the barrier of its bus."""
    return msg.arbitration_id == SYNC_ID and not msg.is_extended_id and not msg.is_error_frame


class Recorder:
    """Puts each observed frame on its bus's wire model and hands the settled frames to every sink.

    ``clock``: the run's simulated time (``wheelleg.hil.bus.plant_bus.SimClock``);
    ``channels``: every bus the run records, in the order that breaks ties of
    time; ``load_to``: where the ``/bus/load`` windows go (the MCAP trace), or None.
    """

    def __init__(self, sinks: Sequence[FrameSink], clock, channels: Sequence[str], *, load_to=None,
                 bitrate: int = 1_000_000):
        self.sinks = list(sinks)
        self._to_sinks = tuple(sink.on_frame for sink in self.sinks)  # bound once: the per-frame path
        self.sim_clock = clock
        self.bitrate = bitrate
        self.wires: dict[str, BusWire] = {channel: BusWire(bitrate) for channel in channels}
        self.frames = 0
        self.load = LoadMeter(self.wires, load_to)  # /bus/load every 100 ms of bus time
        self._sync_end_ns: dict[str, int] = {}  # channel -> end of its latest SYNC
        self._run_to_ns = -1  # the wires have been run up to here

    def wire(self, channel: str) -> BusWire:
        if channel not in self.wires:
            self.wires[channel] = BusWire(self.bitrate)
        return self.wires[channel]

    def sent(self, channel: str, msg: can.Message, answers: Queued | None = None) -> None:
        """A frame the plant side put on ``channel``; ``answers``: the received frame it replies to."""
        now_ns = self._arrive()
        frame = self._frame(channel, msg)
        if is_sync(msg):
            self._sync_end_ns[channel] = self.wire(channel).barrier(frame, now_ns)
            self._advance(now_ns, emit=True)
        else:
            self.wire(channel).queue(frame, now_ns, answers)
            self._advance(now_ns)

    def received(self, channel: str, msg: can.Message) -> Queued:
        """A frame the plant side took off ``channel`` (the controller's); its place on the wire."""
        now_ns = self._arrive()
        tick_ns = max(self._sync_end_ns.values(), default=0)
        item = self.wire(channel).queue_controller(self._frame(channel, msg), max(now_ns, tick_ns))
        self._advance(now_ns)
        return item

    def _arrive(self) -> int:
        now_ns = self.sim_clock.now_ns
        self.load.sample(now_ns)
        self.frames += 1
        return now_ns

    @staticmethod
    def _frame(channel: str, msg: can.Message) -> Frame:
        return Frame(0, channel, msg.arbitration_id, msg.is_extended_id, bytes(msg.data[:msg.dlc]), msg.dlc, "",
                     msg.is_error_frame, msg.is_remote_frame, msg.is_fd)

    def _advance(self, now_ns: int, emit: bool = False) -> None:
        """Once the clock has moved (or ``emit``): every wire run up to it, what is settled to the sinks.

        A frame queued at the clock's time starts at it or later, so wires run up
        to ``now_ns`` stay so while the clock stands still.
        """
        if now_ns > self._run_to_ns:
            for wire in self.wires.values():
                wire.run_until(now_ns)
            self._run_to_ns = now_ns
            emit = True
        if emit:
            self._emit(now_ns)

    def _emit(self, now_ns: int | None) -> None:
        """Hand the sinks every sent frame no later frame can precede (None: every one), in time order.

        A wire's next frame ends after its last one and after ``now_ns`` (nothing
        is queued in the past), so frames up to the earliest of those are settled.
        """
        queues = [wire.sent for wire in self.wires.values()]
        if now_ns is None:
            settled = None
        else:
            settled = min(max(wire.free_ns, now_ns) for wire in self.wires.values())
        to_sinks = self._to_sinks
        while True:
            first = None
            for queue in queues:
                if queue and (first is None or queue[0].t_ns < first[0].t_ns):
                    first = queue
            if first is None or (settled is not None and first[0].t_ns > settled):
                return
            frame = first.popleft()
            for on_frame in to_sinks:
                on_frame(frame)

    def stop(self) -> None:
        """Every frame still queued sent and handed over, the last (partial) load window, every sink stopped."""
        for wire in self.wires.values():
            wire.run_until(None)
        self._emit(None)
        self.load.sample(self.sim_clock.now_ns, final=True)
        for sink in self.sinks:
            sink.stop()
