"""``wheelleg replay``: identical replays, the first diverging frame, broken logs, --update."""
from __future__ import annotations

import gzip
import json
from pathlib import Path

import can
import pytest
from mcap.reader import make_reader

from wheelleg import dbc
from wheelleg.controller import lqr
from wheelleg.controller import params as P
from wheelleg.controller.modes import ENABLED
from wheelleg.controller.node import ControllerNode
from wheelleg.dbc import cybergear as cg
from wheelleg.hil.record.candump import CandumpWriter
from wheelleg.hil.cli import main
from wheelleg.hil.analyze.bug_report import bug_report_gaps, environment_warnings
from wheelleg.hil.analyze.replay import MemoryBus, default_tolerances, parse_tolerance, replay
from wheelleg.hil.analyze.update import write_reference
from wheelleg.hil.record.trace import TraceReader, TraceWriter
from wheelleg.hil.record.sources import open_recording, sent_by_controller
from synthetic_trace import SyntheticRig, attachments, robot_log, run_metadata

TICKS = 150
C620_CMD = dbc.load_bus("can1").get_message_by_name("C620_Cmd_1_4")


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    """A synthetic rig run: MCAP trace + candump log of the same 150 ticks."""
    out = tmp_path_factory.mktemp("synthetic")
    run = SyntheticRig(out / "run.mcap", out / "run.log").run(TICKS)
    assert any(m in ENABLED for m in run.modes), f"controller never enabled: modes {set(run.modes)}"
    return run, out / "run.mcap", out / "run.log"


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    path = tmp_path_factory.mktemp("robot") / "robot.log"
    modes = robot_log(path, TICKS)
    assert any(m in ENABLED for m in modes)
    return path


def _lines(path: Path) -> list[str]:
    return path.read_text().splitlines(keepends=True)


def _write(path: Path, lines: list[str]) -> Path:
    path.write_text("".join(lines))
    return path


def _first_changed_tick(before: SyntheticRig, after: SyntheticRig) -> tuple[int, str, int]:
    """(tick, bus, frame index) of the first frame the changed controller sent differently."""
    for tick, (a, b) in enumerate(zip(before.sent, after.sent)):
        for bus in ("can1", "can2"):
            for j, (x, y) in enumerate(zip(a[bus], b[bus])):
                if (x.arbitration_id, bytes(x.data)) != (y.arbitration_id, bytes(y.data)):
                    return tick, bus, j
    raise AssertionError("the changed controller sent the same frames")


def _scaled_gain(row: int, col: int, factor: float):
    original = lqr.gain_matrix

    def gain_matrix(L0):
        k = [list(r) for r in original(L0)]
        k[row][col] *= factor
        return tuple(tuple(r) for r in k)
    return gain_matrix


# -- identical replays -----------------------------------------------------------------------------
@pytest.mark.parametrize("which", ["mcap", "log"])
def test_rig_recording_replays_identical(rig, which, capsys):
    run, mcap, log = rig
    path = mcap if which == "mcap" else log
    assert main(["replay", str(path)]) == 0
    out = capsys.readouterr().out
    assert "identical" in out and f"{TICKS} ticks" in out and "sync mode" in out
    frames = sum(len(s["can1"]) + len(s["can2"]) for s in run.sent)
    assert f"{frames} controller frames" in out


def test_robot_log_replays_identical_in_free_run(robot, capsys):
    assert main(["replay", str(robot)]) == 0
    out = capsys.readouterr().out
    assert "identical" in out and "free-run mode" in out and "can0/can1" in out


def test_controller_frames_come_from_dbc_senders(rig):
    source = open_recording(rig[1])
    ours = [f for f in source.frames if sent_by_controller(f)]
    assert {f.arbitration_id for f in ours if not f.is_extended} == {0x200, 0x710}
    assert {cg.comm_type(f.arbitration_id) for f in ours if f.is_extended} <= {
        cg.T_MOTION, cg.T_STOP, cg.T_ENABLE, cg.T_PARAM_WRITE}
    assert sum(len(s["can1"]) + len(s["can2"]) for s in rig[0].sent) == len(ours)


