"""The DBC files: clean loads, round trips of every message (every multiplexer value),
every signal's range (hypothesis), and the CyberGear byte orders and id fields pinned
with vectors from docs/protocols.md."""
from __future__ import annotations

import gzip
import json
import logging
import math
import re
import struct
import subprocess
import sys
import warnings
from pathlib import Path

import cantools
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wheelleg import dbc
from wheelleg.dbc import all_dbc_files, load_bus, load_file, truncating_raw
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc.codec import MessageCodec

from sharing import same_fixture

FILES = all_dbc_files()
TRACES = Path(__file__).resolve().parent / "traces"


def _cases() -> list[tuple]:
    """(file name, message name, multiplexer value or None): one per layout a frame can take."""
    out = []
    for path in FILES:
        for msg in load_file(path.name).messages:
            muxes = sorted({i for s in msg.signals for i in (s.multiplexer_ids or ())}) or [None]
            out += [(path.name, msg.name, mux) for mux in muxes]
    return out


CASES = _cases()


def _branch(case: tuple) -> tuple:
    """The message and the signals present for the case's multiplexer value."""
    name, msg_name, mux = case
    msg = load_file(name).get_message_by_name(msg_name)
    return msg, [s for s in msg.signals if mux is None or not s.multiplexer_ids or mux in s.multiplexer_ids]


def _raw_range(sig) -> tuple[int, int]:
    return (-(1 << (sig.length - 1)), (1 << (sig.length - 1)) - 1) if sig.is_signed else (0, (1 << sig.length) - 1)


def _close(sig, got, want) -> bool:
    if sig.is_float:  # float32 on the wire
        return got == struct.unpack("<f", struct.pack("<f", want))[0]
    return abs(got - want) <= sig.scale / 2 * (1 + 1e-9) + 1e-12


# -- loading -----------------------------------------------------------------------------
def test_every_dbc_is_found():
    assert {p.name for p in FILES} == {"c610.dbc", "c620.dbc", "cybergear.dbc", "damiao.dbc", "cybergear_4pi.dbc", "cybergear_id.dbc",
                                        "gm6020.dbc", "quadruped.dbc", "rig.dbc", "robstride_rs01.dbc",
                                        "robstride_rs02.dbc", "robstride_rs03.dbc", "robstride_rs04.dbc"}


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_loads_strictly_without_warnings(path, caplog):
    caplog.set_level(logging.DEBUG, logger="cantools")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        db = cantools.database.load_file(str(path), strict=True)
    assert [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING] == []
    assert db.messages and all(m.signals or m.length == 8 for m in db.messages)


# cantools' command line (``python -m cantools ARGS``) for each call in one fresh interpreter, which
# imports nothing of the rig: each call parses its own argv and reads its own stdin as its own process
# would; one start-up (~1.2 s of CPU: the interpreter, cantools) instead of one a call
_CANTOOLS_CALLS = r"""
import contextlib, io, json, sys
import cantools
results = []
for argv, stdin in json.load(sys.stdin):
    out, err, code = io.StringIO(), io.StringIO(), 0
    sys.argv, sys.stdin = ["cantools", *argv], io.StringIO(stdin)
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            cantools._main()  # what `python -m cantools` runs
        except SystemExit as exc:  # sys.exit("error: ...") as a process prints and exits 1
            code = exc.code if isinstance(exc.code, int) or exc.code is None else print(exc.code, file=sys.stderr) or 1
    results.append((code or 0, out.getvalue(), err.getvalue()))
json.dump(results, sys.__stdout__)
"""
DECODE_LOG = TRACES / "motor-fault.log.gz"


def _dump_args(path: Path) -> list[str]:
    return ["dump", str(path)]


def _decode_args(name: str) -> list[str]:
    return ["decode", "--single-line", str(dbc.dbc_path(name)), "-m", "0x1F000000"]


