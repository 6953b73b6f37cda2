"""Checks every run of a program other than the in-process Python one gets on top of its scenario's.

Judged from the trace alone, like the scenario's: the program's process ran to the
run's end (a ``program_exit`` event carries its status and the tail of its output),
it sent commands every period (its frames on the bus: a program that sends nothing
fails here, not only through a fallen robot), and its frames fit the bus (the
``/bus/load`` windows of 100 ms stay below a full bus).
"""
from __future__ import annotations

from wheelleg.hil.program.process import tail_line
from wheelleg.hil.run.scenario import Check, RunData
from wheelleg.hil.scenarios.common import bus_command_timing

FULL_BUS = 1.0  # a 100 ms window's load (s of frames on the wire per s) that means the bus is flooded


def ran_to_the_end() -> Check:
    def fn(run: RunData):
        exits = run.events_of("program_exit")
        if not exits:
            return True, "the program's process ran to the end of the run"
        e = exits[0]
        tail = tail_line(str(e.get("output_tail", "")))
        return False, (f"the program exited with status {e.get('status')} at {float(e['t']):.3f} s"
                       + (f"; its output ends: {tail}" if tail else "; it wrote nothing"))

    return Check("the program ran to the end", fn)


def bus_not_flooded() -> Check:
    def fn(run: RunData):
        worst = {bus: float(load.max()) for bus, (_, load) in run.bus_load.items() if len(load)}
        if not worst:
            return False, "no /bus/load windows recorded"
        ok = all(v < FULL_BUS for v in worst.values())
        return ok, "peak bus load " + ", ".join(f"{bus} {v * 100:.1f} %" for bus, v in sorted(worst.items()))

    return Check("the program's frames fit the bus (load < 100 % in every 100 ms)", fn)


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
