"""The robot's program alone: its inputs from a rig run fed again to a fresh one, outputs compared.

    python -m tools.controller_replay capture SCENARIO OUT.pkl [--duration S]
    python -m tools.controller_replay replay OUT.pkl [--reps N] [--count]

``capture`` runs the scenario in lockstep and keeps every frame the controller
took in (with the time it was given) and every tick's outputs (mode, frames,
debug record). ``replay`` builds a fresh controller of the same class, feeds
it the same frames and ticks, and says whether every tick's outputs are the
same bits (exit 1 if one differs): a stricter check than the candump log
(the debug record too), and the controller's cost without the rig around it,
in microseconds a tick (best of ``--reps``) or, with ``--count``, in machine
instructions a tick counted by valgrind (load-proof, like
``tools.loop_instructions``). Capture with the tree before a change, replay
with the tree after it. The file is a pickle: only for this tool, on this machine.
"""
from __future__ import annotations

import argparse
import importlib
import pickle
import re
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import can

from tools import known_scenario
from tools.loop_instructions import callgrind, under_callgrind


def tick_outputs(result) -> tuple:
    """A tick's outputs as comparable values: mode, each bus's frames (id, extended, data, time), debug."""
    frames = tuple((bus, tuple((m.arbitration_id, m.is_extended_id, bytes(m.data), m.timestamp) for m in msgs))
                   for bus, msgs in sorted(result.frames.items()))
    return int(result.mode), frames, repr(tuple(result.debug.items()) if result.debug else ())


def capture(scenario_name: str, out: Path, duration_s: float | None) -> int:
    """Run the scenario; write its controller's inputs and outputs to ``out``. Returns the ticks kept."""
    captured = capture_events(scenario_name, duration_s)
    with open(out, "wb") as f:
        pickle.dump(captured, f)
    return sum(e[0] == "tick" for e in captured["events"])


def capture_events(scenario_name: str, duration_s: float | None) -> dict:
    """Run the scenario in lockstep: {"program": "module:Class" of its controller, "events": its
    inputs and outputs in order, ("frame", fields, bus, now s) and ("tick", number, now s, outputs)}."""
    from wheelleg.hil import scenarios  # noqa: PLC0415 (replay needs none of the rig)
    from wheelleg.hil.run.rig import Rig, RigConfig  # noqa: PLC0415

    scenario = scenarios.get(scenario_name)
    if duration_s is not None:
        scenario = replace(scenario, duration_s=duration_s)
    with tempfile.TemporaryDirectory() as tmp:
        rig = Rig(scenario, RigConfig(), Path(tmp))
        program = rig.controller.controller
        events: list[tuple] = []
        on_frame, tick = program.on_frame, program.tick

        def kept_frame(msg: can.Message, bus: str, now_s: float):
            events.append(("frame", (msg.timestamp, msg.arbitration_id, msg.is_extended_id, msg.is_remote_frame,
                                     msg.is_error_frame, msg.dlc, bytes(msg.data)), bus, now_s))
            return on_frame(msg, bus, now_s)

        def kept_tick(number: int, now_s: float):
            result = tick(number, now_s)
            events.append(("tick", number, now_s, tick_outputs(result)))
            return result

        program.on_frame, program.tick = kept_frame, kept_tick
        rig.schedule.run(rig, round(scenario.duration_s / rig.config.period_s))
        rig.close()
    kind = type(program)
    return {"program": f"{kind.__module__}:{kind.__qualname__}", "events": events}


def program_class(captured: dict):
    """The captured controller's class, imported."""
    module, _, name = captured["program"].partition(":")
    return getattr(importlib.import_module(module), name)


def message(fields: tuple) -> can.Message:
    """A captured frame's fields (time s, id, extended, remote, error, dlc, data) as a frame."""
    t, can_id, extended, remote, error, dlc, data = fields
    return can.Message(timestamp=t, arbitration_id=can_id, is_extended_id=extended, is_remote_frame=remote,
                       is_error_frame=error, dlc=dlc, data=data)


def replay(path: Path, reps: int, counting: bool = False) -> tuple[int, float, int]:
    """Feed the captured inputs to fresh controllers ``reps`` times: (ticks, best s a tick, ticks that differ)."""
    with open(path, "rb") as f:
        captured = pickle.load(f)
    return replay_events(captured, reps, counting)


def replay_events(captured: dict, reps: int, counting: bool = False) -> tuple[int, float, int]:
    """``replay`` of what ``capture_events`` returned."""
    inputs, expected = [], []  # (is a frame, frame or tick number, bus or now s, now s or None)
    for kind, *fields in captured["events"]:
        if kind == "frame":
            frame, bus, now_s = fields
            inputs.append((True, message(frame), bus, now_s))
        else:
            number, now_s, outputs = fields
            inputs.append((False, number, now_s, None))
            expected.append(outputs)
    best, differ = float("inf"), 0
    make_program = program_class(captured)
    for _ in range(reps):
        program = make_program()
        on_frame, tick, results = program.on_frame, program.tick, []
        if counting:
            callgrind("on")
        start = time.perf_counter()
        for is_frame, a, b, c in inputs:
            if is_frame:
                on_frame(a, b, c)
            else:
                results.append(tick(a, b))
        best = min(best, time.perf_counter() - start)
        if counting:
            callgrind("off")
        differ = sum(tick_outputs(r) != e for r, e in zip(results, expected)) + abs(len(results) - len(expected))
    return len(expected), best / max(1, len(expected)), differ


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    cap = sub.add_parser("capture", help="run a scenario, keep its controller's inputs and outputs")
    cap.add_argument("scenario", type=known_scenario)
    cap.add_argument("out", type=Path)
    cap.add_argument("--duration", type=float, help="simulated seconds (default: the scenario's)")
    rep = sub.add_parser("replay", help="feed them to a fresh controller; compare its outputs")
    rep.add_argument("file", type=Path)
    rep.add_argument("--reps", type=int, default=3, help="replays, the best timed (default 3)")
    rep.add_argument("--count", action="store_true", help="machine instructions a tick, under valgrind")
    rep.add_argument("--inside", action="store_true", help=argparse.SUPPRESS)  # the replay under valgrind
    args = parser.parse_args(argv)
    if args.command == "capture":
        print(f"{args.out}: {capture(args.scenario, args.out, args.duration)} ticks captured")
        return 0
    if args.count and not args.inside:
        return _count(args.file)
    ticks, seconds, differ = replay(args.file, 1 if args.inside else max(1, args.reps), counting=args.inside)
    print(f"{ticks} ticks, {seconds * 1e6:.1f} us a tick (controller alone), "
          f"{'outputs identical' if not differ else f'OUTPUTS DIFFER in {differ} ticks'}")
    return 1 if differ else 0


def _count(path: Path) -> int:
    done, total, _ = under_callgrind(["tools.controller_replay", "replay", str(path.resolve()), "--inside"])
    ticks = re.search(r"^(\d+) ticks", done.stdout, re.M)
    if total is None or ticks is None:
        print(f"controller_replay: valgrind run failed (exit {done.returncode}):\n{done.stderr[-2000:]}",
              file=sys.stderr)
        return 1
    n = int(ticks.group(1))
    print(f"{n} ticks, {total / n / 1e6:.3f} M instructions a tick (controller alone); {done.stdout.strip()}")
    return done.returncode


if __name__ == "__main__":
    raise SystemExit(main())
