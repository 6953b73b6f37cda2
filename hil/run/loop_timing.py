"""Period statistics of a control loop and of the real-time plant (pure functions).

A free-running controller (``ControllerNode(sync=False)``) runs tick
``k = floor(t / T)`` at the first chance after ``k T`` of its own clock and
skips the ticks whose whole period passed while it was busy elsewhere. From
its ``tick_log`` of (tick, monotonic start s):

- period: the wall time between consecutive tick starts (s); mean, min, max;
- jitter: |period - T| (s); p99 and max;
- missed deadlines: periods in which no tick ran at all, i.e. a tick started
  more than one period after the one before it (sum of skipped tick numbers).
"""
from __future__ import annotations

import numpy as np

def loop_timing(ticks, starts_s, period_s: float) -> dict:
    """Statistics of one loop run; ``ticks`` (n,) int tick numbers, ``starts_s`` (n,) s.

    Needs at least two ticks for periods; with fewer the period fields are NaN.
    """
    ticks = np.asarray(ticks, dtype=np.int64)
    starts = np.asarray(starts_s, dtype=float)
    if ticks.shape != starts.shape or ticks.ndim != 1:
        raise ValueError(f"ticks {ticks.shape} and starts_s {starts.shape} must be equal 1-d shapes")
    if not period_s > 0:
        raise ValueError(f"period_s must be > 0, got {period_s!r}")
    periods = np.diff(starts)
    steps = np.diff(ticks)
    if np.any(steps <= 0):
        raise ValueError("tick numbers must increase")
    jitter = np.abs(periods - period_s)
    nan = float("nan")
    return {
        "ticks": int(ticks.size),
        "period_s": float(period_s),
        "mean_period_s": float(periods.mean()) if periods.size else nan,
        "min_period_s": float(periods.min()) if periods.size else nan,
        "max_period_s": float(periods.max()) if periods.size else nan,
        "p99_jitter_s": float(np.percentile(jitter, 99)) if jitter.size else nan,
        "max_jitter_s": float(jitter.max()) if jitter.size else nan,
        "missed_deadlines": int(np.sum(steps - 1)),
    }


def per_tick(ticks, starts_s, period_s: float) -> list[dict]:
    """One record per tick after the first (``ticks`` (n,) int, ``starts_s`` (n,) s): its
    start since the first tick, period and jitter (s) and the ticks skipped before it."""
    out = []
    for k in range(1, len(ticks)):
        period = float(starts_s[k] - starts_s[k - 1])
        out.append({"tick": int(ticks[k]), "start_s": float(starts_s[k] - starts_s[0]), "period_s": period,
                    "jitter_s": period - period_s, "missed": int(ticks[k] - ticks[k - 1] - 1)})
    return out


def describe(timing: dict) -> str:
    """One line for the run summary, in ms."""
    if not timing or timing.get("ticks", 0) < 2:
        return "control loop: no timing (fewer than two ticks, or the controller ran elsewhere)"
    ms = {k: 1e3 * timing[k] for k in ("period_s", "mean_period_s", "p99_jitter_s", "max_jitter_s",
                                        "max_period_s")}
    return (f"control loop: {timing['ticks']} ticks, period {ms['mean_period_s']:.3f} ms mean "
            f"(nominal {ms['period_s']:g}, max {ms['max_period_s']:.3f}), jitter p99 {ms['p99_jitter_s']:.3f} ms, "
            f"max {ms['max_jitter_s']:.3f} ms, {timing['missed_deadlines']} missed deadlines")


