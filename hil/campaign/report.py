"""DIR/report.md and DIR/pass_fail.png from a campaign's rows (analysis.py does the figures)."""
from __future__ import annotations

import math
from pathlib import Path

from wheelleg.hil.campaign import analysis

REPORT = "report.md"
PLOT = "pass_fail.png"
MOST_FAILURES_LISTED = 200  # the report lists at most this many failing runs; results.jsonl has them all


def fmt(value: float) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.4g}"


def write_report(out_dir: Path, rows: list[dict], spec: dict, command: str) -> Path:
    """Write report.md and pass_fail.png for ``rows``; returns the report's path."""
    ranges = {k: tuple(v) for k, v in spec["ranges"].items()}
    clusters = analysis.clustering(rows, ranges)
    plot_pass_fail(out_dir / PLOT, rows, clusters)
    text = "\n".join(["# Campaign report", "", f"    {command}", "",
                      *pass_rate_section(rows, ranges), *checks_section(rows),
                      *clustering_section(clusters), *failures_section(rows)])
    path = out_dir / REPORT
    path.write_text(text + "\n")
    from wheelleg.hil.watch.report_html import write_html  # noqa: PLC0415

    write_html(out_dir, rows, spec, command, out_dir / PLOT)  # report.html: the same, for the eye
    return path


def pass_rate_section(rows: list[dict], ranges: dict) -> list[str]:
    varied = ", ".join(f"{k} {lo:g}..{hi:g}" for k, (lo, hi) in ranges.items()) or "nothing (seeds only)"
    lines = [f"Overrides drawn uniformly from: {varied}.", "", "## Pass rate", "",
             "| scenario | runs | passed | rate | could not run |", "| --- | --- | --- | --- | --- |"]
    lines += [f"| {p.scenario} | {p.runs} | {p.passed} | {p.rate:.1%} | {p.errors} |"
              for p in analysis.pass_rates(rows)]
    cost = analysis.cpu_per_sim_second(rows)
    if cost is not None:
        lines += ["", f"Cost: {cost:.2f} CPU s per simulated s (each run in its worker process, checks included)."]
    return lines + ["", f"![pass/fail over the two most telling overrides]({PLOT})", ""]


def checks_section(rows: list[dict]) -> list[str]:
    lines = ["## Worst figures", "",
             "Each check's figure (the first number of its detail) over the runs, and the run farthest "
             "from the passing runs' median (a failing one if any).", "",
             "| scenario | check | failed | min | median | max | worst run |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for c in analysis.check_summaries(rows):
        lo, mid, hi = (fmt(f) for f in c.figures)
        lines.append(f"| {c.scenario} | {c.check} | {c.failures} | {lo} | {mid} | {hi} | "
                     f"sample {c.extreme['sample']}: {c.extreme_detail} |")
    return lines + [""]


def clustering_section(clusters: list[analysis.Clustering]) -> list[str]:
    if not clusters:
        return []
    lines = ["## Where the failures cluster", "",
             "Separation: 0 when failing runs spread over an override like passing ones, 1 when they lie "
             "apart (|2 AUC - 1| of the value or of its distance from the range's middle, whichever is "
             "larger; - when a scenario has no failures or no passes). Then failed/runs per tenth of the "
             "range, low to high.", "",
             "| scenario | override | separation | " + " | ".join(f"{b + 1}" for b in range(analysis.BINS)) + " |",
             "| --- | --- | --- |" + " --- |" * analysis.BINS]
    for c in clusters:
        bins = " | ".join(f"{f}/{n}" if n else "-" for f, n in c.bin_failures)
        lines.append(f"| {c.scenario} | {c.key} | {fmt(c.separation)} | {bins} |")
    return lines + [""]


def failures_section(rows: list[dict]) -> list[str]:
    failing = [r for r in rows if not r["passed"]]
    lines = ["## Failing runs", ""]
    if not failing:
        return lines + ["None.", ""]
    for r in failing[:MOST_FAILURES_LISTED]:
        why = r.get("error") or "; ".join(c["detail"] for c in r["checks"] if not c["passed"])
        trace = f"trace `{r['trace']}`, " if r.get("trace") else ""
        lines += [f"- {r['scenario']} sample {r['sample']} (seed {r['seed']}): {why}; {trace}rerun alone:",
                  "", f"      {r['rerun']}", ""]
    if len(failing) > MOST_FAILURES_LISTED:
        lines.append(f"... and {len(failing) - MOST_FAILURES_LISTED} more in results.jsonl.")
    return lines


def coordinate(row: dict, key: str) -> float:
    """An override's value in ``row``, or one of the row's own fields ("sample", "seed")."""
    return row["overrides"][key] if key in row["overrides"] else row[key]


def plot_pass_fail(path: Path, rows: list[dict], clusters: list[analysis.Clustering]) -> None:
    """One panel per scenario: each run at its two most telling overrides (the sample index where fewer)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    table = analysis.by_scenario(rows)
    fig, axes = plt.subplots(1, len(table), figsize=(4.2 * len(table), 3.8), squeeze=False)
    for ax, (name, rs) in zip(axes[0], table.items()):
        keys = ([c.key for c in clusters if c.scenario == name] + ["sample", "sample"])[:2]
        if keys[0] == "sample":
            keys = ["sample", "seed"]
        for passed, style in ((True, dict(marker="o", color="tab:green", label="pass")),
                              (False, dict(marker="x", color="tab:red", label="fail"))):
            pts = [(coordinate(r, keys[0]), coordinate(r, keys[1])) for r in rs if r["passed"] == passed]
            if pts:
                ax.scatter(*zip(*pts), s=18, **style)
        ax.set(title=name, xlabel=keys[0], ylabel=keys[1])
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
