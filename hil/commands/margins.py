"""``wheelleg margins SCENARIO...``: how far each plant override may go from nominal before a scenario fails.

Per key and side, a bisection between nominal and the key's allowed limit
(hil/campaign/margins.py), its runs on the campaign engine (margin_runs.py);
prints the table, writes DIR/margins.md and DIR/margins.json and keeps each
edge's failing run with its rerun command; DIR/results.jsonl journals the runs
(the campaign's format), so an interrupted search resumes.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from wheelleg.hil import robots
from wheelleg.hil.campaign import execution, journal, margin_runs, margins, sampling
from wheelleg.hil.campaign.progress import Progress
from wheelleg.hil.commands.run import positive_seconds

NAME = "margins"
HELP = ("find, key by key, how far the plant may go from nominal (down and up) before a scenario fails; "
        "prints the table, writes DIR/margins.md and DIR/margins.json")
DEFAULT_PRESET = "tolerance"
DEFAULT_RUNS_PER_KEY = 6
TABLE = "margins.md"
DATA = "margins.json"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenarios", nargs="+", metavar="SCENARIO",
                        help="scenario names (see `wheelleg list`); ROBOT/NAME for another robot's")
    robots.add_argument(parser, "the robot whose scenarios they are (default: the wheel-legged robot)")
    parser.add_argument("--keys", nargs="+", action="extend", default=[], metavar="KEY[=LOW..HIGH]",
                        help="the overrides to search (default: every key of the preset's box); KEY is "
                             "judged against the preset's range, KEY=LOW..HIGH against that box")
    parser.add_argument("--preset", default=DEFAULT_PRESET,
                        help=f"the box the edges are measured against: {', '.join(sorted(sampling.PRESETS))} "
                             f"(default {DEFAULT_PRESET})")
    parser.add_argument("--seed", type=int, default=0, help="every run's rig seed (default 0)")
    add_runs_per_key(parser)
    parser.add_argument("--duration", type=positive_seconds, default=None,
                        help="every run's duration (s; default each scenario's own)")
    parser.add_argument("--out", type=Path, default=Path("out/margins"),
                        help="directory for margins.md, margins.json and the failing runs (default out/margins)")
    parser.add_argument("--workers", type=int, default=None, help="local worker processes (default: all cores)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def add_runs_per_key(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--runs-per-key", type=int, default=DEFAULT_RUNS_PER_KEY,
                        help=f"most runs a key, half on each side (default {DEFAULT_RUNS_PER_KEY})")


def runs_per_side(runs_per_key: int) -> int:
    """``--runs-per-key`` split between the two sides; ValueError (one line) below 2."""
    if runs_per_key < 2:
        raise ValueError(f"--runs-per-key {runs_per_key}: need at least 2 (one a side)")
    return runs_per_key // 2


def canonical_command(args: argparse.Namespace) -> str:
    words = ["wheelleg", "margins", *args.scenarios, "--preset", args.preset, "--seed", str(args.seed),
             "--runs-per-key", str(args.runs_per_key)]
    if args.keys:
        words += ["--keys", *args.keys]
    if args.duration is not None:
        words += ["--duration", f"{args.duration:g}"]
    return " ".join(words + ["--out", str(args.out)])


def margin_spec(args: argparse.Namespace) -> margin_runs.MarginSpec:
    """The search the arguments ask for; ValueError (one line) on bad input."""
    names = margin_runs.qualified_scenarios(args.scenarios, args.robot)
    per_side = runs_per_side(args.runs_per_key)
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers {args.workers}: need at least 1")
    boxes = margin_runs.margin_boxes(args.preset, args.keys)
    margin_runs.check_robots_take(names, boxes)
    return margin_runs.MarginSpec(names, boxes, args.seed, per_side)


def run_search(spec: margin_runs.MarginSpec, settings: execution.RunSettings, workers: int | None,
               quiet: bool, runner: execution.Runner = execution.run_job, processes: bool = True,
               address: str | None = None) -> list[margins.ScenarioMargins]:
    """``margin_runs.search`` on the campaign engine: a local Dask cluster, or ``address``'s."""
    bar = Progress(margin_runs.most_runs(spec), enabled=not quiet)
    settings.out_dir.mkdir(parents=True, exist_ok=True)
    log = journal.Journal(settings.out_dir)
    if log.rows:
        print(f"margins: {len(log.rows)} runs journalled in {log.path}; each one this search asks for again "
              "is not run again", file=sys.stderr)
    try:
        with execution.Engine(address, workers, processes) as engine:
            return margin_runs.search(spec, margin_runs.engine_rounds(engine, runner, settings, log, bar))
    finally:
        bar.close()


def write_results(out_dir: Path, results: list, spec: margin_runs.MarginSpec, command: str) -> list[str]:
    """DIR/margins.md and DIR/margins.json; returns the table's lines."""
    lines = margins.render_markdown(results, spec.runs_per_side, heading="#")
    (out_dir / TABLE).write_text("\n".join([lines[0], "", f"    {command}", *lines[1:]]) + "\n")
    data = {"command": command, **margins.to_json(results, spec.runs_per_side)}
    (out_dir / DATA).write_text(json.dumps(data, indent=1) + "\n")
    return lines


def run(args: argparse.Namespace, runner: execution.Runner = execution.run_job, processes: bool = True) -> int:
    """The search; ``runner`` and ``processes`` let tests run a fake rig in threads.

    Exit 0 when every scenario's nominal run passed and no edge is within
    ``margins.GATE`` box half-widths, 1 otherwise, 2 on bad input.
    """
    try:
        spec = margin_spec(args)
        args.out.mkdir(parents=True, exist_ok=True)
    except ValueError as exc:
        print(f"margins: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"margins: cannot write to {args.out}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    settings = execution.RunSettings(args.out.resolve(), args.duration)
    try:
        results = run_search(spec, settings, args.workers, args.quiet, runner, processes)
    except KeyboardInterrupt:
        print(f"\nmargins: interrupted, no table written; the runs so far are in {args.out / journal.RESULTS} "
              "and the same command resumes", file=sys.stderr)
        return 130
    lines = write_results(args.out, results, spec, canonical_command(args))
    print("\n".join(lines))
    print(f"table {args.out / TABLE}, data {args.out / DATA}")
    good = all(r.nominal_passed and not r.flagged() for r in results)
    return 0 if good else 1
