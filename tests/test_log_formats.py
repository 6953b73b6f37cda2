"""Reading and writing through python-can: every log format can.LogReader reads goes into
inspect and replay; the rig's .mcap is a python-can log format; a killed trace is recovered."""
import sys
from pathlib import Path

import can
import can.logconvert as logconvert
import pytest
from mcap.reader import make_reader

from wheelleg.hil.cli import main
from wheelleg.hil.record import can_batch
from wheelleg.hil.record.trace import TraceReader


@pytest.fixture(scope="module")
def short_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("formats")
    assert main(["run", "balance", "--duration", "0.2", "--out", str(out), "--no-plot", "-q"]) in (0, 1)
    return out


def _convert(src: Path, dst: Path) -> Path:
    """``python -m can.logconvert SRC DST``: its ``main()`` in this process (a process of its own cost
    ~0.4 s of start-up a call); python-can finds the .mcap reader and writer by the same entry points."""
    argv = sys.argv
    sys.argv = ["can.logconvert", str(src), str(dst)]
    try:
        logconvert.main()
    finally:
        sys.argv = argv
    return dst


@pytest.mark.parametrize("suffix", [".asc", ".blf", ".trc"])
def test_inspect_and_replay_read_what_python_can_reads(short_run, tmp_path, capsys, suffix):
    log = _convert(short_run / "balance.log", tmp_path / f"balance{suffix}")
    assert main(["inspect", str(log), "--no-signals"]) == 0
    out = capsys.readouterr().out
    assert "log read by python-can" in out and f"{sum(1 for _ in can.LogReader(log))} frames" in out
    assert main(["replay", str(log)]) == 0
    assert "identical" in capsys.readouterr().out


def test_a_log_without_channels_is_read_and_the_missing_bus_named(short_run, tmp_path, capsys):
    """python-can's CSV keeps no channel: the frames are read, the two buses cannot be told apart."""
    log = _convert(short_run / "balance.log", tmp_path / "balance.csv")
    assert main(["inspect", str(log), "--no-signals"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "carries both CyberGear (CAN2) and C620/IMU (CAN1) frames" in err


def test_python_can_reads_and_writes_the_rig_trace(short_run, tmp_path):
    trace = short_run / "balance.mcap"
    from_log = [(m.arbitration_id, bytes(m.data), m.channel) for m in can.LogReader(short_run / "balance.log")]
    from_trace = [(m.arbitration_id, bytes(m.data), m.channel) for m in can.LogReader(trace)]
    assert sorted(from_trace, key=repr) == sorted(from_log, key=repr) and len(from_trace) > 1000
    asc = _convert(trace, tmp_path / "t.asc")  # can.logconvert: .mcap -> .asc -> .mcap
    back = _convert(asc, tmp_path / "back.mcap")
    assert len(list(TraceReader(back).frames())) == len(from_trace)
    with open(back, "rb") as f:  # the writer's trace is indexed: mcap's indexed reader finds every frame
        assert sum(len(can_batch.unpack(m.data, m.log_time, c.topic)) for _, c, m in make_reader(f).iter_messages()) \
            == len(from_trace)


def test_recover_writes_an_indexed_copy_of_a_killed_trace(short_run, tmp_path, capsys):
    blob = (short_run / "balance.mcap").read_bytes()
    cut = tmp_path / "killed.mcap"
    cut.write_bytes(blob[:len(blob) * 2 // 3])
    survived = TraceReader(cut)
    assert survived.truncated
    with open(cut, "rb") as f, pytest.raises(Exception):
        list(make_reader(f).iter_messages())  # mcap's indexed reader fails without a summary
    assert main(["inspect", str(cut), "--no-signals"]) == 0
    assert f"wheelleg recover {cut}" in capsys.readouterr().out
    assert main(["recover", str(cut), "-o", str(tmp_path / "fixed.mcap")]) == 0
    with open(tmp_path / "fixed.mcap", "rb") as f:
        reader = make_reader(f)
        topics = {}
        for _, channel, _ in reader.iter_messages():
            topics[channel.topic] = topics.get(channel.topic, 0) + 1
        assert reader.get_summary() is not None
    assert topics == {t: n for t, n in survived.topics.items() if n}
    assert TraceReader(tmp_path / "fixed.mcap").metadata == survived.metadata


def test_recover_refuses_what_is_no_trace(short_run, capsys):
    assert main(["recover", str(short_run / "balance.log")]) == 2
    assert "not an MCAP trace" in capsys.readouterr().err


def test_logconvert_of_the_trace_to_candump_gives_the_runs_log_lines(short_run, tmp_path):
    """python-can's candump writer pads times its own way and adds the direction: the frames, their
    times (us) and their order are the run's log's, line for line."""
    def lines(path: Path) -> list[tuple[float, str, str]]:
        out = []
        for line in path.read_text().splitlines():
            stamp, channel, frame = line.split()[:3]
            out.append((round(float(stamp.strip("()")) * 1e6), channel, frame))
        return out

    converted = _convert(short_run / "balance.mcap", tmp_path / "from-trace.log")
    assert lines(converted) == lines(short_run / "balance.log") and len(lines(converted)) > 1000
