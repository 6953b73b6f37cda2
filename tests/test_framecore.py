"""The compiled record path (hil/fast/, C) against the Python one (the reference): the same
settled frames, load windows, candump text and /can/ records from the same frames; the fallback forced."""
from __future__ import annotations

import io
import random
from dataclasses import replace

import can
import pytest

from wheelleg.hil import fast, scenarios
from wheelleg.hil.bus import busload, recorder as recorder_module
from wheelleg.hil.bus.plant_bus import SimClock
from wheelleg.hil.bus.recorder import Recorder
from wheelleg.hil.record import can_batch
from wheelleg.hil.record.candump import CandumpWriter
from wheelleg.hil.record.frame import Frame
from wheelleg.hil.run import rig as rig_module

compiled = pytest.mark.skipif(not fast.available(), reason="hil/fast/ not built (no C compiler?)")
SYNC = recorder_module.SYNC_ID


@pytest.fixture
def choice_restored():
    """The test switches paths with ``force_python``; afterwards the environment decides again."""
    yield
    fast.force_python(None)


def test_forcing_the_python_path_leaves_the_recorder_without_its_core(monkeypatch):
    fast.force_python(True)
    try:
        assert fast.core() is None and Recorder([], SimClock(), ["vcan0"])._core is None
    finally:
        fast.force_python(None)
    monkeypatch.setenv(fast.ENV, "1")
    assert fast.core() is None and CandumpWriter(io.StringIO())._lines is None
    monkeypatch.setenv(fast.ENV, "0")
    assert (fast.core() is not None) == fast.available()


class Sink:
    """A recorder sink keeping what it gets: every field of each frame, with its type."""

    def __init__(self):
        self.frames, self.stopped = [], False

    def on_frames(self, frames):
        assert all(type(f) is Frame for f in frames)
        self.frames += [tuple((getattr(f, k), type(getattr(f, k))) for k in Frame.__slots__) for f in frames]

    def stop(self):
        self.stopped = True


class Loads:
    """A trace stand-in keeping the /bus/load messages."""

    def __init__(self):
        self.rows = []

    def message(self, topic, t_ns, values, *_):
        self.rows.append((topic, t_ns, values))


def _random_msg(r: random.Random) -> can.Message:
    extended = r.random() < 0.5
    ident = r.randrange(1 << 29) if extended else r.choice([SYNC, 0x200, 0x201, 0x710, r.randrange(1 << 11)])
    size = r.randrange(9)
    data = bytes(r.choice([0, 255, r.randrange(256)]) for _ in range(size))
    return can.Message(arbitration_id=ident, is_extended_id=extended, data=data, dlc=size,
                       is_error_frame=r.random() < 0.02, is_remote_frame=r.random() < 0.02, check=False)


def _drive(seed: int, batch: int, slice_size: int | None) -> tuple[list, list, int]:
    """A recorder fed random traffic in the rig's manner: (what the sink got, the load rows, frames)."""
    r, clock, sink, loads = random.Random(seed), SimClock(), Sink(), Loads()
    rec = Recorder([sink], clock, ["vcan0", "vcan1"], load_to=loads, batch=batch, slice_size=slice_size)
    for tick in range(400):
        clock.now_ns = tick * 1_000_000 + r.choice([0, 0, 250_000])
        for _ in range(r.randrange(8)):
            channel = r.choice(["vcan0", "vcan1", "vcan1", "vcan2"])  # vcan2: a bus met on the way
            kind = r.random()
            if kind < 0.4:
                handle = rec.received(channel, _random_msg(r))
                for _ in range(r.randrange(3)):  # the devices' replies to it
                    rec.sent(channel, _random_msg(r), handle)
            else:
                rec.sent(channel, _random_msg(r))
        if r.random() < 0.2:
            rec.settle(r.choice([None, 3]))
    rec.stop()
    assert sink.stopped
    return sink.frames, loads.rows, rec.frames


