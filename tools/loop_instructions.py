"""Machine instructions per lockstep control tick, counted by valgrind: a speed figure load cannot blur.

    python -m tools.loop_instructions [SCENARIO] [--duration S] [--decoded] [--mujoco]

Timings on the shared 2-core machine swing by 30 % with the other jobs on it;
an instruction count does not. This runs the scenario's lockstep loop inside
``valgrind --tool=callgrind`` with counting switched on (``callgrind_control
-i on``) only after the rig is built and its first tick ran, and off after
the recorder closed: start-up is left out, the trace's last chunk is in.
Chunks close by size and bus time only (the wall-clock flush would close
them every few ticks under valgrind's ~50x slowdown). Needs valgrind; a
0.6 s run takes about a minute. Compare two trees by running it in each.
``--mujoco`` also gives MuJoCo's own share, ``mj_step`` inclusive of all it
calls (``callgrind_annotate``): with ``tools.controller_replay --count`` (the
program alone) what is left is the rig's own work. ``WHEELLEG_PURE_PYTHON=1``
counts the rig without its compiled record path (``wheelleg.hil.fast``).
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

from tools import known_scenario


def count_loop(scenario_name: str, duration_s: float, decode: bool, out: Path) -> int:
    """Inside valgrind: build the rig, count the instructions of its ticks; returns the ticks counted."""
    from wheelleg.hil import scenarios  # noqa: PLC0415 (the outer process runs none of the rig)
    from wheelleg.hil.run.rig import Rig, RigConfig  # noqa: PLC0415

    scenario = replace(scenarios.get(scenario_name), duration_s=duration_s)
    rig = Rig(scenario, RigConfig(decode=decode, trace_flush_s=None), out)
    ticks = round(scenario.duration_s / rig.config.period_s)
    rig.schedule.step_tick(rig, 0)  # first-use caches filled outside the count
    callgrind("on")
    for tick in range(1, ticks):
        rig.schedule.step_tick(rig, tick)
    rig.close()
    callgrind("off")
    return ticks - 1


def callgrind(state: str) -> None:
    """Switch valgrind's instruction counting for this process "on" or "off" (it runs inside callgrind)."""
    subprocess.run(["callgrind_control", "-i", state, str(os.getpid())], check=True, capture_output=True)


def under_callgrind(module_args: list[str], function: str | None = None
                    ) -> tuple[subprocess.CompletedProcess, int | None, int | None]:
    """``python -m MODULE_ARGS`` from the repository root under valgrind's callgrind, counting only
    what it switches on (``callgrind``): (the finished process, the instructions counted, None
    when valgrind reported no count; the instructions inside the C ``function`` and what it
    calls, None when not asked or not found)."""
    with tempfile.TemporaryDirectory() as tmp:
        command = ["valgrind", "--tool=callgrind", "--instr-atstart=no", f"--callgrind-out-file={tmp}/cg.out",
                   sys.executable, "-m", *module_args]
        done = subprocess.run(command, capture_output=True, text=True, cwd=Path(__file__).resolve().parents[1])
        inside = None
        if function is not None and done.returncode == 0:
            inside = inclusive_count(Path(tmp) / "cg.out", function)
    counted = re.search(r"Collected : (\d+)", done.stderr)
    return done, int(counted.group(1)) if counted else None, inside


def inclusive_count(out_file: Path, function: str) -> int | None:
    """Instructions in ``function`` and everything it called, from a callgrind output file."""
    annotated = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out_file)],
                               capture_output=True, text=True)
    return inclusive_in(annotated.stdout, function)


def inclusive_in(annotated: str, function: str) -> int | None:
    """``function``'s count in ``callgrind_annotate --inclusive=yes`` text, None when it is not listed."""
    for line in annotated.splitlines():  # "1,234,567 (12.3%)  file:function [object]"
        m = re.match(r"\s*([\d,]+)\s.*?:(\S+)\s", line + " ")
        if m and m.group(2) == function:
            return int(m.group(1).replace(",", ""))
    return None


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default="balance", type=known_scenario)
    parser.add_argument("--duration", type=float, default=0.6, help="simulated seconds (default 0.6)")
    parser.add_argument("--decoded", action="store_true", help="also record /decoded/ live (RigConfig.decode)")
    parser.add_argument("--mujoco", action="store_true", help="also MuJoCo's share (mj_step, inclusive)")
    parser.add_argument("--inside", action="store_true", help=argparse.SUPPRESS)  # the run under valgrind
    args = parser.parse_args(argv)
    if args.inside:
        with tempfile.TemporaryDirectory() as tmp:
            print(f"ticks {count_loop(args.scenario, args.duration, args.decoded, Path(tmp))}")
        return 0
    done, total, mujoco = under_callgrind(["tools.loop_instructions", args.scenario, "--duration", str(args.duration),
                                           "--inside"] + (["--decoded"] if args.decoded else []),
                                          "mj_step" if args.mujoco else None)
    ticks = re.search(r"ticks (\d+)", done.stdout)
    if done.returncode != 0 or total is None or ticks is None:
        print(f"loop_instructions: valgrind run failed (exit {done.returncode}):\n{done.stderr[-2000:]}",
              file=sys.stderr)
        return 1
    n = int(ticks.group(1))
    print(f"{args.scenario}: {n} ticks, {total / 1e9:.3f} G instructions, {total / n / 1e6:.2f} M per tick")
    if args.mujoco:
        print("  of it MuJoCo (mj_step inclusive): " + ("not found" if mujoco is None else
                                                         f"{mujoco / n / 1e6:.3f} M per tick"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
