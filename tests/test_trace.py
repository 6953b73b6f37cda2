"""The MCAP trace: round trip, decoding, schemas, crash recovery (wheelleg.hil.record.trace)."""
from __future__ import annotations

import itertools
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from wheelleg import dbc
from wheelleg.dbc import cybergear as cg
from wheelleg.hil.record import can_batch, schemas
from wheelleg.hil.record.frame import Frame, FrameColumns
from wheelleg.hil.record.trace import TraceReader, TraceWriter
from wheelleg.hil.record.decode import FrameDecoder

REPO = Path(__file__).resolve().parents[1]
DBS = {"can1": dbc.load_bus("can1"), "can2": dbc.load_bus("can2")}
HOST = 0xFD
STATE_KEYS = [k for k in schemas.SIM_STATE_FIELDS if k != "t"]
METADATA = {"run": {"scenario": "unit", "seed": "7", "control_period_s": "0.002",
                    "git_revision": "abc123", "controller_params": json.dumps({"kp": 1.5})},
            "extra": {"note": "ünïcode ok"}}
ATTACHMENTS = [("c620.dbc", dbc.dbc_path("c620.dbc").read_bytes(), "text/x-dbc"),
               ("robot.xml", b"<mujoco/>", "application/xml")]


def _encode(bus: str, name: str, **values) -> tuple[int, bool, bytes]:
    message = DBS[bus].get_message_by_name(name)
    full = {s.name: values.get(s.name, 0) for s in message.signals}
    return message.frame_id, message.is_extended_frame, message.encode(full)


def _frames() -> list[Frame]:
    """A mix of every frame kind of both buses, at distinct bus times."""
    out, t = [], 1_000
    feedback = _encode("can2", "CG_Feedback", Pos=0.5, Vel=-1.25, Torque=3.0, Temp=31.5)[2]
    param = DBS["can2"].get_message_by_name("CG_ParamRead").encode(
        {"Index": 0x7005, "run_mode": 0}, strict=False)
    rows = [
        ("can1", *_encode("can1", "C620_Cmd_1_4", ESC1_Current=2.5, ESC2_Current=-1.0)),
        ("can1", *_encode("can1", "C620_Feedback_1", RotorAngle=90, RotorSpeed=-300, TorqueCurrent=0.75, MotorTemp=40)),
        ("can1", *_encode("can1", "Heartbeat")),
        ("can1", 0x555, False, b"\x01\x02"),  # no DBC message: raw only
        ("can1", 0x201, False, b"\x01\x02\x03"),  # known id, wrong length: raw only
        ("can2", cg.motion_id(-2.5, 3), True, bytes(8)),
        ("can2", cg.reply_id(cg.T_FEEDBACK, 3, HOST, mode=2, faults={"FaultOverTemp"}), True, feedback),
        ("can2", cg.request_id(cg.T_ENABLE, HOST, 4), True, bytes(8)),
        ("can2", cg.request_id(cg.T_PARAM_READ, HOST, 2), True, param),
        ("can2", cg.reply_id(cg.T_PARAM_READ, 2, HOST), True, param),
        ("can2", cg.set_id_id(9, HOST, 2), True, bytes(8)),
    ]
    for k in range(20):
        for channel, can_id, ext, data in rows:
            out.append(Frame(t, channel, can_id, ext, data, len(data)))
            t += 37_000 + k
    out.append(Frame(t, "can1", 0x80, False, bytes(8), 8, is_error=True))
    return out


def _state(k: int) -> dict:
    state = {key: 0.01 * k + i for i, key in enumerate(STATE_KEYS)}
    state["pitch_motor_temp"] = 30.0 + k  # an extra field
    return state


def _write(path: Path, frames, decode: bool = True, **options) -> None:
    with TraceWriter(path, metadata=METADATA, attachments=ATTACHMENTS, dbs=DBS, decode=decode,
                     **options) as trace:
        for i, f in enumerate(frames):
            trace.frame(f)
            if i % 10 == 0:
                trace.sim_state(f.t_ns, _state(i))
        trace.event(5_000, "push", force_n=12.5, body="base")
        trace.event(7_000, "fault", motor=3)
        trace.message("/controller/debug", 9_000, {"pitch_ref": 0.1, "nan_value": float("nan")}, "Debug")