def plant_timing(batches, lags_s, dt_s: float, sim_s: float, wall_s: float, busy_s=(), idle_work_s=()) -> dict:
    """The real-time plant's pacing: ``batches`` (n,) physics steps taken at once,
    ``lags_s`` (n,) how late each batch started after its first step was due (s),
    ``busy_s`` (m,) wall s of each batch's work (the headroom: against ``dt_s``),
    ``idle_work_s`` (k,) wall s of each piece of housekeeping done in the slack."""
    batches = np.asarray(batches, dtype=np.int64)
    lags = np.asarray(lags_s, dtype=float)
    busy = np.asarray(busy_s, dtype=float)
    idle = np.asarray(idle_work_s, dtype=float)
    return {
        "physics_dt_s": float(dt_s),
        "steps": int(batches.sum()),
        "overruns": int(np.count_nonzero(batches > 1)),  # batches that had to catch up
        "steps_caught_up": int(np.sum(np.maximum(batches - 1, 0))),
        "max_batch": int(batches.max()) if batches.size else 0,
        "p99_lag_s": float(np.percentile(lags, 99)) if lags.size else 0.0,
        "max_lag_s": float(lags.max()) if lags.size else 0.0,
        "p99_busy_s": float(np.percentile(busy, 99)) if busy.size else 0.0,
        "max_busy_s": float(busy.max()) if busy.size else 0.0,
        "idle_work": int(idle.size),
        "max_idle_work_s": float(idle.max()) if idle.size else 0.0,
        "sim_s": float(sim_s),
        "wall_s": float(wall_s),
        "stretched_s": float(max(0.0, wall_s - sim_s)),  # wall time the plant fell behind for good
    }


STRETCH_TOLERANCE_S = 0.01  # s of wall time the plant may end behind before the run is not real time
STALL_NOTE_S = 0.005  # a catch-up this long (s) is told apart: the devices were silent that long


def describe_plant(plant: dict) -> str:
    """The run summary's plant lines (``plant_timing``'s dict), in ms; says when it was not real time."""
    late = f", {plant['late_wakes']} of them after a late wake-up" if "late_wakes" in plant else ""
    text = (f"plant: {plant['steps']} physics steps, {plant['overruns']} overruns{late} "
            f"({plant['steps_caught_up']} steps caught up in batches, largest {plant['max_batch']}), "
            f"lag p99 {1e3 * plant['p99_lag_s']:.3f} ms, max {1e3 * plant['max_lag_s']:.3f} ms, "
            f"{plant['sim_s']:.2f} s simulated in {plant['wall_s']:.2f} s wall")
    if plant.get("host_steal_s") is not None:
        text += f"; the hypervisor stole {1e3 * plant['host_steal_s']:.0f} ms of CPU meanwhile"
    if "p99_busy_s" in plant:  # older traces' metadata has no busy figures
        text += (f"\n  plant busy a step: p99 {1e3 * plant['p99_busy_s']:.3f} ms, max {1e3 * plant['max_busy_s']:.3f} ms "
                 f"of {1e3 * plant['physics_dt_s']:g} ms; {plant['idle_work']} pieces of the record's housekeeping in the slack, "
                 f"max {1e3 * plant['max_idle_work_s']:.3f} ms")
        if "memory" in plant:
            text += f"; memory {plant['memory']}"
    if plant["max_lag_s"] >= STALL_NOTE_S and plant.get("worst_overrun_cause"):
        text += (f"\n  STALL: the plant caught up {1e3 * plant['max_lag_s']:.1f} ms at {plant['worst_overrun_at_s']:.3f} s "
                 f"({_stall_cause(plant['worst_overrun_cause'])}); "
                 "the emulated devices sent nothing that long, an outage to the controller")
    if plant["stretched_s"] > STRETCH_TOLERANCE_S:
        text += (f"\n  NOT REAL TIME: the plant fell {plant['stretched_s']:.2f} s behind the wall clock "
                 "(simulated time stretched; the controller saw a slow world)")
    return text


def _stall_cause(cause: str) -> str:
    """An overrun's cause as the STALL line says it: whose the late wake-up was."""
    return f"{cause}: the machine woke it late" if cause == "late wake" else cause


