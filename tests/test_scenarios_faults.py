"""The fault scenarios, run in the rig (one cached run each) and judged from their traces."""
import argparse
from dataclasses import replace

import numpy as np
import pytest

from wheelleg.controller import detect
from wheelleg.controller.modes import Mode
from wheelleg.hil.commands.run import execute
from wheelleg.hil.run.scenario import NoHeartbeat, RunData
from wheelleg.hil.scenarios import faults as fs

from sharing import each_run, same_run

FAULTS = ("offline-wheel", "offline-joint", "offline-imu", "frozen-imu", "offline-remote", "motor-fault", "esc-hold",
          "frame-loss", "bus-off", "overload")


@pytest.mark.parametrize("name", each_run(FAULTS))
def test_scenario_passes_its_checks(name, rig_run):
    rig_run(name).assert_passed()


@pytest.mark.parametrize("name", each_run(FAULTS))
def test_every_injected_fault_is_an_event_with_its_target(name, rig_run):
    events = [e for e in rig_run(name).events if e["kind"].startswith("fault_") and e["kind"] != "fault_end"]
    assert events
    for e in events:
        assert ("device" in e or "bus" in e) and "duration_s" in e and e["t"] == pytest.approx(e["t_s"], abs=1e-9)


@same_run("offline-joint")
def test_offline_joint_reaction_is_the_joint_threshold(rig_run):
    """Not just under the bound: the controller waits the threshold out (no premature trip)."""
    run = rig_run("offline-joint")
    t_f = fs.fault_time(run, "fault_silent")
    last = fs.nonzero_command_times(run)
    reaction = last[last >= t_f][-1] - t_f
    assert detect.RULES[0].offline_after_s - 0.002 < reaction <= detect.RULES[0].offline_after_s + 0.002


@same_run("frame-loss")
def test_frame_loss_keeps_the_robot_balancing_in_balance_mode(rig_run):
    run = rig_run("frame-loss")
    hb = run.heartbeat
    late = hb["t"] > 0.5
    assert np.all(hb["Mode"][late] == int(Mode.BALANCE))
    assert np.all(hb["MotorsEnabled"][late] == 1)


@same_run("overload")
def test_overload_shows_the_load_before_and_during(rig_run):
    """At 500 Hz CAN2 carries ~65 %; the babbling node pushes the wire to ~100 %."""
    t, load = rig_run("overload").bus_load["can2"]
    before = load[(t > 0.2) & (t <= fs.FAULT_AT)]
    during = load[(t > fs.FAULT_AT + 0.1) & (t <= fs.FAULT_AT + 0.3)]
    assert np.all((before > 0.55) & (before < 0.75)), before
    assert np.all(during > 0.95), during


def test_the_same_seed_gives_the_same_lost_frames(tmp_path):
    def log(out, seed):
        args = argparse.Namespace(scenario="frame-loss", out=out, interface="virtual", channel=["vcan0", "vcan1"],
                                  seed=seed, duration=0.7, realtime=False, external_controller=False,
                                  no_plot=True)
        return execute(args)[0].log_path.read_bytes()

    assert log(tmp_path / "a", 4) == log(tmp_path / "b", 4)


def test_a_controller_exception_is_an_event_and_fails_the_alive_check(tmp_path, monkeypatch):
    from wheelleg.controller.node import Controller
    from wheelleg.hil.record.rundata import load_run

    real_tick = Controller.tick

    def tick(self, n, now_s):
        if n == 100:
            raise ZeroDivisionError("injected")
        return real_tick(self, n, now_s)

    monkeypatch.setattr(Controller, "tick", tick)
    args = argparse.Namespace(scenario="offline-joint", out=tmp_path, interface="virtual", channel=["vcan0", "vcan1"],
                              seed=0, duration=0.3, realtime=False, external_controller=False, no_plot=True)
    outcome, results, _ = execute(args)
    crash = load_run(outcome.trace_path).events_of("controller_exception")
    assert len(crash) == 1 and crash[0]["tick"] == 100 and "ZeroDivisionError: injected" in crash[0]["error"]
    assert outcome.deadline_misses == 150 - 100
    alive = [r for r in results if r.name.startswith("controller answered")][0]
    assert not alive.passed and "ZeroDivisionError" in alive.detail


