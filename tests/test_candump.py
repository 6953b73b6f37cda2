"""candump -L logs: writer, reader, and the players that must accept them (wheelleg.hil.record.candump)."""
from __future__ import annotations

import gzip
import shutil
import subprocess
import sys

import can
import can.player
import pytest
from hypothesis import given, settings, strategies as st

from wheelleg.hil.record.frame import Frame
from wheelleg.hil.record.candump import (CAN_ERR_BUSERROR, CAN_ERR_FLAG, CandumpWriter, LogFormatError,
                         format_timestamp, read_candump)

# (channel, t_ns, id, extended, data, kwargs)
FRAMES = [
    ("can0", 1_436_509_052_249_713_999, 0x123, False, bytes.fromhex("DEADBEEF"), {}),
    ("can1", 1_436_509_052_250_000_000, 0x1F000001, True, bytes(8), {}),
    ("can1", 1_436_509_052_250_000_001, 0x7FF, False, b"", {}),
    ("can0", 1_436_509_052_251_000_000, 0x0AB, False, b"", {"is_remote": True, "remote_dlc": 4}),
    ("can0", 1_436_509_052_252_000_000, 0x123, False, bytes(range(12)), {"is_fd": True, "fd_flags": 1}),
    ("can1", 1_436_509_052_253_000_000, CAN_ERR_BUSERROR, False, bytes(8), {"is_error": True}),
]
EXPECTED_LINES = [
    "(1436509052.249713) can0 123#DEADBEEF",
    "(1436509052.250000) can1 1F000001#0000000000000000",
    "(1436509052.250000) can1 7FF#",
    "(1436509052.251000) can0 0AB#R4",
    "(1436509052.252000) can0 123##1000102030405060708090A0B",
    "(1436509052.253000) can1 20000080#0000000000000000",
]


def _frame(channel, t_ns, can_id, ext, data, is_error=False, *, is_remote=False, remote_dlc=0, is_fd=False,
           fd_flags=0) -> Frame:
    return Frame(t_ns, channel, can_id, ext, data, remote_dlc if is_remote else len(data), is_error=is_error,
                 is_remote=is_remote, is_fd=is_fd, fd_flags=fd_flags)


def _write(path, frames=FRAMES) -> None:
    with CandumpWriter(path) as log:
        for channel, t_ns, can_id, ext, data, kwargs in frames:
            log.write(_frame(channel, t_ns, can_id, ext, data, **kwargs))


def test_lines_are_candump_format(tmp_path):
    path = tmp_path / "a.log"
    _write(path)
    assert path.read_text().splitlines() == EXPECTED_LINES
    assert format_timestamp(1_000_002_999) == "(0000000001.000002)"  # %010d.%06d, truncated


def test_same_input_gives_byte_identical_output(tmp_path):
    _write(tmp_path / "a.log")
    _write(tmp_path / "b.log")
    assert (tmp_path / "a.log").read_bytes() == (tmp_path / "b.log").read_bytes()



def test_gzipped_log_reads_the_same_frames(tmp_path):
    plain, packed = tmp_path / "a.log", tmp_path / "a.log.gz"
    _write(plain)
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    assert [f.line_no for f in read_candump(packed)] == [f.line_no for f in read_candump(plain)]
    assert list(read_candump(packed)) == list(read_candump(plain))

@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2**63 - 1))
def test_timestamps_are_exact_integer_arithmetic(t_ns):
    text = format_timestamp(t_ns)
    sec, usec = text[1:-1].split(".")
    assert len(usec) == 6 and len(sec) >= 10
    assert int(sec) * 1_000_000 + int(usec) == t_ns // 1000


