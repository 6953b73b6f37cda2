"""The record's bus order (hil/bus/wire_order.py, hil/bus/recorder.py): arbitration, the
controller's transmit queue, SYNC as a barrier, time order across buses; and the run itself
left alone by it."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from wheelleg.dbc import cybergear as cg
from wheelleg.hil import scenarios
from wheelleg.hil.bus import wire_order
from wheelleg.hil.bus.busload import wire_ns
from wheelleg.hil.bus.wire_order import BusWire
from wheelleg.hil.record.candump import read_candump
from wheelleg.hil.record.frame import Frame
from wheelleg.hil.record.trace import TraceReader
from wheelleg.hil.scenarios.common import push
from wheelleg.hil.run import rig as rig_module

from sharing import same_fixture

BITRATE = 1_000_000
SYNC, HEARTBEAT = 0x080, 0x710


def frame(arbitration_id: int, extended: bool = False, size: int = 8, error: bool = False) -> Frame:
    return Frame(0, "vcan1", arbitration_id, extended, bytes(size), size, is_error=error)


def wire_of(f: Frame) -> int:
    return wire_ns(f.arbitration_id, f.is_extended, f.data, BITRATE)


def on_wire(wire: BusWire) -> list[int]:
    wire.run_until(None)
    return [f.arbitration_id for f in wire.sent]


# -- the model, frame by frame -----------------------------------------------------------------
def test_the_controllers_frames_go_back_to_back_in_the_order_it_queued_them():
    wire = BusWire(BITRATE)
    first, second = frame(0x0180_0001, True), frame(0x0170_0002, True)  # the second has the lower id
    wire.queue_controller(first, 1000)
    wire.queue_controller(second, 1000)
    assert on_wire(wire) == [0x0180_0001, 0x0170_0002]
    assert first.t_ns == 1000 + wire_of(first)  # stamped at the end of its transmission
    assert second.t_ns == first.t_ns + wire_of(second)


def test_a_reply_with_a_lower_id_wins_over_the_queued_commands_a_higher_one_waits():
    wire = BusWire(BITRATE)
    stops = [wire.queue_controller(frame(cg.request_id(cg.T_STOP, 0xFD, m), True), 0) for m in (1, 2)]
    wire.queue_controller(frame(HEARTBEAT), 0)
    wire.queue(frame(cg.reply_id(cg.T_FEEDBACK, 1, 0xFD, 2), True), 0, answers=stops[0])  # type 2 < type 4
    assert on_wire(wire) == [0x0400_FD01, 0x0280_01FD, 0x0400_FD02, HEARTBEAT]

    wire = BusWire(BITRATE)
    torques = [wire.queue_controller(frame(cg.motion_id(0.0, m), True), 0) for m in (1, 2)]
    wire.queue_controller(frame(HEARTBEAT), 0)
    wire.queue(frame(cg.reply_id(cg.T_FEEDBACK, 1, 0xFD, 2), True), 0, answers=torques[0])  # type 1 < type 2
    assert on_wire(wire) == [cg.motion_id(0.0, 1), cg.motion_id(0.0, 2), 0x0280_01FD, HEARTBEAT]  # 0x710 last


def test_a_reply_is_queued_when_the_frame_it_answers_has_been_received(monkeypatch):
    monkeypatch.setattr(wire_order, "RESPONSE_NS", 500_000)
    wire = BusWire(BITRATE)
    command = wire.queue_controller(frame(cg.motion_id(0.0, 1), True), 0)
    reply = frame(cg.reply_id(cg.T_FEEDBACK, 1, 0xFD, 2), True)
    wire.queue(reply, 0, answers=command)
    wire.queue_controller(frame(HEARTBEAT), 0)
    assert on_wire(wire) == [cg.motion_id(0.0, 1), HEARTBEAT, 0x0280_01FD]  # a slow motor: 0x710 goes first
    assert reply.t_ns == command.end_ns + 500_000 + wire_of(reply)


def test_sync_is_a_barrier_and_error_frames_follow_their_frame():
    wire = BusWire(BITRATE)
    late = frame(0x300)
    wire.queue(late, 0)
    wire.queue(frame(0x100), 0)
    wire.queue(frame(0x0, error=True), 0)  # flags 0x100 (queued just before it)
    sync = frame(SYNC, size=4)
    end = wire.barrier(sync, 0)
    wire.queue(frame(0x001), 0)  # a lower id than SYNC, queued after it
    assert on_wire(wire) == [0x100, 0x0, 0x300, SYNC, 0x001]
    assert end == sync.t_ns == late.t_ns + wire_of(sync)


def test_nothing_is_decided_before_its_time_and_load_counts_frames_when_queued():
    wire = BusWire(BITRATE)
    wire.queue(frame(0x300), 100_000)
    wire.run_until(100_000)  # the wire is free until 100 us: another frame may still be queued for then
    assert not wire.sent and wire.frames_total == 1
    wire.queue(frame(0x100), 100_000)
    wire.run_until(100_001)  # 0x100 wins at 100 us; 0x300's turn comes after it, not yet decided
    assert [f.arbitration_id for f in wire.sent] == [0x100]
    assert on_wire(wire) == [0x100, 0x300]
    assert wire.busy_ns_total == wire_of(frame(0x100)) + wire_of(frame(0x300))


# -- a run of the rig --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def balance_log(tmp_path_factory):
    scenario = replace(scenarios.get("balance"), duration_s=0.3)
    out = rig_module.Rig(scenario, rig_module.RigConfig(), tmp_path_factory.mktemp("order")).run()
    return list(read_candump(out.log_path))


@same_fixture("balance_log")
def test_the_log_is_in_time_order_across_both_buses(balance_log):
    times = [f.t_ns for f in balance_log]
    assert len(times) > 2500 and {f.channel for f in balance_log} == {"vcan0", "vcan1"}
    back = [i for i in range(1, len(times)) if times[i] < times[i - 1]]
    assert not back, f"{len(back)} steps back, first at line {back[0] + 1}"


def _ticks(frames: list[Frame], channel: str) -> list[list[Frame]]:
    """One bus's frames cut at each SYNC: [SYNC, what follows up to the next SYNC]."""
    ticks: list[list[Frame]] = []
    for f in frames:
        if f.channel != channel:
            continue
        if f.arbitration_id == SYNC and not f.is_extended:
            ticks.append([])
        if ticks:
            ticks[-1].append(f)
    return ticks


