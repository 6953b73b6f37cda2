"""A failing run's short video of its failing moment (clips.py): beside a failing campaign run's trace
(named in its results row), and beside a failing test's trace (the pytest plugin's bug report)."""
from __future__ import annotations

from pathlib import Path

from wheelleg.hil.watch.clips import FAILURE_VIDEO, failure_clip


def add_failure_video(row: dict, out_dir: Path) -> None:
    """Render ``row``'s clip beside its trace; ``row["video"]`` (relative to ``out_dir``) and
    ``row["moment_s"]``, or ``row["video_error"]`` (one line) when it cannot be drawn: never raises."""
    trace = out_dir / row["trace"]
    try:
        moment, _ = failure_clip(trace, trace.parent / FAILURE_VIDEO)
    except Exception as exc:  # noqa: BLE001 - a run without video is still a judged run
        row["video_error"] = f"{type(exc).__name__}: {exc}".splitlines()[0]
        return
    row["video"] = str(Path(row["trace"]).parent / FAILURE_VIDEO)
    row["moment_s"] = round(moment, 3)


def bug_report_video(trace: Path) -> str:
    """Render ``trace``'s failing moment to TRACE.failure.mp4; the bug report's line naming it (or why not)."""
    out = trace.with_suffix(".failure.mp4")
    try:
        moment, _ = failure_clip(trace, out)
    except Exception as exc:  # noqa: BLE001 - the report goes on without a video
        return f"  video:   none ({type(exc).__name__}: {exc})".splitlines()[0]
    return f"  video:   {out} (the failing moment, {moment:.2f} s, and 1.5 s before it)"