_frames = st.one_of(
    st.tuples(st.integers(0, 0x7FF), st.just(False), st.binary(max_size=8), st.just({})),
    st.tuples(st.integers(0, 0x1FFFFFFF), st.just(True), st.binary(max_size=8), st.just({})),
    st.tuples(st.integers(0, 0x7FF), st.just(False), st.just(b""),
              st.builds(lambda n: {"is_remote": True, "remote_dlc": n}, st.integers(0, 8))),
    st.tuples(st.integers(0, 0x7FF), st.just(False), st.binary(max_size=64),
              st.builds(lambda f: {"is_fd": True, "fd_flags": f}, st.integers(0, 7))),
    st.tuples(st.integers(0, 0x1FFFFFFF), st.just(True), st.binary(max_size=64),
              st.builds(lambda f: {"is_fd": True, "fd_flags": f}, st.integers(0, 7))),
    st.tuples(st.integers(1, 0x1FFFFFFF), st.just(False), st.binary(min_size=8, max_size=8),
              st.just({"is_error": True})),
)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["can0", "vcan1", "can2"]), st.integers(0, 2**62), _frames),
                max_size=20))
def test_round_trip(tmp_path_factory, rows):
    path = tmp_path_factory.mktemp("rt") / "rt.log"
    frames = [(ch, t, *f) for ch, t, f in rows]
    _write(path, frames)
    back = list(read_candump(path))
    assert len(back) == len(frames)
    for got, (channel, t_ns, can_id, ext, data, kw) in zip(back, frames):
        assert (got.channel, got.t_ns) == (channel, t_ns // 1000 * 1000)
        assert got.arbitration_id == can_id and got.data == data
        assert got.is_error == kw.get("is_error", False)
        assert got.is_extended == (ext and not got.is_error)
        assert got.is_remote == kw.get("is_remote", False) and got.is_fd == kw.get("is_fd", False)
        assert got.fd_flags == kw.get("fd_flags", 0)
        assert got.dlc == (kw["remote_dlc"] if got.is_remote else len(data))


def test_python_can_reader_reads_our_files(tmp_path):
    path = tmp_path / "a.log"
    _write(path)
    messages = list(can.io.CanutilsLogReader(str(path)))
    assert len(messages) == len(FRAMES)
    for msg, (channel, t_ns, can_id, ext, data, kw) in zip(messages, FRAMES):
        assert round(msg.timestamp * 1e6) == t_ns // 1000
        if kw.get("is_error"):
            assert msg.is_error_frame
            continue
        assert (msg.channel, msg.arbitration_id, msg.is_extended_id) == (channel, can_id, ext)
        assert msg.is_remote_frame == kw.get("is_remote", False)
        assert msg.is_fd == kw.get("is_fd", False)
        if msg.is_remote_frame:
            assert msg.dlc == kw["remote_dlc"]
        else:
            assert bytes(msg.data) == data
        assert msg.bitrate_switch == bool(kw.get("fd_flags", 0) & 1)


def test_error_frame_without_class_gets_the_bus_error_class(tmp_path):
    """python-can only sees an error frame when CAN_ERR_BUSERROR is set."""
    path = tmp_path / "err.log"
    with CandumpWriter(path) as log:
        log.write(_frame("can0", 0, 0, False, bytes(8), is_error=True))
    assert path.read_text() == "(0000000000.000000) can0 20000080#0000000000000000\n"
    assert next(iter(can.io.CanutilsLogReader(str(path)))).is_error_frame
    frame = next(iter(read_candump(path)))
    assert frame.is_error and frame.arbitration_id == CAN_ERR_BUSERROR


def test_can_player_replays_our_log_on_a_virtual_bus(tmp_path, monkeypatch):
    path = tmp_path / "play.log"
    frames = [("can0", 10_000_000 * k, 0x200 + k, k % 2 == 1, bytes([k] * (k % 9)), {}) for k in range(8)]
    _write(path, frames)
    channel = f"player-{tmp_path.name}"
    with can.Bus(interface="virtual", channel=channel) as rx:
        monkeypatch.setattr(sys, "argv", ["can.player", "-i", "virtual", "-c", channel, str(path)])
        can.player.main()  # honours the timestamps: 70 ms of log
        got = [rx.recv(timeout=1) for _ in frames]
    assert all(m is not None for m in got)
    assert [(m.arbitration_id, m.is_extended_id, bytes(m.data)) for m in got] == \
           [(i, e, d) for _, _, i, e, d, _ in frames]


@pytest.mark.skipif(shutil.which("log2asc") is None, reason="can-utils not installed")
def test_can_utils_parses_our_log(tmp_path):
    """log2asc runs can-utils' own parse_canframe (lib.c) over every frame line."""
    path = tmp_path / "a.log"
    _write(path)
    out = subprocess.run(["log2asc", "-I", str(path), "can0", "can1"], capture_output=True,
                         text=True, check=True).stdout.splitlines()
    body = [line.split() for line in out if line[:1] == " " or line[:1].isdigit()]
    assert len(body) == len(FRAMES)
    assert body[0][1:] == ["1", "123", "Rx", "d", "4", "DE", "AD", "BE", "EF"]
    assert body[1][2] == "1F000001x"
    assert body[3][1:5] == ["1", "AB", "Rx", "r"]
    assert body[4][1:3] == ["CANFD", "1"] and "DE" not in body[4]
    assert body[5][2] == "ErrorFrame"


READ_ME = """\
# a comment, as people add them
(1436509052.249713) can0 123#DEADBEEF

DROPCOUNT: dropped 3 CAN frames on 'can0' socket (total drops 3)
(1436509052.249800) can1 1F000001#R
(1436509052.249900) can1 20000004#0000000000000000\r
(1436509052.250000) can1 123##3DEADBEEF00112233445566
(1436509052.250100) can0 12345678#11.22.33 T
(1436509052.250200) can0 456#1122334455667788_C
DROPCOUNT: dropped 1 CAN frame on 'can1' socket (total drops 4)
*** DROPCOUNT something else
(1436509052.25) can0 001#
"""


def test_reader_handles_comments_dropcount_fd_error_rtr(tmp_path):
    path = tmp_path / "mixed.log"
    path.write_bytes(READ_ME.encode())
    reader = read_candump(path)
    frames = list(reader)
    assert [f.line_no for f in frames] == [2, 5, 6, 7, 8, 9, 12]
    assert frames[0] == Frame(1_436_509_052_249_713_000, "can0", 0x123, False, bytes.fromhex("DEADBEEF"),
                              4, line_no=2)
    assert frames[1].is_remote and frames[1].is_extended and frames[1].dlc == 0
    assert frames[2].is_error and frames[2].arbitration_id == 4 and not frames[2].is_extended
    assert frames[3].is_fd and frames[3].fd_flags == 3 and len(frames[3].data) == 11
    assert frames[4].data == bytes.fromhex("112233") and frames[4].direction == "T"
    assert frames[5].dlc == 12 and len(frames[5].data) == 8
    assert frames[6].t_ns == 1_436_509_052_250_000_000
    assert reader.comments == 1 and reader.frames == 7
    assert [(d.line_no, d.channel, d.dropped, d.total) for d in reader.drops] == \
           [(4, "can0", 3, 3), (10, "can1", 1, 4), (11, "", 0, None)]
    assert reader.drops[0].after_t_ns == frames[0].t_ns
    assert reader.dropped_frames == 4


@pytest.mark.parametrize("line, reason", [
    ("(1.000000) can0 1234#00", "frame is not"),  # 4 id digits
    ("(1.000000) can0 123#0", "frame is not"),  # odd number of hex digits
    ("(1.000000) can0 123#001122334455667788", "max 8"),  # 9 bytes, classic
    ("(1.000000) can0 800#00", "0x7FF"),
    ("(1.000000) can0 C0000000#00", "bits 30/31"),
    ("(1.0000000000) can0 123#00", "timestamp"),
    ("(-1.000000) can0 123#00", "timestamp"),
    ("1.000000 can0 123#00", "not a frame line"),
    ("(1.000000) can0", "fields"),
    ("(1.000000) can0 123#00 X", "direction"),
    ("(1.000000) can0 123#GG", "frame is not"),
])
def test_malformed_line_names_file_and_line(tmp_path, line, reason):
    path = tmp_path / "bad.log"
    path.write_text(f"(1.000000) can0 123#00\n# ok\n{line}\n(2.000000) can0 124#00\n")
    with pytest.raises(LogFormatError, match=reason) as info:
        list(read_candump(path))
    assert f"{path}:3:" in str(info.value)
    assert info.value.line_no == 3


def test_non_strict_mode_counts_and_skips(tmp_path):
    path = tmp_path / "bad.log"
    path.write_text("(1.000000) can0 123#00\ngarbage here\n(1.5) can0 1234#00\n(2.000000) can0 124#01\n")
    reader = read_candump(path, strict=False)
    frames = list(reader)
    assert [f.arbitration_id for f in frames] == [0x123, 0x124]
    assert [line for line, _ in reader.skipped] == [2, 3]


def test_a_last_line_cut_off_by_a_killed_writer_is_left_out(tmp_path):
    path = tmp_path / "cut.log"
    path.write_text("(1.000000) can0 123#00\n(2.000000) can0 124#0")  # writer killed mid-line
    reader = read_candump(path)
    assert [f.arbitration_id for f in reader] == [0x123] and reader.cut_off
    path.write_text("(1.000000) can0 123#00\n(2.000000) can0 124#0\n")  # a whole bad line: an error
    with pytest.raises(LogFormatError):
        list(read_candump(path))


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["can0", "vcan1"]), st.integers(0, 2**62), _frames), max_size=30),
       st.integers(0, 2**40))