# -- a changed gain ---------------------------------------------------------------------------------
@pytest.mark.parametrize("which", ["mcap", "log"])
def test_changed_leg_gain_names_first_diverging_frame(rig, which, monkeypatch, capsys):
    run, mcap, log = rig
    monkeypatch.setattr(P, "LEG_KP", P.LEG_KP * 1.25)
    changed = SyntheticRig(None, None).run(TICKS)
    tick, bus, index = _first_changed_tick(run, changed)
    result = replay(mcap if which == "mcap" else log)
    first = result.first
    assert first is not None and (first.tick, first.bus) == (tick, bus)
    assert (first.message, first.signal) == ("CG_MotionCmd", "TorqueRef")
    expected, got = run.sent[tick][bus][index], changed.sent[tick][bus][index]
    assert first.arbitration_id == expected.arbitration_id
    assert first.expected == pytest.approx(cg.motion_torque(expected.arbitration_id), abs=1e-9)
    assert first.got == pytest.approx(cg.motion_torque(got.arbitration_id), abs=1e-9)
    assert abs(first.got - first.expected) > default_tolerances()["TorqueRef"]
    assert main(["replay", str(mcap)]) == 1
    captured = capsys.readouterr()
    assert f"first difference at tick {tick}" in captured.out and "signal TorqueRef" in captured.out
    assert "controller parameters differ from the recording: LEG_KP" in captured.err


def test_changed_lqr_gain_names_wheel_current_and_tolerance_hides_it(rig, monkeypatch, capsys):
    run, mcap, _ = rig
    monkeypatch.setattr(lqr, "gain_matrix", _scaled_gain(0, 4, 1.1))  # T row, body pitch gain
    changed = SyntheticRig(None, None).run(TICKS)
    tick, bus, index = _first_changed_tick(run, changed)
    assert bus == "can1"
    first = replay(mcap).first
    assert (first.tick, first.bus, first.message) == (tick, "can1", "C620_Cmd_1_4")
    assert first.signal in ("ESC1_Current", "ESC2_Current")
    want = C620_CMD.decode(bytes(run.sent[tick]["can1"][index].data))[first.signal]
    got = C620_CMD.decode(bytes(changed.sent[tick]["can1"][index].data))[first.signal]
    assert (first.expected, first.got) == (pytest.approx(want), pytest.approx(got))
    # the wheel torque also reaches the hips a period later (the LQR's T_prev state), a
    # few LSB of TorqueRef: wide enough tolerances on both make the run identical again
    assert main(["replay", str(mcap), "--tolerance", "ESC1_Current=40", "--tolerance",
                 "C620_Cmd_1_4.ESC2_Current=40"]) == 1
    assert main(["replay", str(mcap), "--tolerance", "ESC1_Current=40", "--tolerance",
                 "C620_Cmd_1_4.ESC2_Current=40", "--tolerance", "TorqueRef=0.05"]) == 0
    capsys.readouterr()


def test_tolerance_parsing():
    scale = dbc.load_file(cg.ID_DBC).get_message_by_name("CG_Id_Motion").get_signal_by_name("TorqueRef").scale
    assert parse_tolerance("TorqueRef=2lsb") == ("TorqueRef", pytest.approx(2 * scale))
    assert parse_tolerance("C620_Cmd_1_4.ESC1_Current=0.5") == ("C620_Cmd_1_4.ESC1_Current", 0.5)
    assert default_tolerances()["TorqueRef"] == pytest.approx(scale)
    assert "Tick" not in default_tolerances()  # integers stay exact
    for bad in ("TorqueRef", "=1", "TorqueRef=abc", "TorqueRef=-1", "NoSuchSignal=1lsb", "X=nan"):
        with pytest.raises(ValueError):
            parse_tolerance(bad)


def test_bad_tolerance_exits_2(rig, capsys):
    assert main(["replay", str(rig[1]), "--tolerance", "TorqueRef"]) == 2
    assert "SIGNAL=VALUE" in capsys.readouterr().err


# -- candump logs as the robot writes them ----------------------------------------------------------
def _insert_after(lines: list[str], predicate, new: list[str]) -> list[str]:
    at = next(i for i, line in enumerate(lines) if predicate(line)) + 1
    return lines[:at] + new + lines[at:]


