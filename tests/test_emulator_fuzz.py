"""Random frames at every emulator: no exception, no internal error, only well-formed replies.

A seeded loop sends a few thousand frames per device (standard and extended
ids, DLC 0-8, random bytes), biased towards frames the device might take for
its own (its id, its types, parameter indices, NaN/inf floats); a hypothesis
test does the same with shrinking. Every reply must be a frame the real
device could send: the right id kind, DLC, a layout the DBC decodes, and for
a CyberGear at most one reply, of the type docs/protocols.md gives for the request.
"""
from __future__ import annotations

import functools
import math
import random
import struct

import can
import cantools
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import load_bus, load_file
from wheelleg.emulators.c620 import C620
from wheelleg.emulators.cybergear import CyberGear
from wheelleg.emulators.imu import Imu

REPLY_TYPE = {0: 0, 1: 2, 2: 2, 3: 2, 4: 2, 5: 2, 6: 2, 7: 0, 9: 9, 17: 17, 18: 2, 19: 19, 20: 2, 21: 21, 22: 0}  # docs/protocols.md, how the emulated CyberGear answers
REPLY_MESSAGE = {0: "CG_DeviceId", 2: "CG_Feedback", 5: "CG_Calibration", 17: "CG_ParamRead", 21: "CG_FaultWarn"}
UNASKED_TYPE = 5  # the only frame a CyberGear sends on its own: the calibration result
PARAM_INDICES = sorted({i for s in load_file("cybergear.dbc").get_message_by_name("CG_ParamWrite").signals
                        for i in (s.multiplexer_ids or ())})
NASTY_FLOATS = [math.nan, math.inf, -math.inf, 1e30, -1e30, 0.0, -0.0, 5e-324]
CAN1 = load_bus("can1")


@functools.lru_cache(maxsize=None)
def _with_id_layouts(name: str):
    """A CyberGear DBC plus the payloads of cybergear_id.dbc, looked up by name."""
    both = cantools.database.Database()
    for m in (*load_file(name).messages, *load_file(cg.ID_DBC).messages):
        both.messages.append(m)
    both.refresh()
    return both


def _devices() -> list:
    return [CyberGear(motor_id=1), CyberGear(motor_id=0x7F, position_range="4pi"), CyberGear(motor_id=0),
            C620(esc_id=1), C620(esc_id=6, command_timeout_s=0.01), Imu()]


def random_frame(rng: random.Random, device) -> can.Message:
    """A frame biased towards what ``device`` might take for its own."""
    kind = rng.random()
    dlc = rng.choice([8, 8, 8, rng.randrange(0, 9)])
    data = bytearray(rng.randbytes(dlc))
    extended = rng.random() < 0.6
    if isinstance(device, CyberGear) and kind < 0.6:
        ctype = rng.choice(list(REPLY_TYPE) * 3 + list(range(32)))
        target = device.motor_id if rng.random() < 0.8 else rng.randrange(256)
        can_id = (ctype << 24) | (rng.randrange(1 << 16) << 8) | target
        extended = rng.random() < 0.95
        if ctype in (17, 18) and dlc == 8 and rng.random() < 0.7:
            data[0:2] = rng.choice(PARAM_INDICES).to_bytes(2, "little")
            if rng.random() < 0.5:
                data[4:8] = struct.pack("<f", rng.choice(NASTY_FLOATS))
    elif isinstance(device, C620) and kind < 0.5:
        can_id = rng.choice([0x200, 0x1FF, 0x201, 0x205])
    else:
        can_id = rng.randrange(1 << 29) if extended else rng.randrange(1 << 11)
    msg = can.Message(arbitration_id=can_id, data=bytes(data), dlc=dlc, is_extended_id=extended,
                      is_remote_frame=rng.random() < 0.02, check=False)
    if rng.random() < 0.05:  # a malformed object: dlc disagrees with the data
        msg.dlc = rng.choice([8, rng.randrange(16)])
    return msg


def _reply_message(ctype: int, reply: can.Message) -> str:
    """The layout of a reply: by type, and for the table answers by fragment or data-type code."""
    if ctype == cg.T_PARAM_TABLE:
        return "CG_ParamTable" if cg.table_fragment(reply.arbitration_id) == 4 else "CG_ParamTableText"
    if ctype == cg.T_CONFIG_READ:
        return "CG_ConfigReadText" if reply.data[2] == 0x0A else "CG_ConfigRead"
    return REPLY_MESSAGE[ctype]