def _kind(f: Frame) -> str:
    if not f.is_extended:
        return {SYNC: "sync", HEARTBEAT: "hb"}.get(f.arbitration_id, hex(f.arbitration_id))
    if cg.is_reply(f.arbitration_id, 0xFD):
        return f"reply{cg.reply_motor(f.arbitration_id)}"
    return f"type{cg.comm_type(f.arbitration_id)}-{cg.target(f.arbitration_id)}"


@same_fixture("balance_log")
def test_each_bus_is_in_the_order_arbitration_gives(balance_log):
    can2 = _ticks(balance_log, "vcan1")
    enable = [_kind(f) for f in can2[1]]  # tick 1 enables: stop, run-mode write, enable per motor
    assert enable[:7] == ["sync", "type4-1", "reply1", "type18-1", "reply1", "type3-1", "reply1"]  # 2 < 18, 3, 4
    steady = [tick for tick in can2[50:] if _kind(tick[1]).startswith("type1")]
    assert len(steady) > 50
    unsorted = 0
    for tick in steady:
        assert [_kind(f) for f in tick] == ["sync", "type1-1", "type1-2", "type1-3", "type1-4",
                                            "reply1", "reply2", "reply3", "reply4", "hb"]
        commands = [f.arbitration_id for f in tick[1:5]]
        unsorted += commands != sorted(commands)  # a lower id still waits for the one queued before it
        for before, f in zip(tick[1:], tick[2:]):  # the bus never idles from the first command on
            assert f.t_ns - before.t_ns == wire_of(f)
    assert unsorted > 0


class HandlingOrder:
    """The recorder as it was: each frame stamped with the rig's clock, in the order the rig handles it."""

    def __init__(self, sinks, clock, channels, load_to=None, batch=None, slice_size=None):
        self.sinks, self.clock = sinks, clock

    def sent(self, channel, msg, answers=None):
        for sink in self.sinks:
            sink.on_frame(Frame.of(msg, channel, self.clock.now_ns))

    def received(self, channel, msg):
        self.sent(channel, msg)

    def stop(self):
        for sink in self.sinks:
            sink.stop()


def test_the_record_order_leaves_the_run_alone(tmp_path, monkeypatch):
    """The same ground truth and the same frames per bus and tick, recorded in either order."""
    balance = scenarios.get("balance")  # pushed at 0.1 s: the physics has work to do
    scenario = replace(balance, duration_s=0.4, timeline=[*balance.timeline, *push(0.1, (20.0, 0.0, 0.0), 0.1)])
    wire = rig_module.Rig(scenario, rig_module.RigConfig(), tmp_path / "wire").run()
    monkeypatch.setattr(rig_module, "Recorder", HandlingOrder)
    handled = rig_module.Rig(scenario, rig_module.RigConfig(), tmp_path / "handled").run()
    truth = [TraceReader(out.trace_path).sim_state() for out in (wire, handled)]
    assert truth[0].keys() == truth[1].keys() and len(truth[0]["t"]) == 200
    for key in truth[0]:
        np.testing.assert_array_equal(truth[0][key], truth[1][key], err_msg=key)
    logs = [list(read_candump(out.log_path)) for out in (wire, handled)]
    for channel in ("vcan0", "vcan1"):
        ticks = [[sorted((f.arbitration_id, f.data) for f in tick) for tick in _ticks(log, channel)]
                 for log in logs]
        assert ticks[0] == ticks[1]
    assert [(f.channel, f.arbitration_id, f.data) for f in logs[0]] != \
        [(f.channel, f.arbitration_id, f.data) for f in logs[1]]
