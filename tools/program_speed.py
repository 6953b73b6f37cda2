"""Each program's speed side by side: ``balance`` in-process with each, in one process, one after the other.

    python -m tools.program_speed [PROGRAM ...] [--duration S]     # default: python, and firmware if it builds

Per program: its microseconds a tick as the rig drives it (wall time inside its ``tick``: the
Python program's ``Controller.tick``; for a library the adapter's, ctypes and heartbeat
included), a library's own ``wl_step`` alone (what an MCU budget is planned from), the rig's
real-time factor for the whole run, and each as a ratio to the first program's. Timings are
of this machine as it is: state its load with them.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from wheelleg.hil import program as programs
from wheelleg.hil import scenarios
from wheelleg.hil.run.rig import Rig, RigConfig


def measure(program: programs.Program, duration_s: float, out: Path) -> dict:
    """{'tick_us': mean us a tick inside the program's tick, 'own_us': a library's wl_step alone (else
    the same), 'rtf': simulated s per wall s of the run}."""
    spent: list[float] = []
    scenario = replace(scenarios.get("balance"), duration_s=duration_s)
    rig = Rig(scenario, RigConfig(program=program), out)
    node = rig.controller  # built in-process: its controller's tick is wrapped with a timer
    tick = node.controller.tick

    def wrapped(n, now_s):
        t0 = time.perf_counter()
        result = tick(n, now_s)
        spent.append(time.perf_counter() - t0)
        return result

    node.controller.tick = wrapped
    own = node.controller.step_times = [] if hasattr(node.controller, "step_times") else spent
    outcome = rig.run()
    return {"tick_us": 1e6 * sum(spent) / max(len(spent), 1), "own_us": 1e6 * sum(own) / max(len(own), 1),
            "rtf": outcome.sim_s / outcome.wall_s}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("programs", nargs="*", help="as `wheelleg run --program` (in-process kinds)")
    parser.add_argument("--duration", type=float, default=5.0, help="simulated s of balance per program (default 5)")
    args = parser.parse_args(argv)
    texts = args.programs or ["python", "firmware"]
    chosen = []
    for text in texts:
        try:
            chosen.append(programs.parse(text))
        except ValueError as exc:
            if args.programs:
                parser.error(str(exc))
            print(f"skipped {text}: {exc}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, program in enumerate(chosen):
            rows.append((program.text, measure(program, args.duration, Path(tmp) / str(i))))
    base = rows[0][1] if rows else None
    print(f"balance, {args.duration:g} s simulated, each program in-process (lockstep):")
    for text, r in rows:
        print(f"  {text:<40} {r['tick_us']:8.1f} us a tick ({r['tick_us'] / base['tick_us']:.2f}x), "
              f"its own step {r['own_us']:8.1f} us   real-time factor {r['rtf']:6.2f} ({r['rtf'] / base['rtf']:.2f}x)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
