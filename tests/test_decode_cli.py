"""``wheelleg decode``: cantools decode's text with the CyberGear id fields, filters by id,
CyberGear type and motor and by signal, CSV, every input format, and bad input."""
from __future__ import annotations

import contextlib
import csv
import gzip
import io
import runpy
import sys
from pathlib import Path

import can
import pytest

from wheelleg import dbc
from wheelleg.dbc import cybergear as cg
from wheelleg.hil.analyze.decode_log import decode, parse_id_filter, select_signals
from wheelleg.hil.cli import main
from wheelleg.hil.record.frame import Frame
from wheelleg.hil.record.sources import open_recording
from wheelleg.hil.record.trace import TraceWriter

TRACES = Path(__file__).resolve().parent / "traces"
FAULT_LOG = TRACES / "motor-fault.log.gz"  # CAN1 on vcan0, CAN2 on vcan1; motor 4 latches over-temperature
HOST = 0xFD


@pytest.fixture(scope="module")
def fault_log(tmp_path_factory) -> Path:
    """The motor-fault rig log, plain text (cantools reads only that): its start (the enable
    sequence) and the 0.15 s around the fault at 1 s."""
    lines = gzip.decompress(FAULT_LOG.read_bytes()).decode().splitlines(keepends=True)
    path = tmp_path_factory.mktemp("decode") / "motor-fault.log"
    path.write_text("".join(line for line in lines if line < "(0000000000.300000)"
                            or "(0000000000.950000)" <= line < "(0000000001.100000)"))
    return path


def _ids(log: Path) -> set[str]:
    """The identifiers of a candump log as written (3 or 8 hex digits)."""
    return {line.split()[2].split("#")[0] for line in log.read_text().splitlines()}


def _decode(capsys, *argv) -> tuple[int, str, str]:
    status = main(["decode", *map(str, argv)])
    out, err = capsys.readouterr()
    return status, out, err


def _cantools(database: str, text: str, *options: str) -> list[str]:
    """What ``python -m cantools decode -s DATABASE OPTIONS < text`` prints: the same module run in this
    process (``runpy``, as ``-m`` does; a process of its own cost ~0.6 s of imports a call). An error
    exits (SystemExit), which fails the test as a non-zero status would."""
    argv, stdin, out = sys.argv, sys.stdin, io.StringIO()
    sys.argv, sys.stdin = ["cantools", "decode", "-s", str(dbc.dbc_path(database)), *options], io.StringIO(text)
    try:
        with contextlib.redirect_stdout(out):
            runpy.run_module("cantools", run_name="__main__")
    finally:
        sys.argv, sys.stdin = argv, stdin
    return out.getvalue().splitlines()


# -- what it prints ------------------------------------------------------------------------------
@pytest.mark.parametrize("database, ids", [("rig.dbc", ("080", "710", "100", "101", "102", "300")),
                                          ("c620.dbc", ("200", "201", "202"))])
def test_standard_frames_print_exactly_as_cantools_decode_prints_them(fault_log, capsys, database, ids):
    theirs = "".join(line for line in fault_log.read_text().splitlines(keepends=True)
                     if line.split()[2].split("#")[0] in ids)
    status, out, _ = _decode(capsys, fault_log, *(a for i in ids for a in ("--id", i)), "-s")
    assert status == 0
    assert out.splitlines() == _cantools(database, theirs)
    assert len(out.splitlines()) > 400


def test_cybergear_frames_show_cantools_payload_and_the_id_fields(fault_log, capsys):
    status, out, _ = _decode(capsys, fault_log, "--id", "type=1", "--id", "type=2", "-s")
    ours = out.splitlines()
    theirs = _cantools("cybergear.dbc", "".join(line.split(" :: ")[0] + "\n" for line in ours), "-m", "0x1F000000")
    assert status == 0 and len(ours) == len(theirs) > 400
    for mine, ref in zip(ours, theirs):
        payload = ref.split(" :: ")[1].partition("(")[2].rstrip(")").split(", ")
        assert mine.split(" :: ")[0] == ref.split(" :: ")[0]
        assert mine.endswith(", ".join(payload) + ")")  # the same payload values, after the id fields
    motion = next(line for line in ours if "CG_MotionCmd(" in line)
    can_id = int(motion.split()[2].split("#")[0], 16)
    assert f"CG_MotionCmd(Type: 1, Target: {cg.target(can_id)}, TorqueRef: {cg.motion_torque(can_id)} Nm," in motion


