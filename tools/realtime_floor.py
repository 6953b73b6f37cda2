"""The machine's own real-time floor: how often the OS wakes a bare 1 ms loop a step late.

    python -m tools.realtime_floor [--seconds S] [--runs N] [--step-ms MS]

A real-time run's plant sleeps to the next physics step and counts an overrun
when it wakes a whole step late or later (hil/run/realtime.py); the run says how
many of its overruns came after such a late wake-up. This loop does the same and
nothing else, at the plant's SCHED_FIFO priority, alone in its process: the late
wake-ups it counts are the machine's (the hypervisor, the kernel, other
processes), and no program on the machine can run a 1 ms loop with fewer. Run it
on the idle machine before judging a real-time run: compare the run's late-wake
overruns with this, per 10 s.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

from wheelleg.hil.run.realtime import PLANT_FIFO_PRIORITY, realtime_priority


def late_wakes(seconds: float, step_s: float) -> list[float]:
    """Sleep to each step of a ``step_s`` grid for ``seconds``; returns how late (s) each
    wake-up came that was a whole step late or more (the plant would catch up then)."""
    late = []
    start = time.monotonic()
    step = 1
    steps = round(seconds / step_s)
    while step < steps:
        now = time.monotonic() - start
        due = int(now / step_s)
        if due < step:
            time.sleep(step * step_s - now)
            continue
        if due > step:  # woke a step late or more
            late.append(now - step * step_s)
        step = due + 1
    return late


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.realtime_floor", description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="length of each run (s), default 10")
    parser.add_argument("--runs", type=int, default=3, help="runs, default 3")
    parser.add_argument("--step-ms", type=float, default=1.0, help="the loop's step (ms), default 1: the plant's")
    args = parser.parse_args(argv)
    if args.seconds <= 0 or args.runs < 1 or args.step_ms <= 0:
        parser.error("--seconds and --step-ms must be > 0, --runs >= 1")
    print(f"scheduler: {realtime_priority(PLANT_FIFO_PRIORITY)}; load {os.getloadavg()[0]:.2f}")
    clean = 0
    for run in range(1, args.runs + 1):
        late = late_wakes(args.seconds, args.step_ms / 1e3)
        clean += not late
        worst = f", worst {1e3 * max(late):.1f} ms" if late else ""
        print(f"run {run}: {len(late)} wake-ups a step late or more in {args.seconds:g} s{worst}")
    print(f"{clean} of {args.runs} runs without one: a real-time run here can do no better")
    return 0


if __name__ == "__main__":
    sys.exit(main())
