"""The record's model of one CAN bus: when each frame is queued and in what order the wire takes them.

The rig hands frames to the recorder in the order it runs: the plant serves a
bus frame by frame, so each command comes with its reply right after it, and
a tick's SYNC, commands and replies are all handled at one instant of
simulated time. A real bus orders them otherwise. ``BusWire`` takes the
frames of one bus in the rig's order, each with the time its sender queued
it, and gives them back in the order and at the times a classic CAN bus
delivers them:

- one frame at a time: a frame starts when the wire is free and is stamped
  with the end of its transmission (its wire time from ``busload.wire_ns``,
  stuff bits included), as a receiver sees it;
- arbitration: when the wire is free, of the frames queued by then the one
  with the lowest identifier wins (``busload.arbitration_priority``); equal
  identifiers go in the order they were queued;
- the controller's frames form one transmit queue that goes out back to back
  in the order it sent them: only its head arbitrates;
- a reply is queued when the frame it answers has been received (the end of
  that frame) plus the device's response time, ``RESPONSE_NS``;
- an error frame follows the frame it flags at once;
- a barrier (the rig's SYNC) goes on the wire after every frame queued before
  it, and every frame queued after it waits for its end.

Frames are decided as simulated time passes (``run_until``): a transmission
that starts before the rig's clock cannot be overtaken by a frame queued
later, since nothing is ever queued in the past.
"""
from __future__ import annotations

from collections import deque

from wheelleg.hil.bus.busload import arbitration_priority, wire_ns
from wheelleg.hil.record.frame import Frame

# ns from the end of a received command to the device's reply being queued. The
# CyberGear's reply latency is undocumented; 0 takes it as instant. Any latency below
# about 0.44 ms (the three torque commands queued behind the first) gives the same log
# from the first torque tick on: the replies wait for the wire either way (0.4 ms
# changes only the enable ticks, 0.45 ms every tick: measured on balance).
RESPONSE_NS = 0
_FIRST = -1  # priority of an error frame: it takes the wire right after the frame it flags


class Queued:
    """One frame waiting for (or put on) the wire; ``frame.t_ns`` is set when it has been sent."""

    __slots__ = ("frame", "wire_ns", "key", "ready_ns", "answers", "delay_ns", "end_ns")

    def __init__(self, frame: Frame, duration_ns: int, key: tuple, ready_ns: int | None,
                 answers: "Queued | None" = None, delay_ns: int = 0):
        self.frame, self.wire_ns, self.key = frame, duration_ns, key
        self.ready_ns = ready_ns  # None while the frame it answers is still waiting
        self.answers, self.delay_ns = answers, delay_ns
        self.end_ns: int | None = None

    def ready(self) -> int | None:
        """When the sender queued it (ns), None while that is not known yet."""
        if self.ready_ns is None and self.answers.end_ns is not None:
            self.ready_ns = self.answers.end_ns + self.delay_ns
        return self.ready_ns


class BusWire:
    """One bus's wire in the record: frames queued in the rig's order, sent in the bus's.

    ``busy_ns_total`` and ``frames_total`` count every frame when it is queued
    (``busload.LoadMeter`` windows them into ``/bus/load``).
    """

    def __init__(self, bitrate: int):
        self.bitrate = bitrate
        self.free_ns = 0  # end of the last frame on the wire
        self.busy_ns_total = 0
        self.frames_total = 0
        self.controller: deque[Queued] = deque()  # the controller's transmit queue, in its order
        self.waiting: list[Queued] = []  # every other node's frames
        self.sent: deque[Frame] = deque()  # frames on the wire, in wire order, not yet taken
        self._seq = 0
        self._last: Queued | None = None  # the frame queued last (an error frame flags it)

    def _queued(self, frame: Frame, ready_ns: int | None, answers: Queued | None = None,
                delay_ns: int = 0) -> Queued:
        duration = wire_ns(frame.arbitration_id, frame.is_extended, frame.data, self.bitrate)
        self.busy_ns_total += duration
        self.frames_total += 1
        self._seq += 1
        priority = _FIRST if frame.is_error else arbitration_priority(
            frame.arbitration_id, frame.is_extended, frame.is_remote)
        item = Queued(frame, duration, (priority, self._seq), ready_ns, answers, delay_ns)
        self._last = item
        return item

    def queue(self, frame: Frame, ready_ns: int, answers: Queued | None = None) -> Queued:
        """A device's frame, queued at ``ready_ns``, or ``RESPONSE_NS`` after ``answers`` ends."""
        if frame.is_error and self._last is not None:
            item = self._queued(frame, None, self._last)
        elif answers is not None:
            item = self._queued(frame, None, answers, RESPONSE_NS)
        else:
            item = self._queued(frame, ready_ns)
        self.waiting.append(item)
        return item

    def queue_controller(self, frame: Frame, ready_ns: int) -> Queued:
        """A frame of the controller, queued at ``ready_ns`` behind its earlier ones."""
        item = self._queued(frame, ready_ns)
        self.controller.append(item)
        return item

    def barrier(self, frame: Frame, ready_ns: int) -> int:
        """Everything queued goes first, then ``frame`` from ``ready_ns``; returns its end (ns)."""
        self.run_until(None)
        item = self._queued(frame, ready_ns)
        self._send(item, max(ready_ns, self.free_ns))
        return self.free_ns

    def run_until(self, now_ns: int | None) -> None:
        """Send every frame whose transmission starts before ``now_ns`` (None: all that wait)."""
        while self.controller or self.waiting:
            start, best = self._next()
            if best is None or (now_ns is not None and start >= now_ns):
                return
            self._send(best, start)

    def _next(self) -> tuple[int, Queued | None]:
        """The frame that takes the wire next and when, if every queued frame were in."""
        start = self.free_ns
        best = self._winner(start)
        if best is None:  # the bus idles until the first frame is queued
            times = [r for r in map(Queued.ready, self.waiting) if r is not None]
            if self.controller:
                times.append(self.controller[0].ready_ns)
            if not times:
                return start, None
            start = min(times)
            best = self._winner(start)
        return start, best

    def _winner(self, t_ns: int) -> Queued | None:
        """The frame that wins arbitration at ``t_ns`` among those queued by then."""
        best = None
        for item in self.waiting:
            ready = item.ready()
            if ready is not None and ready <= t_ns and (best is None or item.key < best.key):
                best = item
        head = self.controller[0] if self.controller else None
        if head is not None and head.ready_ns <= t_ns and (best is None or head.key < best.key):
            best = head
        return best

    def _send(self, item: Queued, start_ns: int) -> None:
        if self.controller and item is self.controller[0]:
            self.controller.popleft()
        elif item in self.waiting:
            self.waiting.remove(item)
        item.end_ns = self.free_ns = start_ns + item.wire_ns
        item.frame.t_ns = item.end_ns
        self.sent.append(item.frame)
