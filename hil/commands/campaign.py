"""``wheelleg campaign SCENARIO...``: many runs over drawn plant overrides, on a Dask cluster.

Each sample draws plant overrides (uniform in the ``--vary`` ranges and the
``--preset``'s), runs every scenario with them and a seed of its own, and
appends a row to DIR/results.jsonl; the same command resumes an interrupted
campaign. DIR/report.md says where the failures cluster (hil/campaign/).
"""
from __future__ import annotations

import argparse
from pathlib import Path

from wheelleg.hil import robots, scenarios
from wheelleg.hil.campaign import analysis, execution, journal, report, sampling
from wheelleg.hil.campaign.progress import Progress
from wheelleg.hil.commands.run import add_epoch_argument
from wheelleg.hil.record.run_metadata import epoch_text

NAME = "campaign"
HELP = ("run scenarios over many drawn plant overrides (all local cores, or --address's Dask cluster); "
        "writes DIR/results.jsonl, DIR/report.md and the failing runs' traces")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenarios", nargs="+", metavar="SCENARIO",
                        help="scenario names (see `wheelleg list`); ROBOT/NAME for another robot's")
    robots.add_argument(parser, "the robot whose scenarios they are (default: the wheel-legged robot, or the "
                                "one robot with a scenario of each name)")
    parser.add_argument("--samples", type=int, default=10, help="samples per scenario (default 10)")
    parser.add_argument("--seed", type=int, default=0, help="campaign seed: draws and run seeds (default 0)")
    parser.add_argument("--vary", action="append", default=[], metavar="KEY=LOW..HIGH",
                        help="draw plant override KEY uniformly in [LOW, HIGH] (repeatable; "
                             "keys as `wheelleg run --plant`)")
    parser.add_argument("--preset", default=None,
                        help=f"a named box of overrides: {', '.join(sorted(sampling.PRESETS))} (--vary adds or wins)")
    parser.add_argument("--duration", type=float, default=None, help="every run's duration (s), for quick campaigns")
    add_epoch_argument(parser)
    parser.add_argument("--out", type=Path, required=True, help="campaign directory (the same one resumes)")
    parser.add_argument("--workers", type=int, default=None, help="local worker processes (default: all cores)")
    parser.add_argument("--address", default=None,
                        help="join an existing Dask scheduler (tcp://HOST:8786) instead of a local cluster")
    parser.add_argument("--program", default="python", metavar="P",
                        help="the program every run tests: python (default), firmware or PATH.so (in-process kinds "
                             "of `wheelleg run --program`)")
    parser.add_argument("--dashboard", nargs="?", const="", default=None, metavar="[HOST:]PORT",
                        help="serve Dask's dashboard of the local cluster (default: none; with no value "
                             "on 127.0.0.1 at a free port; a HOST only when you name one)")
    parser.add_argument("--keep-passing", action="store_true", help="keep passing runs' traces and logs too")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def canonical_command(args: argparse.Namespace) -> str:
    """The command that gives (or resumes) this campaign, as the report shows it."""
    words = ["wheelleg", "campaign", *args.scenarios, "--samples", str(args.samples), "--seed", str(args.seed)]
    if args.preset:
        words += ["--preset", args.preset]
    for text in args.vary:
        words += ["--vary", text]
    if args.duration is not None:
        words += ["--duration", f"{args.duration:g}"]
    if args.epoch:
        words += ["--epoch", epoch_text(args.epoch)]
    return " ".join(words + ["--out", str(args.out)])