def test_type_2_replies_show_motor_host_mode_and_fault_bits(fault_log):
    frames = list(decode(open_recording(fault_log, strict=False), [parse_id_filter("type=2")]))
    assert {d.values["MotorId"] for d in frames} == {1, 2, 3, 4}
    assert {d.values["Host"] for d in frames} == {HOST}
    assert {d.values["Mode"] for d in frames} == {0, 2}  # reset, run
    faulty = {d.values["MotorId"] for d in frames if d.values["FaultOverTemp"]}
    assert faulty == {4}
    assert {d.values[name] for d in frames for name in cg.FAULT_NAMES if name != "FaultOverTemp"} == {0}


def test_multi_line_is_the_default_and_choices_are_named(fault_log, capsys):
    status, out, _ = _decode(capsys, fault_log, "--id", "type=2,motor=4")
    first = out.split("\n)\n")[0].splitlines()
    assert status == 0
    assert first[0].endswith(" vcan1 020004FD#846C7FFF7FFF00FA ::")
    assert first[1:5] == ["CG_Feedback(", "    Type: 2,", "    MotorId: 4,", "    Host: 253,"]
    assert "    Mode: reset," in first and "    Temp: 25.0 degC" in first


# -- filters -------------------------------------------------------------------------------------
@pytest.mark.parametrize("spec, wanted", [
    ("201", lambda i: i == "201"),  # standard, as candump writes it
    ("0x201", lambda i: i == "201"),
    ("020001FD", lambda i: i == "020001FD"),
    ("02000000:1F000000", lambda i: len(i) == 8 and i[:2] == "02"),  # candump's ID:MASK: type 2
    ("type=4", lambda i: len(i) == 8 and i[:2] == "04"),
    ("type=2,motor=4", lambda i: len(i) == 8 and i[:2] == "02" and i[4:6] == "04"),
    ("motor=3", lambda i: len(i) == 8 and (i[4:6] == "03" if i[:2] == "02" else i[6:] == "03")),
])
def test_id_filters(fault_log, spec, wanted):
    ids = {format(d.frame.arbitration_id, "08X" if d.frame.is_extended else "03X")
           for d in decode(open_recording(fault_log, strict=False), [parse_id_filter(spec)])}
    assert ids and ids == {i for i in _ids(fault_log) if wanted(i)}


def test_several_ids_are_any_of_them(fault_log, capsys):
    _, out, _ = _decode(capsys, fault_log, "--id", "201", "--id", "202", "-s")
    assert {line.split()[2][:4] for line in out.splitlines()} == {"201#", "202#"}


def test_motor_filter_takes_a_reply_to_host_0_as_from_its_motor(tmp_path):
    read = dbc.load_bus("can2").get_message_by_name("CG_ParamRead").encode({"Index": 0x7005, "run_mode": 2},
                                                                          strict=False)
    log = tmp_path / "robot.log"
    log.write_text(f"(0000000001.000000) can0 {cg.request_id(cg.T_PARAM_READ, 0, 1):08X}#{read.hex().upper()}\n"
                   f"(0000000001.000200) can0 {cg.reply_id(cg.T_PARAM_READ, 1, 0):08X}#{read.hex().upper()}\n")
    frames = list(decode(open_recording(log, strict=False), [parse_id_filter("motor=1")]))
    assert [(d.values.get("Target"), d.values.get("MotorId"), d.values["Host"]) for d in frames] == \
        [(1, None, 0), (None, 1, 0)]
    assert frames[1].values["run_mode"] == 2 and frames[1].message == "CG_ParamRead"


def test_signal_selection_bare_and_qualified(fault_log, capsys):
    status, out, _ = _decode(capsys, fault_log, "--signal", "TorqueRef", "--signal", "CG_Feedback.Torque", "-s")
    names = {line.split(" :: ")[1].partition("(")[0] for line in out.splitlines()}
    assert status == 0 and names == {"CG_MotionCmd", "CG_Feedback"}
    assert all(line.split("(", 2)[2].startswith(("TorqueRef: ", "CG_Feedback.Torque: "))
               and line.count(": ") == 2 for line in out.splitlines())


def test_csv_has_one_row_per_frame_with_the_selected_signals(fault_log, capsys):
    status, out, _ = _decode(capsys, fault_log, "--csv", "--id", "motor=4", "--signal", "TorqueRef",
                             "--signal", "FaultOverTemp")
    rows = list(csv.reader(io.StringIO(out)))
    assert status == 0 and rows[0] == ["time_s", "bus", "channel", "id", "message", "TorqueRef", "FaultOverTemp"]
    commands = [r for r in rows[1:] if r[4] == "CG_MotionCmd"]
    replies = [r for r in rows[1:] if r[4] == "CG_Feedback"]
    assert len(commands) > 100 and len(replies) > 100 and len(commands) + len(replies) == len(rows) - 1
    assert all(r[1:3] == ["can2", "vcan1"] and r[6] == "" for r in commands)
    assert {r[6] for r in replies} == {"0", "1"} and all(r[5] == "" for r in replies)
    assert all(cg.motion_torque(int(r[3], 16)) == float(r[5]) for r in commands)
    times = [float(r[0]) for r in rows[1:]]
    assert times == sorted(times) and times[0] > 0


