"""A failing campaign run's short video of its failing moment (clips.py), named in its results row."""
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
