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

from operator import attrgetter
from typing import Protocol, Sequence

import can

from wheelleg.dbc import CAN1, load_bus
from wheelleg.hil import fast
from wheelleg.hil.bus import wire_order
from wheelleg.hil.bus.busload import LoadMeter, wire_ns, wire_ns_batch
from wheelleg.hil.bus.wire_order import BusWire, Queued
from wheelleg.hil.record.frame import Frame

SYNC_ID = load_bus(CAN1).get_message_by_name("SYNC").frame_id
_T_NS = attrgetter("t_ns")


class FrameSink(Protocol):
    """Where recorded frames go, in the manner of python-can's ``Listener``.

    ``on_frames`` gets every frame in time order, at its bus time, a list at a
    time; ``stop`` ends the recording (flush and close). ``TraceWriter``
    (MCAP) and ``CandumpWriter`` (candump log) are the rig's two sinks.
    """

    def on_frames(self, frames: list[Frame]) -> None: ...

    def stop(self) -> None: ...


def is_sync(msg: can.Message) -> bool:
    """The rig's lockstep SYNC (rig.dbc), the barrier of its bus."""
    return msg.arbitration_id == SYNC_ID and not msg.is_extended_id and not msg.is_error_frame


class Recorder:
    """Puts each observed frame on its bus's wire model and hands the settled frames to every sink.

    ``clock``: the run's simulated time (``wheelleg.hil.bus.plant_bus.SimClock``);
    ``channels``: every bus the run records, in the order that breaks ties of
    time; ``load_to``: where the ``/bus/load`` windows go (the MCAP trace), or None.

    ``sent`` and ``received`` only note a frame with the clock's time; the
    wire models take the noted frames ``batch`` at a time (``settle``; ``stop``
    takes the rest), in the order they were noted: the same calls in the same
    order as frame by frame, so the same record, with each frame's wire time
    computed for the whole batch at once (``busload.wire_ns_batch``) and the
    sinks handed a list. Nothing the run does waits for the record. Real time
    settles ``slice_size`` at a time between its steps (``Rig.housekeeping``);
    reaching ``batch`` then settles one slice, not the lot.

    Where the compiled record path is built (``wheelleg.hil.fast``), ``sent``,
    ``received`` and the wire models are its ``RecordCore``: the same record,
    frame for frame; ``wires`` then holds a ``WireView`` of each bus.
    """

    def __init__(self, sinks: Sequence[FrameSink], clock, channels: Sequence[str], *, load_to=None,
                 bitrate: int = 1_000_000, batch: int = 1024, slice_size: int | None = None):
        self.sinks = list(sinks)
        self.sim_clock = clock
        self.bitrate = bitrate
        self.batch = max(1, int(batch))
        self.slice_size = slice_size  # what reaching ``batch`` settles (None: every noted frame)
        self.wires: dict[str, BusWire] = {channel: BusWire(bitrate) for channel in channels}
        self.frames = 0
        self.load = LoadMeter(self.wires, load_to)  # /bus/load every 100 ms of bus time
        self._noted: list[tuple] = []  # (clock ns, channel, Frame, answers, handle of a received frame)
        self._tick_ns = 0  # end of the latest SYNC on any bus: the controller has had its turn
        self._run_to_ns = -1  # the wires have been run up to here
        self._core = None
        compiled = fast.core()
        if compiled is not None:
            self._core = core = compiled.RecordCore(
                list(channels), Frame, clock, bitrate, SYNC_ID, wire_order.RESPONSE_NS, wire_ns,
                self._load_sample, lambda: self.settle(self.slice_size), self.batch)
            self.wires.clear()
            self.wires.update((channel, WireView(core, channel)) for channel in channels)
            core.set_load_due(self.load.due_ns)
            self.sent, self.received = core.sent, core.received  # per frame: no Python call

    def _load_sample(self, now_ns: int) -> int:
        """The compiled path's load window: every bus it knows listed, the window closed; the next due time."""
        self._list_wires()
        self.load.sample(now_ns)
        return self.load.due_ns

    def _list_wires(self) -> None:
        """The compiled path: a view in ``wires`` of every bus it has settled a frame of."""
        for channel in self._core.channels:
            if channel not in self.wires:
                self.wires[channel] = WireView(self._core, channel)

    def wire(self, channel: str) -> BusWire:
        if channel not in self.wires:
            self.wires[channel] = BusWire(self.bitrate) if self._core is None else WireView(self._core, channel)
        return self.wires[channel]

    @property
    def frames(self) -> int:
        """Frames settled so far."""
        return self._frames if self._core is None else self._core.frames

    @frames.setter
    def frames(self, value: int) -> None:
        self._frames = value

    def sent(self, channel: str, msg: can.Message, answers: Queued | None = None) -> None:
        """A frame the plant side put on ``channel``; ``answers``: the received frame it replies to."""
        self._noted.append((self.sim_clock.now_ns, channel, _frame(channel, msg), answers, None))
        if len(self._noted) >= self.batch:
            self.settle(self.slice_size)

    def received(self, channel: str, msg: can.Message) -> Queued:
        """A frame the plant side took off ``channel`` (the controller's); its place on the wire."""
        frame = _frame(channel, msg)
        handle = Queued(frame)  # filled in when it is settled
        self._noted.append((self.sim_clock.now_ns, channel, frame, None, handle))
        if len(self._noted) >= self.batch:
            self.settle(self.slice_size)
        return handle

    def pending(self) -> bool:
        """Whether frames are noted and not settled yet."""
        return bool(self._noted) if self._core is None else self._core.pending() > 0

    def settle(self, limit: int | None = None) -> None:
        """Every noted frame (``limit``: the oldest that many) on its wire, in the order noted;
        what is settled handed to the sinks. Slices give the record one settle would: each
        frame is taken in order with the clock time it was noted at.

        Each frame first closes the load window its time reached (the frames
        before it counted); the rig's SYNC is its bus's barrier; a controller's
        frame is queued no earlier than the end of the latest SYNC; whenever
        the clock has moved the wires run up to it.
        """
        if self._core is not None:
            self._hand_over(self._core.settle(-1 if limit is None else limit))
            return
        noted, self._noted = self._noted, []
        if limit is not None and len(noted) > limit:  # the oldest ``limit``: the rest as if noted after
            noted, self._noted = noted[:limit], noted[limit:]
        if not noted:
            return
        durations = wire_ns_batch([n[2] for n in noted], self.bitrate)
        load, out = self.load, []
        wires = self.wires
        self.frames += len(noted)
        for (now_ns, channel, frame, answers, handle), duration in zip(noted, durations):
            if now_ns >= load.due_ns:
                load.sample(now_ns)
            wire = wires.get(channel) or self.wire(channel)
            emit = False
            if handle is not None:
                wire.queue_controller(frame, max(now_ns, self._tick_ns), duration, handle)
            elif frame.arbitration_id == SYNC_ID and not frame.is_extended and not frame.is_error:
                self._tick_ns = max(self._tick_ns, wire.barrier(frame, now_ns, duration))
                emit = True
            else:
                wire.queue(frame, now_ns, answers, duration)
            if now_ns > self._run_to_ns:
                # a frame queued at the clock's time starts at it or later, so wires run up
                # to ``now_ns`` stay so while the clock stands still
                for each in wires.values():
                    each.run_until(now_ns)
                self._run_to_ns = now_ns
                emit = True
            if emit:
                self._emit(now_ns, out)
        self._hand_over(out)

    def _emit(self, now_ns: int | None, out: list[Frame]) -> None:
        """Onto ``out``: every sent frame no later frame can precede (None: every one), in time order.

        A wire's next frame ends after its last one and after ``now_ns`` (nothing
        is queued in the past), so frames up to the earliest of those are settled.
        """
        wires = self.wires.values()
        if now_ns is None:
            settled = None
        else:
            settled = None
            for wire in wires:  # min(max(free_ns, now_ns)), written out: ~4 times a tick
                free = wire.free_ns if wire.free_ns > now_ns else now_ns
                if settled is None or free < settled:
                    settled = free
        # Each wire's frames are in time order (each ends after the one before it): take
        # every wire's settled ones, then one stable sort by time puts the buses' frames
        # in time order with ties in channel order, as a merge would.
        start, buses = len(out), 0
        for wire in wires:
            queue = wire.sent
            if not queue:
                continue
            buses += 1
            if settled is None:
                out += queue
                queue.clear()
            else:
                while queue and queue[0].t_ns <= settled:
                    out.append(queue.popleft())
        if buses > 1 and len(out) - start > 1:
            out[start:] = sorted(out[start:], key=_T_NS)

    def _hand_over(self, frames: list[Frame]) -> None:
        if frames:
            for sink in self.sinks:
                sink.on_frames(frames)

    def stop(self) -> None:
        """Every frame still queued sent and handed over, the last (partial) load window, every sink stopped."""
        self.settle()
        if self._core is not None:
            self._hand_over(self._core.finish())
            self._list_wires()
        else:
            for wire in self.wires.values():
                wire.run_until(None)
            out: list[Frame] = []
            self._emit(None, out)
            self._hand_over(out)
        self.load.sample(self.sim_clock.now_ns, final=True)
        for sink in self.sinks:
            sink.stop()


def _frame(channel: str, msg: can.Message) -> Frame:
    data, dlc = msg.data, msg.dlc
    # the payload up to the DLC; sliced only when longer (a slice is a second copy, ~20 a tick)
    return Frame(0, channel, msg.arbitration_id, msg.is_extended_id, bytes(data) if len(data) <= dlc
                 else bytes(data[:dlc]), dlc, "", msg.is_error_frame, msg.is_remote_frame, msg.is_fd)


class WireView:
    """A bus of the compiled record path as ``LoadMeter`` and readers see a ``BusWire``: its counts."""

    __slots__ = ("_core", "channel")

    def __init__(self, core, channel: str):
        self._core, self.channel = core, channel
        core.wire_state(channel)  # listed from now on

    @property
    def free_ns(self) -> int:
        return self._core.wire_state(self.channel)[0]

    @property
    def busy_ns_total(self) -> int:
        return self._core.wire_state(self.channel)[1]

    @property
    def frames_total(self) -> int:
        return self._core.wire_state(self.channel)[2]

    @property
    def waiting(self) -> int:
        return self._core.wire_state(self.channel)[3]
