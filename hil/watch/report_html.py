"""DIR/report.html: a campaign's report as one page that opens from the file system, no server.

The same findings as report.md (hil/campaign/report.py, figures by
hil/campaign/analysis.py), for the eye: pass rates, each check's figures as a
strip of dots (inline SVG: green passed, red failed), the failure clusters with
pass_fail.png, and each failing run's video of its failing moment (clips.py)
with its rerun command. Images and the first ``EMBEDDED_VIDEOS`` videos are
embedded (base64), so the page alone is the report; later videos are linked by
their path relative to the page (they sit in the campaign directory).
"""
from __future__ import annotations

import base64
import html
import math
from pathlib import Path

import numpy as np

from wheelleg.hil.campaign import analysis

REPORT_HTML = "report.html"
EMBEDDED_VIDEOS = 24  # ~50-150 KB each; past these the page links the files
STRIP_W, STRIP_H = 260, 34  # px of a check's strip of figures
STYLE = """
body { font: 14px/1.4 system-ui, sans-serif; margin: 1.5em auto; max-width: 1100px; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; }
th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: left; vertical-align: middle; }
th { background: #eef; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
pre { background: #f4f4f4; padding: 6px 10px; white-space: pre-wrap; word-break: break-all; }
.failure { border-top: 1px solid #ccc; padding: 0.6em 0; display: flex; gap: 1em; }
.failure video, .failure img.poster { width: 320px; height: 240px; background: #000; flex: none; }
.bad { color: #b00; } .good { color: #070; }
"""


def esc(value) -> str:
    return html.escape(str(value))


def data_uri(path: Path, media_type: str) -> str | None:
    """``path`` as a data: URI, None if it is missing."""
    try:
        return f"data:{media_type};base64,{base64.b64encode(path.read_bytes()).decode()}"
    except OSError:
        return None


def fmt(value) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.4g}"


def write_html(out_dir: Path, rows: list[dict], spec: dict, command: str, plot: Path | None) -> Path:
    """Write DIR/report.html for ``rows``; returns its path."""
    ranges = {k: tuple(v) for k, v in spec["ranges"].items()}
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>Campaign report</title>", f"<style>{STYLE}</style></head><body>",
             "<h1>Campaign report</h1>", f"<pre>{esc(command)}</pre>",
             *pass_rates(rows, ranges), *figures(rows), *clusters(rows, ranges, plot),
             *failures(rows, out_dir), "</body></html>"]
    path = out_dir / REPORT_HTML
    path.write_text("\n".join(parts) + "\n")
    return path


def pass_rates(rows: list[dict], ranges: dict) -> list[str]:
    varied = ", ".join(f"{k} {lo:g}..{hi:g}" for k, (lo, hi) in ranges.items()) or "nothing (seeds only)"
    out = ["<h2>Pass rate</h2>", f"<p>Overrides drawn uniformly from: {esc(varied)}.</p>",
           '<table id="pass-rate"><tr><th>scenario</th><th>runs</th><th>passed</th><th>rate</th>'
           "<th>could not run</th></tr>"]
    for p in analysis.pass_rates(rows):
        tone = "good" if p.passed == p.runs else "bad"
        out.append(f'<tr><td>{esc(p.scenario)}</td><td class="num">{p.runs}</td><td class="num">{p.passed}</td>'
                   f'<td class="num {tone}">{p.rate:.1%}</td><td class="num">{p.errors}</td></tr>')
    return out + ["</table>"]


def strip_svg(points: list[tuple[float, bool]]) -> str:
    """An inline SVG strip: each (figure, passed) a dot along x (min..max), passes above, failures below."""
    values = np.array([v for v, _ in points], dtype=float)
    if not np.isfinite(values).any():
        return "-"
    lo, hi = float(np.nanmin(values)), float(np.nanmax(values))
    span = hi - lo or 1.0
    dots = []
    for i, (value, passed) in enumerate(points):
        if not math.isfinite(value):
            continue
        x = 6 + (value - lo) / span * (STRIP_W - 12)
        y = (9 if passed else 25) + (i * 7 % 5) - 2  # a little deterministic jitter
        colour = "#2a2" if passed else "#d22"
        dots.append(f'<circle cx="{x:.1f}" cy="{y}" r="3" fill="{colour}" fill-opacity="0.7"/>')
    return (f'<svg width="{STRIP_W}" height="{STRIP_H}" viewBox="0 0 {STRIP_W} {STRIP_H}" '
            f'xmlns="http://www.w3.org/2000/svg"><line x1="0" y1="17" x2="{STRIP_W}" y2="17" stroke="#ccc"/>'
            + "".join(dots) + "</svg>")


