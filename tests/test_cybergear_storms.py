"""No reply storms: a CyberGear never answers another device's reply, nor its own echo.

docs/protocols.md (reply storms) gives the rules: a request's bits 15..8 name
its sender, a host; a motor answers a sender in 0..127 only when it is its
CAN_MASTER (``host_id``), because every motor's frame carries the motor's own
id there; and a frame the motor sent itself, heard back on an echoing
transport, is consumed, not answered. The tests feed replies back to their
sender and to a second motor and count the frames until the bus is quiet.
"""
from __future__ import annotations

import itertools
import random
import struct
import uuid

import can
import pytest

from wheelleg.dbc import cybergear as cg
from wheelleg.emulators.cybergear import CyberGear
from wheelleg.emulators.node import DeviceNode

MAX_ROUNDS = 50  # a storm goes on forever; a bounded exchange is over within a few rounds
IQ_REF = struct.pack("<HHf", 0x7006, 0, 0.0)  # a read whose zero value makes reply == request


def frame(can_id: int, data: bytes = bytes(8)) -> can.Message:
    return can.Message(arbitration_id=can_id, data=data, is_extended_id=True)


def exchange(motors: list[CyberGear], seeds: list[can.Message]) -> list[int]:
    """Frames sent per round after ``seeds``, every frame reaching every motor, its sender too.

    Round 1 holds the answers to the seeds; any later round is an answer to an answer.
    """
    pending, rounds, now = list(seeds), [], 0.0
    for _ in range(MAX_ROUNDS):
        if not pending:
            return rounds
        pending = [reply for msg in pending for m in motors for reply in m.handle(msg, now)]
        rounds.append(len(pending))
        now += 0.001
    raise AssertionError(f"still talking after {MAX_ROUNDS} rounds ({rounds} frames): a reply storm")


SEED_TYPES = [0, 1, 2, 3, 4, 5, 6, 7, 17, 18, 19, 20, 21, 22]
SEED_PAYLOADS = [bytes(8), IQ_REF, bytes([1] + [0] * 7), bytes(range(8))]


TABLE_FRAMES = len(CyberGear().handle(frame(cg.request_id(cg.T_PARAM_TABLE, 0xFD, 0x7F)), 0.0))


def answers(request: can.Message) -> int:
    """The frames one request gets at most: the whole table for type 19, four for a type-9 string, else one."""
    return {cg.T_PARAM_TABLE: TABLE_FRAMES, cg.T_CONFIG_READ: 4}.get(cg.comm_type(request.arbitration_id), 1)


def seed_frames() -> list[can.Message]:
    """Every request type, from hosts that are and are not motor ids, to both motors."""
    return [frame((t << 24) | (host << 8) | target, data)
            for t, host, target, data in itertools.product(SEED_TYPES, (0x00, 0x7F, 0x05, 0xFD),
                                                           (0x7F, 0x00, 0x05), SEED_PAYLOADS)]


def three_motors(host_id: int = 0x00) -> list[CyberGear]:
    motors = [CyberGear(motor_id=0x7F, host_id=host_id), CyberGear(motor_id=0x00, host_id=host_id),
              CyberGear(motor_id=0x05, host_id=host_id)]
    for m in motors:  # enabled, so that feedback, faults and torque are live
        m.handle(frame(cg.request_id(cg.T_ENABLE, 0xFD, m.motor_id)), 0.0)
    return motors


@pytest.mark.parametrize("host_id", [0x00, 0x7F, 0x05])
def test_no_single_frame_starts_a_storm(host_id):
    for seed in seed_frames():  # fresh motors each time: type 7 moves ids
        rounds = exchange(three_motors(host_id), [seed])
        # one answer at most, never an answer to an answer
        assert rounds[1:] in ([], [0]) and (not rounds or rounds[0] in (0, answers(seed))), seed


@pytest.mark.parametrize("host_id", [0x00, 0x7F])
def test_no_pair_of_frames_starts_a_storm(host_id):
    rng, seeds = random.Random(7), seed_frames()
    for _ in range(1500):
        pair = rng.sample(seeds, 2)
        rounds = exchange(three_motors(host_id), pair)
        # (type 7 may give two motors one id: one more answer)
        assert rounds[1:] in ([], [0]) and rounds[:1] <= [answers(pair[0]) + answers(pair[1]) + 1], pair


def test_a_motor_ignores_another_motors_reply_to_its_host():
    a, b = CyberGear(motor_id=0x7F), CyberGear(motor_id=0x00)  # host 0x00, as CAN_MASTER's default
    reply = a.handle(frame(cg.request_id(cg.T_PARAM_READ, 0x00, 0x7F), IQ_REF), 0.0)
    assert len(reply) == 1 and cg.target(reply[0].arbitration_id) == 0x00
    assert b.handle(reply[0], 0.0) == []
    # ... while the host itself (sender 0x00) still reaches motor 0x00
    assert len(b.handle(frame(cg.request_id(cg.T_PARAM_READ, 0x00, 0x00), IQ_REF), 0.0)) == 1