@pytest.fixture(scope="module")
def cantools_cli() -> dict[tuple, subprocess.CompletedProcess]:
    """argv -> the outcome of ``python -m cantools ARGV`` for every call this module's tests check."""
    log = gzip.decompress(DECODE_LOG.read_bytes()).decode()
    calls = [(_dump_args(p), "") for p in FILES] + [(_decode_args(n), log) for n in sorted(dbc.CYBERGEAR_FILES.values())]
    done = subprocess.run([sys.executable, "-c", _CANTOOLS_CALLS], input=json.dumps(calls), capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return {tuple(argv): subprocess.CompletedProcess(["cantools", *argv], *outcome)
            for (argv, _), outcome in zip(calls, json.loads(done.stdout))}


@same_fixture("cantools cli")
@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_cantools_dump_reads_every_file(path, cantools_cli):
    result = cantools_cli[tuple(_dump_args(path))]
    assert result.returncode == 0, result.stderr
    for msg in load_file(path.name).messages:
        assert msg.name in result.stdout
    assert "Traceback" not in result.stderr


@same_fixture("cantools cli")
@pytest.mark.parametrize("name", sorted(dbc.CYBERGEAR_FILES.values()))
def test_cantools_decode_matches_a_rig_log_by_the_type_alone(name, cantools_cli):
    """`cantools decode cybergear.dbc -m 0x1F000000 < run.log`: one message per type, no overwriting
    warning, every CyberGear frame of a rig log decoded (the standard ids are rig.dbc's and c620.dbc's)."""
    result = cantools_cli[tuple(_decode_args(name))]
    assert result.returncode == 0 and result.stderr == ""
    extended = [line for line in result.stdout.splitlines() if len(line.split()[2].partition("#")[0]) == 8]
    assert len(extended) > 5000
    names = {line.split(" :: ")[1].partition("(")[0] for line in extended}
    assert names == {"CG_Enable", "CG_Feedback", "CG_MotionCmd", "CG_ParamWrite", "CG_Stop"}


@pytest.mark.parametrize("robot", ["wheel-legged", "quadruped"])
@pytest.mark.parametrize("bus", ["can1", "can2"])
def test_each_bus_database_has_no_id_clash(bus, robot):
    db = load_bus(bus, robot=robot)
    ids = [(m.frame_id, m.is_extended_frame) for m in db.messages]
    assert len(ids) == len(set(ids))


def test_the_quadruped_remote_is_on_its_bus_0_only():
    assert load_bus("can1", robot="quadruped").get_message_by_name("QuadOperator").frame_id == 0x301
    assert "QuadOperator" not in {m.name for m in load_bus("can2", robot="quadruped").messages}
    assert "QuadOperator" not in {m.name for m in load_bus("can1").messages}
    with pytest.raises(ValueError, match="unknown robot"):
        load_bus("can1", robot="hexapod")


def test_quad_operator_carries_the_contract_set_points():
    """Mode 0..4 and E-stop; a 0.5 m/s trot, +-10 deg attitude set points and the height survive encoding."""
    msg = load_file("quadruped.dbc").get_message_by_name("QuadOperator")
    codec = MessageCodec.of(msg)
    ten_deg = math.radians(10.0)
    sent = {"Mode": 3, "EStop": 1, "VelX": 0.5, "VelY": -0.2, "YawRate": 1.0, "Height": 0.25,
            "Roll": ten_deg, "Pitch": -ten_deg, "Yaw": ten_deg}
    got = codec.decode(msg.encode(sent))
    assert got["Mode"] == 3 and got["EStop"] == 1
    for name in ("VelX", "VelY", "YawRate", "Height", "Roll", "Pitch", "Yaw"):
        assert got[name] == pytest.approx(sent[name], abs=msg.get_signal_by_name(name).scale / 2 + 1e-12), name


# -- round trips -----------------------------------------------------------------------------
@pytest.mark.parametrize("case", CASES, ids=lambda c: f"{c[1]}-{c[2]}" if c[2] is not None else c[1])
def test_round_trip_at_the_range_ends_and_middle(case):
    msg, signals = _branch(case)
    for pick in (lambda s: s.minimum, lambda s: s.maximum, lambda s: (s.minimum + s.maximum) / 2):
        values = {s.name: (case[2] if s.is_multiplexer else pick(s)) for s in signals}
        decoded = msg.decode(msg.encode(values), decode_choices=False)
        for s in signals:
            assert _close(s, decoded[s.name], values[s.name]), (s.name, values[s.name], decoded[s.name])


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"{c[1]}-{c[2]}" if c[2] is not None else c[1])
def test_raw_round_trip_of_every_field_end(case):
    """Raw extremes of each field survive encode/decode, and the fast codec agrees with cantools."""
    msg, signals = _branch(case)
    for codec in (MessageCodec(msg, signals), MessageCodec.of(msg)):  # the branch alone, the whole message
        for end in (0, 1):
            raw = {s.name: case[2] if s.is_multiplexer else
                   (float(s.maximum if end else s.minimum) if s.is_float else _raw_range(s)[end]) for s in signals}
            data = msg.encode(raw, scaling=False, strict=False)
            assert codec.encode_raw(raw) == data
            assert msg.decode(data, scaling=False, decode_choices=False) == raw
            assert codec.decode_raw(data) == raw


