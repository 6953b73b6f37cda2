"""``wheelleg run SCENARIO``: run one scenario, write trace, log and plot, check it."""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

from wheelleg.controller.bus_args import add_bus_arguments, bus_choice
from wheelleg.emulators.overrides import help_text, parse_assignment
from wheelleg.emulators.plant import PlantConfig
from wheelleg.hil import cli, robots, scenarios
from wheelleg.hil.record.run_metadata import parse_epoch
from wheelleg.hil import program as programs
from wheelleg.hil.program.checks import program_checks
from wheelleg.hil.run.loop_timing import describe, describe_plant, plant_kept_real_time
from wheelleg.hil.run.progress import RunProgress
from wheelleg.hil.run.rig import Rig, RigConfig
from wheelleg.hil.run.schedule import CONTACT_S, NoController
from wheelleg.hil.record.rundata import load_run
from wheelleg.hil.bus.transport import BusOpenError
from wheelleg.hil.watch import options as watch_options

NAME = "run"
HELP = "run a scenario in the rig; writes DIR/SCENARIO.mcap, .log and .png and checks the run"
DEFAULT_INTERFACE, DEFAULT_CHANNELS = "virtual", ("vcan0", "vcan1")


class UsageError(ValueError):
    """Bad input on the command line: one line, exit status 2 (``wheelleg.hil.cli``)."""


