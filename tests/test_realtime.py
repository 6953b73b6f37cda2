"""Real-time mode: the plant at wall-clock pace, the controller free-running on its own
timer in its own thread; the control loop's period statistics in the trace and summary."""
from __future__ import annotations

import argparse
import gc
import os
import sys
import time
from dataclasses import replace

import numpy as np
import pytest

from wheelleg.dbc import load_bus
from wheelleg.hil.run import realtime
from wheelleg.hil import scenarios
from wheelleg.hil.commands import run as run_command
from wheelleg.hil.run.loop_timing import describe, describe_plant, loop_timing, per_tick, plant_timing
from wheelleg.hil.run.rig import Rig, RigConfig
from wheelleg.hil.record.rundata import load_run
from wheelleg.hil.record.trace import TraceReader

PERIOD_S = 0.002


# -- the statistics (pure) --------------------------------------------------------------------
def test_loop_timing_of_a_perfect_loop():
    ticks = np.arange(100)
    t = loop_timing(ticks, 5.0 + ticks * PERIOD_S, PERIOD_S)
    assert t["ticks"] == 100 and t["missed_deadlines"] == 0
    assert t["mean_period_s"] == pytest.approx(PERIOD_S)
    assert t["max_jitter_s"] == pytest.approx(0.0, abs=1e-9)


def test_loop_timing_counts_skipped_periods_and_jitter():
    # ticks 0..9 on time, tick 10 starts 0.3 ms late, ticks 11 and 12 never run (the loop
    # stalled), tick 13 runs 0.1 ms into its period
    ticks = np.array([*range(11), 13])
    starts = ticks * PERIOD_S
    starts[10] += 0.0003
    starts[11] += 0.0001
    t = loop_timing(ticks, starts, PERIOD_S)
    assert t["missed_deadlines"] == 2
    assert t["max_period_s"] == pytest.approx(3 * PERIOD_S - 0.0002)
    assert t["max_jitter_s"] == pytest.approx(2 * PERIOD_S - 0.0002)
    assert t["mean_period_s"] == pytest.approx((starts[-1] - starts[0]) / 11)
    rows = per_tick(ticks, starts, PERIOD_S)
    assert [r["missed"] for r in rows] == [0] * 9 + [0, 2]
    assert rows[9]["jitter_s"] == pytest.approx(0.0003)
    assert "2 missed deadlines" in describe(t)


@pytest.mark.parametrize("ticks, starts, period, message", [
    ([0, 1], [0.0], PERIOD_S, "shapes"),
    ([0, 0], [0.0, 0.002], PERIOD_S, "increase"),
    ([0, 1], [0.0, 0.002], 0.0, "period_s"),
])
def test_loop_timing_rejects_bad_input(ticks, starts, period, message):
    with pytest.raises(ValueError, match=message):
        loop_timing(ticks, starts, period)


def test_one_tick_has_no_periods():
    t = loop_timing([3], [1.0], PERIOD_S)
    assert t["ticks"] == 1 and np.isnan(t["mean_period_s"]) and t["missed_deadlines"] == 0
    assert "no timing" in describe(t)


def test_plant_timing_counts_catch_up_batches():
    p = plant_timing([1, 1, 3, 1, 2], [0.0, 0.0001, 0.0025, 0.0, 0.0012], 0.001, sim_s=0.008, wall_s=0.0081)
    assert (p["steps"], p["overruns"], p["steps_caught_up"], p["max_batch"]) == (8, 2, 3, 3)
    assert p["max_lag_s"] == pytest.approx(0.0025)
    assert p["stretched_s"] == pytest.approx(0.0001)
    assert "NOT REAL TIME" not in describe_plant(p)
    late = plant_timing([50, 50], [0.5, 0.9], 0.001, sim_s=0.1, wall_s=1.0)
    assert late["stretched_s"] == pytest.approx(0.9)
    assert "NOT REAL TIME: the plant fell 0.90 s behind" in describe_plant(late)
    assert "STALL" not in describe_plant(p)
    stalled = dict(p, max_lag_s=0.0101, worst_overrun_at_s=0.958, worst_overrun_cause="late wake")
    assert ("STALL: the plant caught up 10.1 ms at 0.958 s (late wake: the machine woke it late); "
            "the emulated devices sent nothing that long") in describe_plant(stalled)