def _same(mine: dict, ref: dict) -> bool:
    """Equal keys, values (NaN equals NaN) and value types."""
    return list(mine) == list(ref) and all(
        a == b or (a != a and b != b) for a, b in zip(mine.values(), ref.values())) and [
        type(v) for v in mine.values()] == [type(v) for v in ref.values()]


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_compiled_codec_equals_cantools_for_every_message(data):
    """Any payload of any layout of any DBC: the compiled codec decodes (raw and physical, values
    and types) as cantools does, and encodes the raw values back to the bytes cantools gives."""
    case = data.draw(st.sampled_from(CASES), label="case")
    msg, _ = _branch(case)
    codec = MessageCodec.of(msg)
    payload = data.draw(st.binary(min_size=msg.length, max_size=msg.length), label="payload")
    if case[2] is not None:  # put the case's multiplexer value in the payload
        raw = codec.branches[case[2]].decode_raw(payload)
        payload = codec.encode_raw({**raw, codec.multiplexer.name: case[2]})
    assert _same(codec.decode(payload), msg.decode(payload, decode_choices=False)), msg.name
    raw = msg.decode(payload, scaling=False, decode_choices=False)
    assert _same(codec.decode_raw(payload), raw), msg.name
    if not any(v != v for v in raw.values()):  # a NaN's payload bits are not one value
        assert codec.encode_raw(raw) == msg.encode(raw, scaling=False, strict=False), msg.name


def test_compiled_codec_refuses_bad_input_with_a_clear_error():
    feedback = MessageCodec.of(load_file("cybergear.dbc").get_message_by_name("CG_Feedback"))
    with pytest.raises(ValueError, match="CG_Feedback: 7 bytes, expected 8"):
        feedback.decode(bytes(7))
    raw = feedback.decode_raw(bytes(8))
    with pytest.raises(ValueError, match=r"Pos: raw value 65536 outside 0\.\.65535"):
        feedback.encode_raw({**raw, "Pos": 65536})
    read = MessageCodec.of(load_file("cybergear.dbc").get_message_by_name("CG_ParamRead"))
    with pytest.raises(ValueError, match="no signals for multiplexer Index = 0"):
        read.decode(bytes(8))


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_a_compiled_encoder_gives_encode_raw_of_the_converted_values(data):
    """Any layout, each signal raw, rounded or truncated (where the DBC gives a range of more than one
    value: truncation maps [minimum, maximum] onto the field, and a constant such as CG_QuickMove's
    Index [28677|28677] has no span to map; drawn, it divided by zero): the bytes or the error of
    ``encode_raw`` of the values converted one by one (``SignalCodec.rounded``, ``.truncated``)."""
    case = data.draw(st.sampled_from(CASES), label="case")
    msg, signals = _branch(case)
    codec = MessageCodec(msg, signals) if case[2] is not None else MessageCodec.of(msg)
    kinds, values, raw = {}, [], {}
    for f in data.draw(st.permutations(codec.fields), label="order"):
        ways = ["raw"] if f.float_format is not None else ["raw", "rounded"] + (
            ["truncated"] if f.has_span() else [])
        how = kinds[f.name] = data.draw(st.sampled_from(ways), label=f.name)
        if how == "raw":
            value = data.draw(st.integers(f.raw_lo - 1, f.raw_hi + 1) if f.float_format is None
                              else st.floats(width=32), label=f"{f.name} raw")
            raw[f.name] = value
        else:
            value = data.draw(st.floats(allow_nan=True, allow_infinity=True), label=f"{f.name} value")
            raw[f.name] = f.rounded(value) if how == "rounded" else f.truncated(value)
        values.append(value)
    encode = codec.encoder(kinds)
    try:
        expected = codec.encode_raw(raw)
    except ValueError as exc:
        with pytest.raises(ValueError, match=re.escape(str(exc))):
            encode(*values)
    else:
        assert encode(*values) == expected, (msg.name, kinds)


