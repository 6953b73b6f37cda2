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

import heapq
from collections import deque
from functools import lru_cache

from wheelleg.hil.bus.busload import arbitration_priority, wire_ns
from wheelleg.hil.record.frame import Frame

# ns from the end of a received command to the device's reply being queued. The
# CyberGear's reply latency is undocumented; 0 takes it as instant. Any latency below
# about 0.44 ms (the three torque commands queued behind the first) gives the same log
# from the first torque tick on: the replies wait for the wire either way (0.4 ms
# changes only the enable ticks, 0.45 ms every tick: measured on balance).
RESPONSE_NS = 0
_FIRST = -1  # priority of an error frame: it takes the wire right after the frame it flags
_priority = lru_cache(maxsize=4096)(arbitration_priority)  # a bus has a few dozen identifiers
_SEQ_BITS = 40  # a frame's key: its priority, then the order it was queued in (2^40 frames a run)


class Queued:
    """One frame waiting for (or put on) the wire; ``frame.t_ns`` is set when it has been sent.

    ``key`` orders arbitration (smaller wins): the frame's priority, then
    the order it was queued in. ``ready_ns`` is when its sender queued it,
    None while the frame it answers is still waiting (then ``delay_ns`` after
    that frame's end); ``end_ns`` the end of its transmission once sent.
    """

    __slots__ = ("frame", "wire_ns", "key", "ready_ns", "delay_ns", "end_ns", "replies")

    def __init__(self, frame: Frame, duration_ns: int = 0, key: int = 0, ready_ns: int | None = None):
        self.frame, self.wire_ns, self.key, self.ready_ns = frame, duration_ns, key, ready_ns
        self.delay_ns = 0
        self.end_ns: int | None = None
        self.replies: list | None = None  # (wire, reply) queued before this frame was sent