def test_dropcount_and_comments_fail_with_a_clear_message(robot, tmp_path, capsys):
    lines = ["# candump -L any on the robot\n", "\n"] + _lines(robot)
    lines = _insert_after(lines, lambda s: "can0 710#" in s and s.startswith("(1700000000.1"),
                          ["DROPCOUNT: dropped 3 CAN frames on 'can0' socket (total drops 3)\n"])
    path = _write(tmp_path / "drops.log", lines)
    drop_line = next(i for i, s in enumerate(lines, 1) if s.startswith("DROPCOUNT"))
    assert main(["replay", str(path)]) == 2
    err = capsys.readouterr().err
    assert "DROPCOUNT" in err and f"line {drop_line}" in err and "3 frame(s)" in err
    assert "--allow-drops" in err
    # the notice lost frames the controller did not need: replaying anyway is identical
    assert main(["replay", str(path), "--allow-drops"]) == 0


def test_log_missing_a_heartbeat_cannot_be_replayed(robot, tmp_path, capsys):
    lines = _lines(robot)
    heartbeats = [i for i, s in enumerate(lines) if " can1 710#" in s]
    del lines[heartbeats[40]]  # the joints bus lost the controller's heartbeat of tick 40
    assert main(["replay", str(_write(tmp_path / "lost.log", lines))]) == 2
    err = capsys.readouterr().err
    assert "controller frames missing" in err and "tick 40" in err


def test_time_going_backwards_is_reported(robot, tmp_path, capsys):
    lines = _lines(robot)
    i = next(i for i, s in enumerate(lines) if i > 100 and " can0 201#" in s)
    lines[i] = "(1690000000.000000)" + lines[i][lines[i].index(")") + 1:]
    assert main(["replay", str(_write(tmp_path / "back.log", lines))]) == 2
    err = capsys.readouterr().err
    assert "time goes backwards on can0" in err and f"line {i + 1}" in err


def test_small_steps_back_are_reordering_not_breakage(robot, tmp_path, capsys):
    """The controller's own log (python-can writer) stamps a frame read after a tick's sends
    with its earlier bus time; that is reordering within the bound, replayed in file order."""
    lines = _lines(robot)
    hb = [i for i, s in enumerate(lines) if " can0 710#" in s][10]
    late = lines[hb + 1]
    assert " can0 201#" in late  # the wheel frame that landed while the controller was sending
    t_us = int(late[1:18].replace(".", "")) - 300
    lines[hb + 1] = f"({t_us // 1_000_000:010d}.{t_us % 1_000_000:06d})" + late[19:]
    assert main(["replay", str(_write(tmp_path / "reordered.log", lines))]) == 0
    assert "1 frame(s) stamped up to 0.299 ms before" in capsys.readouterr().err  # 1 us after the heartbeat


def test_log_cut_inside_a_tick_replays_up_to_the_cut(robot, tmp_path, capsys):
    lines = _lines(robot)
    cut = [i for i, s in enumerate(lines) if " can0 710#" in s][100] + 1  # before tick 100's CAN2 frames
    assert main(["replay", str(_write(tmp_path / "cut.log", lines[:cut]))]) == 0
    captured = capsys.readouterr()
    assert "100 ticks" in captured.out and "tick 100 not compared" in captured.err


