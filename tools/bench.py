"""Benchmark (not a test): how fast a lockstep run goes, against MuJoCo alone, and where the time goes.

    python -m tools.bench [SCENARIO] [--duration S] [--decoded] [--no-profile] [--no-check] [--no-ceiling]

Printed, all from one process in one go (the machine is shared: compare the
ratios, which share the load, more than the absolute figures):

1. the rig's real-time factor (simulated s / wall s) and its CPU time;
2. MuJoCo alone stepping the same model for the same simulated time
   (``mj_step`` in a loop, no devices, controller, bus or recording), and the
   rig's speed as a share of it;
3. microseconds per control tick in each phase of the lockstep schedule
   (``PHASES``: the rig's public steps as the schedule calls them, and the
   plant's physics step; recording happens inside them, as frames pass);
   the trace's size per simulated second and the CPU time the checks take
   to read it back (``load_run``);
4. the ceiling: the fastest any rig could run this scenario around its
   program (``tools.lockstep_ceiling``: the program on its buses plus MuJoCo
   alone), and the rig's share of it;
5. under cProfile, each part of the rig's share of the run (profiling slows
   everything, so only shares are reported from it);
6. the candump log of each reference run (``REFERENCES``: the logs committed
   in tests/traces/) made again and compared byte for byte: the bench exits 1
   and prints the first differing line when a speed change changed behaviour.
"""
from __future__ import annotations

import argparse
import cProfile
import gzip
import pstats
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from tools import known_scenario
from tools.lockstep_ceiling import measure, mujoco_only
from wheelleg.hil import scenarios
from wheelleg.hil.record.rundata import load_run
from wheelleg.hil.run.rig import Rig, RigConfig

TRACES = Path(__file__).resolve().parents[1] / "tests" / "traces"
# (scenario, duration s or None for the scenario's own, committed log): how each was made
# is in tests/traces/README.md; a deliberate behaviour change re-records them there.
REFERENCES = (("balance", 1.0, "balance-1s.log.gz"), ("stand-up", 2.0, "stand-up-2s.log.gz"),
              ("motor-fault", None, "motor-fault.log.gz"))

PARTS = (  # (part, path fragments), first match wins
    ("physics (MuJoCo)", ("mujoco", "emulators/physics.py", "emulators/terrain.py")),
    ("emulators", ("emulators/",)),
    ("controller", ("controller/",)),
    ("recording (MCAP, candump, bus load)", ("hil/record/", "hil/bus/recorder", "hil/bus/busload",
                                            "orjson", "zstandard", "/mcap/", "hil.fast._framecore")),
    ("bus (python-can, queues)", ("/can/", "hil/bus/", "queue.py", "threading.py")),
    ("codecs (cantools, dbc)", ("cantools", "bitstruct", "/dbc/")),
    ("rig (lockstep, scenario)", ("hil/",)),
)
# the rig's steps a lockstep tick is made of (wheelleg.hil.run.schedule.Lockstep.step_tick)
PHASES = ("apply_actions", "send_sync", "service_controller", "serve_plant", "record_debug", "record_state")


def part_of(filename: str) -> str:
    for part, fragments in PARTS:
        if any(f in filename for f in fragments):
            return part
    return "other (Python runtime, numpy)"


class Timed:
    """Stands in for ``owner``: its ``methods`` add their wall time to ``seconds[prefix + name]``.

    ``parts`` (attribute -> method names) are stood in for the same way (the
    rig's ``plant``, whose ``step`` the schedule calls); every other attribute
    is the owner's.
    """

    def __init__(self, owner, methods, seconds: dict, prefix: str = "", parts: dict | None = None):
        self._owner = owner
        for name in methods:
            seconds[prefix + name] = 0.0
            setattr(self, name, _timer(getattr(owner, name), seconds, prefix + name))
        for attribute, names in (parts or {}).items():
            setattr(self, attribute, Timed(getattr(owner, attribute), names, seconds, f"{attribute}."))

    def __getattr__(self, name):
        return getattr(self._owner, name)


def _timer(method, seconds: dict, key: str):
    def timed(*args):
        t0 = time.perf_counter()
        try:
            return method(*args)
        finally:
            seconds[key] += time.perf_counter() - t0
    return timed


def timed_run(scenario, decode: bool, out: Path) -> dict:
    """One lockstep run: simulated s, wall s, CPU s, ticks and seconds per phase."""
    rig = Rig(scenario, RigConfig(decode=decode), out)
    ticks = round(scenario.duration_s / rig.config.period_s)
    seconds: dict[str, float] = {}
    phases = Timed(rig, PHASES, seconds, parts={"plant": ("step",)})
    wall0, cpu0 = time.perf_counter(), time.process_time()
    try:
        rig.schedule.run(phases, ticks)
    finally:
        rig.close()
    wall_s, cpu_s = time.perf_counter() - wall0, time.process_time() - cpu0
    read0 = time.process_time()
    load_run(rig.trace_path)
    return {"sim_s": ticks * rig.config.period_s, "wall_s": wall_s, "cpu_s": cpu_s, "ticks": ticks,
            "phases": seconds, "trace_bytes": rig.trace_path.stat().st_size,
            "read_cpu_s": time.process_time() - read0}