def test_csv_without_signals_has_every_signal_seen(fault_log, capsys):
    _, out, _ = _decode(capsys, fault_log, "--csv", "--id", "80", "--id", "201")
    rows = list(csv.reader(io.StringIO(out)))
    assert rows[0] == ["time_s", "bus", "channel", "id", "message", "Tick", "RotorAngle", "RotorSpeed",
                       "TorqueCurrent", "MotorTemp"]
    assert {r[4] for r in rows[1:]} == {"SYNC", "C620_Feedback_1"}


# -- every input -------------------------------------------------------------------------------------
def test_reads_an_mcap_trace_and_a_python_can_log(tmp_path, capsys):
    frames = [Frame(1_000_000, "can2", cg.motion_id(-1.5, 2), True, bytes.fromhex("7FFF7FFF00000000"), 8),
              Frame(1_100_000, "can2", cg.reply_id(cg.T_FEEDBACK, 2, HOST, mode=2, faults={"FaultOverTemp"}), True,
                    bytes.fromhex("7B927FFF7FFF00FA"), 8)]
    trace = tmp_path / "t.mcap"
    with TraceWriter(trace, metadata={}, dbs={"can2": dbc.load_bus("can2")}) as writer:
        for frame in frames:
            writer.frame(frame)
    asc = tmp_path / "t.asc"
    with can.ASCWriter(asc) as writer:
        for frame in frames:
            writer.on_message_received(frame.message())
    for path in (trace, asc):
        status, out, err = _decode(capsys, path, "-s")
        lines = out.splitlines()
        assert status == 0 and len(lines) == 2, err
        assert f"CG_MotionCmd(Type: 1, Target: 2, TorqueRef: {cg.motion_torque(cg.motion_id(-1.5, 2))} Nm" in lines[0]
        assert "CG_Feedback(Type: 2, MotorId: 2, Host: 253, Mode: run, FaultUnderVoltage: 0, FaultOverCurrent: 0, " \
               "FaultOverTemp: 1," in lines[1]


# -- bad input ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("text, where", [
    ("(0000000001.000000) vcan0 201#0000000000001900\nnot a frame\n", ":2:"),
    ("(0000000001.000000) vcan0 201#0000000000001900\n(0000000001.000100) vcan0 2G1#00\n", ":2:"),
    ("(0000000001.000000) vcan0 201#000000000000190\n", ":1:"),  # an odd number of hex digits
    ("(0000000001.000000) vcan0\n", ":1:"),  # cut off
])
def test_a_malformed_line_is_one_line_naming_it_and_exit_2(tmp_path, capsys, text, where):
    log = tmp_path / "bad.log"
    log.write_text(text)
    status, out, err = _decode(capsys, log)
    assert status == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and f"bad.log{where} not a candump -L line" in err


@pytest.mark.parametrize("argv, message", [
    (["--id", "zz"], "--id 'zz': 'zz' is not a hex identifier"),
    (["--id", "type=32"], "type must be 0..31"),
    (["--id", "motor=x"], "motor 'x' is not a number"),
    (["--id", "speed=2"], "expected type=N and/or motor=N"),
    (["--id", "20000000"], "beyond the 29-bit range"),
    (["--signal", "Torq"], "--signal 'Torq': no such signal"),
    (["--signal", "CG_Feedback.TorqueRef"], "no such signal"),  # an id field of type 1, not of type 2
    (["--channels", "vcan0"], "need two different names"),
])
def test_bad_options_are_one_line_and_exit_2(fault_log, capsys, argv, message):
    status, out, err = _decode(capsys, fault_log, *argv)
    assert status == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert message in err


def test_no_such_file_exits_2_and_nothing_matched_exits_1(tmp_path, fault_log, capsys):
    status, _, err = _decode(capsys, tmp_path / "none.log")
    assert status == 2 and "no such file" in err
    status, out, err = _decode(capsys, fault_log, "--id", "7FF")
    assert status == 1 and out == "" and "no frame" in err


def test_the_pure_parts_refuse_bad_input_with_value_error():
    with pytest.raises(ValueError, match="not a hex identifier"):
        parse_id_filter("")
    with pytest.raises(ValueError, match="no such signal"):
        select_signals(["Nope.Tick"])
    assert select_signals(["SYNC.Tick", "MotorId"]).names == ("SYNC.Tick", "MotorId")
