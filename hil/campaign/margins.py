"""Robustness margins, the pure half: the bisection along one side of one override, and the table.

For each plant override (key) and each side of its nominal value (the
described robot, ``OVERRIDES[key].default``), ``SideSearch`` looks for the
nearest value at which the scenario fails, between nominal (which passed) and
the key's allowed limit on that side. Its first probe is the gate, ``GATE``
times the box's half-width on that side out from nominal, where every edge
should lie beyond (so the flag "edge within 1.5x the box" is decided by one
run, not by the resolution); then the limit if the gate passed (a passing limit: the edge is beyond the allowed
range); then halving the bracket (last pass, first fail) with the runs left
(``SideSearch.middle``). The table shows both ends of the final bracket: that
is the resolution.

It assumes one change of verdict per side (pass near nominal, fail farther
out); where the scenario fails only in a window, the edge found is one of its
borders, not necessarily the nearest.

``render_markdown`` is the one renderer of the table: ``wheelleg margins``
prints it and writes it to margins.md, and the campaign report appends it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from wheelleg.hil.campaign.sampling import SIGNIFICANT_DIGITS

GATE = 1.5  # an edge nearer than this many box half-widths from nominal is flagged: the box must sit well inside
SIDES = ("below", "above")


def rounded(value: float) -> float:
    """A probed value rounded as a campaign's draws are, so its rerun command (k=v) is the very same run."""
    return float(f"{value:.{SIGNIFICANT_DIGITS}g}")


@dataclass
class SideSearch:
    """The bisection along one side: ``next_value()`` to probe, ``record(value, passed)`` its verdict.

    ``nominal`` passed; ``limit`` is the allowed value farthest out on this side
    (== nominal: no room, nothing to probe); ``gate`` the first probe (None: no
    box on this side); ``runs`` the most probes this side may take (>= 1).
    """

    nominal: float
    limit: float
    gate: float | None
    runs: int
    passing: float = field(init=False)  # the farthest value that passed (nominal to start)
    failing: float | None = field(init=False, default=None)  # the nearest value that failed
    failing_checks: tuple = field(init=False, default=())
    probes: list = field(init=False, default_factory=list)  # (value, passed) in the order probed

    def __post_init__(self):
        self.passing = self.nominal
        if self.gate is not None:
            self.gate = rounded(self.gate)
            if abs(self.gate - self.nominal) >= abs(self.limit - self.nominal):
                self.gate = None  # the gate lies at or beyond the limit: the limit is the first probe

    def next_value(self) -> float | None:
        """The value to run next, None when the search is over."""
        if len(self.probes) >= self.runs or self.limit == self.nominal or self.passing == self.limit:
            return None
        if self.failing is None:
            if self.gate is not None and self.passing == self.nominal:
                return self.gate
            return self.limit
        middle = rounded(self.middle())
        return None if middle in (self.passing, self.failing) else middle

    def middle(self) -> float:
        """Between the last pass and the first fail: the arithmetic mean while only nominal has
        passed, then the geometric mean of their distances from nominal (a bracket such as 3..50 ms
        of delay is halved in ratio, not in size)."""
        passed, failed = abs(self.passing - self.nominal), abs(self.failing - self.nominal)
        distance = math.sqrt(passed * failed) if passed > 0 else failed / 2
        return self.nominal + math.copysign(distance, self.failing - self.nominal)

    def record(self, value: float, passed: bool, failed_checks: tuple = ()) -> None:
        self.probes.append((value, passed))
        if passed:
            self.passing = value
        else:
            self.failing, self.failing_checks = value, tuple(failed_checks)


def find_edge(oracle, nominal: float, limit: float, gate: float | None, runs: int) -> SideSearch:
    """The whole search on one side against ``oracle(value) -> passed`` (for tests and one-off use)."""
    search = SideSearch(nominal, limit, gate, runs)
    while (value := search.next_value()) is not None:
        search.record(value, oracle(value))
    return search


def gate_value(nominal: float, half_width: float | None, side: str) -> float | None:
    """The first probe on ``side``: GATE half-widths of the box out from nominal (None: no box there)."""
    if not half_width:
        return None
    return nominal + (GATE * half_width if side == "above" else -GATE * half_width)


NEGLIGIBLE = 0.01  # a box reaching less than this share of its width past nominal does not reach that side


def half_widths(nominal: float, box: tuple[float, float] | None) -> tuple[float | None, float | None]:
    """How far the box reaches from nominal (below, above); None for a key outside the box.

    A box that does not contain nominal (a friction of 0.15-0.435 N m where the
    model has none) reaches only one side, by its far end; a side it barely
    reaches (under NEGLIGIBLE of its width: a rounding of nominal) counts as 0.
    """
    if box is None:
        return None, None
    low, high = box
    reaches = (max(nominal - low, 0.0), max(high - nominal, 0.0))
    return tuple(r if r >= NEGLIGIBLE * (high - low) else 0.0 for r in reaches)


@dataclass(frozen=True)
class Edge:
    """The result on one side of one key: where the scenario failed, nearest nominal, and why."""

    side: str
    limit: float  # the key's allowed value on this side (OVERRIDES)
    half_width: float | None  # the box's reach from nominal on this side; None/0: no box here
    passing: float  # the farthest value that passed
    failing: float | None  # the nearest value that failed; None: none found
    failed_checks: tuple  # the checks that failed at ``failing`` (the scenario's names)
    rerun: str | None  # the failing run's `wheelleg run` command
    probes: tuple  # ((value, passed), ...) in the order run

    def ratio(self, nominal: float) -> float | None:
        """|edge - nominal| / half-width: of the failing value, else of the farthest pass (a lower bound)."""
        if not self.half_width:
            return None
        reach = self.failing if self.failing is not None else self.passing
        return abs(reach - nominal) / self.half_width

    def flagged(self, nominal: float) -> bool:
        """It failed within GATE half-widths of the box (less than the minimum margin)."""
        ratio = self.ratio(nominal)
        return self.failing is not None and ratio is not None and ratio <= GATE * (1 + 1e-9)


