"""CyberGear stored parameter table: types 19 (whole table), 9 (read one) and 8 (write one) (docs/protocols.md)."""
from __future__ import annotations

import struct

import can
import pytest

from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import load_file
from wheelleg.emulators.cybergear import CyberGear
from wheelleg.emulators.cybergear_table import BY_INDEX, TABLE

HOST = 0xFD
DB = load_file("cybergear.dbc")
FORMAT = {"u8": "<B", "u16": "<H", "i16": "<h", "u32": "<I", "i32": "<i", "f32": "<f"}


def request(ctype: int, data: bytes, motor: int = 5, host: int = HOST) -> can.Message:
    return can.Message(arbitration_id=cg.request_id(ctype, host, motor), data=data, is_extended_id=True)


def dump(motor: CyberGear) -> list[can.Message]:
    return motor.handle(request(cg.T_PARAM_TABLE, motor.uid.to_bytes(8, "little"), motor.motor_id), 0.0)


def parse_table(frames) -> dict:
    """The table as a reader independent of the emulator would rebuild it: id fragment, index, bytes."""
    out = {}
    for f in frames:
        index = int.from_bytes(f.data[:2], "little")
        entry, fragment = BY_INDEX[index], cg.table_fragment(f.arbitration_id)
        if fragment == 0:
            out[entry.name] = b""
        elif fragment in (6, 7, 8):
            out[entry.name] += bytes(f.data[2:8])
        else:
            assert fragment == 4 and entry.kind != "str"
            out[entry.name] = struct.unpack_from(FORMAT[entry.kind], f.data, 4)[0]
    return out


def test_the_table_request_answers_every_entry_with_the_manuals_values():
    motor = CyberGear(motor_id=5, host_id=0)
    frames = dump(motor)
    assert {cg.reply_motor(f.arbitration_id) for f in frames} == {5}
    assert {f.arbitration_id & 0xFF for f in frames} == {HOST}
    table = parse_table(frames)
    assert list(table) == [e.name for e in TABLE]  # in index order, each once
    assert table["AppCodeName"].rstrip(b"\0") == b"dog_motor" and table["Name"].rstrip(b"\0") == b"\xff" * 16
    assert table["GearRatio"] == pytest.approx(7.75) and table["overTempTime"] == 20000
    assert table["CAN_ID"] == 5 and table["CAN_MASTER"] == 0  # live, not the manual's example motor
    assert table["motorTemp"] == 250 and table["vBus_mv"] == 24000


def test_the_dbc_decodes_every_table_frame():
    msg, text = DB.get_message_by_name("CG_ParamTable"), load_file(cg.ID_DBC).get_message_by_name("CG_ParamTableText")
    for f in dump(CyberGear(motor_id=5)):
        layout = msg if cg.table_fragment(f.arbitration_id) == 4 else text
        assert layout.decode(bytes(f.data))["Index"] == int.from_bytes(f.data[:2], "little")


@pytest.mark.parametrize("payload", [bytes(8), bytes([0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07]), b"",
                                     (0x4347_0000_0000_0005).to_bytes(8, "little")[:7]],
                         ids=["zeros", "fixed", "empty", "short-uid"])
def test_a_table_request_is_answered_whatever_its_payload(payload):
    """The UID form (python-cybergear) and any fixed form (the debugger's) get the same whole table."""
    motor = CyberGear(motor_id=5)
    frames = motor.handle(request(cg.T_PARAM_TABLE, payload), 0.0)
    assert [bytes(f.data) for f in frames] == [bytes(f.data) for f in dump(motor)]
    assert list(parse_table(frames)) == [e.name for e in TABLE]


def test_the_table_follows_the_motor_id_and_its_angle():
    motor = CyberGear(motor_id=5)
    motor.handle(can.Message(arbitration_id=cg.set_id_id(9, HOST, 5), data=bytes(8), is_extended_id=True), 0.0)
    motor.shaft.angle = 1.25
    table = parse_table(dump(motor))
    assert table["CAN_ID"] == 9 and table["mechPos"] == pytest.approx(1.25)