def first_difference(new: list[bytes], ref: list[bytes]) -> str | None:
    """'line N: expected ... got ...' for the first line where two logs differ, None when equal."""
    for n, (a, b) in enumerate(zip(ref, new), start=1):
        if a != b:
            return f"line {n}: expected {a.decode(errors='replace')!r}, got {b.decode(errors='replace')!r}"
    if len(new) != len(ref):
        return f"line {min(len(new), len(ref)) + 1}: expected {len(ref)} lines, got {len(new)}"
    return None


def check_references(tmp: Path) -> list[str]:
    """Each reference run made again; one message per candump log that differs from its committed copy."""
    failures = []
    for name, duration_s, file in REFERENCES:
        scenario = scenarios.get(name)
        if duration_s is not None:
            scenario = replace(scenario, duration_s=duration_s)
        outcome = Rig(scenario, RigConfig(), tmp / f"ref-{name}").run()
        diff = first_difference(outcome.log_path.read_bytes().splitlines(),
                                gzip.decompress((TRACES / file).read_bytes()).splitlines())
        print(f"  {name}: {'identical to' if diff is None else 'DIFFERS from'} tests/traces/{file}")
        if diff is not None:
            failures.append(f"{name}: candump log differs from tests/traces/{file}, {diff}")
    return failures


def report_speed(scenario, run: dict, alone: dict) -> None:
    rtf, rtf_alone = run["sim_s"] / run["wall_s"], alone["sim_s"] / alone["wall_s"]
    cpu, cpu_alone = run["sim_s"] / run["cpu_s"], alone["sim_s"] / alone["cpu_s"]
    print(f"{scenario.name}: {run['sim_s']:.1f} s simulated in {run['wall_s']:.2f} s wall "
          f"({run['cpu_s']:.2f} s CPU): real-time factor {rtf:.2f}x ({cpu:.2f}x on CPU time)")
    print(f"MuJoCo alone, same model: {rtf_alone:.1f}x real time ({cpu_alone:.1f}x on CPU time, "
          f"{alone['us_per_step']:.1f} us per step); the rig runs at {100 * rtf / rtf_alone:.1f} % of it "
          f"({100 * cpu / cpu_alone:.1f} % on CPU time)")
    print(f"per control tick ({run['ticks']} ticks), wall us:")
    total = 1e6 * run["wall_s"] / run["ticks"]
    for name, seconds in run["phases"].items():
        print(f"  {name:<20} {1e6 * seconds / run['ticks']:8.1f}")
    print(f"  {'whole tick':<20} {total:8.1f}")
    print(f"trace {run['trace_bytes'] / run['sim_s'] / 1e6:.3f} MB per simulated s; the checks read it back in "
          f"{run['read_cpu_s']:.2f} s CPU ({run['read_cpu_s'] / run['sim_s']:.3f} s per simulated s)")


def report_ceiling(name: str, run: dict) -> None:
    """The ceiling any rig could reach around this program (``tools.lockstep_ceiling``, best of 2) and the rig's share."""
    ceiling = measure(name, run["sim_s"], reps=2)
    rtf = run["sim_s"] / run["wall_s"]
    print(f"ceiling (the program on its buses {1e6 * ceiling.bused_s:.1f} us + MuJoCo {1e6 * ceiling.physics_s:.1f} us "
          f"a tick): {ceiling.factor:.1f}x for any rig around this program; the rig runs at "
          f"{100 * rtf / ceiling.factor:.0f} % of it" + ("" if ceiling.identical else " (OUTPUTS DIFFER: see tools.lockstep_ceiling)"))


def report_profile(profiler: cProfile.Profile) -> None:
    shares: dict[str, float] = {}
    for (filename, _, function), row in pstats.Stats(profiler).stats.items():
        where = function if filename == "~" else filename  # a C function: its name says its module
        shares[part_of(where)] = shares.get(part_of(where), 0.0) + row[2]  # tottime
    total = sum(shares.values())
    print("where the time goes (share of profiled run time):")
    for part, seconds in sorted(shares.items(), key=lambda kv: -kv[1]):
        print(f"  {part:<40} {100 * seconds / total:5.1f} %")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default="balance", type=known_scenario)
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds (default 5)")
    parser.add_argument("--decoded", action="store_true", help="also record /decoded/ live (RigConfig.decode)")
    parser.add_argument("--no-profile", action="store_true", help="skip the cProfile run")
    parser.add_argument("--no-check", action="store_true", help="skip the candump reference check")
    parser.add_argument("--no-ceiling", action="store_true", help="skip the ceiling (tools.lockstep_ceiling)")
    args = parser.parse_args(argv)
    scenario = replace(scenarios.get(args.scenario), duration_s=args.duration)
    with tempfile.TemporaryDirectory() as tmp:
        run = timed_run(scenario, args.decoded, Path(tmp) / "plain")
        report_speed(scenario, run, mujoco_only(scenario, run["sim_s"]))
        if not args.no_ceiling:
            report_ceiling(args.scenario, run)
        if not args.no_profile:
            profiler = cProfile.Profile()
            profiler.enable()
            timed_run(scenario, args.decoded, Path(tmp) / "profiled")
            profiler.disable()
            report_profile(profiler)
        failures = [] if args.no_check else check_references(Path(tmp))
    for failure in failures:
        print(f"FAIL {failure}")
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(main())
