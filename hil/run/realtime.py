"""Real-time mode: the plant at wall-clock pace, the controller on its own timer.

``wheelleg run SCENARIO --realtime``. Nothing is in lockstep: no SYNC, no
waiting for heartbeats. The controller is a free-running ``ControllerNode``
(as on the robot, ``python -m wheelleg.controller`` without ``--sync``) in its own
thread; with ``--external-controller`` it is whatever process answers on the
buses. The plant steps the physics each ``physics_dt_s`` of wall time since
the start, serving the buses before each batch of steps and after it.

When the plant cannot keep pace (the machine is slow or busy), it does not
stretch simulated time: it takes the physics steps that are due in one batch
(up to ``MAX_BATCH_S`` of them), serving the buses only around the batch, and
reports each such catch-up as a plant overrun (events ``plant_overrun``, and
totals in the summary), with its cause: a late wake (the loop went to sleep in
time and the OS woke it a step or more late: the machine's stall) or a long
step (the work before it ran past the next step). Only when even a full batch is not enough does
simulated time fall behind wall time; that is reported as ``stretched_s``.
The wall time of each advance (``busy``: the plant's work for its steps) is
the headroom figure: its p99 and max against the physics step.

Housekeeping goes into the slack: the record's work (``Rig.housekeeping``: the
trace's lumps with ``defer_close``, each bus's finished ``/can/`` window packed,
0.1-0.3 ms every 100 ms, and a chunk closed, 0.2-0.5 ms every 0.5 s; then the
frames noted during the steps, settled on the wire model and handed to the log
and the trace a slice at a time, ~0.1 ms) waits until the plant has finished a
step with at least ``IDLE_WORK_MIN_S`` left before the next and the controller's
period grid has no start in that slack, instead of landing on top of a step;
pieces follow each other while the slack lasts, and work that has waited
``HOUSEKEEPING_OVERDUE_S`` for one takes any slack of ``IDLE_WORK_OVERDUE_MIN_S``.

The controller's ticks are timed from its ``tick_log``; periods in which it
ran no tick are deadline misses (``deadline_miss`` events, which the
scenarios' ``no_deadline_miss`` check counts). Per-tick timing goes to
``/controller/timing``, the totals to the trace metadata records
``controller_timing`` and ``plant_timing`` and to the run summary.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import gc
import math
import os
import sys
import threading
import time
from contextlib import contextmanager

from wheelleg.hil.bus.plant_bus import SimClock
from wheelleg.hil.bus.transport import open_bus
from wheelleg.hil.record import schemas
from wheelleg.hil.run.loop_timing import loop_timing, per_tick, plant_timing
from wheelleg.hil.run.schedule import HeartbeatWatch

MAX_BATCH_S = 0.05  # s of physics the plant takes in one batch when behind (then it stretches time)
IDLE_WORK_MIN_S = 0.0006  # slack before the next step (s) in which the plant may do the record's housekeeping
HOUSEKEEPING_OVERDUE_S = 0.02  # housekeeping that waited this long (s) takes any slack of at least:
IDLE_WORK_OVERDUE_MIN_S = 0.0003  # s (a window packs in 0.1-0.3 ms)
SWITCH_INTERVAL_S = 0.0002  # Python's GIL hand-over bound while two loops share the process
FIFO_PRIORITY = 10  # SCHED_FIFO priority of the controller thread, when the OS allows it (as on the robot)
# The controller's period grid starts this many physics steps after the plant's clock, so
# its ticks fall late in a physics step, after the plant served the buses and before it
# steps again, instead of both waking at once for the GIL. 10 s real-time balance runs on
# the idle 2-core machine, control-loop jitter p99 / plant overruns: at 1.0 (in phase)
# 0.28-0.33 ms / 3-7, at 1.25 0.27-0.32 / 5-9, 1.5 0.14-0.25 / 0-6, 1.65-1.85 0.07-0.28 / 0-7.
CONTROLLER_PHASE_STEPS = 1.75
_MCL_CURRENT = 1  # mlockall(2): lock the pages mapped now
PLANT_FIFO_PRIORITY = 5  # the plant's, below the controller's: other processes must not preempt the
# plant while it holds the GIL the controller waits for (priority inversion through the GIL)


class ControllerThread:
    """A robot's free-running controller node on its own buses and thread; its ticks logged."""

    def __init__(self, build_controller, interface: str, channels: dict, period_s: float):
        """``build_controller``: the program's node factory (``Robot.build_controller``'s signature,
        ``wheelleg.hil.program.Program.node_factory``); ``channels``: bus role -> channel."""
        self.node = build_controller({role: open_bus(interface, name) for role, name in channels.items()},
                                     False, period_s)
        self.node.tick_log = []
        self.node.prepare()  # its first-use work before the clock, not in its first ticks (run repeats it: cached)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="controller", daemon=True)
        self.error: BaseException | None = None
        self.error_at_s: float | None = None  # monotonic s when the loop died
        self.scheduler = "not started"
        self.start_at_s: float | None = None  # monotonic s at which its first period starts

    def _run(self) -> None:
        self.scheduler = realtime_priority()
        if self.start_at_s is not None:
            time.sleep(max(0.0, self.start_at_s - time.monotonic()))
        try:
            self.node.run(self._stop)
        except BaseException as exc:  # the robot's program died: recorded by the run, never hidden
            self.error, self.error_at_s = exc, time.monotonic()

    def start(self, at_s: float | None = None) -> None:
        """Start the loop; ``at_s``: monotonic s at which its period grid starts (None: now)."""
        self.start_at_s = at_s
        self._thread.start()

    def stop(self) -> None:
        """Stop the loop (it disables the motors on its way out) and close its buses.
        A loop that died earlier left ``error`` and ``error_at_s`` for the run to record."""
        self._stop.set()
        self._thread.join(5.0)
        for bus in self.node.buses.values():
            bus.shutdown()


