"""Plant-side bus ends that hold received frames until the rig releases them.

On python-can's in-process virtual bus the controller's frames of one tick
are all in the plant's queues by the time the controller's ``service`` call
returns, and the plant takes them bus by bus: all of CAN1's, then all of
CAN2's. Over a real transport (SocketCAN) each bus is its own socket and a
frame is delivered when the kernel gets to it, so draining the sockets as
frames trickle in would interleave the buses differently from run to run and
from the virtual bus. The rig therefore first *gathers* each bus's frames
(up to that bus's heartbeat) into a ``HeldBus`` without handing them to the
devices, and only when both heartbeats are in lets the plant drain the held
frames in the virtual bus's order. Same frames, same order, same bytes in the
recording, whatever the transport.
"""
from __future__ import annotations

from collections import deque
from collections.abc import Iterator

import can


class HeldBus:
    """A bus end whose ``recv`` returns only frames already gathered by ``gather``.

    Shaped like the part of ``can.BusABC`` the plant uses (``send``, ``recv``,
    ``shutdown``), so it slots under ``wheelleg.hil.bus.plant_bus.PlantBus``: the
    recorder sees a frame when the plant takes it, not when it was gathered.
    """

    def __init__(self, bus: can.BusABC):
        self.bus = bus
        self.held: deque[can.Message] = deque()

    def gather(self) -> Iterator[can.Message]:
        """Move every frame the transport has now into the hold; yields each one."""
        recv = self.bus.recv
        while (msg := recv(timeout=0.0)) is not None:
            self.held.append(msg)
            yield msg

    def recv(self, timeout: float | None = None) -> can.Message | None:
        """The oldest held frame, or None at once (never waits on the transport)."""
        return self.held.popleft() if self.held else None

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self.bus.send(msg, timeout)

    def shutdown(self) -> None:
        self.bus.shutdown()