class BusWire:
    """One bus's wire in the record: frames queued in the rig's order, sent in the bus's.

    ``busy_ns_total`` and ``frames_total`` count every frame when it is queued
    (``busload.LoadMeter`` windows them into ``/bus/load``). Arbitration keeps
    two heaps instead of scanning every waiting frame: ``_timed`` (ready time,
    key) of the frames whose queueing time is known, and ``_eligible`` (key) of
    those queued by the wire's clock (``free_ns`` never goes back, so a frame
    once eligible stays so); a reply joins ``_timed`` when the frame it answers
    has been sent.
    """

    def __init__(self, bitrate: int):
        self.bitrate = bitrate
        self.free_ns = 0  # end of the last frame on the wire
        self.busy_ns_total = 0
        self.frames_total = 0
        self.controller: deque[Queued] = deque()  # the controller's transmit queue, in its order
        self._timed: list[tuple] = []  # heap of (ready ns, key, Queued): every other node's frames
        self._eligible: list[tuple] = []  # heap of (key, Queued): those queued by the wire's clock
        self._unresolved = 0  # replies whose frame has not been sent yet
        self.sent: deque[Frame] = deque()  # frames on the wire, in wire order, not yet taken
        self._seq = 0
        self._last: Queued | None = None  # the frame queued last (an error frame flags it)

    def _queued(self, frame: Frame, ready_ns: int | None, duration_ns: int | None = None,
                item: Queued | None = None) -> Queued:
        if duration_ns is None:
            duration_ns = wire_ns(frame.arbitration_id, frame.is_extended, frame.data, self.bitrate)
        self.busy_ns_total += duration_ns
        self.frames_total += 1
        self._seq = seq = self._seq + 1
        priority = _FIRST if frame.is_error else _priority(frame.arbitration_id, frame.is_extended, frame.is_remote)
        key = (priority << _SEQ_BITS) + seq
        if item is None:
            item = Queued(frame, duration_ns, key, ready_ns)
        else:  # a handle made when the frame was handed over (``Recorder.received``)
            item.frame, item.wire_ns, item.key, item.ready_ns = frame, duration_ns, key, ready_ns
        self._last = item
        return item

    def queue(self, frame: Frame, ready_ns: int, answers: Queued | None = None,
              duration_ns: int | None = None) -> Queued:
        """A device's frame, queued at ``ready_ns``, or ``RESPONSE_NS`` after ``answers`` ends.

        ``duration_ns``: its wire time when the caller has it (``busload.wire_ns`` otherwise).
        """
        if frame.is_error and self._last is not None:
            answers, delay_ns = self._last, 0
        else:
            delay_ns = RESPONSE_NS
        if answers is None:
            item = self._queued(frame, ready_ns, duration_ns)
            heapq.heappush(self._timed, (ready_ns, item.key, item))
            return item
        item = self._queued(frame, None, duration_ns)
        if answers.end_ns is not None:
            item.ready_ns = answers.end_ns + delay_ns
            heapq.heappush(self._timed, (item.ready_ns, item.key, item))
        else:
            item.delay_ns = delay_ns
            if answers.replies is None:
                answers.replies = []
            answers.replies.append((self, item))
            self._unresolved += 1
        return item

    def queue_controller(self, frame: Frame, ready_ns: int, duration_ns: int | None = None,
                         item: Queued | None = None) -> Queued:
        """A frame of the controller, queued at ``ready_ns`` behind its earlier ones."""
        item = self._queued(frame, ready_ns, duration_ns, item)
        self.controller.append(item)
        return item

    def barrier(self, frame: Frame, ready_ns: int, duration_ns: int | None = None) -> int:
        """Everything queued goes first, then ``frame`` from ``ready_ns``; returns its end (ns)."""
        self.run_until(None)
        item = self._queued(frame, ready_ns, duration_ns)
        self._send(item, max(ready_ns, self.free_ns))
        return self.free_ns

    @property
    def waiting(self) -> int:
        """Frames queued by other nodes than the controller and not sent yet."""
        return len(self._timed) + len(self._eligible) + self._unresolved

    def run_until(self, now_ns: int | None) -> None:
        """Send every frame whose transmission starts before ``now_ns`` (None: all that wait).

        The next frame starts when the wire is free, or, idle, when the first
        frame is queued; it is the one with the lowest key among the frames
        queued by then (the controller's by its queue's head only).
        """
        timed, eligible, controller = self._timed, self._eligible, self.controller
        pop, push = heapq.heappop, heapq.heappush
        while True:
            start = self.free_ns
            while timed and timed[0][0] <= start:
                _, key, item = pop(timed)
                push(eligible, (key, item))
            head = controller[0] if controller and controller[0].ready_ns <= start else None
            if not eligible and head is None:  # idle until the first frame is queued
                if timed:
                    start = timed[0][0]
                    if controller and controller[0].ready_ns < start:
                        start = controller[0].ready_ns
                elif controller:
                    start = controller[0].ready_ns
                else:
                    return
                if now_ns is not None and start >= now_ns:
                    return
                while timed and timed[0][0] <= start:
                    _, key, item = pop(timed)
                    push(eligible, (key, item))
                head = controller[0] if controller and controller[0].ready_ns <= start else None
            elif now_ns is not None and start >= now_ns:
                return
            if head is not None and (not eligible or head.key < eligible[0][0]):
                controller.popleft()
                self._send(head, start)
            else:
                self._send(pop(eligible)[1], start)

    def _send(self, item: Queued, start_ns: int) -> None:
        item.end_ns = self.free_ns = start_ns + item.wire_ns
        item.frame.t_ns = item.end_ns
        self.sent.append(item.frame)
        if item.replies is not None:  # the replies to it are queued now
            for wire, reply in item.replies:
                reply.ready_ns = item.end_ns + reply.delay_ns
                heapq.heappush(wire._timed, (reply.ready_ns, reply.key, reply))
                wire._unresolved -= 1
            item.replies = None
