"""Where the test suite's time goes: a pytest plugin that notes each test's CPU and each rig run.

    WHEELLEG_CENSUS=DIR python -m pytest -q -p tools.suite_census [TESTS]
    python -m tools.suite_census DIR            # by file, the costliest tests, runs made twice

Per test (one JSON line in ``DIR/<worker>.jsonl``): wall seconds of setup, call and
teardown together, the worker's own CPU seconds and those of the processes it waited
for (``RUSAGE_CHILDREN``). CPU seconds are what a loaded, shared machine changes least;
the wall clock follows the other jobs. Per ``Rig.run`` in the worker: the scenario, its
seed, simulated seconds, plant overrides, program and the CPU of the thread that ran it,
so the summary shows runs made more than once (on two workers, or by two tests that
could share one ``rig_run``).
Runs inside processes a test starts (``wheelleg run``, a campaign's workers) are counted
in the test's children CPU, not listed.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path

import pytest

_RUNS: list[dict] = []


def _cpu() -> tuple[float, float]:
    """(this process's user+sys CPU s, its waited-for children's)."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, kids.ru_utime + kids.ru_stime


def _note_rig_runs() -> None:
    """Wrap ``Rig.run`` (imported lazily by the tests, so patched once here) to note each run."""
    from wheelleg.hil.run.rig import Rig  # noqa: PLC0415 (only when the census is on)

    original = Rig.run

    def noted(self):
        start = time.thread_time()
        try:
            return original(self)
        finally:
            config = self.config
            _RUNS.append({"scenario": f"{self.scenario.robot or ''}/{self.scenario.name}",
                          "seed": config.seed, "sim_s": round(self.scenario.duration_s, 3),
                          "plant": config.plant.overrides_dict(), "program": str(config.program.kind),
                          "realtime": config.realtime, "cpu_s": round(time.thread_time() - start, 3)})
    Rig.run = noted


def _out_file() -> Path | None:
    folder = os.environ.get("WHEELLEG_CENSUS")
    if not folder:
        return None
    Path(folder).mkdir(parents=True, exist_ok=True)
    return Path(folder) / f"{os.environ.get('PYTEST_XDIST_WORKER', 'main')}.jsonl"


def pytest_configure(config):
    if _out_file() is not None:
        _note_rig_runs()


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item, nextitem):
    out = _out_file()
    if out is None:
        return (yield)
    wall0, (own0, kids0) = time.perf_counter(), _cpu()
    del _RUNS[:]
    try:
        return (yield)
    finally:
        own1, kids1 = _cpu()
        row = {"test": item.nodeid, "worker": os.environ.get("PYTEST_XDIST_WORKER", "main"),
               "wall_s": round(time.perf_counter() - wall0, 3), "cpu_s": round(own1 - own0, 3),
               "children_cpu_s": round(kids1 - kids0, 3), "runs": list(_RUNS)}
        with out.open("a") as f:
            f.write(json.dumps(row) + "\n")


def load(folder: Path) -> list[dict]:
    """Every test's row from the census files in ``folder``."""
    return [json.loads(line) for path in sorted(folder.glob("*.jsonl")) for line in path.read_text().splitlines()]


def summary(rows: list[dict], top: int = 40) -> list[str]:
    """Lines: totals, CPU by file, the costliest tests, rig runs made more than once."""
    def cost(row):
        return row["cpu_s"] + row["children_cpu_s"]

    lines = [f"{len(rows)} tests, {sum(cost(r) for r in rows):.1f} CPU s "
             f"({sum(r['children_cpu_s'] for r in rows):.1f} in processes they started), "
             f"{sum(len(r['runs']) for r in rows)} rig runs in the workers "
             f"({sum(run['cpu_s'] for r in rows for run in r['runs']):.1f} CPU s, "
             f"{sum(run['sim_s'] for r in rows for run in r['runs']):.1f} simulated s)", "", "CPU s by file:"]
    by_file = defaultdict(float)
    for row in rows:
        by_file[row["test"].split("::")[0]] += cost(row)
    lines += [f"  {cpu:7.1f}  {name}" for name, cpu in sorted(by_file.items(), key=lambda kv: -kv[1])]
    lines += ["", f"the {top} costliest tests (CPU s, children's, wall s, worker):"]
    for row in sorted(rows, key=cost, reverse=True)[:top]:
        lines.append(f"  {cost(row):7.1f} {row['children_cpu_s']:6.1f} {row['wall_s']:7.1f}  {row['worker']}  {row['test']}")
    made = Counter()
    where = defaultdict(list)
    for row in rows:
        for run in row["runs"]:
            key = (run["scenario"], run["seed"], run["sim_s"], json.dumps(run["plant"], sort_keys=True),
                   run["program"], run["realtime"])
            made[key] += 1
            where[key].append(f"{row['worker']} {row['test']} ({run['cpu_s']:.1f} CPU s)")
    twice = {key: n for key, n in made.items() if n > 1}
    lines += ["", f"rig runs made more than once: {len(twice)}"]
    for key, n in sorted(twice.items(), key=lambda kv: -kv[1]):
        lines.append(f"  {n}x {key[0]} seed {key[1]} {key[2]} s plant {key[3]} program {key[4]}"
                     + (" realtime" if key[5] else ""))
        lines += [f"      {w}" for w in where[key]]
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.suite_census", description=__doc__.split("\n")[0])
    parser.add_argument("folder", type=Path, help="the WHEELLEG_CENSUS folder of a suite run")
    parser.add_argument("--top", type=int, default=40, help="how many of the costliest tests to list")
    args = parser.parse_args(argv)
    rows = load(args.folder)
    if not rows:
        print(f"error: no census rows in {args.folder}", file=sys.stderr)
        return 1
    print("\n".join(summary(rows, args.top)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
