"""Short videos and stills of a run's telling moments: a failure's clip, the PNG's filmstrip.

The failing moment is read from the ground truth: the first instant the body
tilts past ``FALLEN_TILT_RAD`` (or touches the ground), else the last scenario
event (a push, a fault), else the largest tilt. A clip spans ``CLIP_BEFORE_S``
before it to ``CLIP_AFTER_S`` after, inside the run.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from wheelleg.hil.watch.render import IGNORED_EVENTS, FrameRenderer, frame_times, motion_frames, write_video
from wheelleg.hil.watch.scene import RecordedMotion, recorded_motion

FALLEN_TILT_RAD = math.radians(45)
CLIP_BEFORE_S, CLIP_AFTER_S = 1.5, 1.0
CLIP_SIZE, CLIP_FPS = (320, 240), 20.0
FAILURE_VIDEO = "failure.mp4"  # beside a failing campaign run's trace
FILMSTRIP_MOST = 6  # stills at most in a run's filmstrip
FILMSTRIP_SIZE = (240, 180)


def failing_moment(state: dict[str, np.ndarray], events: list[dict]) -> float:
    """When a run went wrong (s), from its /sim/state columns and events (module doc)."""
    t = state["t"]
    tilt = np.maximum(np.abs(state["pitch"]), np.abs(state["roll"]))
    down = tilt > FALLEN_TILT_RAD
    if "body_on_ground" in state:
        down |= state["body_on_ground"] > 0.5
    if down.any():
        return float(t[np.argmax(down)])
    told = [e["t"] for e in events if e.get("kind") not in IGNORED_EVENTS]
    return float(told[-1]) if told else float(t[np.argmax(tilt)])


def clip_span(moment_s: float, start_s: float, end_s: float) -> tuple[float, float]:
    """The clip's (from, to) in s around ``moment_s``, shifted to stay within the run [start_s, end_s]."""
    span = CLIP_BEFORE_S + CLIP_AFTER_S
    begin = min(max(start_s, moment_s - CLIP_BEFORE_S), max(start_s, end_s - span))
    return begin, min(end_s, begin + span)


def failure_clip(trace: Path, out: Path) -> tuple[float, int]:
    """A short MP4 of ``trace``'s failing moment into ``out`` and its frame at the moment beside it
    (``out`` with .png: the video's poster); (the moment in s, frames written)."""
    from PIL import Image  # noqa: PLC0415

    motion = recorded_motion(trace)
    moment = failing_moment(motion.state, motion.events)
    begin, end = clip_span(moment, float(motion.t_s[0]), float(motion.t_s[-1]))
    times = frame_times(begin, end, CLIP_FPS)
    with FrameRenderer(motion.model, *CLIP_SIZE) as renderer:
        frames = list(motion_frames(motion, times, renderer))
    Image.fromarray(frames[int(np.argmin(np.abs(times - moment)))]).save(out.with_suffix(".png"), optimize=True)
    return moment, write_video(out, frames, CLIP_FPS)


def filmstrip_times(motion: RecordedMotion, most: int = FILMSTRIP_MOST) -> list[float]:
    """The stills' times (s): the run's events (never two within 0.3 s), else evenly over the run; at most
    ``most``, the first at the start."""
    start, end = float(motion.t_s[0]), float(motion.t_s[-1])
    times = [start]
    for event in motion.events:
        if event.get("kind") not in IGNORED_EVENTS and start < event["t"] <= end and event["t"] - times[-1] > 0.3:
            times.append(float(event["t"]))
    if len(times) < most:  # few events: fill evenly, so a quiet run still shows how it went
        fill = np.linspace(start, end, most - len(times) + 2)[1:].tolist()
        times = sorted(times + [t for t in fill if min(abs(t - u) for u in times) > 0.3])
    if len(times) > most:
        times = [times[round(i)] for i in np.linspace(0, len(times) - 1, most)]
    return times


def filmstrip(trace: Path) -> list[tuple[float, np.ndarray]]:
    """(time s, image) stills of ``trace`` at ``filmstrip_times``."""
    motion = recorded_motion(trace)
    times = filmstrip_times(motion)
    with FrameRenderer(motion.model, *FILMSTRIP_SIZE, camera="iso") as renderer:
        return list(zip(times, motion_frames(motion, times, renderer, labelled=False)))
