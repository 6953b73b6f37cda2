"""What the robot reaches in the rig: the largest size of each feat that passes.

    python -m tools.limits [--only NAME] [--coarse] [--out DIR] [--seed N]

For each figure a scenario factory (``size -> Scenario``) is run headless (no
plot) at sizes from a ladder; a size passes when every check of its scenario
passes. The search walks the ladder up while sizes pass and, after the first
failure, bisects between the last pass and that failure (``--coarse``: fewer
rungs, fewer bisection steps). It prints a markdown table.

The search logic (``search_limit``) takes any ``passes(size) -> bool`` so it is
tested without the rig; ``rig_passes`` is the one that runs the rig.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Callable


@dataclass(frozen=True)
class Figure:
    """One row of the table: a factory and the sizes to try.

    name      short key for ``--only``
    label     what the figure is, in words
    unit      of the size ("N s", "deg", "m", "m/s")
    factory   size -> Scenario
    ladder    increasing sizes to walk up (the full search)
    coarse    a shorter ladder (``--coarse``)
    aim       the size the robot is meant to reach
    note      shown after the sizes tried (why a figure has no aim, what caps the ladder)
    """

    name: str
    label: str
    unit: str
    factory: Callable
    ladder: tuple
    coarse: tuple
    aim: float
    note: str = ""


@dataclass
class SearchResult:
    """Largest passing size (None: even the first failed) and every size tried."""

    best: float | None
    first_fail: float | None  # smallest failing size found (None: all passed)
    tried: list = field(default_factory=list)  # (size, passed), in the order run


def search_limit(passes: Callable[[float], bool], ladder, bisect_steps: int = 2) -> SearchResult:
    """Walk ``ladder`` (increasing) up while ``passes``; then bisect the gap.

    Stops at the first failing rung: bigger feats are not tried once one
    fails (a robot that cannot take 4 N s is not expected to take 5). Between
    the last pass and the first failure, ``bisect_steps`` midpoints narrow the
    figure. When the first rung fails the result has ``best`` None.
    """
    ladder = [float(v) for v in ladder]
    if not ladder or any(b <= a for a, b in zip(ladder, ladder[1:])):
        raise ValueError(f"ladder must be non-empty and increasing, got {ladder}")
    result = SearchResult(None, None)

    def trial(size: float) -> bool:
        ok = bool(passes(size))
        result.tried.append((size, ok))
        return ok

    for size in ladder:
        if trial(size):
            result.best = size
        else:
            result.first_fail = size
            break
    if result.best is None or result.first_fail is None:
        return result
    lo, hi = result.best, result.first_fail
    for _ in range(bisect_steps):
        mid = 0.5 * (lo + hi)
        if trial(mid):
            lo = result.best = mid
        else:
            hi = result.first_fail = mid
    return result


# -- running a scenario in the rig --------------------------------------------------------------
def run_checks(scenario, out_dir: Path, seed: int = 0) -> list:
    """Run ``scenario`` in the rig (virtual buses, no plot); its CheckResults."""
    from wheelleg.hil.run.rig import Rig, RigConfig  # the rig (MuJoCo, emulators) only when used
    from wheelleg.hil.record.rundata import load_run

    outcome = Rig(scenario, RigConfig(seed=seed), out_dir).run()
    run = load_run(outcome.trace_path)
    return [check(run) for check in scenario.checks]


def rig_passes(factory: Callable, out_dir: Path, seed: int = 0, log=print) -> Callable[[float], bool]:
    """``passes(size)``: run ``factory(size)`` in the rig; True when every check passes."""

    def passes(size: float) -> bool:
        wall0 = time.perf_counter()
        try:
            scenario = factory(size)
            results = run_checks(scenario, out_dir / f"{scenario.name}-{size:g}", seed)
        except ValueError as exc:  # a size the world cannot be set up for (a leg too short...)
            log(f"  {getattr(factory, '__name__', 'factory')} @ {size:g}: FAIL cannot set up: {exc}")
            return False
        failed = [f"{r.name}: {r.detail}" for r in results if not r.passed]
        verdict = "pass" if results and not failed else "FAIL " + "; ".join(failed)
        log(f"  {scenario.name} @ {size:g}: {verdict} ({time.perf_counter() - wall0:.0f} s)")
        return bool(results) and not failed

    return passes


# -- the figures --------------------------------------------------------------------------------
def figures() -> tuple:
    from wheelleg.controller import params as P
    from wheelleg.hil.scenarios import airborne
    from wheelleg.hil.scenarios import collisions
    from wheelleg.hil.scenarios import ground

    return (
        Figure("jump", "jump clearance (wheels above ground)", "m", airborne.jump_scenario,
               (0.05, 0.1, 0.15, 0.2, 0.25, 0.3), (0.05, 0.1, 0.2, 0.3), 0.2),
        Figure("jump-step", "step height climbed (jump onto it)", "m", airborne.jump_step_scenario,
               (0.05, 0.1, 0.15, 0.2, 0.25, 0.3), (0.05, 0.15, 0.25), 0.15),
        Figure("drop", "drop height survived", "m", airborne.drop_scenario,
               (0.1, 0.3, 0.5, 0.7, 1.0, 1.5), (0.1, 0.5, 1.0), 0.5),
        Figure("push", "push impulse at body height survived", "N s", collisions.push_scenario,
               (1.0, 3.0, 5.0, 7.0, 9.0, 12.0, 15.0), (3.0, 6.0, 9.0, 12.0), 5.0),
        Figure("push-front", "push impulse, front only (sudden and steady)", "N s",
               partial(collisions.push_scenario, sides=("front",)),
               (3.0, 5.0, 7.0, 9.0, 12.0, 15.0), (5.0, 9.0, 13.0), 5.0),
        Figure("push-side", "push impulse, side only (sudden and steady)", "N s",
               partial(collisions.push_scenario, sides=("side",)),
               (3.0, 5.0, 7.0, 9.0, 12.0, 15.0), (5.0, 9.0, 13.0), 5.0),
        Figure("wall", "speed into an 8 cm wall, stays up", "m/s", collisions.wall_scenario,
               (0.2, 0.3, 0.4, 0.5, 0.7, 1.0), (0.3, 0.5, 0.7), 0.0, note="no aim in the issue"),
        Figure("slope", "side slope held level", "deg", ground.slope_scenario,
               (5.0, 10.0, 15.0, 20.0, 25.0, 30.0), (10.0, 15.0, 20.0, 25.0), 15.0),
        Figure("speed", "top speed (tracked, upright)", "m/s", ground.sprint_scenario,
               (0.5, 1.0, 1.5, 2.0), (1.0, 2.0), 2.0,
               note=f"capped by the controller's SPEED_LIMIT = {P.SPEED_LIMIT:g} m/s"),
        Figure("step-down", "step height driven down", "m", ground.step_down_scenario,
               (0.05, 0.1, 0.2, 0.4, 0.6, 0.8, 1.0, 1.2), (0.1, 0.4, 0.8, 1.2), 0.15),
    )


def _row(fig: Figure, result: SearchResult) -> str:
    aim = f"{fig.aim:g} {fig.unit}" if fig.aim else "-"
    best = "below the first size tried" if result.best is None else f"{result.best:g} {fig.unit}"
    if result.first_fail is None:
        best = f">= {best} (every size tried passed)"
    tried = ", ".join(f"{s:g}{'' if ok else ' x'}" for s, ok in result.tried)
    note = f"; {fig.note}" if fig.note else ""
    return f"| {fig.label} | {best} | {aim} | tried {tried}{note} |"


def table(rows: list) -> str:
    head = ["| figure | largest that passes | aim | sizes tried (x = failed) |", "|---|---|---|---|"]
    return "\n".join(head + rows)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.limits", description=__doc__.splitlines()[0])
    parser.add_argument("--only", action="append", help="run only this figure (repeatable)")
    parser.add_argument("--coarse", action="store_true", help="short ladders, one bisection step")
    parser.add_argument("--out", type=Path, default=None, help="keep traces here (default: a temporary dir)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    figs = figures()
    known = {f.name for f in figs}
    for name in args.only or ():
        if name not in known:
            parser.error(f"no figure {name!r}; known: {', '.join(sorted(known))}")
    chosen = [f for f in figs if not args.only or f.name in args.only]
    out = args.out or Path(tempfile.mkdtemp(prefix="wheelleg-limits-"))
    rows = []
    for fig in chosen:
        print(f"{fig.name}:", flush=True)
        passes = rig_passes(fig.factory, out / fig.name, args.seed, log=lambda s: print(s, flush=True))
        result = search_limit(passes, fig.coarse if args.coarse else fig.ladder,
                              bisect_steps=1 if args.coarse else 2)
        rows.append(_row(fig, result))
    print()
    print(table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