def test_truncating_a_signal_whose_range_has_no_span_is_a_clear_error():
    """CG_QuickMove's Index is the constant [28677|28677]: truncation has nothing to map it onto."""
    quick = MessageCodec.of(load_file("cybergear_id.dbc").get_message_by_name("CG_QuickMove"))
    index = quick.signals["Index"]
    assert not index.has_span()
    with pytest.raises(ValueError, match=r"Index: its DBC range \[28677\|28677\] has no span"):
        index.truncated(28677.0)
    kinds = {name: "raw" for name in quick.signals}
    with pytest.raises(ValueError, match=r"CG_QuickMove.Index: its DBC range .* has no span"):
        quick.encoder({**kinds, "Index": "truncated"})


def test_a_compiled_encoder_needs_every_signal_once():
    feedback = MessageCodec.of(load_file("cybergear.dbc").get_message_by_name("CG_Feedback"))
    with pytest.raises(ValueError, match="once as raw, rounded or truncated"):
        feedback.encoder({"Pos": "truncated"})
    with pytest.raises(ValueError, match="once as raw, rounded or truncated"):
        feedback.encoder({name: "clamped" for name in feedback.signals})


@settings(max_examples=400, deadline=None)
@given(st.data())
def test_every_signal_over_its_range(data):
    """Any in-range value of every signal of every layout encodes and decodes within half a step."""
    case = data.draw(st.sampled_from(CASES), label="case")
    msg, signals = _branch(case)
    values = {}
    for s in signals:
        if s.is_multiplexer:
            values[s.name] = case[2]
        elif s.is_float:
            values[s.name] = data.draw(st.floats(s.minimum, s.maximum, width=32), label=s.name)
        elif s.scale == 1 and s.offset == 0:
            values[s.name] = data.draw(st.integers(int(s.minimum), int(s.maximum)), label=s.name)
        else:
            values[s.name] = data.draw(st.floats(s.minimum, s.maximum, allow_nan=False), label=s.name)
    decoded = msg.decode(msg.encode(values), decode_choices=False)
    for s in signals:
        assert _close(s, decoded[s.name], values[s.name]), (s.name, values[s.name], decoded[s.name])


def test_every_signal_range_fits_its_field():
    """The declared [min, max] maps inside the raw field, so strict encoding of the ends cannot overflow."""
    for case in CASES:
        for s in _branch(case)[1]:
            if s.is_float:
                continue
            lo, hi = _raw_range(s)
            for end in (s.minimum, s.maximum):
                raw = end if (s.scale, s.offset) == (1, 0) else round((end - s.offset) / s.scale)  # exact for u64
                assert lo <= raw <= hi, (case[0], case[1], s.name, end)


# -- CyberGear vectors (docs/protocols.md) -------------------------------------------------------
CG = load_file("cybergear.dbc")
CG_MSG = CG.get_message_by_name


def test_cybergear_messages_sit_at_their_type_with_extended_ids():
    types = {"CG_DeviceId": 0, "CG_MotionCmd": 1, "CG_Feedback": 2, "CG_Enable": 3, "CG_Stop": 4,
             "CG_SetZero": 6, "CG_SetId": 7, "CG_ParamRead": 17, "CG_ParamWrite": 18, "CG_FaultWarn": 21,
             "CG_SetBaud": 22}
    for name, ctype in types.items():
        msg = CG_MSG(name)
        assert msg.is_extended_frame and msg.length == 8
        assert msg.frame_id == ctype << 24 == cg.canonical_id((ctype << 24) | 0x00ABCD)


def test_type1_payload_is_big_endian_with_the_truncating_encoder():
    cmd = CG_MSG("CG_MotionCmd")
    sig = {s.name: s for s in cmd.signals}
    assert truncating_raw(sig["VelRef"], 5.0) == 0x9554  # debugger capture S9 (rounding gives 0x9555)
    assert truncating_raw(sig["VelRef"], -5.0) == 0x6AAA
    assert truncating_raw(sig["VelRef"], 0.0) == 0x7FFF
    raw = {"PosRef": truncating_raw(sig["PosRef"], 0.0), "VelRef": 0x9554, "Kp": 0x0102, "Kd": 0x0304}
    assert cmd.encode(raw, scaling=False) == bytes.fromhex("7fff955401020304")
    assert all(s.byte_order == "big_endian" for s in cmd.signals)


