"""Figures from a campaign's rows: pass rates, worst figures, and where the failures cluster.

Pure functions of the rows of results.jsonl (dicts; see journal.py) and the
campaign's override ranges (key -> (low, high)).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BINS = 10  # failure rate per tenth of each override's range


@dataclass(frozen=True)
class PassRate:
    scenario: str
    runs: int
    passed: int
    errors: int  # runs that could not run at all (the row's "error")

    @property
    def rate(self) -> float:
        return self.passed / self.runs if self.runs else float("nan")


def cpu_per_sim_second(rows: list[dict]) -> float | None:
    """CPU seconds the runs took (each in its worker process) per simulated second, over the rows
    that say both (older journals do not); None when none does."""
    timed = [r for r in rows if r.get("cpu_s") is not None and r.get("sim_s")]
    sim_s = sum(r["sim_s"] for r in timed)
    return sum(r["cpu_s"] for r in timed) / sim_s if sim_s else None


@dataclass(frozen=True)
class CheckSummary:
    """One check of one scenario over the campaign: its failures and the spread of its figure."""

    scenario: str
    check: str
    failures: int
    figures: tuple  # (min, median, max) of the reported figure, NaN where none
    extreme: dict  # the row whose figure is farthest from the passing runs' median (failing ones first)
    extreme_detail: str


@dataclass(frozen=True)
class Clustering:
    """How strongly one scenario's failures cluster on one override."""

    scenario: str
    key: str
    separation: float  # 0: failures spread like the passes .. 1: fully apart (see separation())
    bin_failures: tuple  # (failed, runs) per tenth of the range, low to high


def by_scenario(rows: list[dict]) -> dict[str, list[dict]]:
    table: dict[str, list[dict]] = {}
    for row in rows:
        table.setdefault(row["scenario"], []).append(row)
    return table


def pass_rates(rows: list[dict]) -> list[PassRate]:
    return [PassRate(name, len(rs), sum(r["passed"] for r in rs), sum(bool(r.get("error")) for r in rs))
            for name, rs in by_scenario(rows).items()]


def auc(high: np.ndarray, low: np.ndarray) -> float:
    """P(a value of ``high`` > one of ``low``), ties half (Mann-Whitney); ``high`` (n,), ``low`` (m,)."""
    diff = high[:, None] - low[None, :]
    return float(np.mean((diff > 0) + 0.5 * (diff == 0)))


def separation(values: np.ndarray, failed: np.ndarray, middle: float) -> float:
    """How far apart failing and passing runs lie on one override, 0..1 (NaN if either is empty).

    |2 AUC - 1| of the value (failures at one end) or of its distance from the
    range's ``middle`` (failures at both ends, as with a CoM offset either way),
    whichever is larger. ``values`` (n,) float, ``failed`` (n,) bool.
    """
    if failed.all() or not failed.any():
        return float("nan")
    off = np.abs(values - middle)
    return max(abs(2 * auc(values[failed], values[~failed]) - 1),
               abs(2 * auc(off[failed], off[~failed]) - 1))


def bin_failures(values: np.ndarray, failed: np.ndarray, low: float, high: float) -> tuple:
    """(failed, runs) in each of BINS equal parts of [low, high]; ``values`` (n,), ``failed`` (n,) bool."""
    if high > low:
        index = np.clip(((values - low) / (high - low) * BINS).astype(int), 0, BINS - 1)
    else:
        index = np.zeros(len(values), dtype=int)
    return tuple((int(failed[index == b].sum()), int((index == b).sum())) for b in range(BINS))


def clustering(rows: list[dict], ranges: dict[str, tuple[float, float]]) -> list[Clustering]:
    """Per scenario, each override's separation and failure rate per tenth, most telling first."""
    out = []
    for name, rs in by_scenario(rows).items():
        failed = np.array([not r["passed"] for r in rs])
        found = []
        for key, (low, high) in ranges.items():
            values = np.array([r["overrides"][key] for r in rs], dtype=float)
            found.append(Clustering(name, key, separation(values, failed, (low + high) / 2),
                                    bin_failures(values, failed, low, high)))
        out += sorted(found, key=lambda c: -np.nan_to_num(c.separation, nan=-1.0))
    return out


def check_summaries(rows: list[dict]) -> list[CheckSummary]:
    out = []
    for name, rs in by_scenario(rows).items():
        names = dict.fromkeys(c["name"] for r in rs for c in r["checks"])
        for check in names:
            results = [(r, c) for r in rs for c in r["checks"] if c["name"] == check]
            figures = np.array([np.nan if c["figure"] is None else c["figure"] for _, c in results], dtype=float)
            failing = np.array([not c["passed"] for _, c in results])
            row, detail = extreme_run(results, figures, failing)
            spread = (tuple(float(f) for f in np.nanpercentile(figures, [0, 50, 100]))
                      if np.isfinite(figures).any() else (np.nan,) * 3)
            out.append(CheckSummary(name, check, int(failing.sum()), spread, row, detail))
    return out


def extreme_run(results: list, figures: np.ndarray, failing: np.ndarray) -> tuple[dict, str]:
    """The (row, detail) whose figure is farthest from the passing runs' median, a failing one if any."""
    reference = figures[~failing] if np.isfinite(figures[~failing]).any() else figures
    typical = np.nanmedian(reference) if np.isfinite(reference).any() else 0.0
    distance = np.nan_to_num(np.abs(figures - typical), nan=np.inf)  # a check with no figure stands out
    row, check = results[int(np.lexsort((distance, failing))[-1])]  # failing first, then the farthest
    return row, check["detail"]