def test_a_batch_gives_the_lines_of_its_frames_one_by_one(tmp_path_factory, rows, epoch_ns):
    frames = [_frame(ch, t, can_id, ext, data, **kw) for ch, t, (can_id, ext, data, kw) in rows]
    one, batch = tmp_path_factory.mktemp("b") / "one.log", tmp_path_factory.mktemp("b") / "batch.log"
    with CandumpWriter(one, epoch_ns=epoch_ns) as log:
        for f in frames:
            log.write(f)
    with CandumpWriter(batch, epoch_ns=epoch_ns) as log:
        log.on_frames(frames)
        assert log.frames == len(frames)
    assert batch.read_bytes() == one.read_bytes()


def test_a_bad_frame_in_a_batch_raises_after_the_frames_before_it_are_written(tmp_path):
    good = _frame("can0", 1_000, 0x100, False, b"\x01")
    with CandumpWriter(tmp_path / "w.log") as log:
        with pytest.raises(ValueError, match="0x7FF"):
            log.on_frames([good, _frame("can0", 2_000, 0x800, False, b""), good])
    assert (tmp_path / "w.log").read_text() == "(0000000000.000001) can0 100#01\n"


@pytest.mark.parametrize("args, error", [
    (("can0", 0, 0x800, False, b""), "0x7FF"),
    (("can0", 0, 0x20000000, True, b""), "0x1FFFFFFF"),
    (("can0", 0, 0x100, False, bytes(9)), "max 8"),
    (("can 0", 0, 0x100, False, b""), "interface"),
    (("", 0, 0x100, False, b""), "interface"),
    (("can0", -1, 0x100, False, b""), ">= 0"),
])
def test_writer_rejects_bad_frames(tmp_path, args, error):
    with CandumpWriter(tmp_path / "w.log") as log:
        with pytest.raises(ValueError, match=error):
            log.write(_frame(*args))
    assert (tmp_path / "w.log").read_text() == ""


def test_writer_rejects_float_time_and_bad_fd(tmp_path):
    with CandumpWriter(tmp_path / "w.log") as log:
        with pytest.raises(TypeError):
            log.write(_frame("can0", 1.5e9, 0x100, False, b""))
        with pytest.raises(ValueError, match="FD"):
            log.write(_frame("can0", 0, 0x100, False, bytes(65), is_fd=True))
        with pytest.raises(ValueError, match="remote"):
            log.write(_frame("can0", 0, 0x100, False, b"", is_remote=True, remote_dlc=9))
        log.write(_frame("can0", 0, 0x100, False, b""))
    with pytest.raises(ValueError, match="closed"):
        log.write(_frame("can0", 0, 0x100, False, b""))
    assert CAN_ERR_FLAG == 0x20000000