def realtime_priority(priority: int = FIFO_PRIORITY) -> str:
    """Ask for SCHED_FIFO for the calling thread: without it a busy machine delays the
    controller's wake-ups by whole scheduler slices. Returns what it got."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        return f"SCHED_FIFO {priority}"
    except (OSError, AttributeError) as exc:  # no CAP_SYS_NICE, or not Linux
        return f"SCHED_OTHER (SCHED_FIFO refused: {exc})"


@contextmanager
def _realtime_process():
    """For the run: a short GIL hand-over, no cyclic GC (a collection stalls both loops
    for milliseconds), SCHED_FIFO for the calling (plant) thread, the process's pages
    locked in RAM; all restored after. Yields (the scheduler the plant got, the memory lock)."""
    switch, gc_was_on = sys.getswitchinterval(), gc.isenabled()
    policy = (os.sched_getscheduler(0), os.sched_getparam(0)) if hasattr(os, "sched_getscheduler") else None
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    gc.disable()
    libc, memory = _lock_memory()
    try:
        yield realtime_priority(PLANT_FIFO_PRIORITY), memory
    finally:
        if libc is not None:
            libc.munlockall()
        sys.setswitchinterval(switch)
        if policy is not None:
            os.sched_setscheduler(0, *policy)
        if gc_was_on:
            gc.enable()


def _lock_memory():
    """``mlockall(MCL_CURRENT)``: every page mapped now (the interpreter's, the libraries' and
    MuJoCo's code, the model, the heap so far; ~200-300 MB, ~50 ms) stays in RAM. Without it
    the OS may take mapped pages back mid-run (this VM's kernel pages out cold memory), and
    touching them again cost a step 10-12 ms of page faults (docs/measurements.md, Real
    time). Later allocations are not locked (MCL_FUTURE made every allocation fault its
    pages in at once: slower steps). Returns (libc or None, what happened)."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        if libc.mlockall(_MCL_CURRENT) != 0:
            return None, f"not locked ({os.strerror(ctypes.get_errno())})"
    except (OSError, AttributeError) as exc:  # no libc with mlockall (not Linux)
        return None, f"not locked ({exc})"
    return libc, "locked"


def host_steal_s() -> float | None:
    """CPU time the hypervisor took from this VM's CPUs so far (s, all CPUs; /proc/stat
    'steal'), or None where that is not known. A stolen slice stalls whichever thread
    holds the GIL, and with it the other loop: the run reports how much there was."""
    try:
        with open("/proc/stat") as stat:
            fields = stat.readline().split()
        return int(fields[8]) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return None


class Realtime:
    """The real-time schedule: owns the run's clock; ``run`` returns (ticks, sim s, wall s, timing dict)."""

    def __init__(self, period_s: float, physics_dt_s: float):
        self.period_s, self.dt = period_s, physics_dt_s
        self.clock = SimClock()
        self.watches: dict[str, HeartbeatWatch] = {}  # unused in real time, kept for one bus stack
        self.steps_per_tick = round(period_s / physics_dt_s)
        self.max_batch = max(1, round(MAX_BATCH_S / physics_dt_s))
        self.batches: list[int] = []
        self.lags: list[float] = []
        self.busy: list[float] = []  # wall s of each advance on the clock
        self.late_wakes = 0  # overruns that came from a wake-up the OS made late
        self.worst_overrun = (0.0, 0.0, "")  # (lag s, plant clock s, cause) of the longest catch-up
        self.idle_work: list[float] = []  # wall s of each piece of housekeeping done in the slack
        self._pending_since: float | None = None  # plant clock s since when housekeeping has waited
        self.controller_phase_s: float | None = None  # where the in-process controller's grid starts
        self.rig = None

    def bus_end(self, bus: str, end):
        self.watches[bus] = HeartbeatWatch()
        return end

    def run(self, rig, ticks: int) -> tuple[int, float, float, dict]:
        self.rig = rig
        cfg = rig.config
        total = ticks * self.steps_per_tick
        controller = None
        if cfg.in_process_controller:
            controller = ControllerThread(cfg.program.node_factory(rig.robot), cfg.interface, rig.names,
                                          cfg.period_s)
        steal0 = host_steal_s()
        with _realtime_process() as (plant_scheduler, memory):
            done = self._first_step() if total else 0
            wall0 = time.monotonic() - done * self.dt  # the clock starts with that step done
            try:
                if controller is not None:
                    self.controller_phase_s = CONTROLLER_PHASE_STEPS * self.dt
                    controller.start(wall0 + self.controller_phase_s)
                self._loop(total, wall0, done)
            finally:
                wall_s = time.monotonic() - wall0
                if controller is not None:
                    controller.stop()
        sim_s = total * self.dt
        steal1 = host_steal_s()
        stolen = None if steal0 is None or steal1 is None else steal1 - steal0
        timing = {"plant": dict(plant_timing(self.batches, self.lags, self.dt, sim_s, wall_s,
                                             self.busy, self.idle_work),
                                late_wakes=self.late_wakes, worst_overrun_at_s=self.worst_overrun[1],
                                worst_overrun_cause=self.worst_overrun[2], scheduler=plant_scheduler, memory=memory,
                                host_steal_s=stolen)}
        if controller is not None:
            timing["controller"] = self._record_controller(controller, wall0, ticks)
        self._record_plant(timing["plant"])
        return ticks, sim_s, wall_s, timing

    # -- the plant's wall-clock loop ---------------------------------------------------------
    def _first_step(self) -> int:
        """Physics step 0 before the wall clock starts: it pays every first use (the trace's
        file, header and attachments, MuJoCo's first step, codecs and caches built on first
        call: 3-4 ms), which on the clock made the plant overrun at once in every run; so does
        the ``/sim/state`` channel the first record makes (~2 ms: schema, MuJoCo's first rays).
        Returns the steps done (1)."""
        rig = self.rig
        rig.trace.start()
        self.batches.append(1)
        self.lags.append(0.0)
        self._advance(0, 1)
        rig.trace.prepare_sim_state(rig.physics.ground_truth())  # the first record's ~2 ms, not on the clock
        return 1

    def _loop(self, total: int, wall0: float, step: int = 0) -> None:
        slept = False  # the loop slept since its last piece of work
        while step < total:
            now = time.monotonic() - wall0
            due = min(int(now / self.dt), total)  # steps that should be done by now
            if due <= step:
                wake = (step + 1) * self.dt
                if self._housekeep(now, wake, wall0):
                    slept = False
                    continue
                time.sleep(max(0.0, wake - now))
                slept = True
                continue
            batch = min(due - step, self.max_batch)
            self.batches.append(batch)
            lag = now - (step + 1) * self.dt
            self.lags.append(lag)
            if batch > 1:
                self._overrun(step, batch, lag, slept)
            self._advance(step, batch)
            self.busy.append(time.monotonic() - wall0 - now)
            slept = False
            step += batch

    def _housekeep(self, now: float, wake: float, wall0: float) -> bool:
        """One piece of the record's housekeeping (``Rig.housekeeping``), if it has some and the
        slack from ``now`` to ``wake`` (s on the plant's clock) takes it; True if one was done."""
        rig = self.rig
        if not rig.housekeeping_pending():
            self._pending_since = None
            return False
        if self._pending_since is None:
            self._pending_since = now
        if not (self._slack_is_free(now, wake, now - self._pending_since) and rig.housekeeping()):
            return False
        self.idle_work.append(time.monotonic() - wall0 - now)
        self._pending_since = None  # what is left waits from now: overdue only when no piece fits for long
        return True

    def _overrun(self, step: int, batch: int, lag_s: float, slept: bool) -> None:
        """A ``plant_overrun`` event, with its cause: a late wake (the loop slept in time
        and the OS woke it ``lag_s`` late: the machine's stall, not the plant's work), or
        a long step (the work before it, ``previous_busy_s``, ran past the next step)."""
        cause = "late wake" if slept else "long step"
        if slept:
            self.late_wakes += 1
        if lag_s > self.worst_overrun[0]:
            self.worst_overrun = (lag_s, step * self.dt, cause)
        self.rig.trace.event(round(step * self.dt * 1e9), "plant_overrun", steps=batch, lag_s=lag_s,
                             cause=cause, previous_busy_s=self.busy[-1] if self.busy else 0.0)

    def _slack_is_free(self, now: float, wake: float, waited_s: float) -> bool:
        """Housekeeping may run from ``now`` to the next step at ``wake`` (s on the plant's
        clock): at least ``IDLE_WORK_MIN_S`` of slack, and no start of the in-process
        controller's period in it (it would wait for the GIL the housekeeping holds). Work
        that has ``waited_s`` ``HOUSEKEEPING_OVERDUE_S`` takes any slack of ``IDLE_WORK_OVERDUE_MIN_S``:
        a slower machine then still packs its windows as they come, not in a pile at a forced close."""
        slack = wake - now
        if waited_s >= HOUSEKEEPING_OVERDUE_S:
            return slack >= IDLE_WORK_OVERDUE_MIN_S
        if slack < IDLE_WORK_MIN_S:
            return False
        phase = self.controller_phase_s
        if phase is None:
            return True
        next_tick = phase + math.ceil((now - phase) / self.period_s) * self.period_s
        return next_tick >= wake

    def _advance(self, first: int, count: int) -> None:
        """Physics steps ``first`` .. ``first + count - 1``, the buses served around them."""
        rig, clock = self.rig, self.clock
        t0 = first * self.dt
        clock.set_s(t0)
        rig.serve_plant(t0)  # the controller's frames that came while we slept
        for k in range(first, first + count):
            now = k * self.dt
            if k % self.steps_per_tick == 0:
                clock.set_s(now)
                rig.apply_actions(now)
            rig.plant.step(now)
            if (k + 1) % self.steps_per_tick == 0:
                clock.set_s(now + self.dt)
                rig.record_state()
        t1 = (first + count) * self.dt
        clock.set_s(t1)
        rig.serve_plant(t1)  # feedback of the new state

    # -- the record ------------------------------------------------------------------------------
    def _record_controller(self, controller: ControllerThread, wall0: float, ticks_run: int) -> dict:
        log = controller.node.tick_log or []
        ticks = [tick for tick, _ in log]
        starts = [start for _, start in log]
        period = self.rig.config.period_s
        timing = dict(loop_timing(ticks, starts, period), scheduler=controller.scheduler)
        trace = self.rig.trace
        for rec in per_tick(ticks, starts, period):
            t_ns = round(rec["tick"] * period * 1e9)
            trace.message("/controller/timing", t_ns, rec, "wheelleg.ControllerTiming", schemas.CONTROLLER_TIMING)
            self._record_misses(range(rec["tick"] - rec["missed"], rec["tick"]), "controller timer")
        if controller.error is not None:
            self._record_crash(controller, wall0, ticks_run, timing)
        trace.add_metadata("controller_timing", _strings(timing))
        return timing

    def _record_crash(self, controller: ControllerThread, wall0: float, ticks_run: int, timing: dict) -> None:
        """As in lockstep: the exception is a ``controller_exception`` event, and every
        period from the last tick the dead loop ran to the end of the run is a deadline
        miss (a dead loop logs no more ticks, so the period statistics cannot see them)."""
        error = f"{type(controller.error).__name__}: {controller.error}"
        self.rig.trace.event(round((controller.error_at_s - wall0) * 1e9), "controller_exception",
                             error=error, source="controller thread")
        log = controller.node.tick_log or []
        lost = range(log[-1][0] + 1 if log else 0, ticks_run)
        self._record_misses(lost, "controller dead")
        timing["missed_deadlines"] += len(lost)
        timing["crashed"] = error

    def _record_misses(self, ticks: range, source: str) -> None:
        """One ``deadline_miss`` event per lost control period."""
        period = self.rig.config.period_s
        for tick in ticks:
            self.rig.trace.event(round(tick * period * 1e9), "deadline_miss", tick=tick, source=source)

    def _record_plant(self, plant: dict) -> None:
        self.rig.trace.add_metadata("plant_timing", _strings(plant))


def _strings(record: dict) -> dict[str, str]:
    """A metadata record: str values as they are, numbers as repr (round-trips through float())."""
    return {k: v if isinstance(v, str) else repr(v) for k, v in record.items()}