def positive_seconds(text: str) -> float:
    """argparse type: a duration > 0 s."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0 s, got {text}")
    return value


def epoch_seconds(text: str) -> int:
    """argparse type: ``--epoch SECONDS`` as integer ns (``run_metadata.parse_epoch``)."""
    try:
        return parse_epoch(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_epoch_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--epoch", type=epoch_seconds, default=0, metavar="SECONDS",
                        help="start time of the candump log's timestamps, seconds since 1970 (default 0: "
                             "the run's own time); in the trace's metadata (epoch_s) and its rerun command")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", help="scenario name (see `wheelleg list`); ROBOT/NAME for another robot's")
    robots.add_argument(parser, "the robot whose scenario it is (default: the wheel-legged robot, or the one "
                                "robot with a scenario of this name)")
    parser.add_argument("--out", type=Path, default=Path("out"), help="output directory (default out/)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (noise, faults)")
    parser.add_argument("--duration", type=positive_seconds, default=None, help="override the duration (s)")
    add_epoch_argument(parser)
    parser.add_argument("--realtime", action="store_true",
                        help="plant at wall-clock pace, controller free-running on its own timer in its own "
                             "thread; prints the control loop's period statistics")
    parser.add_argument("--decoded", action="store_true",
                        help="also record the /decoded/<channel>/<Message> topics live, for one file Foxglove "
                             "plots signals from (default: raw frames only; `wheelleg export` adds them later)")
    parser.add_argument("--no-decode", action="store_true", help=argparse.SUPPRESS)  # the default now
    parser.add_argument("--external-controller", action="store_true",
                        help="do not start the controller in-process: another process answers on the buses "
                             "(lockstep: `wheelleg controller --sync`; with --realtime: `wheelleg controller`)")
    add_program_argument(parser)
    parser.add_argument("--no-plot", action="store_true", help="skip the PNG")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress line on stderr")
    parser.add_argument("--plant", action="append", default=[], metavar="KEY=VALUE",
                        help="change the plant's truth for this run (the controller keeps its belief); "
                             "repeatable; the keys are listed below")
    add_bus_arguments(parser, DEFAULT_INTERFACE, DEFAULT_CHANNELS)
    watch_options.add_arguments(parser)
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = ("plant overrides (--plant KEY=VALUE):\n" + help_text()
                     + "\n\nexit status: 0 every check passed, 1 a check failed (or the buses could not be "
                       "opened), 2 bad input")


PROGRAM_HELP = ("the program under test: 'python' (default: the robot's Python program, in-process), "
                "'firmware' (the repository's C firmware, in-process), PATH.so (a library with the lockstep "
                "ABI, in-process, lockstep), or a command the rig starts on the buses and stops at the end "
                "('CMD ARGS': {can1} {can2} {interface} are filled in, else the two channels are appended; "
                "lockstep if it answers SYNC, free-running with --realtime); 'lib:PATH', 'cmd:CMD' force the kind")


def add_program_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--program", default="python", metavar="P", help=PROGRAM_HELP)


def program_of(args: argparse.Namespace, robot: str | None, interface: str):
    """``--program`` as a ``wheelleg.hil.program.Program``; ``UsageError`` (one line) for a bad one."""
    try:
        program = programs.parse(getattr(args, "program", None), robot)
    except ValueError as exc:
        raise UsageError(str(exc)) from exc
    if program.kind == programs.COMMAND and interface == "virtual":
        raise UsageError("a command program needs a bus another process can join (-i socketcan, udp_multicast, "
                         "...): python-can's virtual bus lives inside this process")
    if program.kind != programs.PYTHON and getattr(args, "external_controller", False):
        raise UsageError("--program and --external-controller both name the program: give one")
    return program


def plant_config(assignments: list[str]) -> PlantConfig:
    """PlantConfig of ``--plant KEY=VALUE`` items; ValueError (one line) for a bad one."""
    return PlantConfig.from_overrides(dict(parse_assignment(text) for text in assignments))


def execute(args: argparse.Namespace, started_s: float | None = None):
    """Run and check; returns (outcome, results, run data) for callers such as the pytest plugin.

    ``started_s``: ``time.perf_counter()`` when the command started (default: now), so
    the outcome's ``startup_s`` includes the imports that came before.
    """
    started_s = time.perf_counter() if started_s is None else started_s
    scenario = scenarios.get(args.scenario, getattr(args, "robot", None))
    if args.duration is not None:
        scenario = replace(scenario, duration_s=args.duration)
    try:
        buses = bus_choice(args, DEFAULT_INTERFACE, DEFAULT_CHANNELS)
        plant = plant_config(getattr(args, "plant", None) or [])
        robots.get(scenario.robot).check_overrides(plant.overrides_dict())  # what its plant models
        watch_options.check(args)
    except ValueError as exc:
        raise UsageError(str(exc)) from exc
    if args.external_controller and buses.interface == "virtual":
        raise UsageError("--external-controller needs a bus another process can join (-i socketcan, "
                         "udp_multicast, ...): python-can's virtual bus lives inside this process")
    program = program_of(args, scenario.robot, buses.interface)
    config = RigConfig(interface=buses.interface, channels=buses.channels, bus_kwargs=buses.kwargs,
                       seed=args.seed, realtime=args.realtime,
                       in_process_controller=not args.external_controller and program.in_process, program=program,
                       decode=getattr(args, "decoded", False), plant=plant,
                       epoch_ns=getattr(args, "epoch", 0))
    progress = RunProgress(scenario.name, scenario.duration_s, enabled=not getattr(args, "quiet", True))
    try:
        rig = Rig(scenario, config, args.out, progress=progress)
    except BusOpenError as exc:
        raise SystemExit(f"run: {exc}") from exc
    except OSError as exc:  # the output directory (or a file in it) cannot be written
        raise UsageError(f"cannot write to {args.out}: {exc.strerror or exc}") from exc
    if args.external_controller:
        limit = "" if args.realtime else f"; giving up after {CONTACT_S:g} s without a heartbeat"
        print(f"run: waiting for the controller on {buses.interface} {'/'.join(buses.channels)} "
              f"(`wheelleg controller{'' if args.realtime else ' --sync'} -i {buses.interface} "
              f"-c {' -c '.join(buses.channels)}`){limit}", file=sys.stderr, flush=True)
    watchers = _watch(rig, args)
    first_tick_s = time.perf_counter()
    try:
        outcome = rig.run()
    except NoController as exc:
        raise SystemExit(f"run: {exc}") from exc
    except programs.ProgramError as exc:  # a command program that cannot be started
        raise UsageError(str(exc)) from exc
    except KeyboardInterrupt as stop:  # Ctrl-C or SIGTERM (hil/cli.py): rig.run closed and indexed the files
        progress.close()
        print(f"run: {str(stop) or 'interrupted (Ctrl-C)'} at {rig.clock.now_ns / 1e9:.3f} s of "
              f"{scenario.duration_s:g} s simulated; trace {rig.trace_path} (closed, readable), "
              f"log {rig.log_path}", file=sys.stderr, flush=True)
        raise
    finally:
        progress.close()
        watch_options.detach(watchers)
    if rig.stop_requested:
        print(f"run: the viewer was closed at {outcome.sim_s:.2f} s: the run is judged as it stands",
              file=sys.stderr)
    run = load_run(outcome.trace_path)
    results = [check(run) for check in (*scenario.checks, *program_checks(run.program))]
    outcome = replace(outcome, startup_s=first_tick_s - started_s,
                      verdict_wall_s=time.perf_counter() - first_tick_s)
    if not args.no_plot:
        from wheelleg.hil.analyze.plot import plot_run  # noqa: PLC0415 (matplotlib: ~1 s of start-up, only to plot)

        plot_run(run, args.out / f"{scenario.name}.png", title=f"{scenario.name}: {scenario.summary}",
                 trace=outcome.trace_path)
    return outcome, results, run


def _watch(rig: Rig, args: argparse.Namespace) -> list:
    """The viewer and live server ``args`` ask for (none by default); UsageError if one cannot start."""
    try:
        return watch_options.attach(rig, args)
    except BaseException as exc:
        rig.close()  # its buses and files, before the error
        if isinstance(exc, watch_options.WatchError):
            raise UsageError(str(exc)) from exc
        raise


def run(args: argparse.Namespace) -> int:
    try:
        outcome, results, data = execute(args, started_s=cli.STARTED_S)
    except KeyError as exc:
        print(f"wheelleg run: {exc.args[0]}", file=sys.stderr)
        return 2
    except UsageError as exc:
        print(f"wheelleg run: {exc}", file=sys.stderr)
        return 2
    rtf = outcome.sim_s / outcome.wall_s if outcome.wall_s > 0 else float("inf")
    misses = "deadline misses judged from the bus (below)" if data.program.get("judged_by") == "bus" else \
        f"{outcome.deadline_misses} deadline misses"
    print(f"{args.scenario}: {outcome.sim_s:.2f} s simulated in {outcome.wall_s:.2f} s "
          f"({rtf:.1f}x real time), {outcome.ticks} ticks, {misses}")
    verdict_rtf = outcome.sim_s / outcome.verdict_wall_s if outcome.verdict_wall_s else float("inf")
    print(f"  start-up {outcome.startup_s:.2f} s (imports, model build); "
          f"{verdict_rtf:.2f}x real time from the first tick to the checks' verdict")
    if outcome.timing is not None:
        if "controller" in outcome.timing:
            print(f"  {describe(outcome.timing['controller'])}")
        print(f"  {describe_plant(outcome.timing['plant'])}")
    if args.plant:
        print(f"  plant overrides: {' '.join(args.plant)}")
    if data.program.get("kind", "python") != "python":
        print(f"  program: {programs.describe(data.program)}")
    print(f"  trace {outcome.trace_path}\n  log   {outcome.log_path}")
    print_bus_load(data)
    for r in results:
        print(f"  [{r.mark}] {r.name}: {r.detail}")
    ok = all(r.passed for r in results)
    print(f"{args.scenario}: {verdict(ok, outcome, results)}")
    return 0 if ok else 1


def verdict(ok: bool, outcome, results=()) -> str:
    """PASSED, FAILED, or NOT REAL TIME when a real-time run failed on a plant that could not keep real
    time (``loop_timing.plant_kept_real_time``): then the failure may be the plant's, not the program's.
    FAILED all the same when a check that does not depend on the plant's pace failed (``results``:
    ``CheckResult``s; ``pace_bound`` False, e.g. the program's process exited)."""
    if ok:
        return "PASSED"
    plant = (outcome.timing or {}).get("plant")
    reason = plant_kept_real_time(plant) if plant else None
    if reason is None or any(not r.passed and not r.pace_bound for r in results):
        return "FAILED"
    return f"NOT REAL TIME ({reason}; the checks above failed on a world that ran slow)"


def print_bus_load(run) -> None:
    """Each bus's mean and peak load over the run's 100 ms windows (/bus/load)."""
    for bus, (_, load) in sorted(run.bus_load.items()):
        if len(load):
            print(f"  bus load {bus}: mean {load.mean() * 100:.1f} %, peak {load.max() * 100:.1f} % "
                  f"({len(load)} windows of 100 ms at 1 Mbit/s)")
