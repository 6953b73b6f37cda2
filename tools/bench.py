"""Benchmark (not a test): real-time factor of a lockstep run and where the time goes.

    python -m tools.bench [SCENARIO] [--duration S] [--no-decode]

First a plain run gives the real-time factor (simulated s / wall s, one
process, one core). Then the same run under cProfile attributes the time of
every function to a part of the rig by the file it lives in; profiling slows
everything, so only the shares are reported from it, not absolute times.
"""
from __future__ import annotations

import argparse
import cProfile
import pstats
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from wheelleg.hil import scenarios
from wheelleg.hil.run.rig import Rig, RigConfig

PARTS = (  # (part, path fragments), first match wins
    ("physics (MuJoCo)", ("mujoco", "emulators/physics.py", "emulators/terrain.py")),
    ("emulators", ("emulators/",)),
    ("controller", ("controller/",)),
    ("recording (MCAP, candump, bus load)", ("hil/trace", "hil/mcap_chunks", "hil/candump", "hil/recorder",
                                            "hil/busload", "hil/schemas", "orjson", "zstandard", "/mcap/")),
    ("bus (python-can, queues)", ("/can/", "hil/transport", "queue.py", "threading.py")),
    ("codecs (cantools, dbc)", ("cantools", "bitstruct", "/dbc/")),
    ("rig (lockstep, scenario)", ("hil/",)),
)


def part_of(filename: str) -> str:
    for part, fragments in PARTS:
        if any(f in filename for f in fragments):
            return part
    return "other (Python runtime, numpy)"


def timed_run(scenario, decode: bool, out: Path) -> tuple[float, float]:
    rig = Rig(scenario, RigConfig(decode=decode), out)
    t0 = time.perf_counter()
    outcome = rig.run()
    return outcome.sim_s, time.perf_counter() - t0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default="balance")
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds (default 5)")
    parser.add_argument("--no-decode", action="store_true", help="record raw frames only (no /decoded/)")
    args = parser.parse_args(argv)
    scenario = replace(scenarios.get(args.scenario), duration_s=args.duration)
    with tempfile.TemporaryDirectory() as tmp:
        sim_s, wall_s = timed_run(scenario, not args.no_decode, Path(tmp) / "plain")
        print(f"{scenario.name}: {sim_s:.1f} s simulated in {wall_s:.2f} s wall: "
              f"real-time factor {sim_s / wall_s:.2f}x (lockstep, virtual bus, decode={not args.no_decode})")
        profiler = cProfile.Profile()
        profiler.enable()
        timed_run(scenario, not args.no_decode, Path(tmp) / "profiled")
        profiler.disable()
    shares: dict[str, float] = {}
    for (filename, _, _), row in pstats.Stats(profiler).stats.items():
        shares[part_of(filename)] = shares.get(part_of(filename), 0.0) + row[2]  # tottime
    total = sum(shares.values())
    print("where the time goes (share of profiled run time):")
    for part, seconds in sorted(shares.items(), key=lambda kv: -kv[1]):
        print(f"  {part:<40} {100 * seconds / total:5.1f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