# -- the checks themselves can fail ----------------------------------------------------------
def _synthetic(torque_stops_s: float, mask: int = 0x01, mode: int = int(Mode.DISABLED)) -> RunData:
    """A run with a silent event at 1 s, torque commands every 2 ms until ``torque_stops_s``."""
    t = np.arange(0, 1.5, 0.002)
    tau = np.where(t < torque_stops_s, 1.0, 0.0)
    cmd_t = t[t < torque_stops_s]
    after = t >= 1.0
    hb = {"t": t, "Tick": np.arange(len(t)), "Mode": np.where(after, mode, int(Mode.BALANCE)),
          "OfflineMask": np.where(after, mask, 0), "OfflineCount": np.where(after, 1, 0),
          "WarningLevel": np.where(after, 4, 0), "FaultLatched": np.zeros(len(t)),
          "MotorsEnabled": np.where(t < torque_stops_s, 1, 0)}
    return RunData(state={"t": t}, heartbeat=hb, hip_torque={1: (cmd_t, tau[t < torque_stops_s])},
                   wheel_current={}, events=[{"kind": "fault_silent", "t": 1.0, "device": "left_front_hip"}],
                   meta={"duration_s": "1.5"})


def test_a_late_stop_fails_the_reaction_check():
    check = fs.torque_off_within("fault_silent", 0.022, "joint")
    assert check(_synthetic(1.020)).passed
    late = check(_synthetic(1.030))
    assert not late.passed and "28.00 ms" in late.detail


def test_torque_after_the_stop_fails_the_silence_check():
    check = fs.motors_stay_off("fault_silent", 0.022)
    assert check(_synthetic(1.020)).passed
    assert not check(_synthetic(1.2)).passed


def test_a_wrong_mask_or_mode_fails_the_heartbeat_check():
    check = fs.heartbeat_reports("fault_silent", ["left_front_hip"])
    assert check(_synthetic(1.02)).passed
    assert not check(_synthetic(1.02, mask=0x02)).passed
    assert not check(_synthetic(1.02, mode=int(Mode.FALLEN))).passed


def test_bus_load_windows_cover_the_whole_run(rig_run):
    """Every 100 ms window of the run is in /bus/load, the last, shorter one included."""
    run = rig_run("balance", duration=0.45)
    for bus in ("can1", "can2"):
        t, load = run.bus_load[bus]
        assert len(t) == 5, t
        assert t[-1] == pytest.approx(0.45, abs=0.002)
        assert 0.5 < load[-1] < 0.75  # a partial window is judged over its own length


def _without_heartbeat(run: RunData) -> RunData:
    """The same run as a program on its own clock records it: no heartbeat, judged on the bus."""
    return replace(run, heartbeat=NoHeartbeat(), program={"kind": "command", "judged_by": "bus"})


def test_a_program_without_heartbeat_is_judged_on_its_commands_and_its_report_does_not_apply():
    stays_off = fs.motors_stay_off("fault_silent", 0.022)
    assert stays_off(_without_heartbeat(_synthetic(1.020))).passed
    assert not stays_off(_without_heartbeat(_synthetic(1.2))).passed  # torque commanded after the stop
    report = fs.heartbeat_reports("fault_silent", ["left_front_hip"])(_without_heartbeat(_synthetic(1.02, mask=0x02)))
    assert not report.applies and report.mark == "N/A" and "no heartbeat" in report.detail
    assert fs.heartbeat_reports("fault_silent", ["left_front_hip"])(_synthetic(1.02, mask=0x02)).mark == "FAIL"