def check_reply(device, request: can.Message | None, reply: can.Message, now_s: float) -> None:
    """``request`` None: a frame the device sent on its own."""
    assert isinstance(reply, can.Message)
    assert reply.timestamp == now_s and not reply.is_rx
    assert not (reply.is_remote_frame or reply.is_error_frame or reply.is_fd)
    assert reply.dlc == len(reply.data)
    if isinstance(device, CyberGear):
        assert reply.is_extended_id and 0 <= reply.arbitration_id < (1 << 29) and reply.dlc == 8
        parsed = cg.parse_reply_id(reply.arbitration_id)
        assert parsed.ctype == (UNASKED_TYPE if request is None else REPLY_TYPE[cg.comm_type(request.arbitration_id)])
        assert parsed.motor_id == device.motor_id
        db = _with_id_layouts("cybergear_4pi.dbc" if device.position_range == "4pi" else "cybergear.dbc")
        db.get_message_by_name(_reply_message(parsed.ctype, reply)).decode(reply.data)
    else:
        assert not reply.is_extended_id and 0 <= reply.arbitration_id < (1 << 11)
        msg = CAN1.get_message_by_frame_id(reply.arbitration_id)
        assert reply.dlc == msg.length
        msg.decode(reply.data)


def exercise(device, frames, dt_s: float = 0.0005) -> int:
    """Feed ``frames`` one per ``dt_s`` with the shaft stepping alone; returns the replies checked."""
    now, checked = 0.0, 0
    for request in frames:
        replies = device.handle(request, now)
        assert isinstance(replies, list)
        if isinstance(device, CyberGear):  # one answer, the whole table to type 19, four frames to a type-9 string
            limit = {cg.T_PARAM_TABLE: 200, cg.T_CONFIG_READ: 4}.get(cg.comm_type(request.arbitration_id), 1)
            assert len(replies) <= limit
        else:
            assert replies == []
        for reply in replies:
            check_reply(device, request, reply, now)
            checked += 1
        device.step_alone(dt_s, now + dt_s)
        now += dt_s
        for out in device.periodic(now):
            check_reply(device, None if isinstance(device, CyberGear) else request, out, now)
        assert math.isfinite(device.shaft.angle) and math.isfinite(device.shaft.speed)
        assert math.isfinite(device.output_torque(now))
    assert device.internal_errors == 0
    return checked


@pytest.mark.parametrize("index", range(len(_devices())), ids=[type(d).__name__ + str(i)
                                                                 for i, d in enumerate(_devices())])
def test_seeded_random_frames(index):
    device = _devices()[index]
    rng = random.Random(1234 + index)
    frames = (random_frame(rng, device) for _ in range(4000))  # lazily: type 7 moves the motor's id
    checked = exercise(device, frames)
    if isinstance(device, CyberGear):
        assert checked > 200  # the bias works: the motor did answer plenty of frames


@settings(max_examples=300, deadline=None)
@given(ctype=st.integers(0, 31), data16=st.integers(0, 0xFFFF), target=st.sampled_from([1, 2, 0xFE]),
       payload=st.binary(max_size=8), extended=st.booleans(), dlc=st.none() | st.integers(0, 15))
def test_hypothesis_frames_at_a_cybergear(ctype, data16, target, payload, extended, dlc):
    motor = CyberGear(motor_id=1)
    motor.handle(can.Message(arbitration_id=cg.request_id(cg.T_ENABLE, 0xFD, 1), data=bytes(8),
                             is_extended_id=True), 0.0)
    can_id = (ctype << 24) | (data16 << 8) | target
    request = can.Message(arbitration_id=can_id if extended else can_id & 0x7FF, data=payload,
                          is_extended_id=extended, check=False)
    if dlc is not None:  # a malformed object: dlc disagrees with the data
        request.dlc = dlc
    exercise(motor, [request, request])


@settings(max_examples=200, deadline=None)
@given(can_id=st.sampled_from([0x200, 0x1FF]) | st.integers(0, 0x7FF), payload=st.binary(max_size=8),
       extended=st.booleans(), dlc=st.none() | st.integers(0, 15))
def test_hypothesis_frames_at_a_c620(can_id, payload, extended, dlc):
    esc = C620(esc_id=1)
    request = can.Message(arbitration_id=can_id, data=payload, is_extended_id=extended, check=False)
    if dlc is not None:
        request.dlc = dlc
    exercise(esc, [request] * 3)
    assert abs(esc.commanded_current(0.0)) <= 20.0