@pytest.fixture(scope="module")
def trace_path(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("trace") / "run.mcap"
    _write(path, _frames())
    return path


def test_round_trip_of_every_channel_kind(trace_path):
    reader = TraceReader(trace_path)
    assert not reader.truncated
    frames = _frames()
    assert list(reader.frames()) == sorted(frames, key=lambda f: f.t_ns)
    assert list(reader.frames("can2")) == [f for f in frames if f.channel == "can2"]
    assert reader.metadata == METADATA
    assert reader.attachments == {name: data for name, data, _ in ATTACHMENTS}
    assert reader.attachment_media_types["robot.xml"] == "application/xml"

    state = reader.sim_state()
    written = [(f.t_ns, _state(i)) for i, f in enumerate(frames) if i % 10 == 0]
    np.testing.assert_array_equal(state["t"], [t / 1e9 for t, _ in written])
    for key in STATE_KEYS + ["pitch_motor_temp"]:
        np.testing.assert_array_equal(state[key], [s[key] for _, s in written])
        assert state[key].shape == (len(written),)

    assert reader.events() == [{"t": 5e-6, "kind": "push", "force_n": 12.5, "body": "base"},
                               {"t": 7e-6, "kind": "fault", "motor": 3}]
    assert reader.topic("/controller/debug") == [(9_000, {"pitch_ref": 0.1, "nan_value": None})]


def test_decoded_channels_match_cantools(trace_path):
    reader = TraceReader(trace_path)
    frames = _frames()
    for name in ("C620_Cmd_1_4", "C620_Feedback_1", "Heartbeat"):
        message = DBS["can1"].get_message_by_name(name)
        mine = [f for f in frames if f.channel == "can1" and f.arbitration_id == message.frame_id
                and len(f.data) == message.length and not f.is_error]
        decoded = reader.decoded("can1", name)
        np.testing.assert_array_equal(decoded["t"], [f.t_ns / 1e9 for f in mine])
        for sig in message.signals:
            expected = [message.decode(f.data, decode_choices=False)[sig.name] for f in mine]
            np.testing.assert_array_equal(decoded[sig.name], expected)
    assert "/decoded/can1/C620_Feedback_1" in reader.topics
    # the short 0x201 frame and the unknown 0x555 are raw only
    assert reader.topics["/decoded/can1/C620_Feedback_1"] == 20
    assert not [t for t in reader.topics if "0x555" in t or t.endswith("/1365")]


def test_cybergear_payload_and_id_fields(trace_path):
    reader = TraceReader(trace_path)
    feedback = reader.decoded("can2", "CG_Feedback")
    message = DBS["can2"].get_message_by_name("CG_Feedback")
    payload = _encode("can2", "CG_Feedback", Pos=0.5, Vel=-1.25, Torque=3.0, Temp=31.5)[2]
    expected = message.decode(payload, decode_choices=False)
    for name, value in expected.items():
        assert np.all(feedback[name] == value)
    assert np.all(feedback["MotorId"] == 3) and np.all(feedback["Host"] == HOST)
    assert np.all(feedback["Mode"] == 2) and np.all(feedback["FaultOverTemp"] == 1)
    assert np.all(feedback["FaultOverCurrent"] == 0)

    motion = reader.decoded("can2", "CG_MotionCmd")
    assert np.all(motion["Target"] == 3)
    assert np.all(motion["TorqueRef"] == cg.motion_torque(cg.motion_id(-2.5, 3)))
    assert abs(motion["TorqueRef"][0] + 2.5) < 1e-3

    params = reader.topic("/decoded/can2/CG_ParamRead")
    requests = [p for _, p in params if "Target" in p and "MotorId" not in p]
    replies = [p for _, p in params if "MotorId" in p]
    assert len(requests) == len(replies) == 20
    assert requests[0]["Target"] == 2 and requests[0]["Host"] == HOST
    assert replies[0]["MotorId"] == 2 and replies[0]["Host"] == HOST
    assert requests[0]["Index"] == 0x7005 and requests[0]["run_mode"] == 0
    set_id = reader.decoded("can2", "CG_SetId")
    assert np.all(set_id["NewId"] == 9) and np.all(set_id["Target"] == 2)
    enable = reader.decoded("can2", "CG_Enable")
    assert np.all(enable["Type"] == cg.T_ENABLE) and np.all(enable["Target"] == 4)


def test_schemas_are_valid_and_every_message_validates(trace_path):
    import jsonschema  # noqa: PLC0415 (dev extra)
    seen = set()
    with open(trace_path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        validators = {}
        for schema, channel, message in reader.iter_messages():
            seen.add(channel.topic)
            if channel.topic.startswith(("/can/", "/sim/state")):  # binary: test_*_with_mcaps_ros2_decoder*
                assert (schema.encoding, channel.message_encoding) == ("ros2msg", "cdr")
                continue
            assert schema.encoding == "jsonschema" and channel.message_encoding == "json"
            if schema.id not in validators:
                body = json.loads(schema.data)
                jsonschema.Draft202012Validator.check_schema(body)
                jsonschema.Draft7Validator.check_schema(body)
                validators[schema.id] = jsonschema.Draft202012Validator(body)
            validators[schema.id].validate(json.loads(message.data))
    assert {"/can/can1", "/can/can2", "/sim/state", "/scenario/events", "/controller/debug",
            "/decoded/can2/CG_Feedback", "/decoded/can1/Heartbeat"} <= seen


def test_can_records_decode_with_mcaps_ros2_decoder_to_the_frames_written(trace_path):
    """Foxglove and mcap-ros2-support read /can/ by its ros2msg schema: numbers, not text; one message
    per bus and 100 ms window, its frames as arrays (the payloads one after another, ``length`` bytes each)."""
    decoder = pytest.importorskip("mcap_ros2.decoder").DecoderFactory()
    with open(trace_path, "rb") as f:
        got, messages = [], 0
        for schema, channel, message in make_reader(f).iter_messages(topics=["/can/can1", "/can/can2"]):
            m = decoder.decoder_for(channel.message_encoding, schema)(message.data)
            times = list(itertools.accumulate(m.gap_ns, initial=message.log_time))[1:]  # gaps after the previous
            assert schema.name == "wheelleg/msg/CanFrames" and m.gap_ns[0] == 0
            assert all(t // 100_000_000 == times[0] // 100_000_000 for t in times)  # one 100 ms window
            data, at = bytes(m.data), 0
            for t, can_id, flags, dlc, length in zip(times, m.id, m.flags, m.dlc, m.length):
                got.append((t, channel.topic[5:], can_id, bool(flags & 1), data[at:at + length], dlc,
                            bool(flags & 2)))
                at += length
            messages += 1
    written = [(f.t_ns, f.channel, f.arbitration_id, f.is_extended, f.data, f.dlc, f.is_error) for f in _frames()]
    assert sorted(got) == sorted(written) and len(got) > 10 and messages >= 2


def test_float_records_decode_with_mcaps_ros2_decoder_to_the_values_written(tmp_path):
    """/sim/state and /controller/debug are float64 ROS 2 messages: Foxglove plots each field by its
    (lower-case) ROS name; TraceReader gives the rig's names back, 't' from the log time."""
    decoder = pytest.importorskip("mcap_ros2.decoder").DecoderFactory()
    fields = {"left_L0": "[m] leg", "Fn_left": "[N] support", "jump_phase": "phase", "FR_foot_z": "[m] foot"}
    debug_schema = schemas.described_schema("wheelleg.ControllerDebug", fields)
    path = tmp_path / "floats.mcap"
    with TraceWriter(path, metadata={}) as trace:
        for k in range(5):
            trace.sim_state(1_000 + k * 2_000_000, _state(k))
            trace.numbers("/controller/debug", 1_000 + k * 2_000_000,
                          {"left_L0": 0.17 + k, "Fn_left": 20.5 - k, "jump_phase": k, "FR_foot_z": None}, debug_schema)
    with open(path, "rb") as f:
        got: dict[str, list] = {}
        for schema, channel, message in make_reader(f).iter_messages():
            m = decoder.decoder_for(channel.message_encoding, schema)(message.data)
            got.setdefault(channel.topic, []).append((message.log_time, m))
    assert [m.pitch for _, m in got["/sim/state"]] == [_state(k)["pitch"] for k in range(5)]
    assert [m.pitch_motor_temp for _, m in got["/sim/state"]] == [30.0 + k for k in range(5)]
    assert [(m.left_l0, m.fn_left, m.jump_phase) for _, m in got["/controller/debug"]] == [
        (0.17 + k, 20.5 - k, k) for k in range(5)]
    reader = TraceReader(path)
    assert reader.topic("/controller/debug")[1] == (
        2_001_000, {"left_L0": 1.17, "Fn_left": 19.5, "jump_phase": 1.0, "FR_foot_z": None})
    t, row = reader.topic("/sim/state")[2]
    assert row == {"t": t / 1e9, **_state(2)} and list(row)[:3] == ["t", "x", "y"]
    debug = reader.columns("/controller/debug")
    assert list(debug) == list(fields) and np.isnan(debug["FR_foot_z"]).all()
    np.testing.assert_array_equal(reader.sim_state()["t"], [(1_000 + k * 2_000_000) / 1e9 for k in range(5)])


def test_a_can_record_by_column_holds_the_frames_it_unpacks_to():
    """Checks and derived signals read /can/ records by column (``unpack_columns``): the same frames."""
    rng = np.random.default_rng(3)
    frames, t_ns = [], 5_000
    for k in range(40):
        t_ns += int(rng.integers(0, 300_000))
        fd, extended = k % 9 == 4, bool(rng.integers(2))
        size = int(rng.integers(0, 65 if fd else 9))
        frames.append(Frame(t_ns, "vcan1", int(rng.integers(0, 0x1FFFFFFF if extended else 0x7FF)), extended,
                            rng.bytes(size), size, is_error=k % 13 == 7, is_fd=fd))
    record = can_batch.pack(frames)
    columns = can_batch.unpack_columns(record, frames[0].t_ns)
    expected = FrameColumns.of(can_batch.unpack(record, frames[0].t_ns, "vcan1"))
    for name in ("t_ns", "arbitration_id", "is_extended", "is_error"):
        np.testing.assert_array_equal(getattr(columns, name), getattr(expected, name))
        assert getattr(columns, name).dtype == getattr(expected, name).dtype
    assert columns.data == expected.data == [f.data for f in frames]
    with pytest.raises(ValueError):
        can_batch.unpack_columns(record[:len(record) // 2], 0)


def test_sim_state_prepared_before_the_first_record_reads_back_the_same(tmp_path):
    """Real time registers /sim/state before its clock starts (``prepare_sim_state``); the records are
    the ones ``sim_state`` alone writes."""
    columns = []
    for prepared in (False, True):
        path = tmp_path / f"prepared-{prepared}.mcap"
        with TraceWriter(path, metadata={}) as trace:
            if prepared:
                trace.prepare_sim_state(_state(9))
                with pytest.raises(ValueError, match="missing"):
                    TraceWriter(tmp_path / "x.mcap", metadata={}).prepare_sim_state({"x": 0.0})
            for k in range(3):
                trace.sim_state(k * 2_000_000, _state(k))
        columns.append(TraceReader(path).sim_state())
    assert list(columns[0]) == list(columns[1])
    for name, column in columns[0].items():
        np.testing.assert_array_equal(column, columns[1][name])


def test_float_records_refuse_what_they_cannot_hold(tmp_path):
    trace = TraceWriter(tmp_path / "bad.mcap", metadata={})
    trace.sim_state(0, _state(0))
    with pytest.raises(ValueError, match="wind"):  # a field the first record did not have
        trace.sim_state(1, {**_state(1), "wind": 1.0})
    schema = schemas.described_schema("wheelleg.D", {"a": "[m]"})
    with pytest.raises(TypeError, match="'a'"):
        trace.numbers("/d", 0, {"a": "high"}, schema)
    with pytest.raises(ValueError, match="topic"):
        trace.numbers("/sim/state", 0, {"a": 1.0}, schema)
    trace.finish()


def test_schema_rejects_a_wrong_record():
    import jsonschema  # noqa: PLC0415 (dev extra)
    validator = jsonschema.Draft202012Validator(schemas.CAN_FRAME_JSON)
    good = {"id": 0x123, "extended": False, "dlc": 2, "data": "0aff", "error": False}
    assert validator.is_valid(good)
    for bad in ({**good, "data": "0AF"}, {**good, "id": -1}, {**good, "extra": 1},
                {k: v for k, v in good.items() if k != "dlc"}):
        assert not validator.is_valid(bad)
    state = jsonschema.Draft202012Validator(schemas.sim_state_schema(["motor_temp"]))
    assert not state.is_valid({"t": 0.0})  # the contract's fields are required
    assert "motor_temp" in schemas.sim_state_schema(["motor_temp"])["properties"]


def test_mcap_library_reads_the_finished_file(trace_path):
    with open(trace_path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        counts = {}
        for _, channel, _ in reader.iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
        attachments = {a.name: a.data for a in reader.iter_attachments()}
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    stats = summary.statistics
    assert stats.message_count == sum(counts.values())
    by_topic = {summary.channels[cid].topic: n for cid, n in stats.channel_message_counts.items()}
    assert by_topic == counts
    assert counts["/can/can1"] == len({f.t_ns // 100_000_000 for f in _frames() if f.channel == "can1"})
    assert attachments == {name: data for name, data, _ in ATTACHMENTS}
    assert metadata == METADATA
    with open(trace_path, "rb") as f:  # topic filtering uses the chunk's message indexes
        only = list(make_reader(f).iter_messages(topics=["/sim/state"]))
    assert len(only) == counts["/sim/state"]


def test_decode_false_records_raw_only_and_the_reader_decodes_later(tmp_path, trace_path):
    path = tmp_path / "raw.mcap"
    _write(path, _frames(), decode=False)
    raw = TraceReader(path)
    assert not [t for t in raw.topics if t.startswith("/decoded/")]
    assert raw.decoded("can2", "CG_Feedback") == {}
    later = TraceReader(path, dbs=DBS)
    eager = TraceReader(trace_path)
    for channel, name in [("can2", "CG_Feedback"), ("can1", "C620_Cmd_1_4"), ("can2", "CG_MotionCmd")]:
        a, b = later.decoded(channel, name), eager.decoded(channel, name)
        assert a.keys() == b.keys() and a
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])


def test_chunking_options_give_the_same_content(tmp_path, trace_path):
    path = tmp_path / "small.mcap"
    _write(path, _frames(), compression="", chunk_size=2_000, flush_interval_s=None, can_window_s=0.0002)
    small, ref = TraceReader(path), TraceReader(trace_path)
    assert small.scan.chunks > 5 * ref.scan.chunks
    assert list(small.frames()) == list(ref.frames())
    assert small.topic("/decoded/can2/CG_Feedback") == ref.topic("/decoded/can2/CG_Feedback")


def test_batched_and_frame_by_frame_decoding_write_the_same_messages(tmp_path, trace_path):
    """The writer decodes each message's frames in batches; one at a time must give the same records."""
    path = tmp_path / "one-by-one.mcap"
    frames = _frames()
    frames += [replace(f, t_ns=f.t_ns + frames[-1].t_ns) for f in frames if f.dlc == 8]  # a batch on the numpy path
    _write(path, frames, decode_batch=1)
    _write(tmp_path / "batched.mcap", frames)
    assert _records_by_topic(path) == _records_by_topic(tmp_path / "batched.mcap")


def test_frames_in_batches_write_the_records_of_frame_by_frame(tmp_path):
    """A recorder hands its frames over a list at a time (``on_frames``): the same records per topic."""
    frames = _frames()
    with TraceWriter(tmp_path / "batches.mcap", metadata=METADATA, dbs=DBS, decode=True, chunk_size=500) as trace:
        for start in range(0, len(frames), 64):
            trace.on_frames(frames[start:start + 64])
    with TraceWriter(tmp_path / "one.mcap", metadata=METADATA, dbs=DBS, decode=True, chunk_size=500) as trace:
        for f in frames:
            trace.on_frame(f)
    batches, one = _records_by_topic(tmp_path / "batches.mcap"), _records_by_topic(tmp_path / "one.mcap")
    can = ("/can/can1", "/can/can2")  # a /can/ message is cut where a chunk closes: they differ by the chunks
    assert {k: v for k, v in batches.items() if k not in can} == {k: v for k, v in one.items() if k not in can}
    assert len(batches["/decoded/can2/CG_Feedback"]) == 20
    assert list(TraceReader(tmp_path / "batches.mcap").frames()) == list(TraceReader(tmp_path / "one.mcap").frames())
    assert TraceReader(tmp_path / "batches.mcap").scan.chunks > 3


def _records_by_topic(path: Path) -> dict[str, list[tuple[int, bytes]]]:
    """Each topic's (log time, record bytes) in time order, as mcap's reader gives them."""
    out: dict[str, list[tuple[int, bytes]]] = {}
    with open(path, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            out.setdefault(channel.topic, []).append((message.log_time, message.data))
    return out


def test_decode_many_gives_the_dicts_of_decode_for_every_message():
    """numpy over a batch (DecodePlan.decode_many) = the compiled codec frame by frame: same keys, types, values."""
    rng = np.random.default_rng(3)
    decoder, vectorised = FrameDecoder(DBS), 0
    for channel, db in DBS.items():
        for message in db.messages:
            ids = [message.frame_id] * 40
            if message.is_extended_frame:  # any id fields: torque, host, target, mode, faults
                ids = [(message.frame_id & (0x1F << 24)) | int(r) for r in rng.integers(0, 1 << 24, 40)]
            payloads = [rng.integers(0, 256, message.length, dtype=np.uint8).tobytes() for _ in ids]
            plan = decoder.plan(channel, message.frame_id, message.is_extended_frame)
            batch = plan.decode_many(ids, payloads)
            one_by_one = [plan.decode(i, d) for i, d in zip(ids, payloads)]
            assert [json.dumps(r) for r in batch] == [json.dumps(r) for r in one_by_one], message.name
            vectorised += plan.vectorised
    assert vectorised > 30  # most messages take the numpy path (not: multiplexed, 64-bit fields, bare requests)


def test_decoder_skips_what_it_cannot_decode():
    decoder = FrameDecoder(DBS)
    assert decoder.decode("can1", 0x555, False, b"\x00") is None
    assert decoder.decode("can1", 0x201, False, b"\x00") is None  # 1 byte for an 8-byte message
    assert decoder.decode("can1", 0x201, True, bytes(8)) is None  # standard id sent as extended
    assert decoder.decode("can9", 0x201, False, bytes(8)) is None  # no DBC for the channel
    plan, values = decoder.decode("can1", 0x201, False, bytes(8))
    assert plan.name == "C620_Feedback_1" and set(values) == {s.name for s in plan.message.signals}


def test_bad_input_gets_clear_errors(tmp_path):
    trace = TraceWriter(tmp_path / "bad.mcap", metadata={"run": {"seed": "1"}})
    with pytest.raises(ValueError, match="missing"):
        trace.sim_state(0, {"x": 0.0})
    with pytest.raises(TypeError, match="pitch"):
        trace.sim_state(0, {**{k: 0.0 for k in STATE_KEYS}, "pitch": "up"})
    with pytest.raises(ValueError, match="t_ns"):
        trace.frame(Frame(-5, "can1", 0x100, False, b"", 0))
    with pytest.raises(ValueError, match="topic"):
        trace.message("/sim/state", 0, {"a": 1}, "X")
    with pytest.raises(ValueError, match="kind"):
        trace.event(0, "")
    with pytest.raises(ValueError, match="channel"):
        trace.frame(Frame(0, "can 1", 0x100, False, b"", 0))
    trace.finish()
    with pytest.raises(RuntimeError, match="finished"):
        trace.frame(Frame(0, "can1", 0x100, False, b"", 0))
    with pytest.raises(TypeError, match="seed"):
        TraceWriter(tmp_path / "m.mcap", metadata={"run": {"seed": 1}})
    assert TraceReader(tmp_path / "bad.mcap").truncated is False


_KILLED_WRITER = textwrap.dedent("""
    import sys, time
    from wheelleg.hil.record.frame import Frame
    from wheelleg.hil.record.trace import TraceWriter
    mode, path = sys.argv[1], sys.argv[2]
    if mode == "bus-time":  # bus time runs faster than real time, as in a lockstep run: chunks close on their span
        trace = TraceWriter(path, metadata={"run": {"scenario": "killed"}},
                            attachments=[("note.txt", b"kept", "text/plain")], flush_interval_s=None)
        step_ns, per_report, pause_s = 100_000, 200, 0.005
    else:  # bus time crawls: only the wall-clock flush closes chunks
        trace = TraceWriter(path, metadata={"run": {"scenario": "killed"}}, chunk_size=1 << 30,
                            chunk_span_s=1e6, flush_interval_s=0.25)
        step_ns, per_report, pause_s = 1, 200, 0.02
    trace.start()
    t0, n = time.monotonic(), 0
    while True:
        trace.frame(Frame(n * step_ns, "can1", 0x123, False, n.to_bytes(8, "little"), 8))
        n += 1
        if n % per_report == 0:
            print(f"{n} {n * step_ns} {time.monotonic() - t0:.6f}", flush=True)
            time.sleep(pause_s)
""")


def _run_and_kill(path: Path, mode: str, until) -> list[tuple[int, int, float]]:
    """Start a writer, SIGKILL it once ``until(reports)``; reports are (frames, bus ns, wall s)."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-c", _KILLED_WRITER, mode, str(path)], cwd=REPO,
                            stdout=subprocess.PIPE, text=True, env=env)
    reports = []
    try:
        deadline = time.monotonic() + 60
        for line in proc.stdout:
            n, t_ns, wall = line.split()
            reports.append((int(n), int(t_ns), float(wall)))
            if until(reports) or time.monotonic() > deadline:
                break
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        proc.stdout.close()
    assert proc.returncode == -signal.SIGKILL
    return reports


def _check_contiguous(frames: list[Frame]) -> None:
    """Recovered frames are exactly the first ones written, none corrupt."""
    assert [int.from_bytes(f.data, "little") for f in frames] == list(range(len(frames)))


def test_killed_writer_leaves_a_trace_up_to_about_the_last_second(tmp_path):
    path = tmp_path / "killed.mcap"
    reports = _run_and_kill(path, "bus-time", lambda r: r[-1][1] >= 1_500_000_000)
    reader = TraceReader(path)
    assert reader.truncated and reader.scan.error
    assert reader.metadata == {"run": {"scenario": "killed"}}
    assert reader.attachments == {"note.txt": b"kept"}
    frames = list(reader.frames("can1"))
    _check_contiguous(frames)
    last_reported_ns = reports[-1][1]
    assert last_reported_ns >= 1_500_000_000
    # at most one chunk span (0.5 s of bus time) may be lost; allow up to a second
    assert frames[-1].t_ns >= last_reported_ns - 1_000_000_000
    assert frames[-1].t_ns >= 0.6 * last_reported_ns


def test_killed_writer_is_bounded_by_the_wall_clock_flush(tmp_path):
    path = tmp_path / "slow.mcap"
    reports = _run_and_kill(path, "wall", lambda r: r[-1][2] >= 1.5)
    frames = list(TraceReader(path).frames("can1"))
    _check_contiguous(frames)
    # everything written 0.25 s (the flush interval) before the last report is on disk
    safe = [n for n, _, wall in reports if wall <= reports[-1][2] - 0.25]
    assert safe and len(frames) >= safe[-1]


def test_a_file_cut_anywhere_reads_back_a_prefix(tmp_path):
    """Cut a finished trace at many byte offsets: reading never fails and keeps whole chunks."""
    full = tmp_path / "full.mcap"
    _write(full, _frames(), chunk_size=1_500, flush_interval_s=None)
    blob = full.read_bytes()
    reference = list(TraceReader(full).frames("can2"))
    cut = tmp_path / "cut.mcap"
    seen_lengths = set()
    for size in range(0, len(blob), max(1, len(blob) // 97)):
        cut.write_bytes(blob[:size])
        reader = TraceReader(cut)
        assert reader.truncated
        frames = list(reader.frames("can2"))
        assert frames == reference[:len(frames)]
        seen_lengths.add(len(frames))
    assert len(seen_lengths) > 5  # the cuts fell inside many different chunks


def test_a_corrupt_chunk_ends_the_read_there(tmp_path):
    path = tmp_path / "corrupt.mcap"
    _write(path, _frames(), compression="", chunk_size=1_500, flush_interval_s=None)
    blob = bytearray(path.read_bytes())
    reference = list(TraceReader(path).frames("can1"))
    # a C620 feedback frame's id (0x201) in can1's binary /can/ records, inside some chunk near the middle
    at = blob.index((0x201).to_bytes(4, "little"), len(blob) // 2)
    blob[at] = 0x09  # still a valid record (id 0x209), but the chunk's CRC no longer matches
    path.write_bytes(bytes(blob))
    reader = TraceReader(path)
    assert reader.truncated and "CRC" in reader.scan.error
    frames = list(reader.frames("can1"))
    assert 0 < len(frames) < len(reference) and frames == reference[:len(frames)]


def test_stdlib_json_fallback_writes_the_same_values(tmp_path, trace_path):
    """Without orjson the json module encodes (NaN -> null too); the values read back are equal."""
    script = textwrap.dedent(f"""
        import sys
        sys.modules["orjson"] = None  # import fails: wheelleg.hil.record.trace falls back to json
        sys.path.insert(0, {str(REPO)!r})
        import tests.test_trace as t
        import wheelleg.hil.record.trace
        assert wheelleg.hil.record.trace.orjson is None
        t._write(__import__("pathlib").Path(sys.argv[1]), t._frames())
    """)
    path = tmp_path / "stdlib.mcap"
    subprocess.run([sys.executable, "-c", script, str(path)], cwd=REPO, check=True)
    mine, ref = TraceReader(path), TraceReader(trace_path)
    assert mine.topics == ref.topics
    for topic in mine.topics:
        assert mine.topic(topic) == ref.topic(topic), topic


OLD_TRACE = REPO / "tests" / "old_traces" / "per-frame-can.mcap"


def test_a_trace_of_one_message_per_frame_still_reads_back(trace_path):
    """tests/old_traces/per-frame-can.mcap: ``_write(path, _frames())`` by the writer before the batched
    /can/ records (main at bf859dd: one CDR message per frame, /decoded/ recorded live)."""
    import can  # noqa: PLC0415

    old, new = TraceReader(OLD_TRACE), TraceReader(trace_path)
    assert old.topics["/can/can1"] == sum(1 for f in _frames() if f.channel == "can1")  # the old layout
    assert list(old.frames()) == list(new.frames()) == sorted(_frames(), key=lambda f: f.t_ns)
    assert old.topic("/can/can2") == new.topic("/can/can2")
    for name in ("CG_Feedback", "CG_MotionCmd"):
        a, b = old.decoded("can2", name), new.decoded("can2", name)
        assert list(a) == list(b) and a
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
    assert [m.arbitration_id for m in can.LogReader(OLD_TRACE)] == [f.arbitration_id for f in old.frames()]
    a, b = old.sim_state(), new.sim_state()  # JSON then, float64 records now: the same columns
    assert list(a) == list(b) and len(a["t"]) == 23
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    assert old.topic("/sim/state") == new.topic("/sim/state")


def test_a_can_schema_of_another_version_is_refused_with_the_reason(tmp_path):
    from mcap.records import Schema  # noqa: PLC0415

    path = tmp_path / "future.mcap"
    with TraceWriter(path, metadata={}) as trace:
        future = Schema(id=0, name="wheelleg/msg/CanFramesV9", encoding="ros2msg", data=b"uint8[] blob\n")
        trace.copy(trace.copy_channel("/can/can1", future, "cdr"), 1_000, schemas.CDR_LE + bytes(4))
    reader = TraceReader(path)
    with pytest.raises(ValueError, match="CanFramesV9.*does not know"):
        list(reader.frames())
