"""Decoded signals derived on reading and ``wheelleg export`` (wheelleg.hil.record.derived, hil/analyze/export.py).

A run's trace keeps raw frames; readers decode them with the trace's own DBC
attachments and get what a trace recorded with ``/decoded/`` topics gives;
``wheelleg export`` writes those topics for Foxglove, record for record.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from wheelleg import dbc
from wheelleg.hil.analyze.export import export_decoded
from wheelleg.hil.cli import main
from wheelleg.hil.record.trace import TraceReader, TraceWriter
from tests.test_trace import DBS, _frames, _state

RUN = {"run": {"scenario": "unit", "robot": "wheel-legged", "can1": "can1", "can2": "can2"}}
DBC_FILES = [(p.name, p.read_bytes(), "text/x-dbc") for p in dbc.all_dbc_files()]


def _write(path: Path, decode: bool, attachments=DBC_FILES, frames=None) -> Path:
    with TraceWriter(path, metadata=RUN, attachments=attachments, dbs=DBS, decode=decode,
                     flush_interval_s=None) as trace:
        for i, f in enumerate(frames or _frames()):
            trace.frame(f)
            if i % 10 == 0:
                trace.sim_state(f.t_ns, _state(i))
        trace.event(5_000, "push", force_n=12.5)
        trace.message("/controller/debug", 9_000, {"pitch_ref": 0.1, "nan_value": float("nan")}, "Debug")
    return path


def _many_frames():
    """The mix of every frame kind, five times over (batches long enough for the numpy path)."""
    frames, shift = [], 0
    for _ in range(5):
        batch = _frames()
        frames += [replace(f, t_ns=f.t_ns + shift) for f in batch]
        shift = frames[-1].t_ns
    return frames


@pytest.fixture(scope="module")
def traces(tmp_path_factory) -> tuple[Path, Path]:
    """(raw frames only, the same run with /decoded/ recorded live)."""
    out = tmp_path_factory.mktemp("derived")
    frames = _many_frames()
    return _write(out / "raw.mcap", False, frames=frames), _write(out / "live.mcap", True, frames=frames)


def _records(path: Path) -> dict[str, list[tuple[int, bytes]]]:
    out: dict[str, list[tuple[int, bytes]]] = {}
    with open(path, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            out.setdefault(channel.topic, []).append((message.log_time, message.data))
    return out


def test_a_raw_trace_reads_back_the_decoded_signals_of_a_live_decoded_one(traces):
    raw, live = TraceReader(traces[0]), TraceReader(traces[1])
    stored = [t for t in live.topics if t.startswith("/decoded/")]
    assert not [t for t in raw.topics if t.startswith("/decoded/")] and len(stored) == 8
    for topic in stored:
        channel, _, message = topic[len("/decoded/"):].partition("/")
        derived, recorded = raw.decoded(channel, message), live.decoded(channel, message)
        assert list(derived) == list(recorded), topic  # the same fields in the same order
        for key in recorded:
            np.testing.assert_array_equal(derived[key], recorded[key], err_msg=f"{topic} {key}")
        assert raw.topic(topic) == live.topic(topic), topic


def test_the_trace_decodes_with_its_own_dbc_attachments(tmp_path):
    """A trace recorded with another layout decodes by the layout it carries, not this package's."""
    text = dbc.dbc_path("c620.dbc").read_bytes().replace(b"ESC1_Current : 7|16@0- (0.001220703125,0)",
                                                         b"ESC1_Current : 7|16@0- (0.00244140625,0)")
    attachments = [(n, text if n == "c620.dbc" else d, t) for n, d, t in DBC_FILES]
    ours = TraceReader(_write(tmp_path / "ours.mcap", False)).decoded("can1", "C620_Cmd_1_4")
    theirs = TraceReader(_write(tmp_path / "theirs.mcap", False, attachments)).decoded("can1", "C620_Cmd_1_4")
    np.testing.assert_array_equal(theirs["ESC1_Current"], 2 * ours["ESC1_Current"])
    assert ours["ESC1_Current"][0] == pytest.approx(2.5, abs=2e-3)


def test_export_writes_the_decoded_topics_of_a_live_decoded_trace_record_for_record(traces, tmp_path):
    out = tmp_path / "exported.mcap"
    done = export_decoded(traces[0], out)
    exported, live = _records(out), _records(traces[1])
    assert exported == live  # every topic: /can/, /decoded/, /sim/state, events, debug
    assert done.frames == len(_many_frames()) and done.decoded == sum(
        len(v) for k, v in live.items() if k.startswith("/decoded/"))
    copy, source = TraceReader(out), TraceReader(traces[0])
    assert copy.metadata == RUN and copy.attachments.keys() == source.attachments.keys()
    assert copy.topic("/sim/state") == source.topic("/sim/state") and copy.sim_state().keys() == source.sim_state().keys()


def test_export_command_and_its_refusals(traces, tmp_path, capsys):
    assert main(["export", str(traces[0]), "-o", str(tmp_path / "x.mcap")]) == 0
    assert "/decoded/ messages" in capsys.readouterr().out
    log = tmp_path / "x.log"
    log.write_text("(0.000000) can0 123#00\n")
    assert main(["export", str(log)]) == 2
    assert "not an MCAP trace" in capsys.readouterr().err
    assert main(["export", str(traces[0]), "-o", str(traces[0])]) == 2
    bare = tmp_path / "bare.mcap"  # no run record: no channel has a bus, nothing to decode with
    with TraceWriter(bare, metadata={}) as trace:
        trace.on_frames(_frames()[:3])
    assert main(["export", str(bare)]) == 2
    assert "names no CAN channels" in capsys.readouterr().err


def test_the_size_report_counts_every_topic_and_its_index(traces):
    from tools.bench_trace import size_report  # noqa: PLC0415 (a developer tool, run from the repository)

    report = size_report(traces[0])
    rows = {line.split()[0]: line.split()[1:] for line in report.splitlines()[2:]}
    topics = TraceReader(traces[0]).topics
    assert set(rows) == set(topics) and topics["/sim/state"] == len(_many_frames()[::10])
    assert int(rows["/sim/state"][0]) == topics["/sim/state"]
    assert float(rows["/sim/state"][3]) == pytest.approx(16 * topics["/sim/state"] / 1e6, abs=1e-3)  # the index