def test_type1_torque_lives_in_the_id():
    assert cg.motion_id(0.0, 0x01) == 0x017FFF01
    assert cg.motion_id(12.0, 0x7F) == 0x01FFFF7F and cg.motion_id(-12.0, 0x7F) == 0x0100007F
    assert cg.motion_torque(0x01FFFF7F) == pytest.approx(12.0, abs=1e-9)
    assert cg.target(0x017FFF01) == 0x01 and cg.comm_type(0x017FFF01) == cg.T_MOTION


def test_type2_feedback_id_carries_mode_and_faults():
    can_id = cg.reply_id(cg.T_FEEDBACK, 0x01, 0xFD, mode=2, faults={"FaultOverTemp"})
    assert can_id == 0x028401FD
    assert cg.reply_id(cg.T_FEEDBACK, 0x7F, 0x00, mode=0, faults=set(cg.FAULT_NAMES)) == 0x023F7F00
    parsed = cg.parse_reply_id(0x02BF7FFD)
    assert (parsed.ctype, parsed.mode, parsed.motor_id, parsed.host) == (2, 2, 0x7F, 0xFD)
    assert parsed.faults == set(cg.FAULT_NAMES)
    assert cg.reply_motor(0x02BF7FFD) == 0x7F
    bit_of = {name: 16 + i for i, name in enumerate(cg.FAULT_NAMES)}  # type 2: bit 16 under-voltage .. 21
    assert bit_of == {"FaultUnderVoltage": 16, "FaultOverCurrent": 17, "FaultOverTemp": 18,
                      "FaultMagEncoder": 19, "FaultHallEncoder": 20, "FaultNotCalibrated": 21}
    for name, bit in bit_of.items():
        assert cg.reply_id(cg.T_FEEDBACK, 0, 0, faults={name}) == (2 << 24) | (1 << bit)


def test_type2_payload_is_big_endian():
    fb = CG_MSG("CG_Feedback")
    data = fb.encode({"Pos": 0xFAE0, "Vel": 0x7FFF, "Torque": 0x1234, "Temp": 0x014D}, scaling=False)
    assert data == bytes.fromhex("fae07fff1234014d")
    assert fb.decode(data)["Temp"] == pytest.approx(33.3)  # the manual's example
    assert truncating_raw(fb.get_signal_by_name("Pos"), 12.0) == 0xFAE0  # the hardware check value, +-12.5 rad


def test_request_ids_put_host_in_15_8_and_motor_in_7_0():
    assert cg.request_id(cg.T_PARAM_WRITE, 0xFD, 0x01) == 0x1200FD01  # debugger capture (AT 90 07 e8 0c)
    assert cg.request_id(cg.T_ENABLE, 0xFD, 0x7F) == 0x0300FD7F
    assert cg.request_host(0x1200FD01) == 0xFD and cg.target(0x1200FD01) == 0x01
    assert cg.set_id_id(0x05, 0xFD, 0x7F) == 0x0705FD7F and cg.set_id_new_id(0x0705FD7F) == 0x05
    assert cg.reply_id(cg.T_DEVICE_ID, 0x7F, cg.DEVICE_ID_TARGET) == 0x00007FFE
    assert cg.reply_id(cg.T_PARAM_READ, 0x01, 0xFD) == 0x110001FD
    assert cg.reply_id(cg.T_FAULT_WARN, 0x01, 0xFD) == 0x150001FD


def test_replies_and_requests_are_told_apart_by_the_last_byte():
    host = 0xFD
    motors = (0x01, 0x7F)
    for motor in motors:
        for ctype in (cg.T_FEEDBACK, cg.T_PARAM_READ, cg.T_FAULT_WARN):  # 17 and 21 go both ways
            assert cg.is_reply(cg.reply_id(ctype, motor, host, mode=2), host)
            assert not cg.is_reply(cg.request_id(ctype, host, motor), host)
        assert cg.is_reply(cg.reply_id(cg.T_DEVICE_ID, motor, cg.DEVICE_ID_TARGET), host)
        assert not cg.is_reply(cg.request_id(cg.T_DEVICE_ID, host, motor), host)
        assert not cg.is_reply(cg.motion_id(-3.0, motor), host)
        assert not cg.is_reply(cg.set_id_id(0x05, host, motor), host)
    assert not cg.is_reply(cg.reply_id(cg.T_FEEDBACK, 0x01, 0x00), host)  # a reply to another host


def test_bus_names_are_the_dbc_packages():
    assert dbc.BUSES == (dbc.CAN1, dbc.CAN2) == tuple(dbc.BUS_FILES) == ("can1", "can2")


