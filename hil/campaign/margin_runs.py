"""Robustness margins on the campaign engine: which keys and boxes, and the runs the bisections ask for.

The searches of every (scenario, key, side) advance together, one probe each
per round, so a round is a batch of independent runs for the engine's
workers (execution.Engine); the next round's values depend on this round's
verdicts. Every run is a campaign job (its own directory under
``runs/SCENARIO/sample-NNNN``, the failing ones kept with their rerun command),
numbered in the order the rounds ask for them, so the same arguments give the
same runs, the same numbers and the same table, and a journal of them
(``engine_rounds``) lets a search resume.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from wheelleg.emulators.overrides import OVERRIDES, check_override
from wheelleg.hil import robots, scenarios
from wheelleg.hil.campaign import sampling
from wheelleg.hil.campaign.execution import Engine, RunSettings, Runner
from wheelleg.hil.campaign.journal import Journal
from wheelleg.hil.campaign.margins import (SIDES, KeyMargins, ScenarioMargins, SideSearch, edge_from,
                                           gate_value, half_widths)
from wheelleg.hil.campaign.sampling import Job

RunRound = Callable[[list[Job]], list[dict]]  # the rows of a round's jobs, in the jobs' order


@dataclass(frozen=True)
class MarginSpec:
    """What a margins search is: qualified scenario names, key -> box (or None), rig seed, runs a side."""

    scenarios: tuple[str, ...]
    boxes: dict  # key -> (low, high) of the box it is judged against, None: no box (no ratio)
    seed: int
    runs_per_side: int


def qualified_scenarios(names: list[str], robot: str | None = None) -> tuple[str, ...]:
    """Each name as ``scenarios.qualified_name``; ValueError (one line) for an unknown or repeated one."""
    try:
        found = tuple(scenarios.qualified_name(scenarios.get(name, robot)) for name in names)
    except KeyError as exc:
        raise ValueError(exc.args[0]) from None
    if len(set(found)) != len(found):
        raise ValueError("a scenario is named twice")
    return found


def margin_boxes(preset: str | None, key_args: list[str]) -> dict:
    """Key -> box: every key of the preset's box (no ``key_args``), or the keys named.

    A named key is ``KEY`` (its box: the preset's range, None if the preset has
    none) or ``KEY=LOW..HIGH`` (that box, which must contain nominal; a preset's
    range may lie beside nominal, see ``margins.half_widths``).
    ValueError (one line) for an unknown preset or key, a malformed range, a key named twice.
    """
    box = sampling.campaign_ranges(preset, [])
    if not key_args:
        if not box:
            raise ValueError("no keys: name them with --keys or give a --preset with a box")
        return box
    boxes: dict = {}
    for text in key_args:
        if "=" in text:
            key, span = sampling.parse_range(text, option="--keys")
            for value in span:
                check_override(key, value)  # a known key, the range within what it allows
        else:
            key, span = text.strip(), box.get(text.strip())
        if key not in OVERRIDES:
            raise ValueError(f"--keys {key}: unknown plant override; known: {', '.join(OVERRIDES)}")
        if key in boxes:
            raise ValueError(f"--keys {key}: named twice")
        nominal = OVERRIDES[key].default
        if "=" in text and not span[0] <= nominal <= span[1]:  # (a preset's may lie beside it: half_widths)
            raise ValueError(f"--keys {text}: the range must contain the nominal {nominal:g}")
        boxes[key] = span
    return boxes


def check_robots_take(names: tuple[str, ...], keys) -> None:
    """ValueError (one line) when a scenario's robot does not model one of ``keys``."""
    for name in names:
        robot = robots.get(scenarios.get(name).robot)
        robot.check_overrides({key: OVERRIDES[key].default for key in keys})


def failed_checks(row: dict) -> tuple[str, ...]:
    """The names of the checks a row failed, or why it could not run."""
    if row.get("error"):
        return (f"could not run ({row['error']})",)
    return tuple(c["name"] for c in row["checks"] if not c["passed"])