# -- a real-time run ----------------------------------------------------------------------------
def _realtime_rig(tmp_path, duration_s: float) -> Rig:
    scenario = replace(scenarios.get("balance"), duration_s=duration_s)
    return Rig(scenario, RigConfig(realtime=True), tmp_path)


def test_realtime_run_keeps_wall_clock_pace_and_records_the_loop_timing(tmp_path):
    duration_s = 1.0
    rig = _realtime_rig(tmp_path, duration_s)
    before = (sys.getswitchinterval(), gc.isenabled(), os.sched_getscheduler(0))
    outcome = rig.run()
    assert (sys.getswitchinterval(), gc.isenabled(), os.sched_getscheduler(0)) == before  # restored
    # Structure only: wall time, tick rates and periods depend on the machine's load and
    # are figures for `wheelleg run --realtime` and the bench, never asserted here.
    ctl, plant = outcome.timing["controller"], outcome.timing["plant"]
    assert ctl["ticks"] >= 2
    assert plant["steps"] == round(duration_s / 0.001)
    reader = TraceReader(outcome.trace_path)
    rows = [p for _, p in reader.topic("/controller/timing")]
    assert len(rows) == ctl["ticks"] - 1
    assert sum(r["missed"] for r in rows) == ctl["missed_deadlines"] == outcome.deadline_misses
    missed = [e["tick"] for e in reader.events() if e["kind"] == "deadline_miss"]
    assert missed == [t for r in rows for t in range(r["tick"] - r["missed"], r["tick"])]
    meta = reader.metadata["controller_timing"]
    assert float(meta["p99_jitter_s"]) == pytest.approx(ctl["p99_jitter_s"])
    assert int(reader.metadata["plant_timing"]["steps"]) == plant["steps"]
    if realtime.host_steal_s() is not None:  # Linux: the hypervisor's share is reported, >= 0
        assert plant["host_steal_s"] >= 0.0
    # no SYNC in real time: the controller ticks on its own clock
    sync_id = load_bus("can1").get_message_by_name("SYNC").frame_id
    assert not any(f.arbitration_id == sync_id and not f.is_extended for f in reader.frames("vcan0"))
    assert len(reader.sim_state()["t"]) == round(duration_s / PERIOD_S)


def test_a_plant_that_cannot_keep_pace_reports_overruns_instead_of_stretching_time(tmp_path, monkeypatch):
    """Each physics step costs 1.5 ms of wall time for a 1 ms step: the plant catches up
    in batches, says so (plant_overrun events, overruns), and simulated time stays with
    the wall clock."""
    duration_s = 0.5
    rig = _realtime_rig(tmp_path, duration_s)
    step = rig.plant.step

    def slow_step(now_s):
        deadline = time.perf_counter() + 0.0015
        step(now_s)
        while time.perf_counter() < deadline:
            pass
    monkeypatch.setattr(rig.plant, "step", slow_step)
    outcome = rig.run()
    plant = outcome.timing["plant"]
    assert plant["overruns"] > 10 and plant["max_batch"] > 1
    assert plant["steps"] == round(duration_s / 0.001)
    # 0.75 s of stepping work for 0.5 s simulated: batches serve the buses less often, but
    # time is not silently stretched; what stretching is left is reported
    assert plant["stretched_s"] == pytest.approx(outcome.wall_s - outcome.sim_s, abs=1e-6)
    events = [e for e in TraceReader(outcome.trace_path).events() if e["kind"] == "plant_overrun"]
    assert len(events) == plant["overruns"]
    assert all(e["steps"] > 1 for e in events)
    # the plant's own work made them: long steps, each after an advance of >= 1.5 ms
    long_steps = [e for e in events if e["cause"] == "long step"]
    assert len(long_steps) > 10 and all(e["previous_busy_s"] >= 0.0015 for e in long_steps)
    assert plant["late_wakes"] == sum(e["cause"] == "late wake" for e in events)


