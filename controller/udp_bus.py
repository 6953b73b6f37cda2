"""python-can's ``udp_multicast`` without its own echo.

A multicast socket hears what it sends (the host loops the group back to
every member, the sender included) and python-can's ``UdpMulticastBus`` cannot
turn that off (``receive_own_messages=True`` is "not yet implemented", False
still echoes). The rig's plant would record each of its frames twice and
count it twice in the bus load; a controller or an emulated device would take
its own frames for the bus's. This bus remembers what it sent and
not yet heard back, and drops a received frame equal to one of those (the
first such). Not only the oldest: a program that sends from two threads (the
controller's tick and its start-up or stop sequence) puts datagrams on the wire
in another order than it noted them, and matching only the oldest then let
every echo after it through. Only this bus's frames are dropped: the rig's two
sides never send the same identifier.

It lives with the controller (the robot's program must not import the rig)
so that every node on the rig's buses, ``wheelleg run``'s plant and
controller, ``wheelleg controller`` and ``wheelleg emulate``, opens it the
same way: ``wheelleg.controller.bus_args.open_bus``.
"""
from __future__ import annotations

from collections import deque

import can
from can.interfaces.udp_multicast import UdpMulticastBus

MAX_PENDING = 4096  # own frames awaiting their echo; beyond this the oldest is forgotten (a lost datagram)


def _key(msg: can.Message) -> tuple:
    return msg.arbitration_id, msg.is_extended_id, msg.is_remote_frame, bytes(msg.data)


class EchoFreeUdpMulticastBus(UdpMulticastBus):
    """``UdpMulticastBus`` that does not receive the frames it sent itself."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.pending = deque(maxlen=MAX_PENDING)  # keys of frames sent and not yet heard back

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        # noted before sending: the host loops the datagram back inside sendto, and a
        # reader in another thread can take the echo before send returns
        key = _key(msg)
        self.pending.append(key)
        try:
            super().send(msg, timeout)
        except BaseException:
            if self.pending and self.pending[-1] == key:
                self.pending.pop()
            raise

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        msg, filtered = super()._recv_internal(timeout)
        if msg is not None and self.pending:
            try:
                self.pending.remove(_key(msg))
            except ValueError:
                return msg, filtered  # another node's
            return None, filtered  # our own frame come back
        return msg, filtered
