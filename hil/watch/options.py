"""The watching options of ``wheelleg run`` (``--view``, ``--view-fast``, ``--live``, ``--host``, ``--port``,
``--live-wait``, ``--scene``) and the rig watchers they attach. Nothing of this is imported or built unless asked for."""
from __future__ import annotations

import argparse

DEFAULT_HOST, DEFAULT_PORT = "127.0.0.1", 8765  # Foxglove's own default port; this machine only by default


class WatchError(Exception):
    """A watcher cannot start (no display, a port in use): one line, exit status 2."""


def add_view_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--view", action="store_true",
                        help="follow the run in MuJoCo's viewer, paced to wall time; closing the window "
                             "ends the run (judged as it stands). Needs a display")
    parser.add_argument("--view-fast", action="store_true",
                        help="with --view: as fast as the rig runs, not paced to wall time")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_view_arguments(parser)
    parser.add_argument("--live", action="store_true",
                        help="stream the run to the Foxglove app over its WebSocket protocol while it runs "
                             "(the robot as a 3D scene, ground truth, controller signals, frames, events); "
                             "`wheelleg layout` prints the layout to open")
    parser.add_argument("--host", default=DEFAULT_HOST,
                        help=f"with --live: the address to listen on (default {DEFAULT_HOST}: this machine only)")
    parser.add_argument("--port", type=int, default=DEFAULT_PORT,
                        help=f"with --live: the port to listen on (default {DEFAULT_PORT}; 0: any free one)")
    parser.add_argument("--live-wait", type=float, default=0.0, metavar="S",
                        help="with --live: start the run when a client subscribes to /scene, waiting at most "
                             "S s (default 0: at once)")
    parser.add_argument("--scene", action="store_true",
                        help="also record /scene (the robot as a Foxglove 3D scene, 50 Hz) into the trace, "
                             "+5 %% of its size")


def check(args: argparse.Namespace) -> None:
    """ValueError (one line) for options that do not go together."""
    view = getattr(args, "view", False)
    if getattr(args, "view_fast", False) and not view:
        raise ValueError("--view-fast goes with --view")
    watching = view or getattr(args, "live", False) or getattr(args, "scene", False)
    if watching and getattr(args, "realtime", False):
        raise ValueError("--view, --live and --scene follow the lockstep run: drop --realtime")
    if getattr(args, "live_wait", 0.0) and not getattr(args, "live", False):
        raise ValueError("--live-wait goes with --live")
    if not 0 <= getattr(args, "port", 0) <= 65535:
        raise ValueError(f"--port {args.port}: must be 0..65535")


def attach(rig, args: argparse.Namespace) -> list:
    """The watchers ``args`` ask for, started and added to ``rig.watchers``; WatchError if one cannot start."""
    watchers = []
    try:
        if getattr(args, "scene", False):
            from wheelleg.hil.watch.scene_record import SceneRecorder  # noqa: PLC0415

            watchers.append(SceneRecorder(rig))
        if getattr(args, "live", False):
            from wheelleg.hil.watch.live import LiveServer  # noqa: PLC0415

            watchers.append(LiveServer(rig, args.host, args.port, getattr(args, "live_wait", 0.0)))
        if getattr(args, "view", False):
            from wheelleg.hil.watch.viewer import RunViewer, ViewerError  # noqa: PLC0415

            try:
                watchers.append(RunViewer(rig, fast=args.view_fast))
            except ViewerError as exc:
                raise WatchError(str(exc)) from exc
    except Exception:
        detach(watchers)
        raise
    rig.watchers.extend(watchers)
    return watchers


def detach(watchers: list) -> None:
    for watcher in watchers:
        watcher.close()
