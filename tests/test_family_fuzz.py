"""The new device families under random frames and crowded buses (Damiao, RobStride, C610, GM6020).

Fuzz: any frame (standard or extended, DLC 0-8, remote, biased towards each
family's ids and commands, NaN/inf floats) never raises, never counts an
internal error, and every reply is a frame the family's DBC decodes. Storms:
several devices of one family on one bus, every frame reaching every device
(the senders too), settle within a round: nobody answers an answer.
"""
from __future__ import annotations

import math
import struct

import can
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wheelleg.dbc import load_file
from wheelleg.emulators.damiao import Damiao
from wheelleg.emulators.dji import C610, GM6020
from wheelleg.emulators.robstride import RobStride

NASTY = [math.nan, math.inf, -math.inf, 1e30, -0.0, 5e-324]


def damiao_devices():
    return [Damiao("DM-J4310-2EC", esc_id=1, master_id=0x11), Damiao("DM-J4340-2EC", esc_id=2, master_id=0x12),
            Damiao("DM-J8009P-2EC", esc_id=3, master_id=0x00)]


def robstride_devices():
    return [RobStride("RS01", motor_id=1), RobStride("RS03", motor_id=2), RobStride("RS04", motor_id=0x7F)]


def dji_devices():
    return [C610(1), C610(6), GM6020(1), GM6020(7)]


def _decodes(device, msg: can.Message) -> bool:
    """The reply is a frame the device's DBC describes (by id, or for 29-bit ids by the type bits)."""
    if isinstance(device, Damiao):
        if msg.is_extended_id or len(msg.data) != 8 or msg.arbitration_id != device.master_id:
            return False
        return True  # feedback or register frame at MST_ID: both 8 bytes (tests/test_damiao.py decodes them)
    if isinstance(device, RobStride):
        db = load_file(device.model.dbc)
        ctype = msg.arbitration_id >> 24
        layout = db.get_message_by_frame_id((1 << 31) | (ctype << 24)) if ctype in (0, 2, 17, 21) else None
        return msg.is_extended_id and layout is not None and layout.decode(bytes(msg.data)) is not None
    db = load_file(device.model.dbc)
    return not msg.is_extended_id and db.get_message_by_frame_id(msg.arbitration_id) is not None


ids = st.one_of(st.sampled_from([1, 2, 3, 0x101, 0x102, 0x201, 0x301, 0x7FF, 0x200, 0x1FF, 0x1FE, 0x2FE, 0x2FF]),
                st.integers(0, 0x7FF))
ext_ids = st.builds(lambda t, mid, target: (t << 24) | (mid << 8) | target, st.integers(0, 31),
                    st.integers(0, 0xFFFF), st.sampled_from([1, 2, 0x7F, 0, 0xFE]))
payloads = st.one_of(st.binary(max_size=8),
                     st.builds(lambda op, rid, f: bytes([1, 0, op, rid]) + struct.pack("<f", f),
                               st.sampled_from([0x33, 0x55, 0xAA, 0xCC]), st.integers(0, 90), st.sampled_from(NASTY)),
                     st.builds(lambda idx, f: struct.pack("<HH", idx, 0) + struct.pack("<f", f),
                               st.integers(0x7005, 0x7029), st.sampled_from(NASTY)),
                     st.builds(lambda c: bytes([0xFF] * 7 + [c]), st.integers(0xF0, 0xFF)),
                     st.builds(lambda b: bytes(range(1, 7)) + bytes([b, 0]), st.integers(0, 3)))


@settings(max_examples=400, deadline=None)
@given(frames=st.lists(st.tuples(st.booleans(), ids, ext_ids, payloads, st.booleans()), min_size=1, max_size=12))
def test_random_frames_never_break_an_emulator(frames):
    devices = damiao_devices() + robstride_devices() + dji_devices()
    t = 0.0
    for extended, sid, eid, data, remote in frames:
        msg = can.Message(arbitration_id=eid if extended else sid, is_extended_id=extended, data=data,
                          dlc=len(data), is_remote_frame=remote and not data)
        for d in devices:
            for reply in d.handle(msg, t):
                assert _decodes(d, reply), (d, msg, reply)
            d.step_alone(0.002, t + 0.002)
            for out in d.periodic(t + 0.002):
                assert _decodes(d, out), (d, out)
        t += 0.002
    assert all(d.internal_errors == 0 for d in devices)
    for d in devices:
        assert math.isfinite(d.output_torque(t)) and math.isfinite(d.shaft.speed)