@compiled
@pytest.mark.parametrize("seed, batch, slice_size", [(1, 1024, None), (2, 7, None), (3, 50, 5), (4, 1, None)])
def test_the_compiled_recorder_settles_what_the_python_one_does(seed, batch, slice_size):
    got = _drive(seed, batch, slice_size)
    fast.force_python(True)
    try:
        want = _drive(seed, batch, slice_size)
    finally:
        fast.force_python(None)
    assert len(want[0]) > 1000 and want[1]
    assert got == want


def _frames(r: random.Random, n: int, plain: bool) -> list[Frame]:
    out, t = [], r.randrange(10**12)
    for _ in range(n):
        t += r.randrange(200_000)
        extended = r.random() < 0.5
        size = r.randrange(9)
        f = Frame(t, r.choice(["vcan0", "can1"]), r.randrange(1 << 29) if extended else r.randrange(1 << 11),
                  extended, bytes(r.randrange(256) for _ in range(size)), size)
        if not plain and r.random() < 0.1:  # the other forms, and frames the writers turn away
            f = replace(f, **r.choice([{"is_error": True}, {"is_remote": True, "data": b""}, {"is_fd": True, "fd_flags": 1},
                                       {"channel": "bad name"}, {"arbitration_id": 0x800, "is_extended": False},
                                       {"data": bytearray(f.data)}, {"t_ns": -5 * 10**12}, {"t_ns": 1 << 70}]))
        out.append(f)
    return out


def _candump(frames: list[Frame], epoch_ns: int) -> tuple[str, str | None]:
    text = io.StringIO()
    writer = CandumpWriter(text, flush_interval_s=None, epoch_ns=epoch_ns)
    error = None
    for at in range(0, len(frames), 97):  # a batch at a time, as the recorder hands them over
        try:
            writer.on_frames(frames[at:at + 97])
        except ValueError as exc:
            error = str(exc)
            break
    return text.getvalue(), error


@compiled
@pytest.mark.parametrize("plain", [True, False])
def test_the_compiled_candump_lines_are_the_python_ones(plain, choice_restored):
    r = random.Random(5)
    for trial in range(20):
        frames, epoch = _frames(r, 300, plain), r.choice([0, 1_700_000_000 * 10**9, -10**12, 1 << 63])
        fast.force_python(True)
        want = _candump(frames, epoch)
        fast.force_python(False)
        got = _candump(frames, epoch)
        assert got == want
        if plain and epoch >= 0:  # nothing to turn away: every line written
            assert want[1] is None and want[0].count("\n") == 300


@compiled
def test_the_compiled_can_records_are_the_python_ones(choice_restored):
    r = random.Random(6)
    for trial in range(50):
        frames = _frames(r, r.randrange(1, 200), plain=trial % 2 == 0)
        fast.force_python(True)
        try:
            want = can_batch.pack(frames)
        except ValueError as exc:
            want = str(exc)
        fast.force_python(False)
        try:
            got = can_batch.pack(frames)
        except ValueError as exc:
            got = str(exc)
        assert got == want
        if isinstance(want, bytes):
            assert [replace(f, bus="") for f in can_batch.unpack(got, frames[0].t_ns, "x")] == \
                [replace(f, channel="x") for f in frames]


@compiled
def test_the_compiled_wire_time_is_busloads():
    r = random.Random(7)
    for _ in range(5000):
        extended = r.random() < 0.5
        ident = r.randrange(1 << 29) if extended else r.randrange(1 << 11)
        data = bytes(r.choice([0, 0xFF, 0xAA, r.randrange(256)]) for _ in range(r.randrange(65)))
        assert fast._framecore.frame_bits(ident, extended, data) == busload.frame_bits(ident, extended, data)


