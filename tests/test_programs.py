"""The rig tests any program (hil/program): a lockstep-ABI library in-process, a command on the
buses, and the bad ones (no ABI, another ABI version, silent, flooding, dying mid-run), each a
clear one-line error or a failed check with the trace kept; the program's record in the trace;
commands judged from the bus when no heartbeat is seen; the NOT REAL TIME verdict."""
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from wheelleg.hil import program as programs
from wheelleg.hil.cli import main
from wheelleg.hil.commands.run import verdict
from wheelleg.hil.program.checks import ran_to_the_end
from wheelleg.hil.program.process import command_argv
from wheelleg.hil.record.rundata import load_run
from wheelleg.hil.record.sources import open_recording
from wheelleg.hil.record.rundata import busy_since_ns
from wheelleg.hil.run.loop_timing import bus_timing
from wheelleg.hil.run.rig import RunOutcome
from wheelleg.hil.run.scenario import CheckResult, RunData
from wheelleg.hil.scenarios.common import no_deadline_miss
from udp_groups import claimed_pair

FIXTURES = Path(__file__).resolve().parent / "fixtures"
VARIANTS = {"zero": [], "silent": ["-DSILENT"], "flood": ["-DFLOOD"], "abi1": ["-DABI_VERSION_1"], "noabi": ["-DNO_ABI"]}


@pytest.fixture(scope="module")
def libs(tmp_path_factory) -> dict[str, Path]:
    """The fixture program (tests/fixtures/zero_program.c) built in each variant with the machine's cc."""
    if shutil.which("cc") is None:
        pytest.skip("no C compiler (cc)")
    out = tmp_path_factory.mktemp("programs")
    built = {}
    for name, flags in VARIANTS.items():
        built[name] = out / f"{name}.so"
        subprocess.run(["cc", "-std=c11", "-Wall", "-Werror", "-shared", "-fPIC", *flags, "-o", str(built[name]),
                        str(FIXTURES / "zero_program.c")], check=True)
    return built


def _run(tmp_path, *extra, duration="0.3"):
    return main(["run", "balance", "--duration", duration, "--no-plot", "-q", "--out", str(tmp_path), *extra])


# -- which program ------------------------------------------------------------------------------
def test_program_kinds_are_told_apart(libs):
    assert programs.parse(None).kind == programs.PYTHON
    assert programs.parse("python").kind == programs.PYTHON
    lib = programs.parse(str(libs["zero"]))
    assert (lib.kind, lib.build_id) == (programs.LIBRARY, "zero-program test fixture 1")
    assert len(lib.sha256) == 64
    cmd = programs.parse("wheelleg controller --sync -c {can1} -c {can2}")
    assert cmd.kind == programs.COMMAND and cmd.words[:2] == ("wheelleg", "controller")
    assert programs.parse(f"cmd:{sys.executable}").kind == programs.COMMAND


def test_a_command_gets_its_channels_by_placeholder_or_appended():
    channels = {"can1": "vcan0", "can2": "vcan1"}
    assert command_argv(["fw", "--sync"], "socketcan", channels) == ["fw", "--sync", "vcan0", "vcan1"]
    assert command_argv(["c", "-i", "{interface}", "-c", "{can2}", "{can1}"], "socketcan", channels) == \
        ["c", "-i", "socketcan", "-c", "vcan1", "vcan0"]


@pytest.mark.parametrize("text, says", [
    ("no-such-program-xyz --sync", "is not an executable file or on PATH"),
    (f"{sys.executable} {{can3}}", "bad placeholder"),
    ("/nonexistent/prog.so", "no such file"),
])
def test_a_bad_program_is_one_line(tmp_path, capsys, text, says):
    assert _run(tmp_path, "--program", text) == 2
    err = capsys.readouterr().err.strip()
    assert says in err and "\n" not in err
    assert not any(tmp_path.iterdir())  # refused before the rig opened a file


@pytest.mark.parametrize("variant, says", [("noabi", "not the lockstep ABI (no wl_abi_version"),
                                           ("abi1", "lockstep ABI version 1, the rig speaks 2")])
def test_a_library_without_the_abi_is_refused(tmp_path, capsys, libs, variant, says):
    assert _run(tmp_path, "--program", str(libs[variant])) == 2
    err = capsys.readouterr().err.strip()
    assert says in err and "\n" not in err
    assert not any(tmp_path.iterdir())