def test_killed_trace_replays_what_it_holds(tmp_path, capsys):
    path = tmp_path / "killed.mcap"
    trace = TraceWriter(path, metadata=run_metadata(), attachments=attachments(), chunk_span_s=0.02,
                        dbs={"vcan0": dbc.load_bus("can1"), "vcan1": dbc.load_bus("can2")})
    rig = SyntheticRig(None, None, trace=trace)
    rig.run(100)
    data = path.read_bytes()
    with open(path, "rb") as f:  # the chunks follow the attachments (the DBC files, ~75 kB)
        first = make_reader(f).get_summary().chunk_indexes[0].chunk_start_offset
    path.write_bytes(data[:first + (len(data) - first) * 2 // 3])  # a killed writer leaves no summary, no footer
    assert main(["replay", str(path)]) == 0
    captured = capsys.readouterr()
    ticks = int(captured.out.split("identical (")[1].split(" ticks")[0])
    assert 0 < ticks < 100 and "writer killed" in captured.err


def test_controller_restart_in_a_log_is_reported(robot, tmp_path, capsys):
    second = tmp_path / "second.log"
    robot_log(second, 20, t0_us=1_700_000_010_000_000)  # the controller restarted 10 s later
    path = _write(tmp_path / "restart.log", _lines(robot) + _lines(second))
    assert main(["replay", str(path)]) == 2
    assert f"tick goes from {TICKS - 1} to 0" in capsys.readouterr().err


def test_unknown_channel_needs_explicit_channels(robot, tmp_path, capsys):
    lines = _insert_after(_lines(robot), lambda s: True, ["(1700000000.000001) can7 123#00\n"])
    path = _write(tmp_path / "other.log", lines)
    assert main(["replay", str(path)]) == 2
    err = capsys.readouterr().err
    assert "can7" in err and "--channels" in err
    assert main(["replay", str(path), "--channels", "can0,can1"]) == 0
    assert "can7" in capsys.readouterr().err  # noted as ignored


def test_log_without_controller_frames(robot, tmp_path, capsys):
    path = tmp_path / "inputs.log"
    with CandumpWriter(path) as log:
        for f in open_recording(robot).frames:
            if not sent_by_controller(f):
                log.write(f)
    assert main(["replay", str(path)]) == 2
    assert "no controller frames" in capsys.readouterr().err


def test_malformed_line_is_named(robot, tmp_path, capsys):
    lines = _lines(robot)
    lines.insert(5, "(1700000000.000001) can0 12345#00\n")
    assert main(["replay", str(_write(tmp_path / "bad.log", lines))]) == 2
    assert ":6:" in capsys.readouterr().err


def test_error_and_fd_frames_do_not_break_replay(robot, tmp_path, capsys):
    lines = _insert_after(_lines(robot), lambda s: " can0 710#" in s,
                          ["(1700000000.000001) can0 20000080#0000000000000000\n",
                           "(1700000000.000001) can1 123##1DEADBEEF\n"])
    assert main(["replay", str(_write(tmp_path / "fd.log", lines))]) == 0
    assert "1 CAN FD frame(s) not delivered" in capsys.readouterr().err


def test_log_that_starts_mid_run_warns(robot, tmp_path, capsys):
    lines = _lines(robot)
    cut = [i for i, s in enumerate(lines) if " can1 710#" in s][60] + 1
    assert main(["replay", str(_write(tmp_path / "late.log", lines[cut:]))]) == 1
    err = capsys.readouterr().err
    assert "starts with the controller in mode" in err


def test_memory_bus_drives_a_controller_node():
    a, b = MemoryBus("a"), MemoryBus("b")
    node = ControllerNode(a, b, sync=True)
    sync = dbc.load_bus("can1").get_message_by_name("SYNC")
    for bus in (a, b):
        bus.inbox.append(can.Message(arbitration_id=sync.frame_id, data=sync.encode({"Tick": 7}),
                                     is_extended_id=False))
    assert node.service() and node.now() == pytest.approx(7 * P.CONTROL_PERIOD)
    assert a.take_sent()[-1].arbitration_id == 0x710 and b.take_sent()[-1].arbitration_id == 0x710
    assert not node.service()  # no new SYNC: no tick
    a.shutdown()
    b.shutdown()


# -- --update ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("which", ["mcap", "log"])
def test_update_writes_a_reference_the_changed_controller_matches(rig, which, tmp_path, monkeypatch, capsys):
    _, mcap, log = rig
    path = mcap if which == "mcap" else log
    out = tmp_path / ("new.mcap" if which == "mcap" else "new.log")
    with monkeypatch.context() as m:
        m.setattr(P, "LEG_KP", P.LEG_KP * 1.25)
        assert main(["replay", str(path), "--update", str(out)]) == 1
        assert main(["replay", str(out)]) == 0
    assert main(["replay", str(out)]) == 1  # the original controller no longer matches the new reference
    capsys.readouterr()
    old, new = open_recording(path), open_recording(out)
    assert len(new.frames) == len(old.frames)
    inputs = lambda src: [(f.bus, f.arbitration_id, f.data) for f in src.frames if not sent_by_controller(f)]
    assert inputs(new) == inputs(old)
    if which == "mcap":
        reader, original = TraceReader(out), TraceReader(mcap)
        assert reader.metadata["run"]["reference_from"] == "run.mcap"
        assert json.loads(reader.metadata["run"]["controller_params"])["LEG_KP"] == 1.25 * P.LEG_KP
        assert len(reader.sim_state()["t"]) == len(original.sim_state()["t"])
        assert "robot.xml" in reader.attachments and "/controller/debug" in reader.topics


def test_update_needs_kept_frames(rig, tmp_path):
    with pytest.raises(ValueError, match="keep_sent"):
        write_reference(replay(rig[1]), tmp_path / "x.mcap")


# -- the trace as a bug report -----------------------------------------------------------------------
def test_rig_trace_carries_what_replay_needs(rig, robot):
    assert bug_report_gaps(open_recording(rig[1])) == []
    assert "candump log carries no DBC" in bug_report_gaps(open_recording(robot))[0]


def test_replay_warns_about_dbc_revision_and_parameter_differences(tmp_path, monkeypatch, capsys):
    meta = run_metadata(git_revision="0123456789abcdef")
    del meta["run"]["seed"]
    files = [(n, d + b"\n" if n == "rig.dbc" else d, t) for n, d, t in attachments() if n != "robot.xml"]
    path = tmp_path / "old.mcap"
    trace = TraceWriter(path, metadata=meta, attachments=files,
                        dbs={"vcan0": dbc.load_bus("can1"), "vcan1": dbc.load_bus("can2")})
    rig = SyntheticRig(None, None, trace=trace)
    rig.run(40)
    gaps = bug_report_gaps(open_recording(path))
    assert "run metadata 'seed'" in gaps and "MJCF attachment (*.xml)" in gaps
    monkeypatch.setattr(P, "ROLL_KD", P.ROLL_KD + 1.0)
    warnings = "\n".join(environment_warnings(open_recording(path)))
    assert "rig.dbc differs from the installed " in warnings and "dbc/rig.dbc: replay" in warnings
    assert "0123456789ab" in warnings and "ROLL_KD" in warnings
    assert main(["replay", str(path)]) in (0, 1)
    err = capsys.readouterr().err
    assert "warning:" in err and "rig.dbc" in err


def test_unreadable_files_exit_2(tmp_path, capsys):
    assert main(["replay", str(tmp_path / "missing.mcap")]) == 2
    (tmp_path / "empty.log").write_text("# nothing\n")
    assert main(["replay", str(tmp_path / "empty.log")]) == 2
    (tmp_path / "cut.mcap").write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 5)
    assert main(["replay", str(tmp_path / "cut.mcap")]) == 2
    (tmp_path / "cut.log.gz").write_bytes(gzip.compress(b"(0.000001) vcan0 123#00\n" * 50)[:40])
    assert main(["replay", str(tmp_path / "cut.log.gz")]) == 2
    err = capsys.readouterr().err
    assert err.count("cannot replay") == 4 and "damaged gzip" in err


# -- a real rig trace ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def rig_trace(tmp_path_factory):
    import argparse
    from wheelleg.hil.commands.run import execute
    out = tmp_path_factory.mktemp("rig")
    args = argparse.Namespace(scenario="balance", out=out, interface="virtual", channel=["vcan0", "vcan1"],
                              seed=3, duration=0.3, realtime=False, external_controller=False, no_plot=True)
    outcome, _, _ = execute(args)
    return outcome.trace_path, outcome.log_path


def test_real_rig_trace_replays_identical_and_names_a_changed_gain(rig_trace, monkeypatch):
    trace, log = rig_trace
    for path in (trace, log):
        result = replay(path)
        assert result.identical and result.ticks == 150 and result.schedule.mode == "sync"
    monkeypatch.setattr(lqr, "gain_matrix", _scaled_gain(1, 4, 1.2))  # Tp row, body pitch gain
    first = replay(trace).first
    assert first is not None and first.bus == "can2" and first.signal == "TorqueRef"
    assert first.tick > 0 and first.message == "CG_MotionCmd"