TYPE_CODE = {"u8": 0, "u16": 2, "i16": 3, "u32": 4, "i32": 5, "f32": 6, "str": 0x0A}  # CyberGearDriver's DataType


def read_config(motor: CyberGear, index: int):
    replies = motor.handle(request(cg.T_CONFIG_READ, struct.pack("<H6x", index)), 0.0)
    assert len(replies) == 1 and cg.parse_reply_id(replies[0].arbitration_id).ctype == cg.T_CONFIG_READ
    entry = BY_INDEX[index]
    assert int.from_bytes(replies[0].data[:2], "little") == index
    assert replies[0].data[2] == TYPE_CODE[entry.kind]  # the entry's data-type code in byte 2
    return struct.unpack_from(FORMAT[entry.kind], replies[0].data, 4)[0]


@pytest.mark.parametrize("entry", [e for e in TABLE if e.kind != "str"], ids=lambda e: e.name)
def test_type_9_reads_each_entry_as_the_table_has_it(entry):
    motor = CyberGear(motor_id=5)
    assert read_config(motor, entry.index) == pytest.approx(parse_table(dump(motor))[entry.name])


def write_config(motor: CyberGear, index: int, value, type_code: int = 0) -> list:
    entry = BY_INDEX[index]
    data = struct.pack("<HBx", index, type_code) + struct.pack(FORMAT[entry.kind], value)
    return motor.handle(request(cg.T_CONFIG_WRITE, data), 0.0)


def test_type_8_writes_a_writable_entry_within_its_range_and_answers_nothing():
    motor = CyberGear(motor_id=5)
    assert write_config(motor, 0x2018, 10.0) == []  # limit_spd, float
    assert write_config(motor, 0x2000, 40) == []  # echoPara1, u16 in a 6-byte frame
    assert read_config(motor, 0x2018) == pytest.approx(10.0) and read_config(motor, 0x2000) == 40
    assert motor.params["limit_spd"] == 2.0  # the runtime value is loaded only at power-up


@pytest.mark.parametrize("index, value", [(0x2018, 500.0), (0x2000, 2), (0x2018, float("nan")),
                                          (0x200A, 9), (0x3016, 3.0), (0x2005, 1.0)])
def test_type_8_ignores_out_of_range_values_and_read_only_entries(index, value):
    motor = CyberGear(motor_id=5)
    before = read_config(motor, index)
    write_config(motor, index, value)
    assert read_config(motor, index) == pytest.approx(before)


@pytest.mark.parametrize("data", [b"", b"\x0a", struct.pack("<H6x", 0x7005), struct.pack("<H6x", 0x2FFF)])
def test_type_9_of_an_unknown_index_or_no_index_is_silent(data):
    assert CyberGear(motor_id=5).handle(request(cg.T_CONFIG_READ, data), 0.0) == []


@pytest.mark.parametrize("entry", [e for e in TABLE if e.kind == "str"], ids=lambda e: e.name)
def test_type_9_of_a_string_is_four_frames_of_four_characters(entry):
    motor = CyberGear(motor_id=5)
    replies = motor.handle(request(cg.T_CONFIG_READ, struct.pack("<H6x", entry.index)), 0.0)
    assert len(replies) == 4
    for part, reply in enumerate(replies):
        assert cg.parse_reply_id(reply.arbitration_id).ctype == cg.T_CONFIG_READ
        assert bytes(reply.data[:4]) == struct.pack("<HBB", entry.index, 0x0A, part)
    text = b"".join(bytes(r.data[4:8]) for r in replies)
    assert text == str(entry.default).encode("latin-1")[:16].ljust(16, b"\0")
    decoded = [load_file(cg.ID_DBC).get_message_by_name("CG_ConfigReadText").decode(bytes(r.data)) for r in replies]
    assert [d["Part"] for d in decoded] == [0, 1, 2, 3]