class _StubTrace:
    def __init__(self):
        self.events = []

    def event(self, t_ns, kind, **fields):
        self.events.append(dict(fields, kind=kind, t_ns=t_ns))


class _StubRig:
    """A rig whose record has no housekeeping: only the loop's own timing is left."""

    def __init__(self):
        self.trace = _StubTrace()

    def housekeeping_pending(self) -> bool:
        return False

    def housekeeping(self) -> bool:
        return False


def _oversleep_once(monkeypatch, call: int, extra_s: float) -> None:
    """``time.sleep`` sleeps ``extra_s`` longer at its ``call``-th call: the OS waking a loop late."""
    calls = []
    real_sleep = time.sleep

    def sleep(s):
        calls.append(s)
        real_sleep(s + (extra_s if len(calls) == call else 0.0))
    monkeypatch.setattr(time, "sleep", sleep)


def test_an_overrun_after_a_late_wake_up_is_the_machines(monkeypatch):
    """The loop goes to sleep in time and the OS wakes it 4 ms late: the overrun that
    follows is a late wake, told apart from the plant's own long steps."""
    schedule = realtime.Realtime(0.002, 0.001)
    schedule.rig = _StubRig()
    trace = schedule.rig.trace
    monkeypatch.setattr(schedule, "_advance", lambda first, count: None)  # no work at all
    _oversleep_once(monkeypatch, call=20, extra_s=0.004)
    schedule._loop(60, time.monotonic())
    late = [e for e in trace.events if e["cause"] == "late wake"]
    assert any(e["lag_s"] >= 0.004 and e["steps"] > 1 for e in late)
    assert schedule.late_wakes == len(late)
    lag, _, cause = schedule.worst_overrun  # the summary's STALL line names the longest catch-up
    assert lag >= 0.004 and cause == "late wake"


def test_batches_are_bounded(tmp_path):
    assert realtime.Realtime(0.002, 0.001).max_batch == round(realtime.MAX_BATCH_S / 0.001)


