"""Checks every run of a program other than the in-process Python one gets on top of its scenario's.

Judged from the trace alone, like the scenario's: the program's process ran to the
run's end (a ``program_exit`` event carries its status and the tail of its output),
it sent commands every period (its frames on the bus: a program that sends nothing
fails here, not only through a fallen robot), and it does not flood the bus (its own
frames hold less than ``FLOOD_SHARE`` of each bus in every 100 ms window).
"""
from __future__ import annotations

from wheelleg.hil.program.process import tail_line
from wheelleg.hil.run.scenario import Check, RunData
from wheelleg.hil.scenarios.common import bus_command_timing

FLOOD_SHARE = 0.8  # share of a bus's 100 ms window the program's own frames may hold (the Python program: ~0.3)


def ran_to_the_end() -> Check:
    def fn(run: RunData):
        exits = run.events_of("program_exit")
        if not exits:
            return True, "the program's process ran to the end of the run"
        e = exits[0]
        tail = tail_line(str(e.get("output_tail", "")))
        return False, (f"the program exited with status {e.get('status')} at {float(e['t']):.3f} s"
                       + (f"; its output ends: {tail}" if tail else "; it wrote nothing"))

    return Check("the program ran to the end", fn, pace_bound=False)  # an exit is one on any plant


def bus_not_flooded() -> Check:
    """Its own frames' share of each bus (``RunData.program_load``: the frames the DBC names as the
    controller's), not the bus's load: a scenario's babbling node (overload) is not the program's flood."""
    def fn(run: RunData):
        if not run.program_load:
            return False, "no frames of the program recorded"
        ok = all(v < FLOOD_SHARE for v in run.program_load.values())
        return ok, "its own frames' peak share of the bus " + ", ".join(
            f"{bus} {v * 100:.1f} %" for bus, v in sorted(run.program_load.items()))

    return Check(f"the program does not flood the bus (its frames < {FLOOD_SHARE * 100:g} % of each 100 ms)", fn)


def commands_every_period() -> Check:
    return Check("the program sent commands every period (on the bus)", bus_command_timing)


def program_checks(program: dict) -> tuple[Check, ...]:
    """The checks a run adds for its program (the trace's ``program`` record, hil/program: kind python,
    library, command or external; judged_by heartbeat, tick_log or bus)."""
    kind = program.get("kind", "python")
    if kind in ("python", "external"):
        return ()
    checks = [bus_not_flooded()]
    if program.get("judged_by") != "bus":  # else the scenario's deadline check judges the same timing
        checks.insert(0, commands_every_period())
    if kind == "command":
        checks.insert(0, ran_to_the_end())
    return tuple(checks)
