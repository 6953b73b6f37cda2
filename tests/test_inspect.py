"""``wheelleg inspect``: rates, bus load, signal ranges, faults and deadline misses."""
from __future__ import annotations

import math

import pytest

from wheelleg.hil.record.candump import CandumpWriter
from wheelleg.hil.cli import main
from wheelleg.hil.analyze.inspect_trace import summarize
from wheelleg.hil.analyze.replay import build_schedule
from wheelleg.hil.record.sources import open_recording
from synthetic_trace import PERIOD, POSE, REMOTE_EVERY, Devices, SyntheticRig, robot_log

TICKS = 200
FAULT_TICK, SILENT_AFTER = 120, 60  # motor 3 over-temperature; the remote's last frame


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    out = tmp_path_factory.mktemp("inspect")
    events = {30: ("fault_bus_off", {"bus": "can2", "duration_s": 0.01}), 31: ("push", {"force_n": 20.0}),
              90: ("deadline_miss", {"tick": 90})}
    run = SyntheticRig(out / "run.mcap", out / "run.log", Devices(remote_silent_after=SILENT_AFTER,
                                                                  fault_at=FAULT_TICK), events=events)
    return run.run(TICKS), out / "run.mcap", out / "run.log"


@pytest.mark.parametrize("which", [1, 2])
def test_rates_per_id_match_the_devices(rig, which):
    s = summarize(rig[which])
    per_tick = 1 / PERIOD
    expect = {("vcan0", "C620_Feedback_1"): 2 * per_tick, ("vcan0", "C620_Feedback_2"): 2 * per_tick,
              ("vcan0", "IMU_Orientation"): per_tick, ("vcan0", "SYNC"): per_tick,
              ("vcan0", "Heartbeat"): per_tick, ("vcan1", "Heartbeat"): per_tick,
              ("vcan0", "Operator"): per_tick / REMOTE_EVERY}
    for (channel, message), rate in expect.items():
        assert s.rate(channel, message) == pytest.approx(rate, rel=0.01), (channel, message)
    counts = {(r.channel, r.message): r.frames for r in s.ids}
    assert counts[("vcan0", "Operator")] == SILENT_AFTER // REMOTE_EVERY + 1
    assert counts[("vcan1", "SYNC")] == TICKS
    to_motor_3 = sum(1 for sent in rig[0].sent for m in sent["can2"] if m.is_extended_id
                     and m.arbitration_id & 0xFF == 3)  # each command gets one reply
    assert counts[("vcan1", "CG_Feedback from motor 3")] == to_motor_3
    assert s.frames == sum(counts.values())


def test_text_report_lists_rates_load_and_ranges(rig, capsys):
    assert main(["inspect", str(rig[1])]) == 0
    out = capsys.readouterr().out
    rates = {tuple(line.split()[:3]): float(line.split()[-1]) for line in out.splitlines()
             if line.startswith("  vcan") and line.split()[-1].replace(".", "").isdigit()}
    # each rate from the span of its frames' bus times, which carry arbitration: a frame
    # waits up to ~0.6 ms behind lower ids (0.15 % of the 0.4 s span)
    assert rates[("vcan0", "0x201", "C620_Feedback_1")] == pytest.approx(1000.0, rel=0.002)
    assert rates[("vcan0", "0x300", "Operator")] == pytest.approx(50.0, rel=0.002)
    assert "bus load" in out and "signal ranges:" in out and "scenario synthetic" in out


def test_bus_load_matches_the_recorders_bus_clock(rig):
    run, mcap, _ = rig
    s = summarize(mcap)
    for channel, wire in run.recorder.wires.items():
        busy_s = wire.busy_ns_total / 1e9
        mean, peak = s.bus_load[channel]
        assert mean == pytest.approx(busy_s / s.duration_s, rel=0.01)
        assert mean <= peak + 1e-9 and peak < 1.0