def _exchange(devices, seeds, rounds_max: int = 20) -> list[int]:
    """Frames per round after ``seeds``, every frame handed to every device (its sender too)."""
    pending, rounds = list(seeds), []
    for _ in range(rounds_max):
        if not pending:
            return rounds
        pending = [r for msg in pending for d in devices for r in d.handle(msg, 0.0)]
        rounds.append(len(pending))
    raise AssertionError(f"still talking after {rounds_max} rounds: {rounds}")


@pytest.mark.parametrize("family", ["damiao", "robstride"])
def test_several_devices_of_a_family_on_one_bus_never_answer_each_other(family):
    devices = damiao_devices() if family == "damiao" else robstride_devices()
    if family == "damiao":
        seeds = [can.Message(arbitration_id=i + off, data=bytes([0xFF] * 7 + [c]), is_extended_id=False)
                 for i in (1, 2, 3) for off in (0, 0x100) for c in (0xFC, 0xFD, 0xFE, 0xFB)]
        seeds += [can.Message(arbitration_id=0x7FF, data=bytes([i, 0, op, 7, 0x11, 0, 0, 0]), is_extended_id=False)
                  for i in (1, 2, 3) for op in (0x33, 0x55, 0xCC)]
        seeds += [can.Message(arbitration_id=i, data=bytes([0x7F, 0xFF, 0x7F, 0xF0, 0, 0, 0x07, 0xFF]),
                              is_extended_id=False) for i in (1, 2, 3)]
    else:
        seeds = [can.Message(arbitration_id=(t << 24) | (host << 8) | target, data=data, is_extended_id=True)
                 for t in (0, 1, 2, 3, 4, 6, 17, 18, 21, 22, 23, 24, 25) for host in (0x00, 0x02, 0xFD)
                 for target in (1, 2, 0x7F) for data in (bytes(8), bytes(range(1, 9)))]
    for seed in seeds:
        fresh = damiao_devices() if family == "damiao" else robstride_devices()
        rounds = _exchange(fresh, [seed])
        assert rounds[1:] in ([], [0]) and (not rounds or rounds[0] <= 1), (seed, rounds)
    assert all(d.internal_errors == 0 for d in devices)


def test_dji_devices_answer_nothing_on_a_crowded_bus():
    devices = dji_devices()
    feedback = [f for d in devices for f in d.periodic(0.0)]
    assert len(feedback) == len(devices)
    assert _exchange(devices, feedback) == [0]  # feedback frames (0x201.., 0x205..) are nobody's command


def test_every_new_device_takes_the_plants_supply_calls():
    """The plant's battery-sag override sets each motor's supply and asks the power it draws."""
    for d in damiao_devices() + robstride_devices() + dji_devices():
        d.set_supply_voltage(20.0)
        assert (d.supply_v if hasattr(d, "supply_v") else d.vbus_v) == 20.0
        assert d.supply_power_w(0.0) == 0.0  # at rest, disabled or no command: nothing drawn
    m = Damiao("DM-J4310-2EC", esc_id=1)
    m.handle(can.Message(arbitration_id=1, data=bytes([0xFF] * 7 + [0xFC]), is_extended_id=False), 0.0)
    m.handle(can.Message(arbitration_id=1, data=bytes([0x7F, 0xFF, 0x7F, 0xF0, 0, 0, 0x0C, 0x00]),
                         is_extended_id=False), 0.0)
    assert m.supply_power_w(0.0) > 0.0  # stalled at a torque: copper loss only
    m.set_supply_voltage(9.0)
    m.advance(0.001, 0.001)
    assert m.state == 0x9  # under UV_Value: under-voltage