@compiled
def test_a_run_records_the_same_bytes_on_either_path(tmp_path):
    """The rig's own frames through both paths: the candump log and every /can/, /bus/load and float record."""
    from wheelleg.hil.record.trace import TraceReader
    scenario = replace(scenarios.get("balance"), duration_s=0.3)
    outs = {}
    for name, forced in (("python", True), ("compiled", False)):
        fast.force_python(forced)
        try:
            outs[name] = rig_module.Rig(scenario, rig_module.RigConfig(trace_flush_s=None), tmp_path / name).run()
        finally:
            fast.force_python(None)
    logs = [outs[k].log_path.read_bytes() for k in ("python", "compiled")]
    assert logs[0].count(b"\n") > 2500 and logs[0] == logs[1]
    readers = [TraceReader(outs[k].trace_path) for k in ("python", "compiled")]
    kinds = ("/can/", "/bus/load", "/sim/", "/controller/debug")  # /sim/state, /sim/qpos
    topics = [t for t in readers[0].topics if t.startswith(kinds)]
    assert len(topics) == 6 and topics == [t for t in readers[1].topics if t.startswith(kinds)]
    for topic in topics:
        assert readers[0].records(topic) == readers[1].records(topic), topic


@compiled
def test_the_compiled_float_records_are_the_python_ones(choice_restored):
    import math

    import numpy as np

    from wheelleg.hil.record.float_records import FloatLayout
    layout = FloatLayout("wheelleg/msg/X", ("a", "b", "c"), "")
    cases = [{"a": 1.5, "b": -0.0, "c": math.inf}, {"a": 2, "b": True}, {"a": np.float64(0.1), "c": math.nan},
             {"a": None, "b": 1.0}, {"a": np.int32(7)}, {"a": 10**400}, {"a": "x"}, {}]
    compiled_ones = 0
    for values in cases:
        try:
            want = layout.pack(values, "/t")
        except TypeError:
            want = None  # the compiled packer leaves it to Python
        got = layout.pack_known(values, fast._framecore)
        assert got == want or (got is None and not all(type(v) in (float, int, bool) for v in values.values())), values
        compiled_ones += got is not None
    assert compiled_ones == 4 and len(got) == 4 + 3 * 8  # the empty dict, last: NaNs
    assert layout.pack_known({"a": 1.0, "t": 2.0}, fast._framecore) is None  # no time field: "t" is unknown
    assert FloatLayout("x", ("a",), "t").pack_known({"a": 1.0, "t": 2.0}, fast._framecore) == \
        FloatLayout("x", ("a",), "t").pack({"a": 1.0}, "/t")


@pytest.mark.parametrize("forced", [True, False])
def test_a_trace_refuses_an_unknown_field_or_a_non_number_on_either_path(tmp_path, forced):
    from wheelleg.hil.record import schemas
    from wheelleg.hil.record.trace import TraceWriter
    fast.force_python(forced)
    try:
        schema = schemas.described_schema("wheelleg.ControllerDebug", {"a": "[m] a", "b": "[N] b"})
        with TraceWriter(tmp_path / "t.mcap", metadata={}) as trace:
            trace.numbers("/controller/debug", 1_000, {"a": 1.0, "b": 2}, schema)
            with pytest.raises(ValueError, match=r"\['c'\] not among the fields"):
                trace.numbers("/controller/debug", 2_000, {"a": 1.0, "c": 2.0}, schema)
            with pytest.raises(ValueError, match=r"\['t'\] not among the fields"):
                trace.numbers("/controller/debug", 2_000, {"a": 1.0, "t": 2.0}, schema)  # no time field here
            with pytest.raises(TypeError, match=r"\['b'\] must be a number"):
                trace.numbers("/controller/debug", 2_000, {"a": 1.0, "b": "x"}, schema)
            trace.numbers("/controller/debug", 3_000, {"b": None}, schema)
    finally:
        fast.force_python(None)
    from wheelleg.hil.record.trace import TraceReader
    rows = TraceReader(tmp_path / "t.mcap").topic("/controller/debug")
    assert rows == [(1_000, {"a": 1.0, "b": 2.0}), (3_000, {"a": None, "b": None})]