@dataclass(frozen=True)
class KeyMargins:
    key: str
    unit: str
    nominal: float
    box: tuple[float, float] | None
    below: Edge
    above: Edge

    def edges(self) -> tuple[Edge, Edge]:
        return self.below, self.above


@dataclass(frozen=True)
class ScenarioMargins:
    """One scenario's margins, or why there are none (its nominal run failed)."""

    scenario: str
    seed: int
    nominal_passed: bool
    nominal_detail: str  # the failing checks' details when nominal failed, else ""
    nominal_rerun: str
    keys: tuple[KeyMargins, ...]

    def flagged(self) -> list[tuple[KeyMargins, Edge]]:
        return [(k, e) for k in self.keys for e in k.edges() if e.flagged(k.nominal)]


def edge_from(search: SideSearch, side: str, half_width: float | None, rerun: str | None) -> Edge:
    return Edge(side, search.limit, half_width, search.passing, search.failing, search.failing_checks,
                rerun, tuple(search.probes))


# -- the table -----------------------------------------------------------------------------------

def number(value: float) -> str:
    return f"{value:.4g}"


def edge_cell(edge: Edge, nominal: float) -> str:
    if edge.limit == nominal:
        return "- (allowed range ends at nominal)"
    if edge.failing is not None:
        return f"{number(edge.failing)} (passes {number(edge.passing)})"
    if edge.passing == edge.limit:
        return f"beyond allowed range (passes {number(edge.limit)})"
    return f"not found (passes {number(edge.passing)})"


def ratio_cell(edge: Edge, nominal: float) -> str:
    ratio = edge.ratio(nominal)
    if ratio is None:
        return "-"
    text = f"{ratio:.2f}" if edge.failing is not None else f">{ratio:.2f}"
    return f"**{text}**" if edge.flagged(nominal) else text


def check_cell(edge: Edge) -> str:
    return ", ".join(edge.failed_checks) if edge.failing is not None else "-"


def render_markdown(results: list[ScenarioMargins], runs_per_side: int, heading: str = "##") -> list[str]:
    """The margins table (markdown lines) of every scenario, and each edge's rerun command."""
    lines = [f"{heading} Robustness margins", "",
             f"Per key and side: the nearest value found to fail (bisection, at most {runs_per_side} runs a "
             f"side, one seed), with the farthest that passed: the edge lies between. The first probe "
             f"is {GATE:g}x the box's half-width on that side, then the key's allowed limit, then halves "
             f"the bracket (in ratio once a value off nominal has passed). "
             f"Ratio: the failing value's distance from nominal over the box's half-width on that side "
             f"(**bold** when it failed within {GATE:g}x, > when no failure was found). Checks: those that failed at "
             f"the failing value.", ""]
    for result in results:
        lines += scenario_lines(result, heading + "#")
    return lines


def scenario_lines(result: ScenarioMargins, heading: str) -> list[str]:
    lines = [f"{heading} {result.scenario} (seed {result.seed})", ""]
    if not result.nominal_passed:
        return lines + [f"The nominal plant fails ({result.nominal_detail}): no margins. Rerun alone:", "",
                        f"    {result.nominal_rerun}", ""]
    lines += ["| key | unit | nominal | box | fails below | checks failed below | ratio below | "
              "fails above | checks failed above | ratio above |",
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for k in result.keys:
        box = f"{number(k.box[0])}..{number(k.box[1])}" if k.box else "-"
        lines.append(f"| {k.key} | {k.unit or 'scale'} | {number(k.nominal)} | {box} | "
                     f"{edge_cell(k.below, k.nominal)} | {check_cell(k.below)} | {ratio_cell(k.below, k.nominal)} | "
                     f"{edge_cell(k.above, k.nominal)} | {check_cell(k.above)} | {ratio_cell(k.above, k.nominal)} |")
    flagged = result.flagged()
    lines += ["", f"{len(flagged)} of {sum(e.limit != k.nominal for k in result.keys for e in k.edges())} "
                  f"edges under {GATE:g}x the box's half-width."]
    reruns = [(k, e) for k in result.keys for e in k.edges() if e.rerun]
    if reruns:
        lines += ["", "Each edge's failing run, alone:", ""]
        for k, e in reruns:
            lines += [f"- {k.key} {e.side}, {number(e.failing)}: {check_cell(e)}", "", f"      {e.rerun}", ""]
    return lines + [""]


def to_json(results: list[ScenarioMargins], runs_per_side: int) -> dict:
    """Everything the table shows and every probe, JSON-able (margins.json)."""
    def edge(e: Edge, nominal: float) -> dict:
        return {"limit": e.limit, "half_width": e.half_width, "passing": e.passing, "failing": e.failing,
                "failed_checks": list(e.failed_checks), "ratio": e.ratio(nominal),
                "flagged": e.flagged(nominal), "rerun": e.rerun, "probes": [list(p) for p in e.probes]}

    return {"gate": GATE, "runs_per_side": runs_per_side, "scenarios": [
        {"scenario": r.scenario, "seed": r.seed, "nominal_passed": r.nominal_passed,
         "nominal_detail": r.nominal_detail, "nominal_rerun": r.nominal_rerun,
         "keys": [{"key": k.key, "unit": k.unit, "nominal": k.nominal, "box": list(k.box) if k.box else None,
                   "below": edge(k.below, k.nominal), "above": edge(k.above, k.nominal)} for k in r.keys]}
        for r in results]}
