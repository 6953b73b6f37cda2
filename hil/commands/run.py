"""``wheelleg run SCENARIO``: run one scenario, write trace, log and plot, check it."""
from __future__ import annotations

import argparse
from pathlib import Path

from wheelleg.emulators.overrides import help_text, parse_assignment
from wheelleg.emulators.plant import PlantConfig
from wheelleg.hil import scenarios
from wheelleg.hil.run.loop_timing import describe, describe_plant
from wheelleg.hil.analyze.plot import plot_run
from wheelleg.hil.run.rig import Rig, RigConfig
from wheelleg.hil.record.rundata import load_run
from wheelleg.hil.bus.transport import BusOpenError

NAME = "run"
HELP = "run a scenario in the rig; writes DIR/SCENARIO.mcap, .log and .png and checks the run"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", help="scenario name (see `wheelleg list`)")
    parser.add_argument("--out", type=Path, default=Path("out"), help="output directory (default out/)")
    parser.add_argument("--interface", default="virtual",
                        help="python-can interface: virtual (default, in-process), socketcan, ...")
    parser.add_argument("--channels", default="vcan0,vcan1",
                        help="CAN1 (wheels) and CAN2 (joints) channel names, comma separated")
    parser.add_argument("--seed", type=int, default=0, help="random seed (noise, faults)")
    parser.add_argument("--duration", type=float, default=None, help="override the duration (s)")
    parser.add_argument("--realtime", action="store_true",
                        help="plant at wall-clock pace, controller free-running on its own timer in its own "
                             "thread; prints the control loop's period statistics")
    parser.add_argument("--no-decode", action="store_true",
                        help="record raw frames only, no /decoded/ channels (less work per frame)")
    parser.add_argument("--external-controller", action="store_true",
                        help="do not start the controller in-process: another process answers on the buses "
                             "(lockstep: `wheelleg controller --sync`; with --realtime: `wheelleg controller`)")
    parser.add_argument("--no-plot", action="store_true", help="skip the PNG")
    parser.add_argument("--plant", action="append", default=[], metavar="KEY=VALUE",
                        help="change the plant's truth for this run (the controller keeps its belief); "
                             "repeatable; the keys are listed below")
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = "plant overrides (--plant KEY=VALUE):\n" + help_text()


def plant_config(assignments: list[str]) -> PlantConfig:
    """PlantConfig of ``--plant KEY=VALUE`` items; ValueError (one line) for a bad one."""
    return PlantConfig.from_overrides(dict(parse_assignment(text) for text in assignments))


def execute(args: argparse.Namespace):
    """Run and check; returns (outcome, results) for callers such as the pytest plugin."""
    scenario = scenarios.get(args.scenario)
    if args.duration is not None:
        from dataclasses import replace
        scenario = replace(scenario, duration_s=args.duration)
    channels = tuple(c.strip() for c in args.channels.split(","))
    if len(channels) != 2:
        raise SystemExit("--channels needs two names: CAN1 (wheels),CAN2 (joints)")
    try:
        plant = plant_config(getattr(args, "plant", None) or [])
    except ValueError as exc:
        raise SystemExit(f"run: {exc}") from exc
    config = RigConfig(interface=args.interface, channels=channels, seed=args.seed,
                       realtime=args.realtime, in_process_controller=not args.external_controller,
                       decode=not getattr(args, "no_decode", False), plant=plant)
    try:
        rig = Rig(scenario, config, args.out)
    except BusOpenError as exc:
        raise SystemExit(f"run: {exc}") from exc
    outcome = rig.run()
    run = load_run(outcome.trace_path)
    results = [check(run) for check in scenario.checks]
    if not args.no_plot:
        plot_run(run, args.out / f"{scenario.name}.png", title=f"{scenario.name}: {scenario.summary}")
    return outcome, results, run


def run(args: argparse.Namespace) -> int:
    try:
        outcome, results, data = execute(args)
    except KeyError as exc:
        print(exc.args[0])
        return 2
    rtf = outcome.sim_s / outcome.wall_s if outcome.wall_s > 0 else float("inf")
    print(f"{args.scenario}: {outcome.sim_s:.2f} s simulated in {outcome.wall_s:.2f} s "
          f"({rtf:.1f}x real time), {outcome.ticks} ticks, {outcome.deadline_misses} deadline misses")
    if outcome.timing is not None:
        if "controller" in outcome.timing:
            print(f"  {describe(outcome.timing['controller'])}")
        print(f"  {describe_plant(outcome.timing['plant'])}")
    if args.plant:
        print(f"  plant overrides: {' '.join(args.plant)}")
    print(f"  trace {outcome.trace_path}\n  log   {outcome.log_path}")
    print_bus_load(data)
    for r in results:
        print(f"  [{'PASS' if r.passed else 'FAIL'}] {r.name}: {r.detail}")
    ok = all(r.passed for r in results)
    print(f"{args.scenario}: {'PASSED' if ok else 'FAILED'}")
    return 0 if ok else 1


def print_bus_load(run) -> None:
    """Each bus's mean and peak load over the run's 100 ms windows (/bus/load)."""
    for bus, (_, load) in sorted(run.bus_load.items()):
        if len(load):
            print(f"  bus load {bus}: mean {load.mean() * 100:.1f} %, peak {load.max() * 100:.1f} % "
                  f"({len(load)} windows of 100 ms at 1 Mbit/s)")