def test_run_command_prints_the_loop_statistics(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    run_command.add_arguments(parser)
    args = parser.parse_args(["balance", "--realtime", "--duration", "0.6", "--out", str(tmp_path),
                              "--no-plot"])
    run_command.run(args)
    out = capsys.readouterr().out
    assert "control loop:" in out and "jitter p99" in out and "missed deadlines" in out
    assert "plant:" in out and "overruns" in out
    trace = tmp_path / "balance.mcap"
    assert not [t for t in TraceReader(trace).topics if t.startswith("/decoded/")]  # the default: raw frames only
    assert len(load_run(trace).heartbeat["t"]) > 200  # the checks still get them, decoded on reading


def test_a_stalled_controller_tick_shows_as_missed_deadlines(tmp_path, monkeypatch):
    """One tick that takes 7 ms: the periods it overran are deadline misses, one event each."""
    from wheelleg.controller.node import Controller

    tick = Controller.tick
    calls = []

    # the 10th tick stalls: early enough that a machine 2.5x slower than the development
    # machine, or one busy with other work, still reaches it within the run (0.5 s: 250 periods)
    def stalling_tick(self, k, now_s):
        calls.append(k)
        if len(calls) == 10:
            time.sleep(0.007)
        return tick(self, k, now_s)
    monkeypatch.setattr(Controller, "tick", stalling_tick)
    outcome = _realtime_rig(tmp_path, 0.5).run()
    ctl = outcome.timing["controller"]
    assert len(calls) > 10, f"only {len(calls)} ticks in 0.5 s of real time"
    assert ctl["missed_deadlines"] >= 2 and ctl["max_period_s"] > 0.007  # 7 ms: the next 2 periods lost
    stalled = calls[9]
    missed = [e["tick"] for e in TraceReader(outcome.trace_path).events() if e["kind"] == "deadline_miss"]
    assert {stalled + 1, stalled + 2} <= set(missed)
    assert len(missed) == ctl["missed_deadlines"] == outcome.deadline_misses


def test_a_controller_crash_is_an_event_and_the_rest_of_the_run_deadline_misses(tmp_path, monkeypatch):
    """As in lockstep: the dead loop's exception is recorded, and every period after its
    last tick counts as missed; the run itself completes so its checks can judge it."""
    from wheelleg.controller.node import Controller

    tick = Controller.tick
    calls = []

    def crashing_tick(self, k, now_s):
        calls.append(k)
        if len(calls) == 50:
            raise ZeroDivisionError("boom")
        return tick(self, k, now_s)
    monkeypatch.setattr(Controller, "tick", crashing_tick)
    duration_s = 0.4
    outcome = _realtime_rig(tmp_path, duration_s).run()
    events = TraceReader(outcome.trace_path).events()
    crashes = [e for e in events if e["kind"] == "controller_exception"]
    assert len(crashes) == 1 and "ZeroDivisionError: boom" in crashes[0]["error"]
    ticks_run = round(duration_s / PERIOD_S)
    last_tick = calls[49]  # the tick that raised: it started (the tick log has it), no tick after
    missed = sorted(e["tick"] for e in events if e["kind"] == "deadline_miss")
    assert set(range(last_tick + 1, ticks_run)) <= set(missed)
    assert outcome.deadline_misses == len(missed) >= ticks_run - 1 - last_tick
    assert outcome.timing["controller"]["crashed"] == "ZeroDivisionError: boom"


# -- the start of a real-time run ----------------------------------------------------------------
class _IdleProgram:
    """A controller program that sends nothing (``CanNode``'s interface)."""

    def on_frame(self, msg, bus, now_s):
        return None

    def tick(self, tick, now_s):
        return argparse.Namespace(frames={})

    def shutdown_frames(self, now_s):
        return {}


def test_a_free_running_node_starts_its_period_grid_when_its_loop_starts():
    """Built, then started 0.2 s later (a real-time run builds the node before its clock
    starts): the first tick is near tick 0, not tick 100 with the periods between counted
    as missed. Near: a loaded machine may hold the thread a few periods (no timing asserted)."""
    import threading

    from wheelleg.controller.can_node import CanNode
    import can

    buses = [can.Bus(interface="virtual", channel=f"grid-{i}") for i in range(2)]
    try:
        node = CanNode(*buses, _IdleProgram(), sync=False, period_s=PERIOD_S)
        node.tick_log = []
        time.sleep(0.2)  # 100 periods
        stop = threading.Event()
        runner = threading.Thread(target=node.run, args=(stop,))
        runner.start()
        deadline = time.monotonic() + 5.0
        while len(node.tick_log) < 3 and time.monotonic() < deadline:
            time.sleep(0.001)
        stop.set()
        runner.join(5.0)
    finally:
        for bus in buses:
            bus.shutdown()
    assert node.tick_log and node.tick_log[0][0] < 50


_FED_TIMES_NS = [k * 50_000 for k in range(2000)]  # the frames ``_feed`` gives, 50 us apart


def _feed(trace, k: int) -> None:
    """Frame ``k`` of the test traces on vcan0, and /sim/state with every 40th."""
    from wheelleg.hil.record.frame import Frame

    t_ns = _FED_TIMES_NS[k]
    trace.frame(Frame(t_ns, "vcan0", 0x201, False, k.to_bytes(8, "little"), 8))
    if k % 40 == 0:
        trace.sim_state(t_ns, {name: k * 0.5 for name in trace._sim_fields})


def _write_trace(path, write_behind: bool) -> bytes:
    from wheelleg.hil.record.trace import TraceWriter

    trace = TraceWriter(path, metadata={"run": {"scenario": "test"}}, flush_interval_s=None,
                        chunk_span_s=0.01, write_behind=write_behind)
    with trace:
        for k in range(2000):  # 20 chunks of 10 ms
            _feed(trace, k)
        trace.add_metadata("late", {"after": "the chunks"})
    return path.read_bytes()


def test_write_behind_writes_the_bytes_the_loop_would_have(tmp_path):
    """Real time hands closed chunks to a worker thread; the file is the same, byte for byte."""
    inline = _write_trace(tmp_path / "inline.mcap", write_behind=False)
    behind = _write_trace(tmp_path / "behind.mcap", write_behind=True)
    assert behind == inline
    assert len(TraceReader(tmp_path / "behind.mcap").sim_state()["t"]) == 50


def _chunk_count(path) -> int:
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        return make_reader(f).get_summary().statistics.chunk_count


def _deferred_trace(path, *, chunk_size: int, ask_every: int | None) -> int:
    """2000 frames 50 us apart in /can/ windows of 10 ms, /sim/state every 40; ``housekeeping``
    every ``ask_every`` frames (None: never). Returns how many pieces it did."""
    from wheelleg.hil.record.trace import TraceWriter

    trace = TraceWriter(path, metadata={"run": {"scenario": "test"}}, flush_interval_s=None,
                        chunk_span_s=0.02, chunk_size=chunk_size, can_window_s=0.01, defer_close=True)
    pieces = 0
    with trace:
        assert not trace.housekeeping()  # nothing open yet
        for k in range(2000):
            _feed(trace, k)
            if ask_every and k % ask_every == ask_every - 1:
                pieces += trace.housekeeping()
    return pieces


def test_deferred_housekeeping_waits_for_the_loop_and_loses_nothing(tmp_path):
    """Real time packs finished /can/ windows and closes chunks in the slack between steps:
    a window (10 ms here) is packed and a chunk due to close (every 20 ms of log time) closes
    only when the loop asks, one piece at a time, and every frame and record is kept in order."""
    path = tmp_path / "deferred.mcap"
    pieces = _deferred_trace(path, chunk_size=512 * 1024, ask_every=50)  # asked every 2.5 ms
    chunks = _chunk_count(path)
    # chunks due every 20 ms of 100 ms: 4 closed when asked, the open one at finish; the
    # other pieces were finished windows (9 in all, some packed by a close that came first)
    assert chunks == 5
    assert chunks - 1 < pieces <= chunks - 1 + 9
    reader = TraceReader(path)
    assert [f.t_ns for f in reader.frames("vcan0")] == _FED_TIMES_NS
    assert len(reader.sim_state()["t"]) == 50
    never = tmp_path / "never.mcap"
    assert _deferred_trace(never, chunk_size=512 * 1024, ask_every=None) == 0
    assert _chunk_count(never) == 1  # never asked, never closed: one chunk at finish
    assert [f.t_ns for f in TraceReader(never).frames("vcan0")] == _FED_TIMES_NS


def test_a_deferred_chunk_that_grows_to_twice_its_size_closes_anyway(tmp_path):
    path = tmp_path / "grown.mcap"
    assert _deferred_trace(path, chunk_size=2048, ask_every=None) == 0
    assert _chunk_count(path) > 3  # ~50 kB of records: closed at 4 kB each without being asked
    assert [f.t_ns for f in TraceReader(path).frames("vcan0")] == _FED_TIMES_NS


def test_the_floor_loop_counts_the_wake_ups_the_os_made_a_step_late(monkeypatch):
    """tools.realtime_floor: the plant's sleep-to-the-next-step loop and nothing else."""
    from tools import realtime_floor

    _oversleep_once(monkeypatch, call=10, extra_s=0.0035)
    late = realtime_floor.late_wakes(0.05, 0.001)
    assert any(lag >= 0.0035 for lag in late)  # the 3.5 ms oversleep, and any the machine added
    assert realtime_floor.main(["--seconds", "0.01", "--runs", "1"]) == 0


def test_housekeeping_takes_a_slack_without_the_controllers_tick_unless_it_waited_too_long():
    schedule = realtime.Realtime(0.002, 0.001)
    schedule.controller_phase_s = 0.00175  # ticks at 1.75, 3.75, ... ms
    fresh, overdue = 0.0, realtime.HOUSEKEEPING_OVERDUE_S
    assert schedule._slack_is_free(0.0102, 0.011, fresh)  # 0.8 ms, no tick before 11.75 ms
    assert not schedule._slack_is_free(0.0112, 0.012, fresh)  # 0.8 ms, but the tick at 11.75 ms
    assert not schedule._slack_is_free(0.0105, 0.011, fresh)  # 0.5 ms: too little
    assert schedule._slack_is_free(0.0112, 0.012, overdue)  # waited: the tick's slack will do
    assert schedule._slack_is_free(0.0106, 0.011, overdue)  # and 0.4 ms of it
    assert not schedule._slack_is_free(0.0108, 0.011, overdue)  # but not 0.2 ms
    schedule.controller_phase_s = None  # an external controller: any slack long enough
    assert schedule._slack_is_free(0.0112, 0.012, fresh)


@pytest.mark.parametrize("robot", ["wheel-legged", "quadruped"])
def test_a_free_running_program_builds_its_frame_layouts_before_its_loop(robot):
    """Built at each message's first frame they cost its first ticks ~2 ms (late, and in real
    time a plant step waiting for the GIL): ``CanNode.prepare`` builds them all first."""
    import can

    from wheelleg.controller.node import ControllerNode
    from wheelleg.controller.quadruped.node import QuadrupedNode
    from wheelleg.controller.quadruped.state import DATABASES
    from wheelleg.dbc import CAN1, CAN2, load_bus
    from wheelleg.dbc.codec import MessageCodec

    kind = ControllerNode if robot == "wheel-legged" else QuadrupedNode
    dbs = [load_bus(CAN1), load_bus(CAN2)] if robot == "wheel-legged" else list(DATABASES.values())
    buses = [can.Bus(interface="virtual", channel=f"prepare-{robot}-{i}") for i in range(2)]
    try:
        kind(*buses, sync=False, period_s=PERIOD_S).prepare()
    finally:
        for bus in buses:
            bus.shutdown()
    compiled = misses = 0
    for db in dbs:
        for message in db.messages:
            try:
                db.get_message_by_frame_id(message.frame_id)
            except KeyError:  # an id the database's lookup does not give: never decoded by the program
                continue
            before = MessageCodec.of.cache_info().misses
            try:
                MessageCodec.of(message)
            except ValueError:  # a layout the codec does not compile: cantools decodes it
                continue
            compiled += 1
            misses += MessageCodec.of.cache_info().misses - before
    assert compiled > 10 and misses == 0


def _recorded(slice_size: int | None) -> list:
    """What a recorder's sink gets for 50 ticks of SYNC, a controller command, its reply and a
    device frame, settled at the end (None) or ``slice_size`` frames at a time after each tick."""
    import can

    from wheelleg.hil.bus.plant_bus import SimClock
    from wheelleg.hil.bus.recorder import SYNC_ID, Recorder

    got = []

    class Sink:
        def on_frames(self, frames):
            got.extend((f.t_ns, f.channel, f.arbitration_id, bytes(f.data)) for f in frames)

        def stop(self):
            pass

    clock = SimClock()
    recorder = Recorder([Sink()], clock, ["vcan0", "vcan1"], batch=10_000)
    for tick in range(50):
        clock.set_s(tick * 0.002)
        for channel in ("vcan0", "vcan1"):
            recorder.sent(channel, can.Message(arbitration_id=SYNC_ID, data=[tick % 256, 0], is_extended_id=False))
        command = recorder.received("vcan1", can.Message(arbitration_id=0x0300FD01, data=bytes(8)))
        recorder.sent("vcan1", can.Message(arbitration_id=0x02000101, data=[tick % 256] * 8), answers=command)
        recorder.sent("vcan0", can.Message(arbitration_id=0x201, data=[tick % 256] * 8, is_extended_id=False))
        if slice_size is not None:
            recorder.settle(slice_size)
    recorder.stop()
    return got


def test_settling_in_slices_records_what_one_settle_does():
    """Real time settles the noted frames a slice at a time in the slack between steps."""
    whole = _recorded(None)
    assert len(whole) == 250 and whole == sorted(whole, key=lambda f: f[0])
    assert _recorded(3) == whole
    assert _recorded(1) == whole