def campaign_spec(args: argparse.Namespace) -> dict:
    """What makes this campaign (checked on resume); ValueError (one line) on bad input.

    Scenario names become qualified (``scenarios.qualified_name``: ROBOT/NAME for
    a robot other than the default), so a worker finds each without ``--robot``.
    """
    try:
        args.scenarios = [scenarios.qualified_name(scenarios.get(name, getattr(args, "robot", None)))
                          for name in args.scenarios]
    except KeyError as exc:
        raise ValueError(exc.args[0]) from None
    if len(set(args.scenarios)) != len(args.scenarios):
        raise ValueError("a scenario is named twice")
    if args.samples < 1:
        raise ValueError(f"--samples {args.samples}: need at least 1")
    if args.duration is not None and not args.duration > 0:
        raise ValueError(f"--duration {args.duration:g}: must be > 0 s")
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers {args.workers}: need at least 1")
    ranges = sampling.campaign_ranges(args.preset, args.vary)
    execution.check_ranges(ranges)
    spec = {"scenarios": list(args.scenarios), "seed": args.seed, "duration_s": args.duration,
            "ranges": {k: list(v) for k, v in ranges.items()}}
    if args.epoch:  # only when given: a campaign directory from before --epoch resumes as it was
        spec["epoch_s"] = epoch_text(args.epoch)
    program = getattr(args, "program", "python")
    if program != "python":  # only when given, as --epoch
        program_to_run(program)  # checked here: one line
        spec["program"] = program
    return spec


def program_to_run(program: str) -> str:
    """What the workers load for ``--program``: a library (``firmware`` built here, once) by its absolute path."""
    if program == "python":
        return program
    return str(execution.rig_config(0, {}, 0, program).program.path)


def run(args: argparse.Namespace, runner: execution.Runner = execution.run_job, processes: bool = True) -> int:
    """The campaign; ``runner`` and ``processes`` let tests run a fake rig in threads."""
    try:
        spec = campaign_spec(args)
        journal.check_spec(args.out, spec)
        args.dashboard = execution.dashboard_address(getattr(args, "dashboard", None))
    except ValueError as exc:
        print(f"campaign: {exc}")
        return 2
    log = journal.Journal(args.out)
    jobs = sampling.plan(args.scenarios, args.samples, args.seed, spec["ranges"])
    todo = [job for job in jobs if not log.finished((job.scenario, job.sample))]
    settings = execution.RunSettings(args.out.resolve(), args.duration, args.keep_passing,  # workers may run elsewhere
                                     args.epoch, program_to_run(getattr(args, "program", "python")))
    if len(todo) < len(jobs):
        print(f"campaign: resuming, {len(jobs) - len(todo)} of {len(jobs)} runs already judged in {log.path}")
    try:
        run_jobs(args, todo, settings, log, runner, processes, done=len(jobs) - len(todo), total=len(jobs))
    except KeyboardInterrupt:
        print(f"\ncampaign: interrupted; {len(log.rows)} runs kept in {log.path}; "
              "the same command resumes")
        return 130
    except OSError as exc:  # e.g. --address cannot be reached
        print(f"campaign: {exc}".splitlines()[0])
        return 2
    log.rewrite(args.scenarios)
    rows = [r for r in log.ordered(args.scenarios) if r["sample"] < args.samples]
    path = report.write_report(args.out, rows, spec, canonical_command(args))
    for rate in analysis.pass_rates(rows):
        print(f"{rate.scenario}: {rate.passed}/{rate.runs} passed ({rate.rate:.1%})")
    cost = analysis.cpu_per_sim_second(rows)
    if cost is not None:
        print(f"cost: {cost:.2f} CPU s per simulated s")
    print(f"report {path}")
    return 0 if all(r["passed"] for r in rows) else 1


def run_jobs(args, todo, settings, log, runner, processes, done: int, total: int) -> None:
    """Run ``todo`` on the engine, journalling each row as it comes."""
    if not todo:
        return
    bar = Progress(total, done, enabled=not args.quiet)
    try:
        with execution.Engine(args.address, args.workers, processes, args.dashboard) as engine:
            if engine.cluster is not None and args.dashboard is not None:
                print(f"campaign: dashboard {engine.client.dashboard_link}", flush=True)
            for row in engine.map(runner, todo, settings):
                log.append(row)
                bar.update(row["passed"])
    finally:
        bar.close()