def figures(rows: list[dict]) -> list[str]:
    out = ["<h2>Figures</h2>",
           "<p>Each check's figure (the first number of its detail) over the runs: passes green above the "
           "line, failures red below, min to max left to right.</p>",
           '<table id="figures"><tr><th>scenario</th><th>check</th><th>failed</th><th>min</th><th>median</th>'
           "<th>max</th><th>distribution</th></tr>"]
    for c in analysis.check_summaries(rows):
        points = [(math.nan if k["figure"] is None else k["figure"], k["passed"])
                  for r in rows if r["scenario"] == c.scenario for k in r["checks"] if k["name"] == c.check]
        lo, mid, hi = (fmt(f) for f in c.figures)
        out.append(f"<tr><td>{esc(c.scenario)}</td><td>{esc(c.check)}</td><td class=\"num\">{c.failures}</td>"
                   f'<td class="num">{lo}</td><td class="num">{mid}</td><td class="num">{hi}</td>'
                   f"<td>{strip_svg(points)}</td></tr>")
    return out + ["</table>"]


def clusters(rows: list[dict], ranges: dict, plot: Path | None) -> list[str]:
    found = analysis.clustering(rows, ranges)
    out = ["<h2>Where the failures cluster</h2>"]
    if found:
        out += ["<p>Separation 0: failures spread over the override like passes; 1: apart. Then failed/runs "
                "per tenth of the range, low to high.</p>",
                '<table id="clusters"><tr><th>scenario</th><th>override</th><th>separation</th>'
                + "".join(f"<th>{b + 1}</th>" for b in range(analysis.BINS)) + "</tr>"]
        for c in found:
            bins = "".join(f'<td class="num">{f}/{n}</td>' if n else "<td>-</td>" for f, n in c.bin_failures)
            out.append(f"<tr><td>{esc(c.scenario)}</td><td>{esc(c.key)}</td>"
                       f'<td class="num">{fmt(c.separation)}</td>{bins}</tr>')
        out.append("</table>")
    uri = data_uri(plot, "image/png") if plot is not None else None
    if uri:
        out.append(f'<p><img alt="pass/fail over the two most telling overrides" src="{uri}"></p>')
    return out


def failures(rows: list[dict], out_dir: Path) -> list[str]:
    failing = [r for r in rows if not r["passed"]]
    out = [f"<h2>Failing runs ({len(failing)})</h2>"]
    if not failing:
        return out + ["<p>None.</p>"]
    for index, r in enumerate(failing):
        why = r.get("error") or "; ".join(c["detail"] for c in r["checks"] if not c["passed"])
        out += ['<div class="failure">', _video(r, out_dir, embed=index < EMBEDDED_VIDEOS), "<div>",
                f"<h3>{esc(r['scenario'])} sample {r['sample']} (seed {r['seed']})</h3>",
                f'<p class="bad">{esc(why)}</p>']
        if r.get("moment_s") is not None:
            out.append(f"<p>failing moment {r['moment_s']:.2f} s (the video: 1.5 s before to 1 s after)</p>")
        if r.get("overrides"):
            out.append("<p>" + esc(", ".join(f"{k}={v:g}" for k, v in r["overrides"].items())) + "</p>")
        if r.get("trace"):
            out.append(f'<p>trace <a href="{esc(r["trace"])}">{esc(r["trace"])}</a></p>')
        out += ["<p>rerun alone:</p>", f"<pre>{esc(r['rerun'])}</pre>", "</div></div>"]
    return out


def _video(row: dict, out_dir: Path, embed: bool) -> str:
    """The run's <video> (poster: its frame at the failing moment), or why there is none."""
    if not row.get("video"):
        reason = row.get("video_error") or ("the run could not run" if row.get("error") else "no trace kept")
        return f'<p class="poster">no video: {esc(reason)}</p>'
    video = out_dir / row["video"]
    poster = data_uri(video.with_suffix(".png"), "image/png")
    source = (data_uri(video, "video/mp4") if embed else None) or esc(row["video"])
    poster_attr = f' poster="{poster}"' if poster else ""
    return f'<video controls muted loop preload="metadata"{poster_attr} src="{source}"></video>'