def test_type17_18_payload_is_little_endian():
    write = CG_MSG("CG_ParamWrite")
    assert write.encode({"Index": 0x7017, "limit_spd": 2.0}) == bytes.fromhex("1770000000000040")  # capture S9
    assert write.encode({"Index": 0x7005, "run_mode": 2}) == bytes.fromhex("0570000002000000")
    assert write.encode({"Index": 0x701D, "rotation": -2}) == bytes.fromhex("1d700000feff0000")
    read = CG_MSG("CG_ParamRead")
    assert read.decode(bytes.fromhex("1970000000004041"))["mechPos"] == 12.0


def test_param_table_covers_0x7005_to_0x7020_in_both_directions():
    expected = {0x7005: "run_mode", 0x7006: "iq_ref", 0x700A: "spd_ref", 0x700B: "limit_torque",
                0x7010: "cur_kp", 0x7011: "cur_ki", 0x7014: "cur_filt_gain", 0x7016: "loc_ref",
                0x7017: "limit_spd", 0x7018: "limit_cur", 0x7019: "mechPos", 0x701A: "iqf",
                0x701B: "mechVel", 0x701C: "VBUS", 0x701D: "rotation", 0x701E: "loc_kp",
                0x701F: "spd_kp", 0x7020: "spd_ki"}
    for name in ("CG_ParamRead", "CG_ParamWrite"):
        table = {s.multiplexer_ids[0]: s.name for s in CG_MSG(name).signals if s.multiplexer_ids}
        assert table == expected
        floats = {s.name for s in CG_MSG(name).signals if s.is_float}
        assert floats == set(expected.values()) - {"run_mode", "rotation"}


def test_type21_words_are_little_endian():
    words = CG_MSG("CG_FaultWarn")
    values = {s.name: 0 for s in words.signals}
    assert words.encode({**values, "FaultOverTemp": 1}) == bytes.fromhex("0100000000000000")
    assert words.encode({**values, "FaultPhaseAOverCurrent": 1}) == bytes.fromhex("0000010000000000")
    assert words.encode({**values, "FaultOverload": 0xAB}) == bytes.fromhex("00ab000000000000")
    assert words.encode({**values, "WarnOverTemp": 1}) == bytes.fromhex("0000000001000000")


def test_4pi_file_differs_only_in_the_position_scale():
    a, b = load_file("cybergear.dbc"), load_file("cybergear_4pi.dbc")
    assert [m.name for m in a.messages] == [m.name for m in b.messages]
    for ma, mb in zip(a.messages, b.messages):
        assert (ma.frame_id, ma.length, ma.is_extended_frame) == (mb.frame_id, mb.length, mb.is_extended_frame)
        assert [s.name for s in ma.signals] == [s.name for s in mb.signals]
        for sa, sb in zip(ma.signals, mb.signals):
            layout = ("start", "length", "byte_order", "is_signed", "is_float", "multiplexer_ids", "unit")
            assert [getattr(sa, k) for k in layout] == [getattr(sb, k) for k in layout], sa.name
            scaling = ("scale", "offset", "minimum", "maximum")
            if sa.name in ("PosRef", "Pos"):
                assert sa.maximum == 12.5 and sb.maximum == pytest.approx(4 * math.pi, rel=1e-15)
                assert sb.minimum == -sb.maximum and sb.offset == sb.minimum
                assert sb.scale == pytest.approx(8 * math.pi / 65535, rel=1e-12)  # u * (hi - lo) / 65535
                assert sa.scale == pytest.approx(25 / 65535, rel=1e-12)
            else:
                assert [getattr(sa, k) for k in scaling] == [getattr(sb, k) for k in scaling], sa.name
    pos = b.get_message_by_name("CG_Feedback").get_signal_by_name("Pos")
    assert truncating_raw(pos, 12.0) == 0xFA3A  # the hardware check value, +-4 pi


@given(st.floats(allow_nan=True, allow_infinity=True, width=64))
def test_fast_truncating_encoder_equals_the_manual_encoder(value):
    for path in ("cybergear.dbc", "cybergear_4pi.dbc"):
        for name in ("CG_MotionCmd", "CG_Feedback"):
            for sig in load_file(path).get_message_by_name(name).signals:
                fast = MessageCodec.of(load_file(path).get_message_by_name(name)).signals[sig.name]
                assert fast.truncated(value) == truncating_raw(sig, value), (path, sig.name)