def test_signal_ranges(rig):
    ranges = {(r.channel, r.message, r.signal): (r.minimum, r.maximum) for r in summarize(rig[1]).signals}
    assert ranges[("vcan0", "Heartbeat", "Tick")] == (0, TICKS - 1)
    assert ranges[("vcan0", "Operator", "LegLength")] == pytest.approx((0.17, 0.17), abs=1e-3)
    low, high = ranges[("vcan1", "CG_Feedback", "Pos")]
    assert min(POSE.values()) - 0.011 <= low and high <= max(POSE.values()) + 0.011
    assert ranges[("vcan1", "CG_Feedback", "FaultOverTemp")] == (0, 1)


def test_faults_warnings_and_deadline_misses(rig):
    s = summarize(rig[1])
    cyber = [f for f in s.faults if f.kind == "cybergear"]
    assert len(cyber) == 1 and "CG_Feedback from motor 3: FaultOverTemp set" in cyber[0].text
    assert cyber[0].t_s == pytest.approx(FAULT_TICK * PERIOD, abs=PERIOD)
    offline = [f for f in s.faults if f.kind == "heartbeat" and "offline remote" in f.text]
    assert offline, [f.text for f in s.faults]
    remote_timeout = 0.100  # wheelleg.controller.detect: remote offline after 100 ms without a frame
    assert offline[0].t_s == pytest.approx(SILENT_AFTER * PERIOD + remote_timeout, abs=2 * PERIOD)
    assert [f.text for f in s.faults if f.kind == "event"] == ["event fault_bus_off (bus=can2, duration_s=0.01)"]
    assert [f.text for f in s.deadline_misses] == ["deadline miss (tick 90)"]
    assert s.events == {"fault_bus_off": 1, "push": 1, "deadline_miss": 1}


def test_sync_without_heartbeat_is_a_deadline_miss(rig, tmp_path):
    lines = rig[2].read_text().splitlines(keepends=True)
    hb = [i for i, s in enumerate(lines) if " vcan0 710#" in s]
    del lines[hb[50]]
    path = tmp_path / "miss.log"
    path.write_text("".join(lines))
    s = summarize(path)
    assert [f.text for f in s.deadline_misses] == ["SYNC(50) without heartbeat"]


def test_robot_log_late_and_skipped_ticks(tmp_path):
    path = tmp_path / "robot.log"
    robot_log(path, 80)
    assert summarize(path).deadline_misses == []
    source = open_recording(path)
    step = build_schedule(source).steps[40]
    assert step.tick == 40
    skipped = set(step.expected["can1"] + step.expected["can2"])  # the controller skipped tick 40
    with CandumpWriter(path) as log:
        for i, f in enumerate(source.frames):
            if i not in skipped:
                log.write(f)
    misses = summarize(path).deadline_misses
    assert len(misses) == 1 and "tick 41 came" in misses[0].text and "(1 skipped)" in misses[0].text


def test_plot_and_candump_quirks(rig, tmp_path, capsys):
    png = tmp_path / "run.png"
    assert main(["inspect", str(rig[1]), "--plot", str(png), "--no-signals"]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    log = tmp_path / "odd.log"
    log.write_text("# comment\n(0000000001.000000) vcan0 201#0000000000000000\n"
                   "DROPCOUNT: dropped 2 CAN frames on 'vcan0' socket (total drops 2)\n"
                   "(0000000001.000100) vcan0 20000080#0000000000000000\n"
                   "(0000000001.000200) vcan0 123##1DEADBEEF\n(0000000001.001000) vcan0 201#0000000000000000\n"
                   "(0000000001.001000) can9 7FF#01\n")
    assert main(["inspect", str(log)]) == 0
    out = capsys.readouterr().out
    assert "2 frame(s) lost" in out and "1 comment line(s)" in out and "can9" in out
    s = summarize(log)
    assert s.rate("vcan0", "C620_Feedback_1") == pytest.approx(1000.0)
    assert math.isnan(s.rate("can9", "?"))


def test_unreadable_file_exits_2(tmp_path, capsys):
    (tmp_path / "x.log").write_text("not a log\n")
    assert main(["inspect", str(tmp_path / "x.log")]) == 2
    assert "cannot read" in capsys.readouterr().err