def test_hosts_above_127_are_always_answered_and_others_only_when_configured():
    motor = CyberGear(motor_id=1)
    for host in (0x00, 0x80, 0xFD, 0xFE, 0xFF):
        assert len(motor.handle(frame(cg.request_id(cg.T_ENABLE, host, 1)), 0.0)) == 1
    assert motor.handle(frame(cg.request_id(cg.T_ENABLE, 0x22, 1)), 0.0) == []
    assert len(CyberGear(motor_id=1, host_id=0x22).handle(frame(cg.request_id(cg.T_ENABLE, 0x22, 1)), 0.0)) == 1


def _serve_until_quiet(nodes: list[DeviceNode], rounds: int = 200) -> int:
    for _ in range(rounds):
        if sum(node.service(0.0) for node in nodes) == 0:
            return sum(node.frames_out for node in nodes)
    raise AssertionError(f"the bus never went quiet: {sum(n.frames_out for n in nodes)} frames")


@pytest.mark.parametrize("host_id, replies", [(0x00, 0), (0x7F, 1)])
def test_host_equal_to_motor_id_on_an_echoing_bus_ends(host_id, replies):
    """``03007F7F#00..``: ignored (0x7F is a motor's id), or answered once when 0x7F is CAN_MASTER."""
    channel = f"echo-{uuid.uuid4().hex}"
    host = can.Bus(interface="virtual", channel=channel)
    device = can.Bus(interface="virtual", channel=channel, receive_own_messages=True)
    motor, sent = CyberGear(motor_id=0x7F, host_id=host_id), 0
    try:
        host.send(frame(0x03007F7F))
        for _ in range(MAX_ROUNDS):  # what DeviceNode does, bounded: a storm would never drain
            if (msg := device.recv(timeout=0)) is None:
                break
            for reply in motor.handle(msg, 0.0):
                device.send(reply)
                sent += 1
        assert device.recv(timeout=0) is None and sent == replies
    finally:
        host.shutdown()
        device.shutdown()


def test_two_emulated_motors_on_separate_nodes_do_not_bounce_replies():
    channel = f"pair-{uuid.uuid4().hex}"
    buses = [can.Bus(interface="virtual", channel=channel) for _ in range(3)]
    try:
        nodes = [DeviceNode(buses[1], [CyberGear(motor_id=0x7F)]), DeviceNode(buses[2], [CyberGear(motor_id=0x00)])]
        for ctype, target in itertools.product((2, 3, 17, 21), (0x7F, 0x00)):
            buses[0].send(frame(cg.request_id(ctype, 0x00, target), IQ_REF if ctype == 17 else bytes(8)))
        assert _serve_until_quiet(nodes) == 8  # one answer per request, none to an answer
    finally:
        for bus in buses:
            bus.shutdown()


def test_change_id_to_the_can_master_id_keeps_the_old_id():
    """At its master's address a motor could not tell the master's requests from a twin's replies."""
    motor = CyberGear(motor_id=0x7F, host_id=0x00)
    reply = motor.handle(frame(cg.set_id_id(0x00, 0xFD, 0x7F)), 0.0)
    assert motor.motor_id == 0x7F and cg.parse_reply_id(reply[0].arbitration_id).motor_id == 0x7F


class _Counting(CyberGear):
    """A CyberGear that counts the frames its node hands it."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.handed = []

    def handle(self, msg, now_s):
        self.handed.append(msg.arbitration_id)
        return super().handle(msg, now_s)


class _Bus:
    """Just what a DeviceNode sends on."""

    def __init__(self):
        self.sent = []

    def send(self, msg, timeout=None):
        self.sent.append(msg)


def test_node_hands_a_motor_only_the_frames_addressed_to_it_and_follows_an_id_change():
    """``rx_filter``: the node skips the motors a frame is not for (standard frames, other
    targets), as the motor's own first test would; the same replies as handing every frame over."""
    one, two = _Counting(motor_id=0x01), _Counting(motor_id=0x02)
    bus = _Bus()
    node = DeviceNode(bus, [one, two])
    enable_two = frame(cg.request_id(cg.T_ENABLE, 0x00, 0x02))
    node.dispatch(enable_two, 0.0)
    node.dispatch(can.Message(arbitration_id=0x02, data=bytes(8), is_extended_id=False), 0.0)  # standard id
    assert one.handed == [] and two.handed == [enable_two.arbitration_id]
    assert len(bus.sent) == 1  # motor 2's answer
    move = frame(cg.set_id_id(0x03, 0x00, 0x01))  # motor 1 takes id 3
    node.dispatch(move, 0.0)
    enable_three = frame(cg.request_id(cg.T_ENABLE, 0x00, 0x03))
    node.dispatch(enable_three, 0.0)
    assert one.motor_id == 0x03 and one.handed == [move.arbitration_id, enable_three.arbitration_id]
    assert two.handed == [enable_two.arbitration_id] and len(bus.sent) == 3