def bus_timing(times_s, period_s: float, end_s: float, queued_s=None) -> dict:
    """A program's command timing as the bus saw it, for a program whose ticks the rig cannot
    see (no heartbeat, another process): ``times_s`` (n,) s of the commands it sent to one device
    on one bus (``RunData.command_times``), in order; ``end_s`` the run's end (s). A tick's frames to
    a device come back to back (an enable sequence is three), so a frame more than half a period
    after the one before starts a tick. From the
    ticks' starts: period (mean, max), jitter |period - T| (p99, max) and the longest gap,
    the run's end included (a program that stopped sending). A gap longer than two periods
    holds at least one whole period of the program's own grid without a tick, whatever its
    phase and the record's resolution: ``missed_deadlines`` counts those periods (floor(gap / T) - 1
    of each); shorter irregular gaps show as jitter. ``queued_s`` (n,) s, if given: the earliest
    each frame can have been sent (``rundata.busy_since_ns``: a full bus holds frames back):
    a gap counts as missed periods only by its length to there, so a tick whose frames
    queued behind a burst is late, not missing."""
    times = np.asarray(times_s, dtype=float)
    if not period_s > 0:
        raise ValueError(f"period_s must be > 0, got {period_s!r}")
    is_start = np.concatenate(([True], np.diff(times) > period_s / 2)) if times.size else np.zeros(0, bool)
    starts = times[is_start]
    periods = np.diff(starts)
    gaps = np.append(periods, end_s - starts[-1]) if starts.size else np.array([end_s])
    jitter = np.abs(periods - period_s)
    nan = float("nan")
    unqueued = gaps.copy()
    if queued_s is not None and starts.size > 1:
        unqueued[:-1] = np.asarray(queued_s, dtype=float)[is_start][1:] - starts[:-1]
    long_gaps = unqueued[unqueued > 2 * period_s]
    return {
        "ticks": int(starts.size),
        "period_s": float(period_s),
        "mean_period_s": float(periods.mean()) if periods.size else nan,
        "max_period_s": float(periods.max()) if periods.size else nan,
        "p99_jitter_s": float(np.percentile(jitter, 99)) if jitter.size else nan,
        "max_jitter_s": float(jitter.max()) if jitter.size else nan,
        "longest_gap_s": float(gaps.max()),
        "first_s": float(starts[0]) if starts.size else nan,
        "missed_deadlines": int(np.sum(np.floor(long_gaps / period_s) - 1)),
    }


def describe_bus(bus: str, timing: dict) -> str:
    """One line of ``bus_timing`` in ms."""
    if timing["ticks"] < 2:
        return f"{bus}: {timing['ticks']} ticks of commands on the bus"
    ms = {k: 1e3 * timing[k] for k in ("mean_period_s", "p99_jitter_s", "longest_gap_s", "period_s")}
    return (f"{bus}: {timing['ticks']} ticks, period {ms['mean_period_s']:.3f} ms (nominal {ms['period_s']:g}), "
            f"jitter p99 {ms['p99_jitter_s']:.3f} ms, longest gap {ms['longest_gap_s']:.3f} ms, "
            f"{timing['missed_deadlines']} missed periods")


def plant_kept_real_time(plant: dict) -> str | None:
    """Why the real-time plant did not keep real time (``plant_timing``'s dict), or None if it did:
    it ended behind the wall clock, its work a step was over the step at p99, or it stalled long
    enough (``STALL_NOTE_S``) that its devices fell silent. A run that fails so is NOT REAL TIME:
    what failed may be the plant's, not the program's."""
    if plant.get("stretched_s", 0.0) > STRETCH_TOLERANCE_S:
        return f"the plant fell {plant['stretched_s']:.2f} s behind the wall clock"
    if plant.get("p99_busy_s", 0.0) > plant["physics_dt_s"]:
        return (f"the plant's work a {1e3 * plant['physics_dt_s']:g} ms step was {1e3 * plant['p99_busy_s']:.2f} ms "
                "at p99")
    if plant.get("max_lag_s", 0.0) >= STALL_NOTE_S:
        return f"the plant stalled {1e3 * plant['max_lag_s']:.1f} ms (its devices silent that long)"
    return None
