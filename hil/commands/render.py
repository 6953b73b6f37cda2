"""``wheelleg render TRACE``: a video of a run from its trace alone (MuJoCo's offscreen renderer)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

NAME = "render"
HELP = "draw a run again from its trace: an MP4 or GIF video (offscreen: OSMesa or EGL)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("trace", type=Path, help="the rig's MCAP trace (it holds the poses, /sim/qpos)")
    parser.add_argument("-o", "--out", type=Path, default=None,
                        help="the video, .mp4 or .gif, or .png for the one frame at --from (default: TRACE with .mp4)")
    parser.add_argument("--from", dest="t_from", type=float, default=None, metavar="S",
                        help="start at this simulated time (s; default the run's start)")
    parser.add_argument("--to", dest="t_to", type=float, default=None, metavar="S",
                        help="end at this simulated time (s; default the run's end)")
    parser.add_argument("--camera", default="side",
                        help="side (default), front, iso, top (each following the body), or a camera of the model")
    parser.add_argument("--fps", type=positive_fps, default=25.0, help="frames per second (default 25)")
    parser.add_argument("--size", default="480x360", metavar="WxH", help="frame size in pixels (default 480x360)")


def positive_fps(text: str) -> float:
    """argparse type: frames per second in (0, 240]."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not 0 < value <= 240:
        raise argparse.ArgumentTypeError(f"must be in (0, 240], got {text}")
    return value


def frame_size(text: str) -> tuple[int, int]:
    """``WxH`` -> (width, height), each even and in 16..4096; ValueError (one line) otherwise."""
    width, _, height = text.lower().partition("x")
    try:
        size = int(width), int(height)
    except ValueError:
        raise ValueError(f"--size {text!r}: expected WIDTHxHEIGHT, e.g. 480x360") from None
    if not all(16 <= v <= 4096 and v % 2 == 0 for v in size):
        raise ValueError(f"--size {text!r}: each side must be even and 16..4096 pixels")
    return size


def run(args: argparse.Namespace) -> int:
    from wheelleg.hil.watch.render import RenderError, SceneError, render_trace

    out = args.out or args.trace.with_suffix(".mp4")
    try:
        size = frame_size(args.size)
        if not args.trace.is_file():
            raise SceneError("no such file")
        count = render_trace(args.trace, out, args.t_from, args.t_to, args.camera, args.fps, size)
    except (RenderError, SceneError, ValueError) as exc:
        print(f"render: {args.trace}: {exc}", file=sys.stderr)
        return 2
    print(f"render: {args.trace} -> {out}: {count} frames of {size[0]}x{size[1]} at {args.fps:g} fps")
    return 0