def test_a_file_that_is_no_library_is_refused(tmp_path, capsys):
    fake = tmp_path / "fake.so"
    fake.write_text("not an ELF file")
    assert _run(tmp_path / "out", "--program", str(fake)) == 2
    assert "cannot be loaded" in capsys.readouterr().err


def test_firmware_is_a_clear_error_until_the_repository_builds_one(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(programs, "FIRMWARE_BUILD", ("wheelleg.hil.program.no_such_module", "build_library"))
    assert _run(tmp_path, "--program", "firmware") == 2
    assert "program 'firmware': this checkout has no firmware build yet" in capsys.readouterr().err


def test_a_command_on_the_virtual_bus_is_refused(tmp_path, capsys):
    assert _run(tmp_path, "--program", f"{sys.executable} -c pass") == 2
    assert "a command program needs a bus another process can join" in capsys.readouterr().err


# -- a library in-process ---------------------------------------------------------------------------
def test_a_library_runs_lockstep_deterministically_and_the_trace_names_it(tmp_path, libs, capsys):
    assert _run(tmp_path / "a", "--program", str(libs["zero"])) == 1  # it balances nothing: the robot falls
    _run(tmp_path / "b", "--program", str(libs["zero"]))
    out = capsys.readouterr().out
    assert "[PASS] no controller deadline miss: 0 deadline misses" in out
    assert "[PASS] the program sent commands every period" in out
    log = (tmp_path / "a" / "balance.log").read_text()
    assert log == (tmp_path / "b" / "balance.log").read_text()  # byte-identical reruns
    assert " vcan1 0400FD01#0000000000000000" in log  # its stop frame to motor 1 reached CAN2
    run = load_run(tmp_path / "a" / "balance.mcap")
    assert run.program["kind"] == "library" and run.program["build_id"] == "zero-program test fixture 1"
    assert run.program["judged_by"] == "heartbeat"
    hb = run.heartbeat  # every field from wl_status
    assert len(hb["Tick"]) == 150 and np.all(hb["Mode"] == 1) and np.all(hb["OfflineMask"] == 0x40)
    assert np.all(hb["OfflineCount"] == 1) and np.all(hb["WarningLevel"] == 5) and np.all(hb["BadFrames"] == 1)
    debug = open_recording(tmp_path / "a" / "balance.mcap").trace.columns("/controller/debug")
    assert np.all(np.diff(debug["now_s"]) > 0) and debug["rx_frames"].max() > 0  # its own debug names


def test_a_silent_library_fails_the_command_check(tmp_path, libs, capsys):
    assert _run(tmp_path, "--program", str(libs["silent"])) == 1
    out = capsys.readouterr().out
    assert "[FAIL] the program sent commands every period" in out and "0 ticks" in out


def test_a_flooding_library_fails_the_bus_check_and_the_trace_is_whole(tmp_path, libs, capsys):
    assert _run(tmp_path, "--program", str(libs["flood"])) == 1
    out = capsys.readouterr().out
    assert "[FAIL] the program does not flood the bus" in out
    assert not open_recording(tmp_path / "balance.mcap").truncated


# -- judged from the bus ----------------------------------------------------------------------------
def test_bus_timing_finds_a_whole_missed_period():
    ticks = np.arange(0, 1.0, 0.002)
    assert bus_timing(ticks, 0.002, 1.0)["missed_deadlines"] == 0
    gap = np.delete(ticks, [100, 101])  # 6 ms between two commands: two periods without
    timing = bus_timing(gap, 0.002, 1.0)
    assert timing["missed_deadlines"] == 2 and timing["longest_gap_s"] == pytest.approx(0.006)
    assert bus_timing(ticks[:100], 0.002, 1.0)["missed_deadlines"] == 400  # stopped at 0.198 s: 802 ms silent


def test_a_tick_queued_behind_a_burst_is_late_not_missed():
    # the re-enable of four CyberGears (twelve frames) fills the bus: the next tick's command
    # leaves 2.2 ms late, right before the one after it; the bus was busy all along
    ticks = np.arange(0, 0.02, 0.002)
    late = ticks.copy()
    late[5] += 0.0022
    late[6] += 0.0009  # 0.8 ms after the late one: the two read as one tick, a 4.3 ms gap
    assert bus_timing(late, 0.002, 0.02)["missed_deadlines"] == 1
    queued = late.copy()
    queued[5] = ticks[4] + 0.0003  # back-to-back frames since just after the tick before
    assert bus_timing(late, 0.002, 0.02, queued)["missed_deadlines"] == 0
    silent = np.delete(ticks, [5, 6])  # two ticks that sent nothing, on an idle bus: each frame its own start
    assert bus_timing(silent, 0.002, 0.02, silent)["missed_deadlines"] == 2


def test_busy_since_follows_back_to_back_frames_only():
    wire = [150_000] * 5  # ns: 8-byte extended frames at 1 Mbit/s
    t = np.array([0, 150_000, 300_000, 800_000, 950_000])  # three back to back, idle, two back to back
    assert busy_since_ns(t, wire).tolist() == [0, 0, 0, 800_000, 800_000]


def _bus_judged(times: dict) -> RunData:
    return RunData(state={"t": np.array([0.0, 1.0])}, heartbeat={}, hip_torque={}, wheel_current={},
                   meta={"control_period_s": "0.002"}, program={"kind": "command", "judged_by": "bus"},
                   command_times=times)


def test_the_deadline_check_can_fail_for_a_program_without_heartbeat():
    """The issue: an external program's ticks were not seen, and the check passed whatever it did."""
    ticks = np.arange(0, 1.0, 0.002)
    assert no_deadline_miss()(_bus_judged({"can1": ticks, "can2": ticks})).passed
    assert not no_deadline_miss()(_bus_judged({})).passed
    late = no_deadline_miss()(_bus_judged({"can1": ticks, "can2": ticks[ticks < 0.5]}))
    assert not late.passed and "longest gap 502.000 ms" in late.detail


def test_a_check_that_needs_the_heartbeat_says_a_bus_judged_program_sent_none():
    """A free-running program sends no heartbeat: a check of its report there does not apply (N/A, not
    counted); any other check that reads the heartbeat fails saying why (they raised KeyError 't' once)."""
    from wheelleg.hil.run.scenario import Check, NoHeartbeat
    from wheelleg.hil.scenarios.faults import heartbeat_reports

    run = replace(_bus_judged({}), heartbeat=NoHeartbeat(), events=[{"t": 0.5, "kind": "fault_silent"}])
    result = heartbeat_reports("fault_silent", ["left_wheel"])(run)
    assert result.mark == "N/A" and result.detail.startswith("does not apply: the program sends no heartbeat")
    reads_mode = Check("mode", lambda r: (bool(len(r.heartbeat["Mode"])), "read"))(run)
    assert not reads_mode.passed and reads_mode.detail.startswith("not judged: no heartbeat in the trace")


def test_a_real_time_run_the_plant_could_not_keep_is_not_real_time():
    slow = {"plant": {"physics_dt_s": 0.001, "stretched_s": 0.0, "p99_busy_s": 0.055, "max_lag_s": 0.002}}
    kept = {"plant": {"physics_dt_s": 0.001, "stretched_s": 0.0, "p99_busy_s": 0.0004, "max_lag_s": 0.001}}
    outcome = RunOutcome(Path("x"), Path("y"), 1, 0, 1.0, 1.0)
    assert verdict(False, outcome) == "FAILED"
    assert verdict(False, RunOutcome(Path("x"), Path("y"), 1, 0, 1.0, 1.0, timing=kept)) == "FAILED"
    assert verdict(False, RunOutcome(Path("x"), Path("y"), 1, 0, 1.0, 1.0, timing=slow)).startswith("NOT REAL TIME")
    assert verdict(True, RunOutcome(Path("x"), Path("y"), 1, 0, 1.0, 1.0, timing=slow)) == "PASSED"
    # a failure the plant's pace cannot explain (the program's process exited) is FAILED on any plant
    exited = ran_to_the_end()(_exited_run())
    pitch = CheckResult("pitch", False, "pitch 44 deg")
    slow_run = RunOutcome(Path("x"), Path("y"), 1, 0, 1.0, 1.0, timing=slow)
    assert not exited.passed and not exited.pace_bound
    assert verdict(False, slow_run, [pitch]).startswith("NOT REAL TIME")
    assert verdict(False, slow_run, [pitch, exited]) == "FAILED"


def _exited_run():
    class Exited:
        def events_of(self, kind):
            return [{"t": 0.5, "status": 139, "output_tail": "Segmentation fault"}] if kind == "program_exit" else []
    return Exited()


# -- a command on the buses -----------------------------------------------------------------------
@pytest.fixture
def udp_pair():
    """Bus flags and first port of a udp_multicast pair no other test on the machine uses meanwhile
    (tests/udp_groups.py: per xdist worker, then held by a lock; a pid-seeded draw let two workers
    share one)."""
    pytest.importorskip("msgpack")
    with claimed_pair() as base:
        port = 43300 + 2 * base  # the program opens port and port + 1: a pair's ports are its own too
        yield ["-i", "udp_multicast", "-c", f"239.74.164.{base}", "-c", f"239.74.164.{base + 1}",
               "--bus-kwargs", f"port={port}"], port


def _fixture_command(port: int, *extra: str) -> str:
    return f"{sys.executable} {FIXTURES / 'sync_program.py'} {{interface}} {port} {{can1}} {{can2}} {' '.join(extra)}"


def test_a_command_answers_sync_in_lockstep(tmp_path, udp_pair, capsys):
    bus, port = udp_pair
    rc = _run(tmp_path, *bus, "--program", _fixture_command(port), duration="0.6")
    out = capsys.readouterr().out
    assert "[PASS] no controller deadline miss: 0 deadline misses" in out, out
    assert "[PASS] the program ran to the end" in out
    run = load_run(tmp_path / "balance.mcap")
    assert run.program["kind"] == "command" and "sync_program.py" in run.program["command"]
    assert rc in (0, 1)  # the scenario's own checks need its full 10 s; these are the program's
    # the same program in-process logs the same bytes: SYNC(0) repeated while it started is not recorded
    _run(tmp_path / "in-process", duration="0.6")
    log = (tmp_path / "balance.log").read_text()
    log = log.replace(f" {bus[3]} ", " vcan0 ").replace(f" {bus[5]} ", " vcan1 ")
    assert log == (tmp_path / "in-process" / "balance.log").read_text()


def test_a_command_that_dies_mid_run_fails_with_its_status_and_output(tmp_path, udp_pair, capsys):
    bus, port = udp_pair
    assert _run(tmp_path, *bus, "--program", _fixture_command(port, "--exit-after", "50", "--status", "3"),
                duration="1.0") == 1
    out = capsys.readouterr().out
    assert "[FAIL] the program ran to the end: the program exited with status 3" in out
    assert "fixture: giving up after 50 ticks" in out
    assert not open_recording(tmp_path / "balance.mcap").truncated  # closed and indexed


def test_a_command_that_ignores_sync_is_told_to_run_in_real_time(tmp_path, udp_pair, monkeypatch):
    from wheelleg.hil.program import process
    monkeypatch.setattr(process, "START_S", 1.0)
    bus, port = udp_pair
    with pytest.raises(SystemExit, match="answers SYNC with the heartbeat.*--realtime"):
        _run(tmp_path, *bus, "--program", f"{sys.executable} -c 'import time; time.sleep(30)'")
    assert not open_recording(tmp_path / "balance.mcap").truncated


def test_lockstep_waits_for_a_program_the_machine_stalled(tmp_path, udp_pair, capsys):
    """A program that answered its last tick gets ``patience_s`` for the next: a loaded machine
    (user-mode-linux on a busy host) that does not run it for longer than ``deadline_s`` is no miss."""
    bus, port = udp_pair
    _run(tmp_path, *bus, "--program", _fixture_command(port, "--stall-at", "50", "--stall-s", "1.0"), duration="0.3")
    out = capsys.readouterr().out
    assert "[PASS] no controller deadline miss: 0 deadline misses" in out, out
    assert "[PASS] the program sent commands every period (on the bus)" in out, out
    _run(tmp_path / "in-process", duration="0.3")
    log = (tmp_path / "balance.log").read_text().replace(f" {bus[3]} ", " vcan0 ").replace(f" {bus[5]} ", " vcan1 ")
    assert log == (tmp_path / "in-process" / "balance.log").read_text()  # as if nothing had stalled


def test_lockstep_reports_a_program_that_went_silent(tmp_path, udp_pair, capsys, monkeypatch):
    """Silent for ``patience_s``, a tick is a deadline miss, and so is each one after it stays silent."""
    from wheelleg.hil.run import schedule
    monkeypatch.setattr(schedule, "PATIENCE_S", 1.0)
    bus, port = udp_pair
    _run(tmp_path, *bus, "--program", _fixture_command(port, "--silent-after", "146"), duration="0.3")
    out = capsys.readouterr().out
    assert "[FAIL] no controller deadline miss: 4 deadline misses" in out, out
    assert [e["tick"] for e in load_run(tmp_path / "balance.mcap").events_of("deadline_miss")] == [146, 147, 148, 149]


def test_a_tick_waits_patience_for_an_answering_program_and_deadline_for_a_silent_one(monkeypatch):
    from wheelleg.hil.program.process import ProgramExited
    from wheelleg.hil.run import schedule

    class Rig:
        exited = False

        def check_program(self):
            if self.exited:
                raise ProgramExited(3, "", 0.1)

    now = [0.0]
    monkeypatch.setattr(schedule.time, "monotonic", lambda: now[0])
    lockstep, rig = schedule.Lockstep(0.002, 0.001, deadline_s=0.5, patience_s=10.0), Rig()
    waited = {}
    for answering in (True, False):
        lockstep.answering = answering
        for now[0] in (0.4, 0.6, 9.9, 10.1):
            waited[answering, now[0]] = lockstep.waited_out(rig, 0.0)
    assert waited == {(True, 0.4): False, (True, 0.6): False, (True, 9.9): False, (True, 10.1): True,
                      (False, 0.4): False, (False, 0.6): True, (False, 9.9): True, (False, 10.1): True}
    rig.exited, lockstep.answering = True, True
    now[0] = 0.4
    assert not lockstep.waited_out(rig, 0.0)  # within the deadline it does not ask
    now[0] = 0.6
    with pytest.raises(ProgramExited):  # past it, a program that exited is not waited on
        lockstep.waited_out(rig, 0.0)


# -- the other commands take a program --------------------------------------------------------------
def test_inspect_replay_and_campaign_take_the_program(tmp_path, libs, capsys):
    _run(tmp_path / "lib", "--program", str(libs["zero"]), duration="0.1")
    capsys.readouterr()
    assert main(["inspect", str(tmp_path / "lib" / "balance.mcap")]) in (0, 1)
    assert "program: library " + str(libs["zero"]) + ", build zero-program test fixture 1" in capsys.readouterr().out
    assert main(["replay", str(tmp_path / "lib" / "balance.mcap"), "--program", str(libs["zero"])]) == 0
    assert "identical" in capsys.readouterr().out  # the library replayed into itself
    assert main(["replay", str(tmp_path / "lib" / "balance.mcap")]) == 1  # into the Python program: it differs
    assert main(["campaign", "balance", "--samples", "1", "--out", str(tmp_path / "c"), "--program",
                 str(libs["noabi"])]) == 2
    assert "not the lockstep ABI" in capsys.readouterr().out


def test_the_pytest_plugin_runs_a_program(rig_run, libs):
    run = rig_run("balance", duration=0.1, program=str(libs["zero"]))
    assert run.program["kind"] == "library" and run.ticks == 50
    assert any(c.name.startswith("the program sent commands") and c.passed for c in run.checks)


def test_a_free_running_command_that_hangs_fails_the_deadline_check_from_the_bus(tmp_path, udp_pair, capsys):
    """Real time, no heartbeat the rig can see: the deadline check reads the program's commands on
    the bus, so a program that stops sending fails it (before, it passed whatever happened)."""
    bus, port = udp_pair
    _run(tmp_path, *bus, "--realtime", "--program", _fixture_command(port, "--free-run", "--silent-after", "100"),
         duration="1.5")
    out = capsys.readouterr().out
    assert "[FAIL] no controller deadline miss: its commands on the bus: can1:" in out, out
    run = load_run(tmp_path / "balance.mcap")
    assert run.program["judged_by"] == "bus"
    # 100 ticks and nothing after, counted rather than timed: a loaded or slower machine
    # stretches the program's 2 ms ticks in wall time, not their number. A tick sends its most
    # commanded device one frame, but the enable tick sends each CyberGear three (stop, run mode,
    # enable: 102 frames to a motor in 100 ticks), so each enable counts two frames less.
    enables = _enables_per_motor(tmp_path / "balance.mcap")
    ticks = {bus: len(times) - (2 * enables if bus == "can2" else 0) for bus, times in run.command_times.items()}
    assert set(ticks) == {"can1", "can2"} and all(0 < n <= 100 for n in ticks.values()), (ticks, enables)


def _enables_per_motor(trace: Path) -> int:
    """How many type-3 enables the program sent each CyberGear (the most any one got), from the trace."""
    from wheelleg.controller import constants as C
    from wheelleg.controller.messages import joint_enable
    from wheelleg.hil.record.trace_reader import TraceReader

    reader = TraceReader(trace)
    ids = [frame.arbitration_id for channel in reader.channels() for frame in reader.frames(channel)
           if frame.is_extended]
    return max(ids.count(joint_enable(joint.motor_id).arbitration_id) for joint in C.JOINTS)


def test_an_external_controller_in_real_time_is_judged_from_the_bus(tmp_path):
    from wheelleg.hil import scenarios
    from wheelleg.hil.run.rig import Rig, RigConfig

    config = RigConfig(channels=("wl-ext-0", "wl-ext-1"), in_process_controller=False, realtime=True)
    rig = Rig(scenarios.get("balance"), config, tmp_path)
    try:
        assert rig._program_record() == {"kind": "external", "program": "another process on the buses",
                                         "judged_by": "bus"}
    finally:
        rig.close()


def test_a_free_running_command_that_sends_nothing_is_given_up_on(tmp_path, udp_pair, monkeypatch):
    from wheelleg.hil.program import process

    monkeypatch.setattr(process, "START_S", 1.0)
    bus, port = udp_pair
    with pytest.raises(SystemExit, match="the program sent nothing in 1 s"):
        _run(tmp_path, *bus, "--realtime", "--program", f"{sys.executable} -c 'import time; time.sleep(30)'")
    assert not open_recording(tmp_path / "balance.mcap").truncated  # the trace closed and indexed


def test_a_library_is_refused_for_another_robot(tmp_path, libs, capsys):
    assert main(["run", "quadruped/quad-trot", "--duration", "0.1", "--no-plot", "-q", "--out", str(tmp_path),
                 "--program", str(libs["zero"])]) == 2
    assert "a library speaks the wheel-legged robot's lockstep ABI" in capsys.readouterr().err


# -- over real vcan (the socketcan stage: user-mode-linux where the kernel has none) ----------------
def _vcan_run(out: Path, program: str, duration: str) -> int:
    from wheelleg.hil.bus import vcan

    reason = vcan.unavailable_reason()
    if reason is not None:
        pytest.fail(reason)
    return _run(out, "-i", "socketcan", "-c", "vcan0", "-c", "vcan1", "--program", program, duration=duration)


@pytest.mark.socketcan
def test_the_python_program_as_a_command_over_vcan_logs_the_in_process_bytes(tmp_path):
    _vcan_run(tmp_path / "vcan", f"{sys.executable} -m wheelleg.hil.cli controller --sync -i {{interface}} "
                                 "-c {can1} -c {can2}", "0.6")
    _run(tmp_path / "in-process", duration="0.6")
    assert (tmp_path / "vcan" / "balance.log").read_text() == (tmp_path / "in-process" / "balance.log").read_text()


@pytest.mark.socketcan
def test_the_firmwares_linux_port_runs_lockstep_over_vcan_as_its_library_in_process(tmp_path):
    """Started by the rig, ticking on its SYNC (``--sync``): the same bytes as the library in-process."""
    build = pytest.importorskip("wheelleg.hil.firmware_build").build
    assert _vcan_run(tmp_path / "vcan", f"{build('linux')} --sync", "1.0") == 0
    assert _run(tmp_path / "in-process", "--program", str(build("lib")), duration="1.0") == 0
    assert (tmp_path / "vcan" / "balance.log").read_text() == (tmp_path / "in-process" / "balance.log").read_text()
