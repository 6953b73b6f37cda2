"""The trace decoder on the CyberGear frames that go both ways (types 0, 17, 21): lookup at
canonical id 0, replies to the default master 0x00, the debugger's one-byte type-0 request."""
from __future__ import annotations

import json

import pytest
from mcap.reader import make_reader

from wheelleg import dbc
from wheelleg.dbc import cybergear as cg
from wheelleg.hil.analyze.inspect_trace import summarize
from wheelleg.hil.record import sources
from wheelleg.hil.record.decode import FrameDecoder
from wheelleg.hil.record.frame import Frame
from wheelleg.hil.record.trace import TraceReader, TraceWriter

DBS = {"can1": dbc.load_bus("can1"), "can2": dbc.load_bus("can2")}
HOST = 0xFD  # the rig's host id
MASTER = 0x00  # the firmware's default CAN_MASTER
PARAM = DBS["can2"].get_message_by_name("CG_ParamRead").encode({"Index": 0x7005, "run_mode": 2}, strict=False)
FAULTS = DBS["can2"].get_message_by_name("CG_FaultWarn").encode(
    {s.name: 0 for s in DBS["can2"].get_message_by_name("CG_FaultWarn").signals} | {"FaultOverTemp": 1})


@pytest.mark.parametrize("can_id", [cg.request_id(cg.T_DEVICE_ID, HOST, 1),
                                    cg.reply_id(cg.T_DEVICE_ID, 1, cg.DEVICE_ID_TARGET)])
def test_type_0_frames_are_looked_up_at_canonical_id_0(can_id):
    assert cg.canonical_id(can_id) == 0
    assert sources.dbc_message("can2", can_id, True).name == "CG_DeviceId"
    assert sources.dbc_message("can2", can_id, False) is None  # a standard id 0 is not CyberGear


@pytest.mark.parametrize("ctype, payload, name", [(cg.T_PARAM_READ, PARAM, "CG_ParamRead"),
                                                   (cg.T_FAULT_WARN, FAULTS, "CG_FaultWarn")])
@pytest.mark.parametrize("motor", [1, 0x7F])
def test_replies_to_host_0_decode_as_replies(ctype, payload, name, motor):
    plan, values = FrameDecoder(DBS).decode("can2", cg.reply_id(ctype, motor, MASTER), True, payload)
    assert plan.name == name
    assert (values["Type"], values["MotorId"], values["Host"]) == (ctype, motor, MASTER)
    assert "Target" not in values
    # the requests they answer stay requests, from either host
    for host, target in ((MASTER, motor), (HOST, motor), (HOST, 0)):
        _, request = FrameDecoder(DBS).decode("can2", cg.request_id(ctype, host, target), True, payload)
        assert (request["Host"], request["Target"]) == (host, target) and "MotorId" not in request


def test_from_motor_tells_direction_for_any_host():
    for ctype in (cg.T_DEVICE_ID, cg.T_FEEDBACK, cg.T_PARAM_READ, cg.T_FAULT_WARN):
        for motor in (1, 0x7F):
            for host in (HOST, MASTER):
                assert cg.from_motor(cg.reply_id(ctype, motor, host), HOST)
                assert not cg.from_motor(cg.request_id(ctype, host, motor), HOST)
    assert not cg.from_motor(cg.request_id(cg.T_PARAM_READ, HOST, 0), HOST)  # to motor 0


@pytest.mark.parametrize("data", [b"\x00", b"", bytes(8)])
def test_type_0_request_of_any_length_decodes_to_its_id_fields(data):
    plan, values = FrameDecoder(DBS).decode("can2", cg.request_id(cg.T_DEVICE_ID, HOST, 0x7F), True, data)
    assert plan.name == "CG_DeviceId"
    assert values == {"Type": cg.T_DEVICE_ID, "Host": HOST, "Target": 0x7F}


def test_type_0_request_and_reply_share_a_valid_trace_topic(tmp_path):
    uid = bytes.fromhex("0102030405060708")
    frames = [Frame(1_000, "can2", cg.request_id(cg.T_DEVICE_ID, HOST, 0x7F), True, b"\x00", 1),
              Frame(2_000, "can2", cg.reply_id(cg.T_DEVICE_ID, 0x7F, cg.DEVICE_ID_TARGET), True, uid, 8)]
    path = tmp_path / "scan.mcap"
    with TraceWriter(path, metadata={}, dbs=DBS, decode=True) as trace:  # the topic recorded live
        for frame in frames:
            trace.frame(frame)
    decoded = TraceReader(path).decoded("can2", "CG_DeviceId")
    assert list(decoded["Target"][:1]) == [0x7F] and list(decoded["MotorId"][1:]) == [0x7F]
    assert decoded["McuUid"][1] == int.from_bytes(uid, "little")
    with open(path, "rb") as stream:
        schema = next(s for s in make_reader(stream).get_summary().schemas.values()
                      if s.name == "wheelleg.decoded.CG_DeviceId")
    assert json.loads(schema.data)["required"] == []  # a request has no McuUid


def test_a_motion_command_is_never_from_a_motor():
    """Bits 15..8 of a type-1 id hold torque: a low byte <= 127 must not read as a motor's id."""
    ids = [cg.motion_id(torque, 0) for torque in [i / 10 for i in range(-120, 121)]]
    assert any((i >> 8) & 0xFF <= cg.MAX_MOTOR_ID for i in ids)  # the case that could mislead
    assert not any(cg.from_motor(i, HOST) for i in ids)


def _reply_to_master_log(tmp_path):
    """A robot's log on host 0x00: motor 1 asked for run_mode and its fault words, and answering."""
    rows = [(cg.request_id(cg.T_PARAM_READ, MASTER, 1), PARAM), (cg.reply_id(cg.T_PARAM_READ, 1, MASTER), PARAM),
            (cg.request_id(cg.T_FAULT_WARN, MASTER, 1), bytes(8)), (cg.reply_id(cg.T_FAULT_WARN, 1, MASTER), FAULTS)]
    log = tmp_path / "robot.log"
    log.write_text("".join(f"(0000000001.{100 * i:06d}) can1 {can_id:08X}#{data.hex().upper()}\n"
                           for i, (can_id, data) in enumerate(rows)))
    return log


def test_replies_to_host_0_are_not_the_controllers(tmp_path):
    frames = sources.open_recording(_reply_to_master_log(tmp_path), strict=False).frames
    assert sources.sent_by_controller(frames[0])  # the type-17 request
    assert not any(sources.sent_by_controller(f) for f in frames[1::2])  # the motor's replies


def test_inspect_counts_replies_to_host_0_per_motor_and_sees_their_faults(tmp_path):
    summary = summarize(_reply_to_master_log(tmp_path))
    labels = {row.message for row in summary.ids}
    assert labels == {"CG_ParamRead to motor 1", "CG_ParamRead from motor 1",
                      "CG_FaultWarn to motor 1", "CG_FaultWarn from motor 1"}
    assert [f.text for f in summary.faults if f.kind == "cybergear"] == \
        ["can1 CG_FaultWarn from motor 1: FaultOverTemp set"]