def search(spec: MarginSpec, run_round: RunRound) -> list[ScenarioMargins]:
    """Every scenario's margins: its nominal run, then the bisections round by round."""
    nominal_jobs = [Job(name, 0, spec.seed, {}) for name in spec.scenarios]
    nominal_rows = dict(zip(spec.scenarios, run_round(nominal_jobs)))
    searches: dict[tuple[str, str, str], SideSearch] = {}
    for name in spec.scenarios:
        if nominal_rows[name]["passed"]:
            searches.update(side_searches(name, spec))
    reruns: dict[tuple[str, str, str], str] = {}
    samples = {name: 1 for name in spec.scenarios}
    while True:
        asked = [(ident, value) for ident, s in searches.items() if (value := s.next_value()) is not None]
        if not asked:
            break
        jobs = []
        for (name, key, _side), value in asked:
            jobs.append(Job(name, samples[name], spec.seed, {key: value}))
            samples[name] += 1
        for (ident, value), row in zip(asked, run_round(jobs)):
            searches[ident].record(value, row["passed"], failed_checks(row))
            if not row["passed"]:
                reruns[ident] = row["rerun"]
    return [scenario_margins(name, spec, nominal_rows[name], searches, reruns) for name in spec.scenarios]


def side_searches(name: str, spec: MarginSpec) -> dict:
    out = {}
    for key, box in spec.boxes.items():
        override = OVERRIDES[key]
        for side, reach in zip(SIDES, half_widths(override.default, box)):
            limit = override.low if side == "below" else override.high
            out[(name, key, side)] = SideSearch(override.default, limit, gate_value(override.default, reach, side),
                                                spec.runs_per_side)
    return out


def scenario_margins(name: str, spec: MarginSpec, nominal: dict, searches: dict, reruns: dict) -> ScenarioMargins:
    if not nominal["passed"]:
        detail = nominal.get("error") or "; ".join(c["detail"] for c in nominal["checks"] if not c["passed"])
        return ScenarioMargins(name, spec.seed, False, detail, nominal["rerun"], ())
    keys = []
    for key, box in spec.boxes.items():
        override = OVERRIDES[key]
        edges = [edge_from(searches[(name, key, side)], side, reach, reruns.get((name, key, side)))
                 for side, reach in zip(SIDES, half_widths(override.default, box))]
        keys.append(KeyMargins(key, override.unit, override.default, box, *edges))
    return ScenarioMargins(name, spec.seed, True, "", nominal["rerun"], tuple(keys))


def most_runs(spec: MarginSpec) -> int:
    """An upper bound of the runs ``search`` makes (for the progress bar)."""
    return len(spec.scenarios) * (1 + 2 * len(spec.boxes) * spec.runs_per_side)


def journalled(log: Journal, job: Job, settings: RunSettings) -> dict | None:
    """The row ``log`` holds for exactly this run (same seed, overrides, duration, epoch; judged), else None."""
    row = log.rows.get((job.scenario, job.sample))
    same = (row is not None and not row.get("error") and row["seed"] == job.seed
            and row["overrides"] == job.overrides and row.get("duration_s") == settings.duration_s
            and row.get("epoch_ns") == settings.epoch_ns)
    return row if same else None


def engine_rounds(engine: Engine, runner: Runner, settings: RunSettings, log: Journal | None = None,
                  progress=None) -> RunRound:
    """``run_round`` on ``engine``: the round's rows back in the jobs' order.

    With ``log`` (DIR/results.jsonl, the campaign's journal format) each row is
    journalled as it comes, and a run the journal already holds is not run
    again: an interrupted search, or the same one with more ``--runs-per-key``
    (its probes begin with the fewer runs' probes), resumes where it stopped.
    """
    def run_round(jobs: list[Job]) -> list[dict]:
        rows = {}
        for job in jobs:
            if log is not None and (row := journalled(log, job, settings)) is not None:
                rows[(job.scenario, job.sample)] = row
        todo = [job for job in jobs if (job.scenario, job.sample) not in rows]
        for row in engine.map(runner, todo, settings) if todo else ():
            row = {**row, "duration_s": settings.duration_s, "epoch_ns": settings.epoch_ns}
            rows[(row["scenario"], row["sample"])] = row
            if log is not None:
                log.append(row)
            if progress is not None:
                progress.update(row["passed"])
        return [rows[(job.scenario, job.sample)] for job in jobs]

    return run_round
